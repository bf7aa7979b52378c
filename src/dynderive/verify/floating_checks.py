"""``dynderive check`` of a floating-base robot: the generated module's functions
against each other, against the power balance along ``integrate`` (which ties the velocity
convention of the dynamics to the configuration's), and against Pinocchio with a
``JointModelFreeFlyer`` root when ``pin`` is installed. Random states: random unit
quaternions, positions and joint coordinates, velocities and efforts."""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..model.symbols import SymbolTable
from .checks import Row, _pinocchio_mass_matrix, _row, generated_module

POWER_BALANCE = "energy balance along integrate: d(T + V)/dt = qd . (inverse_dynamics(q, qd, qdd) - friction_forces(qd))"
MOMENTUM = "momentum conserved without gravity: d(linear, angular momentum)/dt = 0 under the joints' efforts"
ENERGY_RUN = "energy conserved without efforts (simulate on the manifold; with damping or friction, energy + dissipated work)"


def random_configurations(robot: Any, rng: np.random.Generator, states: int) -> np.ndarray:
    """``states`` configurations: floating joints at random positions, random unit quaternions
    (floating and spherical joints), every other coordinate uniform in [-1.5, 1.5]."""
    qs = rng.uniform(-1.5, 1.5, (states, len(robot.configuration_names)))
    for start in robot.quaternion_starts:
        quaternion = rng.normal(size=(states, 4))
        qs[:, start:start + 4] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    return qs


def _applied(robot: Any, u: np.ndarray) -> np.ndarray:
    """The efforts ``u`` at their velocity columns (``Robot.effort_columns``)."""
    Y = np.zeros(robot.velocity_count)
    Y[list(robot.effort_columns())] = u
    return Y


