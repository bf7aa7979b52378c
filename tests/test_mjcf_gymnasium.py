"""MJCF input against MuJoCo itself: every model shipped in Gymnasium's wheel.

Each model is loaded by dynderive (``load_robot`` on the ``.xml``), derived once and its NumPy
module compared at random states (random unit quaternions for free and ball joints, random
joint values and velocities) with MuJoCo's own computation on the same file:

* ``mass_matrix`` mapped to MuJoCo's velocities equals ``mj_fullM``;
* ``inverse_dynamics`` at zero MuJoCo acceleration equals ``qfrc_bias - qfrc_spring -
  qfrc_damper`` (our inverse dynamics holds the joints' springs and dampers as forces the
  efforts must supply, MuJoCo's passive forces act on the robot: opposite signs);
* ``forward_dynamics(q, qd, u)`` with ``u`` MuJoCo's ``qfrc_actuator`` for random controls
  equals ``mj_forward``'s ``qacc`` with constraints disabled (``mjDSBL_CONSTRAINT``: no
  contacts, joint limits or friction loss). The swimmer's fluid forces are switched off in the
  MuJoCo model (``opt.viscosity = opt.density = 0``): dynderive does not model them;
* the frames (sites and named welded bodies) have MuJoCo's poses, Jacobians and Jdot qd.

The mapping between the two velocity conventions (``test_mjcf_mujoco.mujoco_state``): hinge and slide
coordinates are MuJoCo's ``qpos``; quaternions are w-last in ours, w-first in MuJoCo; a free
joint's linear velocity is in the body frame in ours, in the world frame in MuJoCo's ``qvel``
(``v_local = R^T v_world``), so ``qd = T qvel`` with ``T`` block-diagonal, and MuJoCo's zero
acceleration is our ``qdd = -omega x v_local`` in those rows.

``walker2d_v5.xml`` differs from ``walker2d.xml`` only in a geom's friction (nothing the
equations hold) and is not derived twice; ``pusher_v5.xml`` has other masses and is.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive

from conftest import import_code

mujoco = pytest.importorskip("mujoco")
from conftest import compiled_model  # noqa: E402  (MjSpec: no MUJOCO_LOG.TXT)

gymnasium = pytest.importorskip("gymnasium")

from test_mjcf_mujoco import actuated_efforts, check_against_mujoco, check_frames  # noqa: E402

ASSETS = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
MODELS = ["ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_pendulum",
          "inverted_double_pendulum", "point", "pusher", "pusher_v5", "reacher", "swimmer", "walker2d"]


@cache
def gymnasium_module(name: str, directory: str):
    derivation = dynderive.derive(dynderive.load_robot(ASSETS / f"{name}.xml"))
    return import_code(dynderive.render_code(derivation), Path(directory), f"gymnasium_{name}_dynamics")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("gymnasium"))


@pytest.fixture(autouse=True)
def _mujoco_log_elsewhere(tmp_path, monkeypatch):
    """MuJoCo appends its warnings (half_cheetah's deprecated ``settotalmass``) to
    MUJOCO_LOG.TXT in the working directory: the test's own."""
    monkeypatch.chdir(tmp_path)


@pytest.mark.parametrize("name", MODELS)
def test_gymnasium_model_agrees_with_mujoco(name, folder):
    module = gymnasium_module(name, folder)
    m = compiled_model(str(ASSETS / f"{name}.xml"))
    assert len(module.COORDINATES) == m.nq and len(getattr(module, "VELOCITIES", module.COORDINATES)) == m.nv
    check_against_mujoco(module, m, seed=sum(map(ord, name)))
    check_frames(module, compiled_model(str(ASSETS / f"{name}.xml")), seed=sum(map(ord, name)) + 1)


@pytest.mark.parametrize("name", MODELS)
def test_gymnasium_efforts_are_the_actuated_joints(name, folder):
    module = gymnasium_module(name, folder)
    m = compiled_model(str(ASSETS / f"{name}.xml"))
    assert m.nu > 0
    assert len(module.EFFORTS) == len(set(module.EFFORTS))
    assert set(module.EFFORTS) == actuated_efforts(m)


def test_v5_walker_differs_only_in_friction():
    """walker2d_v5 is left out of the derivations because its equations are walker2d's."""
    a = compiled_model(str(ASSETS / "walker2d.xml"))
    b = compiled_model(str(ASSETS / "walker2d_v5.xml"))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_pos", "body_quat", "jnt_type",
                  "jnt_axis", "jnt_pos", "dof_damping", "dof_armature", "jnt_stiffness", "qpos_spring",
                  "actuator_gear", "actuator_trnid"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert not np.array_equal(a.geom_friction, b.geom_friction)
