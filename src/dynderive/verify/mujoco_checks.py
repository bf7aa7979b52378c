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
For a robot whose ``connect`` equalities are closed as loops, MuJoCo keeps its equalities (the rest
of its constraints off) and ``qacc`` is its hard limit (``mujoco_hard_limit``), compared at states
the module's ``assemble`` puts on the loops with velocities the loops allow (``from_ours`` maps
them to MuJoCo's), against ``forward_dynamics`` with ``alpha = beta = 0``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..derivation import Derivation
from ..input.mjcf import mujoco_messages
from ..input.mjcf_tree import quaternion_matrix
from .motions import allowed_velocity
from .mujoco_hard_limit import equality_rows, full_mass_matrix, hard_limit
from .rows import Row, _row, peak

NAME = "agrees with MuJoCo (mj_fullM, qfrc_bias, mj_forward's qacc without constraints)"
LOOPS_NAME = "agrees with MuJoCo (mj_fullM, qfrc_bias, qacc in the hard limit of its connect equalities)"


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


def from_ours(model: Any, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Our state as MuJoCo's ``(qpos, qvel)``: ``to_ours`` the other way."""
    qpos, qvel = np.zeros(model.nq), np.zeros(model.nv)
    c = v = 0   # our coordinate and velocity, joint by joint in MuJoCo's order as ours
    for j in range(model.njnt):
        a, dof, kind = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_type[j])
        if kind == 0:
            x, y, z, w = q[c + 3:c + 7]
            qpos[a:a + 7] = [*q[c:c + 3], w, x, y, z]
            qvel[dof:dof + 3] = quaternion_matrix((w, x, y, z)) @ qd[v:v + 3]
            qvel[dof + 3:dof + 6] = qd[v + 3:v + 6]
            c, v = c + 7, v + 6
        elif kind == 1:
            x, y, z, w = q[c:c + 4]
            qpos[a:a + 4] = [w, x, y, z]
            qvel[dof:dof + 3] = qd[v:v + 3]
            c, v = c + 4, v + 3
        else:
            qpos[a], qvel[dof] = q[c], qd[v]
            c, v = c + 1, v + 1
    return qpos, qvel


def _unclosed_equalities(mujoco: Any, model: Any, loops: int) -> str | None:
    """Why MuJoCo's constrained accelerations cannot be compared with ours for a robot with
    loops: an active equality other than a connect, or a connect not closed as a loop here."""
    kinds = {int(v): k[5:].lower() for k, v in mujoco.mjtEq.__members__.items() if k.startswith("mjEQ_")}
    active = [e for e in range(model.neq) if model.eq_active0[e]]
    other = [e for e in active if int(model.eq_type[e]) != int(mujoco.mjtEq.mjEQ_CONNECT)]
    if other:
        e = other[0]
        return (f"MuJoCo's {kinds.get(int(model.eq_type[e]), 'other')} equality "
                f"'{model.equality(e).name or f'equality{e}'}' is not modelled here: constrained accelerations not compared")
    if len(active) != loops:
        return (f"{len(active) - loops} of MuJoCo's {len(active)} connect equalities are not loops here (to the world "
                "or within one rigid body): constrained accelerations not compared")
    return None


def mujoco_rows(derivation: Derivation, module: Any, values: dict[str, float], states: int,
                rng: np.random.Generator) -> list[Row]:
    """The row for a robot read from an MJCF file (none for other robots)."""
    robot = derivation.robot
    if not robot.source.lower().endswith(".xml"):
        return []
    from ..input.sources import kind_of

    if kind_of(Path(robot.source)) != "mjcf":
        return []
    name = LOOPS_NAME if robot.loops else NAME
    try:
        import mujoco
    except ImportError:
        return [Row(name, "skip", "mujoco is not installed", float("nan"))]
    if robot.mimics:
        return [Row(name, "skip", "joint equalities: our coordinates are the leading joints', MuJoCo's every "
                    "joint's (not compared)", float("nan"))]
    if any(p.value is None or values.get(p.name) != p.value for p in robot.parameters):
        return [Row(name, "skip", "parameters other than the file's values", float("nan"))]
    with mujoco_messages(mujoco):   # the reader has noted them; MuJoCo would print them and
        model = mujoco.MjSpec.from_file(robot.source).compile()   # write MUJOCO_LOG.TXT here
    if np.any(model.body_gravcomp):
        return [Row(name, "skip", "gravity compensation (gravcomp) is not modelled", float("nan"))]
    off = mujoco.mjtDisableBit
    if robot.loops:   # the equalities' rows only: contacts, limits and friction loss off
        unclosed = _unclosed_equalities(mujoco, model, len(robot.loops))
        if unclosed:
            return [Row(name, "skip", unclosed, float("nan"))]
        model.opt.disableflags |= int(off.mjDSBL_CONTACT) | int(off.mjDSBL_LIMIT) | int(off.mjDSBL_FRICTIONLOSS)
        model.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_DENSE)   # efc_J as a dense matrix
    else:
        model.opt.disableflags |= int(off.mjDSBL_CONSTRAINT)
    model.opt.disableflags |= int(off.mjDSBL_ACTUATION)
    model.opt.viscosity = model.opt.density = 0.0   # fluid forces are not modelled, nor tendons
    model.tendon_stiffness[:] = model.tendon_damping[:] = 0.0
    _unmodelled_drives_off(model)
    data = mujoco.MjData(model)
    friction = any(j.friction is not None for j in robot.joints)   # MuJoCo's is a constraint, turned off here
    columns = list(robot.effort_columns())
    with mujoco_messages(mujoco):   # an unstable state's warning: neither printed nor logged
        worst, compared = _worst(mujoco, model, data, module, values, states, rng, columns, friction, bool(robot.loops))
    if not compared:
        return [Row(name, "FAIL", "numeric: no random state could be assembled", float("nan"))]
    return [_row(name, worst <= 1e-9, f"numeric, {compared} states, relative, MuJoCo {mujoco.__version__}", worst)]