def run_floating_checks(derivation: Derivation, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    robot = derivation.robot
    module = generated_module(source, robot.name)
    values = {p.name: (p.value if p.value is not None else 1.0) for p in robot.parameters}
    rng = np.random.default_rng(seed)
    nv = robot.velocity_count
    qs = random_configurations(robot, rng, states)
    vs = rng.uniform(-1.0, 1.0, (states, nv))
    us = rng.uniform(-1.0, 1.0, (states, len(robot.efforts)))
    M = module.mass_matrix(qs, **values)
    scale = max(1.0, float(np.max(np.abs(M))))
    rows = [_row("M symmetric", (worst := float(np.max(np.abs(M - np.swapaxes(M, -1, -2))))) < 1e-12 * scale,
                 "numeric", worst)]
    eig = np.linalg.eigvalsh(M)
    rows.append(_row(f"M positive definite ({states} random states)", bool(np.all(eig[..., 0] > 0)),
                     "numeric, smallest eigenvalue", float(np.min(eig[..., 0]))))
    zero = np.zeros_like(vs)
    bias = module.inverse_dynamics(qs, vs, zero, **values)
    qdds = module.forward_dynamics(qs, vs, us, **values)
    Y = np.array([_applied(robot, u) for u in us])
    forces = np.einsum("...ij,...j->...i", M, qdds) + bias
    worst = float(np.max(np.abs(module.inverse_dynamics(qs, vs, qdds, **values) - forces)))
    worst = max(worst, float(np.max(np.abs(forces - Y))))
    rows.append(_row("inverse_dynamics = M qdd + inverse_dynamics(q, qd, 0), and = Y at forward_dynamics' qdd",
                     worst < 1e-9 * max(scale, float(np.max(np.abs(forces)))), "numeric", worst))
    gravity = float(np.max(np.abs(module.gravity_vector(qs, **values) - module.inverse_dynamics(qs, zero, zero,
                                                                                                 **values))))
    rows.append(_row("gravity_vector = inverse_dynamics(q, 0, 0)", gravity < 1e-12 * max(1.0, float(np.max(
        np.abs(bias)))), "numeric", gravity))
    rows.append(_power_balance(module, values, qs, vs, rng))
    if robot.floating_base:   # a fixed base (spherical joints only) takes the world's reaction
        rows.append(_momentum(module, robot, values, qs[:6], vs[:6], us[:6]))
    rows.append(_energy_along_a_run(derivation, source, values, qs[0], vs[0]))
    rows += _manifold(module, robot, qs, vs)
    if module.FRAMES:
        rows.append(_frames(module, values, qs[:4], vs[:4]))
    rows.append(_pinocchio(derivation, module, values, qs[:5], vs[:5], us[:5]))
    return rows


def _power_balance(module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
                   rng: np.random.Generator) -> Row:
    """Along ``q(t) = integrate(q, v, t)``, ``v(t) = v + t a``: ``d(T + V)/dt = v . (tau - F)`` with
    ``tau`` the inverse dynamics at ``a`` and ``F`` the joints' damping and friction, by central
    differences: ties the module's velocity convention (integrate) to its dynamics, and
    gravity_vector to potential_energy."""
    h, worst, scale = 1e-5, 0.0, 1.0
    for q, v in zip(qs, vs):
        a = rng.uniform(-1.0, 1.0, v.shape)

        def energy(t: float, q: np.ndarray = q, v: np.ndarray = v, a: np.ndarray = a) -> float:
            moved = module.integrate(q, v, t)
            return float(module.kinetic_energy(moved, v + t * a, **values) + module.potential_energy(moved, **values))

        rate = (energy(h) - energy(-h)) / (2 * h)   # damping and friction take power out: F is not in d(T + V)/dt
        power = float(v @ (module.inverse_dynamics(q, v, a, **values) - module.friction_forces(v, **values)))
        worst, scale = max(worst, abs(rate - power)), max(scale, abs(power))
    return _row(POWER_BALANCE, worst < 1e-6 * scale, f"numeric (h = {h:g})", worst)


def _momentum(module: Any, robot: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
              us: np.ndarray) -> Row:
    """Without gravity and without the efforts of the floating base's own joint (a wrench from
    the world, zeroed here) the efforts are internal: the whole robot's
    linear and angular momentum (``system_momentum``) stays constant. Its rate along
    ``q(t) = integrate(q, v, t)``, ``v(t) = v + t a``, with ``a`` the accelerations the efforts
    give without gravity (``M a = Y - (inverse_dynamics(q, v, 0) - gravity_vector(q))``), by
    central differences, against the size of the gravity-free accelerations' momentum change."""
    h, worst, scale = 1e-5, 0.0, 1.0
    external = [k for k, name in enumerate(robot.efforts)
                for j in robot.joints if j.parent == "world" and name in j.effort_names]
    for q, v, u in zip(qs, vs, us):
        u = np.array(u, dtype=float)
        u[external] = 0.0
        bias = module.inverse_dynamics(q, v, np.zeros_like(v), **values) - module.gravity_vector(q, **values)
        mass = module.mass_matrix(q, **values)
        a = np.linalg.solve(mass, _applied(robot, u) - bias)
        ahead, behind = (system_momentum(module, robot, module.integrate(q, v, s * h), v + s * h * a, values)
                         for s in (1, -1))
        worst = max(worst, float(np.max(np.abs(ahead - behind))) / (2 * h))
        scale = max(scale, float(np.max(np.abs(mass @ a))), float(np.max(np.abs(ahead))))
    return _row(MOMENTUM, worst < 1e-6 * scale, f"numeric (h = {h:g})", worst)


def _energy_along_a_run(derivation: Derivation, source: str, values: dict[str, float], q: np.ndarray,
                        v: np.ndarray, duration: float = 0.5) -> Row:
    """The module's rates (``configuration_rate``, ``forward_dynamics``) integrated without
    efforts from a random state, as ``simulate`` does: the energy T + V stays what it was
    (tolerance 1e-10 of the integrator); with damping or friction T + V + W does, W the work
    they dissipate riding along (Coulomb friction smoothed, ``friction_smoothing`` 0.01, so
    that the integrator meets no jump)."""
    try:
        import scipy  # noqa: F401
    except ImportError:
        return Row(ENERGY_RUN, "skip", "SciPy is not installed", float("nan"))
    from scipy.integrate import solve_ivp

    module = generated_module(source, derivation.robot.name)
    nq, zero = len(q), np.zeros(len(derivation.robot.efforts))

    nv, smoothing = len(v), 0.01

    def rhs(time: float, y: np.ndarray) -> np.ndarray:   # the module's own rates: quaternions stay unit
        qd = y[nq:nq + nv]
        return np.concatenate([module.configuration_rate(y[:nq], qd),
                               module.forward_dynamics(y[:nq], qd, zero, friction_smoothing=smoothing, **values),
                               [qd @ module.friction_forces(qd, friction_smoothing=smoothing, **values)]])

    run = solve_ivp(rhs, (0.0, duration), np.concatenate([q, v, [0.0]]), method="DOP853", rtol=1e-10, atol=1e-10,
                    t_eval=np.linspace(0.0, duration, 3))
    position, velocity, work = run.y[:nq].T, run.y[nq:nq + nv].T, run.y[nq + nv]
    energy = module.kinetic_energy(position, velocity, **values) + module.potential_energy(position, **values) + work
    potential = float(module.potential_energy(q, **values))
    scale = max(1.0, abs(energy[0] - potential) + abs(potential))
    worst = float(np.max(np.abs(energy - energy[0])))
    return _row(ENERGY_RUN, worst < 1e-6 * scale, f"numeric ({duration:g} s simulated)", worst)


def _frames(module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray) -> Row:
    """Each frame's Jacobian times qd against the central difference of its position and
    rotation along ``integrate`` (the angular part from ``dR/dt R^T``)."""
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, v in zip(qs, vs):
        for frame in module.FRAMES:
            ahead, behind = (module.frame_transform(module.integrate(q, v, s * h), frame, **values) for s in (1, -1))
            twist = module.frame_jacobian(q, frame, **values) @ v
            spin = (ahead[:3, :3] - behind[:3, :3]) / (2 * h) @ module.frame_transform(q, frame, **values)[:3, :3].T
            numeric = np.concatenate([(ahead[:3, 3] - behind[:3, 3]) / (2 * h), [spin[2, 1], spin[0, 2], spin[1, 0]]])
            worst, scale = max(worst, float(np.max(np.abs(twist - numeric)))), max(scale, float(np.max(np.abs(twist))))
    return _row(f"frames ({len(module.FRAMES)}): frame_jacobian qd = d(pose)/dt along integrate", worst < 1e-5 * scale,
                f"numeric (h = {h:g})", worst)


def _manifold(module: Any, robot: Any, qs: np.ndarray, vs: np.ndarray) -> list[Row]:
    """``integrate`` keeps quaternions unit; ``difference`` inverts it."""
    moved = module.integrate(qs, vs, 0.7)
    norms = [np.linalg.norm(moved[:, start:start + 4], axis=1) for start in robot.quaternion_starts]
    unit = float(np.max(np.abs(np.array(norms) - 1.0)))
    back = float(np.max(np.abs(module.difference(qs, moved) - 0.7 * vs)))
    return [_row("integrate keeps the quaternions unit", unit < 1e-12, "numeric", unit),
            _row("difference(q, integrate(q, v, dt)) = v dt", back < 1e-9, "numeric", back)]


def _rotate(quaternion: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """The vector rotated by the unit quaternion (x, y, z, w)."""
    u, w = quaternion[..., :3], quaternion[..., 3:]
    t = 2.0 * np.cross(u, vector)
    return vector + w * t + np.cross(u, t)


def system_momentum(module: Any, robot: Any, q: np.ndarray, v: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """The whole robot's momentum ``(linear, angular about the origin)``, shape (..., 6), in the
    axes of the floating joint's placement in the world (its ``origin``: a fixed frame, so
    conservation there is conservation in the world). The floating joint's rows of ``M v`` are
    the momentum in the base's own frame, about its origin; rotated and moved by the base's pose."""
    where_q, where_v = robot.offsets()
    joint = next(j for j in robot.joints if j.parent == "world")   # the robot's one joint to the world
    qi, vi = where_q[joint.name], where_v[joint.name]
    local = np.einsum("...ij,...j->...i", module.mass_matrix(q, **values)[..., vi:vi + 6, :], v)
    quaternion, position = q[..., qi + 3:qi + 7], q[..., qi:qi + 3]
    linear = _rotate(quaternion, local[..., :3])
    angular = _rotate(quaternion, local[..., 3:]) + np.cross(position, linear)
    return np.concatenate([linear, angular], axis=-1)


def pinocchio_floating_model(robot: Any, values: dict[str, float]) -> tuple[Any, np.ndarray, np.ndarray]:
    """Pinocchio's model of a floating-base robot (depth first, a floating joint as a
    ``JointModelFreeFlyer``, a spherical joint as a ``JointModelSpherical``, a ``<mimic>`` joint
    as Pinocchio's mimic joint: ``transformJointIntoMimic``), with where its q and v entries are
    in ours (``q_pin = q[qp]``)."""
    import pinocchio as pin

    table = SymbolTable.for_robot(robot)
    numbers = {table.parameters[name]: sympy.Float(v) for name, v in values.items()}

    def num(text: object) -> float:
        return float(table.expr(text).xreplace(numbers).evalf(17))

    model = pin.Model()
    model.gravity.linear = np.array([num(e) for e in robot.gravity])
    where_q, where_v = robot.offsets()
    frame_of: dict[str, tuple[int, Any]] = {"world": (0, pin.SE3.Identity())}

    def inertia(name: str) -> Any:
        link = robot.link(name)
        ixx, iyy, izz, ixy, ixz, iyz = (num(e) for e in link.inertia)
        return pin.Inertia(num(link.mass), np.array([num(e) for e in link.com]),
                           np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))

    def visit(parent: str) -> None:
        for joint in (j for j in robot.joints if j.parent == parent):
            parent_id, parent_frame = frame_of[parent]
            x, y, z, roll, pitch, yaw = (num(e) for e in joint.origin)
            place = parent_frame * pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.array([x, y, z]))
            if not joint.moves:
                frame_of[joint.child] = (parent_id, place)
                model.appendBodyToJoint(parent_id, inertia(joint.child), place)
            else:
                if joint.multi:
                    kind = pin.JointModelFreeFlyer() if joint.type == "floating" else pin.JointModelSpherical()
                else:
                    axis = np.array([num(e) for e in joint.axis])
                    axis = axis / np.linalg.norm(axis)
                    kind = (pin.JointModelRevoluteUnaligned(axis) if joint.type == "revolute"
                            else pin.JointModelPrismaticUnaligned(axis))
                joint_id = model.addJoint(parent_id, kind, place, joint.name)
                model.appendBodyToJoint(joint_id, inertia(joint.child), pin.SE3.Identity())
                frame_of[joint.child] = (joint_id, pin.SE3.Identity())
            visit(joint.child)

    visit("world")
    for joint in (j for j in robot.joints if j.mimic is not None):
        model = pin.transformJointIntoMimic(model, model.getJointId(joint.mimic.joint), model.getJointId(joint.name),
                                            float(joint.mimic.multiplier), float(joint.mimic.offset))
    qp, vp = np.zeros(model.nq, dtype=int), np.zeros(model.nv, dtype=int)
    for index, (name, jmodel) in enumerate(zip(model.names, model.joints)):
        if index > 0 and index not in model.mimicking_joints:
            qp[jmodel.idx_q:jmodel.idx_q + jmodel.nq] = range(where_q[name], where_q[name] + jmodel.nq)
            vp[jmodel.idx_v:jmodel.idx_v + jmodel.nv] = range(where_v[name], where_v[name] + jmodel.nv)
    return model, qp, vp


def _pinocchio(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
               us: np.ndarray) -> Row:
    name = "agrees with Pinocchio's free flyer (crba, rnea, computeGeneralizedGravity, aba, energies, integrate, " \
        "difference)"
    try:
        import pinocchio as pin
    except ImportError:
        return Row(name, "skip", "pin is not installed", float("nan"))
    robot = derivation.robot
    if any(j.stiffness is not None or j.armature is not None for j in robot.joints):
        return Row(name, "skip", "springs or armature (Pinocchio's free flyer here has neither)", float("nan"))
    model, qp, vp = pinocchio_floating_model(robot, values)
    data = model.createData()
    worst, scale = 0.0, 1.0
    for q, v, u, q1 in zip(qs, vs, us, qs[::-1]):
        a = np.linspace(-1.0, 1.0, len(v))
        M = _pinocchio_mass_matrix(pin, model, data, q[qp])
        friction = module.friction_forces(v, **values)   # damping and friction: joint torques taken from tau
        if model.mimicking_joints:   # Pinocchio 4.1's aba and energies refuse mimic joints
            acc = np.linalg.solve(M, (_applied(robot, u) - friction)[vp] - pin.nonLinearEffects(model, data, q[qp], v[vp]))
            kinetic, potential = 0.5 * v[vp] @ M @ v[vp], _pinocchio_potential(pin, model, data, q[qp])
        else:
            acc = pin.aba(model, data, q[qp], v[vp], (_applied(robot, u) - friction)[vp])
            kinetic = pin.computeKineticEnergy(model, data, q[qp], v[vp])
            potential = pin.computePotentialEnergy(model, data, q[qp])
        diffs = [module.mass_matrix(q, **values)[np.ix_(vp, vp)] - M,
                 module.inverse_dynamics(q, v, a, **values)[vp] - pin.rnea(model, data, q[qp], v[vp], a[vp])
                 - friction[vp],
                 module.gravity_vector(q, **values)[vp] - pin.computeGeneralizedGravity(model, data, q[qp]),
                 module.forward_dynamics(q, v, u, **values)[vp] - acc,
                 module.integrate(q, v, 0.3)[qp] - pin.integrate(model, q[qp], 0.3 * v[vp]),
                 module.difference(q, q1)[vp] - pin.difference(model, q[qp], q1[qp]),
                 module.kinetic_energy(q, v, **values) - kinetic, module.potential_energy(q, **values) - potential]
        worst = max(worst, *(float(np.max(np.abs(d))) for d in diffs))
        scale = max(scale, float(np.max(np.abs(M))), float(np.max(np.abs(acc))))
    return _row(name, worst < 1e-9 * scale, "numeric (mimic joints: M from rnea, aba as M^-1 (tau - nle))"
                if model.mimicking_joints else "numeric", worst)


def _pinocchio_potential(pin: Any, model: Any, data: Any, q: np.ndarray) -> float:
    """Gravity's potential ``-sum m_i g . c_i`` from Pinocchio's placements (what its
    ``computePotentialEnergy`` sums; it refuses mimic joints)."""
    pin.forwardKinematics(model, data, q)
    return -sum(inertia.mass * float(model.gravity.linear @ placement.act(inertia.lever))
                for inertia, placement in zip(model.inertias[1:], data.oMi[1:]))
