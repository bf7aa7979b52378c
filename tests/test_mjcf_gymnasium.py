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
  MuJoCo model (``opt.viscosity = opt.density = 0``): dynderive does not model them.

The mapping between the two velocity conventions (``mujoco_state``): hinge and slide
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
gymnasium = pytest.importorskip("gymnasium")

ASSETS = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
MODELS = ["ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_pendulum",
          "inverted_double_pendulum", "point", "pusher", "pusher_v5", "reacher", "swimmer", "walker2d"]
TOLERANCE = 1e-9


def quaternion_matrix(wxyz) -> np.ndarray:
    w, x, y, z = wxyz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def joint_name(m, j: int) -> str:
    """Our name of MuJoCo joint ``j`` (its own, or ``<body>_joint<k>`` for an unnamed one)."""
    from dynderive.input.urdf import identifier

    if m.joint(j).name:
        return identifier(m.joint(j).name)
    body = int(m.jnt_bodyid[j])
    return identifier(f"{m.body(body).name or f'body{body}'}_joint{j - int(m.body_jntadr[body]) + 1}")


def first_coordinate(m, j: int) -> str:
    name, kind = joint_name(m, j), int(m.jnt_type[j])
    return {0: f"{name}_x", 1: f"{name}_qx"}.get(kind, name)


def layout(module, m) -> list[tuple[int, int, int]]:
    """Per MuJoCo joint: (joint, our first coordinate index, our first velocity index), in our order."""
    starts = sorted((module.COORDINATES.index(first_coordinate(m, j)), j) for j in range(m.njnt))
    rows, v = [], 0
    for start, j in starts:
        rows.append((j, start, v))
        v += {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
    assert v == len(getattr(module, "VELOCITIES", module.COORDINATES)) == m.nv
    return rows


def mujoco_state(module, m, rng, qpos=None):
    """A random state in both conventions: (qpos, qvel, q, qd, T, W) with qd = T qvel and
    MuJoCo's zero acceleration our qdd = W. ``qpos`` given: that configuration (random velocities)."""
    randomize = qpos is None
    qpos = m.qpos0.copy() if qpos is None else np.array(qpos, dtype=float)
    qvel = rng.uniform(-1.5, 1.5, m.nv)
    q, qd = np.zeros(len(module.COORDINATES)), np.zeros(m.nv)
    T, W = np.zeros((m.nv, m.nv)), np.zeros(m.nv)
    for j, c, v in layout(module, m):
        a, dof, kind = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), int(m.jnt_type[j])
        if kind in (0, 1):
            at = a + 3 if kind == 0 else a
            if randomize:
                if kind == 0:
                    qpos[a:a + 3] = rng.uniform(-1, 1, 3)
                quat = rng.normal(size=4)
                qpos[at:at + 4] = quat / np.linalg.norm(quat)
            quat = qpos[at:at + 4]
            if kind == 0:
                R = quaternion_matrix(quat)
                q[c:c + 3] = qpos[a:a + 3]
                T[v:v + 3, dof:dof + 3] = R.T
                T[v + 3:v + 6, dof + 3:dof + 6] = np.eye(3)
                local, omega = R.T @ qvel[dof:dof + 3], qvel[dof + 3:dof + 6]
                W[v:v + 3] = -np.cross(omega, local)
                q[c + 3:c + 7] = [*quat[1:], quat[0]]
            else:
                T[v:v + 3, dof:dof + 3] = np.eye(3)
                q[c:c + 4] = [*quat[1:], quat[0]]
        else:
            if randomize:
                qpos[a] = rng.uniform(-1.5, 1.5)
            q[c] = qpos[a]
            T[v, dof] = 1
    return qpos, qvel, q, T @ qvel, T, W


def mujoco_at(m, d, qpos, qvel, ctrl=None):
    d.qpos[:], d.qvel[:], d.qacc[:] = qpos, qvel, 0
    d.ctrl[:] = 0 if ctrl is None else ctrl
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return M


def assert_close(ours, theirs, what: str) -> None:
    scale = max(float(np.max(np.abs(theirs))), 1e-300)
    error = float(np.max(np.abs(np.asarray(ours) - theirs)))
    assert error <= TOLERANCE * scale, f"{what}: max error {error:.3e}, relative {error / scale:.3e}"


