"""``dynderive check``'s comparison with MuJoCo itself, for a robot read from an MJCF file
(optional: skipped when ``mujoco`` is not installed).

MuJoCo's state differs from ours only in a free joint's linear velocity (world frame there,
body frame here) and the quaternions' order (w first there): ``to_ours`` maps a MuJoCo state to
ours, with ``T`` (our velocities = ``T`` MuJoCo's) and our accelerations at zero MuJoCo
acceleration, ``W``. Then ``M_mujoco = T' M T``, ``qfrc_bias - qfrc_spring =
T' (inverse_dynamics(q, qd, W) - friction_forces(qd))`` and ``qacc = T^-1 (forward_dynamics(q, qd, u) - W)``
with ``u`` applied at the efforts' joints (``qfrc_applied``; MuJoCo's actuators, whose servos and
activations are not modelled, off), MuJoCo's constraints (contacts, limits, equalities), fluid forces, tendons' springs
and dampers, and the drive terms of free and ball joints turned off, as the equations leave them out.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..derivation import Derivation
from ..input.mjcf import mujoco_messages
from ..input.mjcf_tree import quaternion_matrix
from .rows import Row, _row, peak

NAME = "agrees with MuJoCo (mj_fullM, qfrc_bias, mj_forward's qacc without constraints)"


def to_ours(model: Any, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A MuJoCo state as ours: ``(q, qd, T, W)`` (see the module's docstring)."""
    q, qd = [], []
    T, W = np.eye(model.nv), np.zeros(model.nv)
    for j in range(model.njnt):
        a, v, kind = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_type[j])
        if kind == 0:   # free: position, quaternion w last; linear velocity into the body frame
            w, x, y, z = qpos[a + 3:a + 7]
            R = quaternion_matrix((w, x, y, z))
            linear, angular = R.T @ qvel[v:v + 3], qvel[v + 3:v + 6]
            q += [*qpos[a:a + 3], x, y, z, w]
            qd += [*linear, *angular]
            T[v:v + 3, v:v + 3] = R.T
            W[v:v + 3] = -np.cross(angular, linear)   # d/dt (R' v_world) at zero world acceleration
        elif kind == 1:   # ball: quaternion w last, local angular velocity as MuJoCo's
            w, x, y, z = qpos[a:a + 4]
            q += [x, y, z, w]
            qd += list(qvel[v:v + 3])
        else:
            q.append(qpos[a])
            qd.append(qvel[v])
    return np.array(q), np.array(qd), T, W


def full_mass_matrix(mujoco: Any, model: Any, data: Any) -> np.ndarray:
    """``mj_fullM``'s dense M (MuJoCo 4 takes the data, MuJoCo 3 the sparse ``qM``)."""
    M = np.zeros((model.nv, model.nv))
    try:
        mujoco.mj_fullM(model, data, M)
    except TypeError:
        mujoco.mj_fullM(model, M, data.qM)
    return M


def random_state(model: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A MuJoCo ``(qpos, qvel)``: unit quaternions, other coordinates in [-1, 1]."""
    qpos = rng.uniform(-1.0, 1.0, model.nq)
    for j in range(model.njnt):
        kind, a = int(model.jnt_type[j]), int(model.jnt_qposadr[j])
        if kind in (0, 1):
            start = a + 3 if kind == 0 else a
            quaternion = rng.normal(size=4)
            qpos[start:start + 4] = quaternion / np.linalg.norm(quaternion)
    return qpos, rng.uniform(-1.0, 1.0, model.nv)


def _unmodelled_drives_off(model: Any) -> None:
    """Armature, damping, friction loss and stiffness on free and ball joints off: the reader
    notes them and builds drive terms only for hinge and slide joints."""
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind in (0, 1):
            first = int(model.jnt_dofadr[j])
            dofs = slice(first, first + (6 if kind == 0 else 3))
            model.dof_armature[dofs] = model.dof_damping[dofs] = model.dof_frictionloss[dofs] = 0.0
            model.jnt_stiffness[j] = 0.0


def mujoco_rows(derivation: Derivation, module: Any, values: dict[str, float], states: int,
                rng: np.random.Generator) -> list[Row]:
    """The row for a robot read from an MJCF file (none for other robots)."""
    robot = derivation.robot
    if not robot.source.lower().endswith(".xml"):
        return []
    from ..input.sources import kind_of

    if kind_of(Path(robot.source)) != "mjcf":
        return []
    try:
        import mujoco
    except ImportError:
        return [Row(NAME, "skip", "mujoco is not installed", float("nan"))]
    if robot.loops or robot.mimics:
        return [Row(NAME, "skip", "MuJoCo's equality constraints are soft; ours are exact", float("nan"))]
    if any(p.value is None or values.get(p.name) != p.value for p in robot.parameters):
        return [Row(NAME, "skip", "parameters other than the file's values", float("nan"))]
    with mujoco_messages(mujoco):   # the reader has noted them; MuJoCo would print them and
        model = mujoco.MjSpec.from_file(robot.source).compile()   # write MUJOCO_LOG.TXT here
    if np.any(model.body_gravcomp):
        return [Row(NAME, "skip", "gravity compensation (gravcomp) is not modelled", float("nan"))]
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT) | int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    model.opt.viscosity = model.opt.density = 0.0   # fluid forces are not modelled, nor tendons
    model.tendon_stiffness[:] = model.tendon_damping[:] = 0.0
    _unmodelled_drives_off(model)
    data = mujoco.MjData(model)
    friction = any(j.friction is not None for j in robot.joints)   # MuJoCo's is a constraint, turned off here
    columns = list(robot.effort_columns())
    with mujoco_messages(mujoco):   # an unstable state's warning: neither printed nor logged
        worst = _worst(mujoco, model, data, module, values, states, rng, columns, friction)
    return [_row(NAME, worst <= 1e-9, f"numeric, {states} states, relative, MuJoCo {mujoco.__version__}", worst)]


def _worst(mujoco: Any, model: Any, data: Any, module: Any, values: dict[str, float], states: int,
           rng: np.random.Generator, columns: list[int], friction: bool) -> float:
    """The largest relative residual of M, the bias forces and (without friction) qacc."""
    worst = 0.0
    for _ in range(states):
        qpos, qvel = random_state(model, rng)
        data.qpos[:], data.qvel[:] = qpos, qvel
        u = rng.uniform(-1.0, 1.0, len(columns))
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[columns] = u   # the efforts as applied forces: MuJoCo's actuators (servos, activations) are off
        mujoco.mj_forward(model, data)
        M = full_mass_matrix(mujoco, model, data)
        q, qd, T, W = to_ours(model, qpos, qvel)
        ours_M = T.T @ module.mass_matrix(q, **values) @ T
        bias = data.qfrc_bias - data.qfrc_spring   # ours: damping and Coulomb friction taken off
        ours_bias = T.T @ (module.inverse_dynamics(q, qd, W, **values) - module.friction_forces(qd, **values))
        floor = 1e-12 * peak(M)   # relative residuals, of quantities that may be tiny (a fish's fin)
        residuals = [peak(ours_M - M) / peak(M), peak(ours_bias - bias) / max(peak(bias), floor)]
        if not friction:
            qacc = np.linalg.solve(T, module.forward_dynamics(q, qd, u, **values) - W)
            residuals.append(peak(qacc - data.qacc) / max(peak(data.qacc), floor))
        worst = max(worst, *residuals)
    return worst