def _loop_states(module: Any, values: dict[str, float]) -> Any:
    """A draw of MuJoCo states on the loops: a perturbed configuration assembled by the module's
    ``assemble`` (the independent coordinates of the module's assembly moved, or, with
    quaternions in q, MuJoCo's ``qpos0`` moved along ``integrate`` and every coordinate
    assembled, the free joints' poses random), velocities in the null space of A_g; None where
    ``assemble`` does not converge."""

    def draw(model: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray] | None:
        qpos, qvel = random_state(model, rng)
        free = np.zeros(model.nv, dtype=bool)
        start = model.qpos0.copy()
        for j in range(model.njnt):
            if int(model.jnt_type[j]) == 0:   # a free joint's pose does not touch the loops
                a, dof = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
                start[a:a + 7], free[dof:dof + 6] = qpos[a:a + 7], True
        q0, qd, _, _ = to_ours(model, start, qvel)
        if hasattr(module, "INDEPENDENT_COORDINATES"):
            guess = np.array(module.ASSEMBLED_CONFIGURATION, dtype=float)
            independent = [module.COORDINATES.index(c) for c in module.INDEPENDENT_COORDINATES]
            guess[independent] += rng.uniform(-0.4, 0.4, len(independent))
        else:
            guess = module.integrate(q0, np.where(free, 0.0, rng.uniform(-0.4, 0.4, model.nv)))
        try:
            q = module.assemble(guess, **values)
        except (ValueError, np.linalg.LinAlgError):
            return None
        return from_ours(model, q, allowed_velocity(module, q, qd, values))

    return draw


def _worst(mujoco: Any, model: Any, data: Any, module: Any, values: dict[str, float], states: int,
           rng: np.random.Generator, columns: list[int], friction: bool, loops: bool) -> tuple[float, int]:
    """The largest relative residual of M, the bias forces and (without friction) qacc, MuJoCo's
    own or, with loops, its hard limit (``mujoco_hard_limit``); and the number of states. With
    loops, M and the bias forces (the tree's) are compared at a velocity the loops need not allow:
    a locked linkage allows none, and its bias at rest is rounding."""
    draw = _loop_states(module, values) if loops else random_state
    worst, compared = 0.0, 0
    for _ in range(4 * states if loops else states):   # a guess assemble does not close: another
        if compared == states:
            break
        state = draw(model, rng)
        if state is None:
            continue
        qpos, qvel = state
        u = rng.uniform(-1.0, 1.0, len(columns))
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[columns] = u   # the efforts as applied forces: MuJoCo's actuators (servos, activations) are off
        residuals = _tree_residuals(mujoco, model, data, module, values, qpos,
                                    rng.uniform(-1.0, 1.0, model.nv) if loops else qvel)
        if not friction:
            if loops:
                data.qvel[:] = qvel
                mujoco.mj_forward(model, data)
            q, qd, T, W = to_ours(model, qpos, qvel)
            qacc = hard_limit(model, data, *equality_rows(model, data)) if loops else data.qacc
            ours = np.linalg.solve(T, module.forward_dynamics(q, qd, u, **values) - W)
            floor = 1e-12 * peak(full_mass_matrix(model, data))
            scale = max(peak(qacc), peak(data.qacc_smooth), floor)   # a locked linkage's qacc is rounding
            residuals.append(peak(ours - qacc) / scale)
        worst, compared = max(worst, *residuals), compared + 1
    return worst, compared


def _tree_residuals(mujoco: Any, model: Any, data: Any, module: Any, values: dict[str, float], qpos: np.ndarray,
                    qvel: np.ndarray) -> list[float]:
    """``mj_forward`` at ``(qpos, qvel)``, and the relative residuals of M and the bias forces."""
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    M = full_mass_matrix(model, data)
    q, qd, T, W = to_ours(model, qpos, qvel)
    ours_M = T.T @ module.mass_matrix(q, **values) @ T
    bias = data.qfrc_bias - data.qfrc_spring   # ours: damping and Coulomb friction taken off
    ours_bias = T.T @ (module.inverse_dynamics(q, qd, W, **values) - module.friction_forces(qd, **values))
    floor = 1e-12 * peak(M)   # relative residuals, of quantities that may be tiny (a fish's fin)
    return [peak(ours_M - M) / peak(M), peak(ours_bias - bias) / max(peak(bias), floor)]