def effort_columns(module) -> list[int]:
    """The velocity each effort acts on (a fixed-base module's efforts are named after coordinates)."""
    if hasattr(module, "EFFORT_COLUMNS"):
        return list(module.EFFORT_COLUMNS)
    return [module.COORDINATES.index(e.removeprefix("tau_").removeprefix("f_")) for e in module.EFFORTS]


def check_against_mujoco(module, m, seed: int, states: int = 3) -> None:
    """Mass matrix, bias and forward dynamics of ``module`` equal MuJoCo's for model ``m``."""
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.viscosity = m.opt.density = 0.0
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    for _ in range(states):
        qpos, qvel, q, qd, T, W = mujoco_state(module, m, rng)
        ctrl = rng.uniform(-1, 1, m.nu)
        lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
        limited = m.actuator_ctrllimited.astype(bool)
        ctrl[limited] = lo[limited] + (hi[limited] - lo[limited]) * rng.uniform(0, 1, int(limited.sum()))
        M = mujoco_at(m, d, qpos, qvel, ctrl)
        assert_close(T.T @ module.mass_matrix(q) @ T, M, "mass matrix")
        bias = d.qfrc_bias - d.qfrc_spring - d.qfrc_damper
        assert_close(T.T @ module.inverse_dynamics(q, qd, W), bias, "inverse dynamics at zero qacc")
        actuation = np.linalg.solve(T.T, d.qfrc_actuator)   # generalized forces: tau_mj = T^T tau_ours
        columns = effort_columns(module)
        unactuated = np.setdiff1d(np.arange(m.nv), columns)
        assert not np.any(actuation[unactuated]), "MuJoCo actuates a velocity that has no effort of ours"
        qdd = module.forward_dynamics(q, qd, actuation[columns])
        assert_close(np.linalg.solve(T, qdd - W), d.qacc, "forward dynamics")


def actuated_efforts(m) -> set[str]:
    """Our effort names of the hinge and slide joints MuJoCo's joint actuators drive."""
    names = set()
    for a in range(m.nu):
        if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT):
            j = int(m.actuator_trnid[a, 0])
            if int(m.jnt_type[j]) in (2, 3):
                names.add(("tau_" if int(m.jnt_type[j]) == 3 else "f_") + joint_name(m, j))
    return names


@cache
def gymnasium_module(name: str, directory: str):
    derivation = dynderive.derive(dynderive.load_robot(ASSETS / f"{name}.xml"))
    return import_code(dynderive.render_code(derivation), Path(directory), f"gymnasium_{name}_dynamics")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("gymnasium"))


@pytest.mark.parametrize("name", MODELS)
def test_gymnasium_model_agrees_with_mujoco(name, folder):
    module = gymnasium_module(name, folder)
    m = mujoco.MjModel.from_xml_path(str(ASSETS / f"{name}.xml"))
    assert len(module.COORDINATES) == m.nq and len(getattr(module, "VELOCITIES", module.COORDINATES)) == m.nv
    check_against_mujoco(module, m, seed=sum(map(ord, name)))


@pytest.mark.parametrize("name", MODELS)
def test_gymnasium_efforts_are_the_actuated_joints(name, folder):
    module = gymnasium_module(name, folder)
    m = mujoco.MjModel.from_xml_path(str(ASSETS / f"{name}.xml"))
    assert m.nu > 0
    assert len(module.EFFORTS) == len(set(module.EFFORTS))
    assert set(module.EFFORTS) == actuated_efforts(m)


def test_v5_walker_differs_only_in_friction():
    """walker2d_v5 is left out of the derivations because its equations are walker2d's."""
    a = mujoco.MjModel.from_xml_path(str(ASSETS / "walker2d.xml"))
    b = mujoco.MjModel.from_xml_path(str(ASSETS / "walker2d_v5.xml"))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_pos", "body_quat", "jnt_type",
                  "jnt_axis", "jnt_pos", "dof_damping", "dof_armature", "jnt_stiffness", "qpos_spring",
                  "actuator_gear", "actuator_trnid"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert not np.array_equal(a.geom_friction, b.geom_friction)
