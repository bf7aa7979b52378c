"""``dynderive check``'s comparisons with Pinocchio (optional: skipped when ``pin`` is not
installed), for every robot: the model of ``pinocchio_model`` (a floating joint as its free
flyer, a spherical joint as its spherical joint, ``<mimic>`` joints as its mimic joints),
against the generated module's mass matrix, bias and gravity forces and forward dynamics, its
frames; with quaternions, its energies, ``integrate`` and ``difference`` too; a 3-D robot's centre of
mass and centroidal momentum (``centroidal_checks.pinocchio_centroidal``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..derivation import Derivation
from ..model.robot import Robot
from .rows import Row, _row, applied, peak

FREE_FLYER = ("agrees with Pinocchio's free flyer (crba, rnea, computeGeneralizedGravity, aba, energies, integrate, "
              "difference)")


def pinocchio_rows(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
                   us: np.ndarray) -> list[Row]:
    """The rows: the dynamics (and with quaternions the configuration maps and energies), and
    the frames where the robot has frames and no quaternions."""
    robot = derivation.robot
    name = (FREE_FLYER.replace("aba, ", "") + " (open tree)" if robot.loops else FREE_FLYER) if robot.floating else \
        "agrees with Pinocchio (crba, rnea" + (", open tree)" if robot.loops else ", aba)")
    try:
        import pinocchio as pin
    except ImportError:
        return [Row(name, "skip", "pin is not installed", float("nan"))]
    from .centroidal_checks import pinocchio_centroidal
    from .contact_checks import pinocchio_contacts
    from .pinocchio_model import NoReference, PinocchioDrives, pinocchio_maps

    try:
        model, qp, vp = pinocchio_maps(robot, values)
    except NoReference as exc:
        return [Row(name, "skip", str(exc), float("nan"))]
    # the centre of mass and the centroidal momentum need neither drives nor the file's defaults
    centroidal = [] if robot.planar else [pinocchio_centroidal(pin, model, module, values, qp, vp, qs, vs),
                                          *pinocchio_contacts(pin, model, derivation, module, values, qp, vp, qs, vs, us)]
    if robot.floating and any(j.stiffness is not None or j.armature is not None for j in robot.joints):
        return [Row(name, "skip", "springs or armature (Pinocchio's free flyer here has neither)", float("nan")),
                *centroidal]
    if not robot.floating and any(p.value is None for p in robot.parameters):
        return [Row(name, "skip", "a parameter has no default value", float("nan")), *centroidal]
    data = model.createData()
    rows = [_dynamics(name, pin, model, data, qp, vp, PinocchioDrives(robot, values, vp), robot, module, values,
                      qs, vs, us)]
    if module.FRAMES and not robot.floating:
        rows.append(_frames(pin, model, data, vp, module, values, qs, vs))
    return rows + centroidal


def _accelerations(pin: Any, model: Any, data: Any, q: np.ndarray, v: np.ndarray, tau: np.ndarray,
                   M: np.ndarray) -> np.ndarray:
    """Pinocchio's forward dynamics under ``tau``: its aba, or with mimic joints (which its aba
    refuses) ``M^-1 (tau - nle)``."""
    if model.mimicking_joints:
        return np.linalg.solve(M, tau - pin.nonLinearEffects(model, data, q, v))
    return pin.aba(model, data, q, v, tau)


def _dynamics(name: str, pin: Any, model: Any, data: Any, qp: np.ndarray, vp: np.ndarray, drives: Any, robot: Robot,
              module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray, us: np.ndarray) -> Row:
    """M, the gravity forces and the forward dynamics (Pinocchio has the armature). A fixed
    base (``q_pin = q[qp]`` with ``qp = vp``): the bias forces C qd too, under efforts spread over
    [-1, 1], the springs and dissipation added here (with loops forward_dynamics is the
    constrained one: not compared). With quaternions: the inverse dynamics (damping and
    friction: joint torques taken from tau), ``integrate``, ``difference`` and the energies."""
    worst, scale = 0.0, 1.0
    for q, v, u, q1 in zip(qs, vs, us, qs[::-1]):
        qm, vm = q[qp], v[vp]
        M = mass_matrix(pin, model, data, qm)
        diffs = [module.mass_matrix(q, **values)[np.ix_(vp, vp)] - M]
        if not robot.floating:
            u = np.linspace(-1, 1, len(q))[: len(module.EFFORTS)]
            g = pin.computeGeneralizedGravity(model, data, qm) + drives.spring(qm)
            bias = pin.rnea(model, data, qm, vm, np.zeros(len(q))) - pin.computeGeneralizedGravity(model, data, qm)
            Y = module.generalized_forces(q, u, **values)
            acc = _accelerations(pin, model, data, qm, vm, Y[vp] - drives.spring(qm) - drives.dissipative(vm), M)
            diffs += [module.gravity_vector(q, **values)[vp] - g, (module.coriolis_matrix(q, v, **values) @ v)[vp] - bias]
            if not robot.loops:   # with loops forward_dynamics is the constrained one
                diffs.append(module.forward_dynamics(q, v, u, **values)[vp] - acc)
        else:
            a = np.linspace(-1.0, 1.0, len(v))
            friction = module.friction_forces(v, **values)
            acc = _accelerations(pin, model, data, qm, vm, (applied(robot, u) - friction)[vp], M)
            if model.mimicking_joints:   # Pinocchio 4.1's energies refuse mimic joints
                kinetic, potential = 0.5 * vm @ M @ vm, _potential(pin, model, data, qm)
            else:
                kinetic = pin.computeKineticEnergy(model, data, qm, vm)
                potential = pin.computePotentialEnergy(model, data, qm)
            diffs += [module.inverse_dynamics(q, v, a, **values)[vp] - pin.rnea(model, data, qm, vm, a[vp]) - friction[vp],
                      module.gravity_vector(q, **values)[vp] - pin.computeGeneralizedGravity(model, data, qm),
                      # with loops forward_dynamics is the constrained one
                      0.0 if robot.loops else module.forward_dynamics(q, v, u, **values)[vp] - acc,
                      module.integrate(q, v, 0.3)[qp] - pin.integrate(model, qm, 0.3 * vm),
                      module.difference(q, q1)[vp] - pin.difference(model, qm, q1[qp]),
                      module.kinetic_energy(q, v, **values) - kinetic, module.potential_energy(q, **values) - potential]
        worst = max(worst, *(peak(d) for d in diffs))
        scale = max(scale, peak(M), peak(acc))
    mimic = robot.floating and model.mimicking_joints
    return _row(name, worst < 1e-9 * scale, "numeric (mimic joints: M from rnea, aba as M^-1 (tau - nle))"
                if mimic else "numeric", worst)


def mass_matrix(pin: Any, model: Any, data: Any, q: np.ndarray) -> np.ndarray:
    """Pinocchio's M(q): its crba; with mimic joints, column by column from its rnea (Pinocchio
    4.1's crba is wrong for a mimic joint below its leader with a joint between them)."""
    if not model.mimicking_joints:
        M = pin.crba(model, data, q)
        return np.triu(M) + np.triu(M, 1).T
    zero = np.zeros(model.nv)
    base = pin.rnea(model, data, q, zero, zero)
    return np.array([pin.rnea(model, data, q, zero, e) - base for e in np.eye(model.nv)]).T


