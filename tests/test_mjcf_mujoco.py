"""MJCF input against MuJoCo on models written for the purpose.

* The bundled Panda and UR5 URDFs converted to MJCF by MuJoCo itself (``MjSpec.from_file`` on
  the ``.urdf``, ``to_xml``): dynderive's derivation of that MJCF has the URDF derivation's mass
  matrix and inverse dynamics (coordinates matched by joint name), and MuJoCo's.
* Small hand-written fixtures in ``tests/mjcf/`` (each one's comment says what it exercises),
  against MuJoCo's ``mj_fullM``, ``qfrc_bias``, ``mj_forward`` and frame poses.

The mapping between the two conventions is ``test_mjcf_gymnasium``'s.
"""

from __future__ import annotations

import ctypes
from contextlib import contextmanager
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive

from conftest import ROBOTS, import_code

mujoco = pytest.importorskip("mujoco")

from test_mjcf_gymnasium import (assert_close, check_against_mujoco, joint_name, mujoco_at,  # noqa: E402
                                 mujoco_state)

FIXTURES = Path(__file__).parent / "mjcf"


@contextmanager
def full_precision_xml():
    """MuJoCo writes numbers in saved XML to 6 significant digits; its test-only switch (the
    library's exported ``_mjPRIVATE__set_xml_precision``) makes them 17, so the saved model is
    the loaded one to the last bit."""
    library = ctypes.CDLL(str(next(Path(mujoco.__file__).parent.glob("libmujoco.so*"))))
    if not hasattr(library, "_mjPRIVATE__set_xml_precision"):
        pytest.skip("this MuJoCo has no switch to write full-precision XML")
    previous = library._mjPRIVATE__get_xml_precision()
    library._mjPRIVATE__set_xml_precision(17)
    try:
        yield
    finally:
        library._mjPRIVATE__set_xml_precision(previous)


@cache
def module_of_file(path: str, directory: str, name: str):
    derivation = dynderive.derive(dynderive.load_robot(path))
    return import_code(dynderive.render_code(derivation), Path(directory), f"{name}_dynamics")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("mjcf_mujoco"))


# the bundled arms through MuJoCo's URDF import -------------------------------------------------

@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_urdf_converted_by_mujoco_keeps_the_urdf_dynamics(arm, folder):
    with full_precision_xml():
        spec = mujoco.MjSpec.from_file(str(ROBOTS / f"{arm}.urdf"))
        spec.compile()
        xml = spec.to_xml()
    path = Path(folder) / f"{arm}_from_urdf.xml"
    path.write_text(xml)
    assert "<inertial" in xml and "<joint" in xml
    converted = mujoco.MjModel.from_xml_path(str(path))
    # MuJoCo kept every moving link's inertial (fusestatic folds only the fixed, massless ones
    # and the root welded to the world; no geoms, so no inertia from geoms)
    urdf = dynderive.load_robot(ROBOTS / f"{arm}.urdf")
    moving = sum(float(link.mass) for link in urdf.links if any(j.child == link.name for j in urdf.joints
                                                                  if j.type == "revolute"))
    assert abs(float(np.sum(converted.body_mass)) - moving) <= 1e-15 * moving

    ours = module_of_file(str(path), folder, f"{arm}_mjcf")
    reference = module_of_file(str(ROBOTS / f"{arm}.urdf"), folder, f"{arm}_urdf")
    assert sorted(ours.COORDINATES) == sorted(reference.COORDINATES)
    order = [reference.COORDINATES.index(c) for c in ours.COORDINATES]
    rng = np.random.default_rng(11 if arm == "ur5" else 12)
    for _ in range(4):
        q, qd, qdd = rng.uniform(-2, 2, (3, len(order)))
        M_ref = reference.mass_matrix(q[np.argsort(order)])
        assert_close(ours.mass_matrix(q), M_ref[np.ix_(order, order)], "mass matrix")
        tau_ref = reference.inverse_dynamics(q[np.argsort(order)], qd[np.argsort(order)], qdd[np.argsort(order)])
        assert_close(ours.inverse_dynamics(q, qd, qdd), tau_ref[order], "inverse dynamics")
    check_against_mujoco(ours, converted, seed=5)


# hand-written fixtures ---------------------------------------------------------------------------

def fixture_module(name: str, folder: str):
    return module_of_file(str(FIXTURES / f"{name}.xml"), folder, f"fixture_{name}")


def mujoco_frame(m, d, name: str):
    """(position, rotation, body, point) of a site or body called ``name`` in MuJoCo's data."""
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
    if site >= 0:
        return d.site_xpos[site], d.site_xmat[site].reshape(3, 3), int(m.site_bodyid[site])
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
    assert body >= 0, name
    return d.xpos[body], d.xmat[body].reshape(3, 3), body


def test_tree_fixture_agrees_with_mujoco(folder):
    """Several joints on one body, refs, springs, armature, a ball joint, welded bodies, motors."""
    module = fixture_module("tree", folder)
    m = mujoco.MjModel.from_xml_path(str(FIXTURES / "tree.xml"))
    assert (m.njnt, m.nbody, m.nsite) == (5, 6, 2)
    assert np.all(m.qpos0[[0, 1, 2]] != 0) and np.all(m.jnt_stiffness[[0, 1]] != 0)
    check_against_mujoco(module, m, seed=21, states=4)


def test_tree_fixture_frames_are_mujocos_sites_and_bodies(folder):
    """The named welded body (``tool``) and the sites are frames; their poses, Jacobians and
    Jdot qd equal MuJoCo's (``xpos``/``xmat``, ``site_xpos``/``site_xmat``, ``mj_jac``, ``mj_jacDot``)."""
    module = fixture_module("tree", folder)
    m = mujoco.MjModel.from_xml_path(str(FIXTURES / "tree.xml"))
    d = mujoco.MjData(m)
    assert set(module.FRAMES) == {"tool", "tip", "hand"}
    rng = np.random.default_rng(22)
    for _ in range(4):
        qpos, qvel, q, qd, T, W = mujoco_state(module, m, rng)
        mujoco_at(m, d, qpos, qvel)
        for frame in module.FRAMES:
            position, rotation, body = mujoco_frame(m, d, frame)
            pose = module.frame_transform(q, frame)
            assert_close(pose[:3, 3], position, f"{frame} position")
            assert_close(pose[:3, :3], rotation, f"{frame} rotation")
            jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, jacp, jacr, position, body)
            assert_close(module.frame_jacobian(q, frame) @ T, np.vstack([jacp, jacr]), f"{frame} Jacobian")
            mujoco.mj_jacDot(m, d, jacp, jacr, position, body)
            assert_close(module.frame_jacobian_dot_qd(q, qd, frame), np.concatenate([jacp @ qvel, jacr @ qvel]),
                         f"{frame} Jdot qd")
