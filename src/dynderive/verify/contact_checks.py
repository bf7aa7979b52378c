"""``dynderive check``'s rows on contact dynamics (DESIGN.md sections 11 and 13) of a 3-D robot:
the robot file's contacts, or its first frame held as a point contact when it
declares none (no rows for a robot without frames). ``constrained_forward_dynamics`` must satisfy its own system (inverse dynamics
at its qdd equals the efforts plus J^T forces; the contacts' accelerations, from the frame
functions, are zero) and ``impulse_dynamics`` leave the contacts at rest with the momentum jump
J^T impulses; with closed loops, up to a loop force A^T lambda, the loops' rows held too.
``pinocchio_contacts`` (robots without loops) compares both with Pinocchio's ``forwardDynamics`` and
``impulseDynamics`` given the same contact Jacobians and drifts."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..derivation import Derivation
from .motions import loop_drift
from .rows import Row, _row, peak

KKT = "contacts: inverse dynamics = efforts + J^T forces; contacts held"
PINOCCHIO = "contacts agree with Pinocchio (forwardDynamics, impulseDynamics)"


def held(module: Any) -> list[tuple[str, str]]:
    """The contacts the rows hold: the module's CONTACTS with their kinds, else its first frame
    as a point contact (none for a robot without frames)."""
    if module.CONTACTS:
        return [(frame, module.CONTACT_KINDS.get(frame, "point")) for frame in module.CONTACTS]
    return [(module.FRAMES[0], "point")] if module.FRAMES else []


def contact_terms(module: Any, q: np.ndarray, qd: np.ndarray, contacts: list[tuple[str, str]],
                  values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The stacked contact Jacobian and its drift from the frame functions: a point's linear
    rows in world-aligned axes and its classical acceleration; a surface's twist rows in its
    own axes and its spatial acceleration there (the classical one minus omega x v, rotated)."""
    rows, drifts = [], []
    for frame, kind in contacts:
        J = module.frame_jacobian(q, frame, **values)
        a = module.frame_jacobian_dot_qd(q, qd, frame, **values)
        if kind == "point":
            rows.append(J[:3])
            drifts.append(a[:3])
            continue
        R = module.frame_transform(q, frame, **values)[:3, :3]
        twist = J @ qd
        rows.append(np.vstack([R.T @ J[:3], R.T @ J[3:]]))
        drifts.append(np.concatenate([R.T @ (a[:3] - np.cross(twist[3:], twist[:3])), R.T @ a[3:]]))
    return np.vstack(rows), np.concatenate(drifts)


def _efforts(derivation: Derivation, module: Any, q: np.ndarray, u: np.ndarray, values: dict[str, float]) -> np.ndarray:
    if derivation.robot.floating:
        tau = np.zeros(derivation.robot.velocity_count)
        tau[list(derivation.robot.effort_columns())] = u
        return tau
    return module.generalized_forces(q, u, **values)


def contact_rows(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
                 us: np.ndarray) -> list[Row]:
    """The module's contact dynamics against its own system, at the states given."""
    if not hasattr(module, "constrained_forward_dynamics"):
        return []
    contacts = held(module)
    if not contacts:   # no frame to hold: nothing to check
        return []
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, vs, us):
        try:
            qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts, **values)
            qd_plus, impulses = module.impulse_dynamics(q, qd, contacts, **values)
        except ValueError as error:   # redundant contacts at this state: forces not unique
            return [Row(KKT, "skip", str(error).split(";")[0], float("nan"))]
        J, drift = contact_terms(module, q, qd, contacts, values)
        tau = _efforts(derivation, module, q, u, values)
        balance = module.inverse_dynamics(q, qd, qdd, **values) - tau - J.T @ forces
        jump = module.mass_matrix(q, **values) @ (qd_plus - qd) - J.T @ impulses
        worst = max(worst, peak(J @ qdd + drift), peak(J @ qd_plus))
        if derivation.robot.loops:   # the loops' forces A^T lambda: the parts of balance and jump outside A's row space
            A = module.loop_jacobian(q, **values)
            balance, jump = (r - A.T @ np.linalg.lstsq(A.T, r, rcond=None)[0] for r in (balance, jump))
            worst = max(worst, peak(A @ qdd + loop_drift(module, q, qd, values)), peak(A @ qd_plus))
        worst = max(worst, peak(balance), peak(jump))
        scale = max(scale, peak(tau), peak(forces), peak(impulses), peak(drift))
    names = ", ".join(f"{frame} ({kind})" for frame, kind in contacts)
    return [_row(KKT, worst < 1e-9 * scale, f"numeric, holding {names}", worst)]


def pinocchio_contacts(pin: Any, model: Any, derivation: Derivation, module: Any, values: dict[str, float],
                       qp: np.ndarray, vp: np.ndarray, qs: np.ndarray, vs: np.ndarray, us: np.ndarray) -> list[Row]:
    """Pinocchio's ``forwardDynamics(model, data, q, v, tau, J, gamma, 0)`` and
    ``impulseDynamics(model, data, q, v, J, 0, 0)`` with J and gamma from its own frames
    (LOCAL_WORLD_ALIGNED for a point, LOCAL for a surface) against the module's."""
    if not hasattr(module, "constrained_forward_dynamics") or derivation.robot.dissipative or derivation.robot.loops:
        return []   # Pinocchio's forwardDynamics leaves damping, friction and loops out: the KKT row covers them
    contacts = held(module)
    if not contacts:
        return []
    data = model.createData()
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, vs, us):
        qm, vm = q[qp], qd[vp]
        pin.computeJointJacobians(model, data, qm)
        pin.forwardKinematics(model, data, qm, vm, np.zeros(model.nv))
        pin.updateFramePlacements(model, data)
        rows, drifts = [], []
        for frame, kind in contacts:
            fid = model.getFrameId(frame)
            if kind == "point":
                rows.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3])
                drifts.append(pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear)
            else:
                rows.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL))
                drifts.append(pin.getFrameAcceleration(model, data, fid, pin.LOCAL).vector)
        J, gamma = np.vstack(rows), np.concatenate(drifts)
        try:
            qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts, **values)
            qd_plus, impulses = module.impulse_dynamics(q, qd, contacts, **values)
        except ValueError:
            return []   # redundant contacts: the KKT row says so
        tau = _efforts(derivation, module, q, u, values)[vp]
        ddq = pin.forwardDynamics(model, data, qm, vm, tau, J, gamma, 0.0).copy()
        lambda_c = data.lambda_c.copy()
        after = pin.impulseDynamics(model, data, qm, vm, J, 0.0, 0.0).copy()
        worst = max(worst, peak(qdd[vp] - ddq), peak(forces - lambda_c), peak(qd_plus[vp] - after),
                    peak(impulses - data.impulse_c))
        scale = max(scale, peak(ddq), peak(lambda_c))
    return [_row(PINOCCHIO, worst < 1e-9 * scale, "numeric", worst)]