def _potential(pin: Any, model: Any, data: Any, q: np.ndarray) -> float:
    """Gravity's potential ``-sum m_i g . c_i`` from Pinocchio's placements (what its
    ``computePotentialEnergy`` sums; it refuses mimic joints)."""
    pin.forwardKinematics(model, data, q)
    return -sum(inertia.mass * float(model.gravity.linear @ placement.act(inertia.lever))
                for inertia, placement in zip(model.inertias[1:], data.oMi[1:]))


def _frames(pin: Any, model: Any, data: Any, perm: np.ndarray, module: Any, values: dict[str, float],
            qs: np.ndarray, qds: np.ndarray) -> Row:
    """Frame placements, LOCAL_WORLD_ALIGNED Jacobians and classical accelerations at qdd = 0."""
    planar = module.frame_jacobian(qs[0], module.FRAMES[0], **values).shape[0] == 3
    rows, k = ([0, 1, 5], 2) if planar else (list(range(6)), 3)
    worst = 0.0
    for q, qd in zip(qs, qds):
        qp, qdp = q[perm], qd[perm]
        pin.forwardKinematics(model, data, qp, qdp, np.zeros(len(q)))
        pin.computeJointJacobians(model, data, qp)
        pin.updateFramePlacements(model, data)
        for frame in module.FRAMES:
            fid = model.getFrameId(frame)
            T = module.frame_transform(q, frame, **values)
            placement = data.oMf[fid]
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[rows]
            acceleration = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            expected = np.concatenate([acceleration.linear, acceleration.angular])[rows]
            diffs = [T[:k, :k] - placement.rotation[:k, :k], T[:k, -1] - placement.translation[:k],
                     module.frame_jacobian(q, frame, **values)[:, perm] - J,
                     module.frame_jacobian_dot_qd(q, qd, frame, **values) - expected]
            worst = max(worst, *(peak(d) for d in diffs))
    return _row("frames agree with Pinocchio (placement, LOCAL_WORLD_ALIGNED Jacobian, classical acceleration)",
                worst < 1e-9, "numeric", worst)
