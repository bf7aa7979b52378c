"""``dynderive check``: every consistency check that applies to a derivation.

Symbolic checks where they are cheap, numeric ones at random states otherwise; the
generated code is checked against the symbolic result, and against Pinocchio when ``pin`` is
installed. Each row says how it was checked and its worst residual.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..mechanics.tidy import Check, check_zero, is_small

#: Quantities larger than this (tree nodes) are not evaluated symbolically against the code.
SYMBOLIC_EVALUATION_NODES = 60_000


@dataclass(frozen=True)
class Row:
    name: str
    status: str        # "pass", "FAIL" or "skip"
    method: str        # "symbolic", "numeric", "engine", or why it was skipped
    residual: float

    def as_dict(self) -> dict[str, Any]:
        """The row for JSON: a residual that is not a number (a skipped check) is null."""
        row = asdict(self)
        row["residual"] = self.residual if np.isfinite(self.residual) else None
        return row


def generated_module(source: str, name: str) -> types.ModuleType:
    """Execute generated source (ours, never user text) as a fresh module."""
    module = types.ModuleType(f"{name}_dynamics")
    exec(compile(source, f"<{name}_dynamics.py>", "exec"), module.__dict__)  # noqa: S102
    return module


def _row(name: str, passed: bool, method: str, residual: float) -> Row:
    return Row(name, "pass" if passed else "FAIL", method, float(residual))


def _from_check(check: Check) -> Row:
    if check.skipped:
        return Row(check.name, "skip", "not derived (too large)", float("nan"))
    return _row(check.name, check.passed, f"engine, {check.method}", check.residual)


def run_checks(derivation: Derivation, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    robot, quantities = derivation.robot, derivation.quantities
    module = generated_module(source, robot.name)
    values = {p.name: (p.value if p.value is not None else 1.0) for p in robot.parameters}
    rng = np.random.default_rng(seed)
    n = len(robot.coordinates)
    qs = rng.uniform(-1.5, 1.5, (states, n))
    qds = rng.uniform(-1.0, 1.0, (states, n))
    us = rng.uniform(-1.0, 1.0, (states, len(robot.efforts)))
    rows: list[Row] = []
    if robot.loops:   # states on the loop constraints, velocities the loops allow
        qs, qds, loop_rows = _loop_states(derivation, module, values, qs, qds)
        us = us[: len(qs)]
        rows += loop_rows

    M = quantities["M_g"]
    if is_small(M, SYMBOLIC_EVALUATION_NODES):
        check = check_zero("M symmetric", "", M - M.T, [])
        rows.append(_row("M symmetric", check.passed, check.method, check.residual))
    else:
        mats = module.mass_matrix(qs, **values)
        worst = float(np.max(np.abs(mats - np.swapaxes(mats, -1, -2))))
        rows.append(_row("M symmetric", worst < 1e-9, "numeric", worst))
    eig = np.linalg.eigvalsh(module.mass_matrix(qs, **values))
    rows.append(_row(f"M positive definite ({states} random states)", bool(np.all(eig[..., 0] > 0)),
                     "numeric, smallest eigenvalue", float(np.min(eig[..., 0]))))
    rows.append(_skew_check(derivation, module, values, qs, qds))
    rows.append(_power_balance(module, values, qs, qds, us, robot.dissipative))
    if robot.loops:
        rows.append(_reduced_agrees(module, values, qs, qds, us))
    rows += [_from_check(c) for c in derivation.checks]
    if "M_m" in quantities:
        rows += _maximal_checks(module, values, qs, qds, us)
    rows += _code_matches_symbolic(derivation, module, values, qs[:3], qds[:3], us[:3])
    rows += _derived_functions(module, values, qs[:4], qds[:4], us[:4], rng)
    rows += _pinocchio(derivation, module, values, qs[:5], qds[:5])
    return rows


def _derived_functions(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray, us: np.ndarray,
                       rng: np.random.Generator) -> list[Row]:
    """The module's linearization, regressor and frames against what they differentiate or
    factor: central differences of ``forward_dynamics`` and of the frames' poses, and
    ``inverse_dynamics`` itself."""
    n, h = qs.shape[1], 1e-6
    rows = []
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        A, B = module.linearize(q, qd, u, **values)
        x = np.concatenate([q, qd])

        def xdot(state: np.ndarray, effort: np.ndarray) -> np.ndarray:
            return np.concatenate([state[n:], module.forward_dynamics(state[:n], state[n:], effort, **values)])

        numeric = np.array([(xdot(x + h * e, u) - xdot(x - h * e, u)) / (2 * h) for e in np.eye(2 * n)]).T
        inputs = np.array([(xdot(x, u + h * e) - xdot(x, u - h * e)) / (2 * h) for e in np.eye(len(u))]).T
        worst = max(worst, float(np.max(np.abs(A - numeric))), float(np.max(np.abs(B - inputs.reshape(B.shape)),
                                                                            initial=0.0)))
        scale = max(scale, float(np.max(np.abs(A))))
    rows.append(_row("linearize matches central differences of forward_dynamics", worst < 1e-5 * scale,
                     "numeric (h = 1e-6)", worst))
    qdds = rng.uniform(-1.0, 1.0, qs.shape)
    Y = module.regressor(qs, qds, qdds, **values)
    tau = module.inverse_dynamics(qs, qds, qdds, **values)
    residual = float(np.max(np.abs(Y @ module.parameter_vector(**values) - tau)))
    rows.append(_row("regressor(q, qd, qdd) @ parameter_vector() = inverse_dynamics (the tree's)",
                     residual < 1e-9 * max(1.0, float(np.max(np.abs(tau)))), "numeric", residual))
    if module.FRAMES:
        worst, scale = 0.0, 1.0
        for q, qd in zip(qs, qds):
            for frame in module.FRAMES:
                J = module.frame_jacobian(q, frame, **values)
                ahead, behind = (module.frame_transform(q + s * h * qd, frame, **values) for s in (1, -1))
                linear = (ahead[:-1, -1] - behind[:-1, -1]) / (2 * h)
                rate = (module.frame_jacobian(q + h * qd, frame, **values)
                        - module.frame_jacobian(q - h * qd, frame, **values)) @ qd / (2 * h)
                worst = max(worst, float(np.max(np.abs(J[: len(linear)] @ qd - linear))),
                            float(np.max(np.abs(module.frame_jacobian_dot_qd(q, qd, frame, **values) - rate))))
                scale = max(scale, float(np.max(np.abs(J))))
        rows.append(_row(f"frames ({len(module.FRAMES)}): J qd = dp/dt and Jdot qd = d(J qd)/dt", worst < 1e-5 * scale,
                         "numeric (h = 1e-6)", worst))
    return rows


def _loop_states(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                 qds: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[Row]]:
    """Random configurations assembled by the generated ``assemble`` (independent coordinates
    near the default assembly), and velocities projected onto the null space of A_g."""
    model = derivation.steps["loops"]
    start = np.array(model.assembled if model.assembled is not None else np.zeros(qs.shape[1]))
    states, rates = [], []
    for q, qd in zip(qs, qds):
        guess = start.copy()
        guess[model.independent] += 0.4 * q[model.independent]
        try:
            assembled = module.assemble(guess, **values)
        except (ValueError, np.linalg.LinAlgError):
            continue
        states.append(assembled)
        rates.append(allowed_velocity(module, assembled, qd, values))
    rows = []
    if not states:
        return qs[:0], qds[:0], [Row("loop constraints hold at assembled states", "FAIL",
                                     "numeric: no random state could be assembled", float("nan"))]
    qs, qds = np.array(states), np.array(rates)
    residual = float(np.max(np.abs(module.loop_constraints(qs, **values))))
    rows.append(_row(f"loop constraints a_g = 0 at {len(qs)} assembled states", residual < 1e-9, "numeric", residual))
    velocity = float(np.max(np.abs(np.einsum("...ij,...j->...i", module.loop_jacobian(qs, **values), qds))))
    rows.append(_row("A_g qd = 0 for the velocities the loops allow", velocity < 1e-9, "numeric", velocity))
    return qs, qds, rows


def allowed_velocity(module: Any, q: np.ndarray, qd: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """``qd`` projected onto the motions the loops allow at ``q``."""
    null = _allowed_motions(module, q, values)
    return null.T @ (null @ qd)


def _allowed_motions(module: Any, q: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """Orthonormal rows spanning the motions the loops allow at ``q``: the null space of A_g,
    of dimension the mobility (the rows of an over-constrained mechanism's A_g are dependent)."""
    A = module.loop_jacobian(q, **values)
    return np.linalg.svd(A)[2][A.shape[1] - len(module.INDEPENDENT_COORDINATES):]


def _reduced_agrees(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                    us: np.ndarray) -> Row:
    """The reduced form R^T (M qdd + C qd + N - Y) = 0 (R: a basis of the motions the loops
    allow) holds for the constrained accelerations of the multiplier form."""
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        R = _allowed_motions(module, q, values).T
        qdd = module.forward_dynamics(q, qd, u, **values)
        worst = max(worst, float(np.max(np.abs(module.reduced_forward_dynamics(q, qd, u, **values) - qdd))))
        forces = module.mass_matrix(q, **values) @ qdd + module.inverse_dynamics(q, qd, np.zeros(len(q)), **values) \
            - module.generalized_forces(q, u, **values)
        worst = max(worst, float(np.max(np.abs(R.T @ forces))))
        scale = max(scale, float(np.max(np.abs(forces))))
    return _row("reduced form R_g^T (M qdd + C qd + N - Y) = 0, reduced_forward_dynamics == forward_dynamics",
                worst < 1e-9 * scale, "numeric", worst)


def _skew_check(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                qds: np.ndarray) -> Row:
    name = "Mdot - 2C skew-symmetric"
    table, M, C = derivation.symbols, derivation["M_g"], derivation["C_g"]
    if is_small(M, 2000) and is_small(C, 4000) and not derivation.intermediate_form:
        Mdot = sum((M.diff(qk) * qdk for qk, qdk in zip(table.q, table.qd)), sympy.zeros(*M.shape))
        S = Mdot - 2 * C
        check = check_zero(name, "", S + S.T, [])
        return _row(name, check.passed, check.method, check.residual)
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, qd in zip(qs, qds):
        Mdot = (module.mass_matrix(q + h * qd, **values) - module.mass_matrix(q - h * qd, **values)) / (2 * h)
        S = Mdot - 2 * module.coriolis_matrix(q, qd, **values)
        worst = max(worst, float(np.max(np.abs(S + S.T))))
        scale = max(scale, float(np.max(np.abs(Mdot))))
    return _row(name, worst < 1e-6 * scale, "numeric (central differences)", worst)


def _power_balance(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                   us: np.ndarray, dissipative: bool) -> Row:
    """dE/dt = qd . Y - qd . F along the dynamics, E = T + V (springs in V, armature in T): the
    dissipated power qd . F of damping and friction is measured, not ignored."""
    h, worst, scale = 1e-5, 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        qdd = module.forward_dynamics(q, qd, u, **values)

        def energy(t: float, q: np.ndarray = q, qd: np.ndarray = qd, qdd: np.ndarray = qdd) -> float:
            qt, qdt = q + qd * t + qdd * t**2 / 2, qd + qdd * t
            return float(module.kinetic_energy(qt, qdt, **values) + module.potential_energy(qt, **values))

        rate = (energy(h) - energy(-h)) / (2 * h)
        dissipated = float(qd @ module.friction_forces(qd, **values))
        power = float(qd @ module.generalized_forces(q, u, **values)) - dissipated
        worst = max(worst, abs(rate - power))
        scale = max(scale, abs(power), abs(dissipated))
    name = "power balance dE/dt = qd . Y - qd . F" if dissipative else "power balance dE/dt = qd . Y"
    return _row(name, worst < 1e-5 * scale, "numeric (central differences)", worst)


def _maximal_checks(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                    us: np.ndarray) -> list[Row]:
    worst = {"H^T M_m H = M_g": 0.0, "H^T (M_m Hdot + C_m H) qd = C_g qd": 0.0, "H^T N_m = N_g": 0.0,
             "H^T Y_m = Y_g": 0.0, "constraint forces consistent": 0.0}
    h = 1e-6
    for q, qd, u in zip(qs, qds, us):
        hq = module.to_maximal(q, **values)
        H = module.to_maximal_jacobian(q, **values)
        Hdot = (module.to_maximal_jacobian(q + h * qd, **values) - module.to_maximal_jacobian(q - h * qd, **values)) / (2 * h)
        v = H @ qd
        Mm = module.maximal_mass_matrix(hq, **values)
        Cm = module.maximal_coriolis_matrix(hq, v, **values)
        Ym = module.maximal_efforts(hq, u, **values)
        pairs = {
            "H^T M_m H = M_g": (H.T @ Mm @ H, module.mass_matrix(q, **values)),
            "H^T (M_m Hdot + C_m H) qd = C_g qd": (H.T @ (Mm @ Hdot + Cm @ H) @ qd,
                                                   module.coriolis_matrix(q, qd, **values) @ qd),
            "H^T N_m = N_g": (H.T @ module.maximal_gravity_vector(hq, **values), module.gravity_vector(q, **values)),
            "H^T Y_m = Y_g": (H.T @ Ym, module.generalized_forces(q, u, **values)),
        }
        friction = np.zeros(len(v))
        if hasattr(module, "maximal_friction_forces"):
            friction = module.maximal_friction_forces(hq, v, **values)
            pairs["H^T F_m = F_g"] = (H.T @ friction, module.friction_forces(qd, **values))
        for key, (a, b) in pairs.items():
            worst[key] = max(worst.get(key, 0.0), float(np.max(np.abs(a - b))))
        qmdd = module.maximal_forward_dynamics(hq, v, u, **values)
        lam = module.constraint_forces(hq, v, u, **values)
        A = module.constraint_jacobian(hq, **values)
        residual = Mm @ qmdd + Cm @ v + module.maximal_gravity_vector(hq, **values) + friction + A.T @ lam - Ym
        acceleration = A @ qmdd + module.constraint_jacobian_dot(hq, v, **values) @ v
        worst["constraint forces consistent"] = max(worst["constraint forces consistent"],
                                                    float(np.max(np.abs(residual))), float(np.max(np.abs(acceleration))))
    tolerance = {"H^T (M_m Hdot + C_m H) qd = C_g qd": 1e-5}
    return [_row(k, w < tolerance.get(k, 1e-8), "numeric", w) for k, w in worst.items()]


def _code_matches_symbolic(derivation: Derivation, module: Any, values: dict[str, float],
                           qs: np.ndarray, qds: np.ndarray, us: np.ndarray) -> list[Row]:
    table = derivation.symbols
    params = [table.parameters[p.name] for p in derivation.robot.parameters]
    specs: list[tuple[str, str, Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]]] = [
        ("M_g", "mass_matrix", lambda q, qd, u: module.mass_matrix(q, **values)),
        ("C_g", "coriolis_matrix", lambda q, qd, u: module.coriolis_matrix(q, qd, **values)),
        ("N_g", "gravity_vector", lambda q, qd, u: module.gravity_vector(q, **values)),
        ("T_g", "kinetic_energy", lambda q, qd, u: module.kinetic_energy(q, qd, **values)),
        ("V_g", "potential_energy", lambda q, qd, u: module.potential_energy(q, **values)),
    ]
    if "F_g" in derivation:
        specs.append(("F_g", "friction_forces", lambda q, qd, u: module.friction_forces(qd, **values)))
    rows = []
    for quantity, function, call in specs:
        name = f"generated {function} == symbolic {quantity}"
        value = derivation[quantity]
        if not is_small(value if not isinstance(value, sympy.MatrixBase) else sympy.Tuple(*value),
                        SYMBOLIC_EVALUATION_NODES):
            rows.append(Row(name, "skip", "symbolic form too large to evaluate", float("nan")))
            continue
        symbolic = derivation.lambdify([table.q, table.qd, list(table.efforts.values()), params], value)
        worst, scale = 0.0, 1.0
        for q, qd, u in zip(qs, qds, us):
            expected = np.asarray(symbolic(q, qd, u, [values[p.name] for p in params]), dtype=float)
            got = np.asarray(call(q, qd, u), dtype=float)
            worst = max(worst, float(np.max(np.abs(expected.reshape(got.shape) - got))))
            scale = max(scale, float(np.max(np.abs(expected))))
        rows.append(_row(name, worst <= 1e-10 * scale, "numeric", worst))
    return rows


def _pinocchio(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
               qds: np.ndarray) -> list[Row]:
    name = "agrees with Pinocchio (crba, rnea" + (", open tree)" if derivation.robot.loops else ", aba)")
    try:
        import pinocchio as pin
    except ImportError:
        return [Row(name, "skip", "pin is not installed", float("nan"))]
    if any(p.value is None for p in derivation.robot.parameters):
        return [Row(name, "skip", "a parameter has no default value", float("nan"))]
    from .pinocchio_model import PinocchioDrives, pinocchio_model

    model, perm = pinocchio_model(derivation.robot, values)
    drives = PinocchioDrives(derivation.robot, values, perm)
    data = model.createData()
    worst, scale = 0.0, 1.0
    for q, qd in zip(qs, qds):
        u = np.linspace(-1, 1, len(q))
        qp, qdp = q[perm], qd[perm]
        M = _pinocchio_mass_matrix(pin, model, data, qp)
        ours = module.mass_matrix(q, **values)[np.ix_(perm, perm)]
        # Pinocchio has the armature (model.armature); springs and dissipation are added here
        g = pin.computeGeneralizedGravity(model, data, qp) + drives.spring(qp)
        bias = pin.rnea(model, data, qp, qdp, np.zeros(len(q))) - pin.computeGeneralizedGravity(model, data, qp)
        Y = module.generalized_forces(q, module_efforts(module, u), **values)
        rhs = Y[perm] - drives.spring(qp) - drives.dissipative(qdp)
        acc = (np.linalg.solve(M, rhs - pin.nonLinearEffects(model, data, qp, qdp)) if derivation.robot.mimics
               else pin.aba(model, data, qp, qdp, rhs))   # Pinocchio's aba refuses mimic joints
        diffs = [ours - M, module.gravity_vector(q, **values)[perm] - g,
                 (module.coriolis_matrix(q, qd, **values) @ qd)[perm] - bias]
        if not derivation.robot.loops:   # with loops forward_dynamics is the constrained one
            diffs.append(module.forward_dynamics(q, qd, module_efforts(module, u), **values)[perm] - acc)
        worst = max(worst, *(float(np.max(np.abs(d))) for d in diffs))
        scale = max(scale, float(np.max(np.abs(M))), float(np.max(np.abs(acc))))
    rows = [_row(name, worst < 1e-9 * scale, "numeric", worst)]
    if module.FRAMES:
        rows.append(_pinocchio_frames(pin, model, data, perm, module, values, qs, qds))
    return rows


def _pinocchio_mass_matrix(pin: Any, model: Any, data: Any, q: np.ndarray) -> np.ndarray:
    """Pinocchio's M(q): its crba; with mimic joints, column by column from its rnea (Pinocchio
    4.1's crba is wrong for a mimic joint below its leader with a joint between them)."""
    if not model.mimicking_joints:
        M = pin.crba(model, data, q)
        return np.triu(M) + np.triu(M, 1).T
    zero = np.zeros(model.nv)
    base = pin.rnea(model, data, q, zero, zero)
    return np.array([pin.rnea(model, data, q, zero, e) - base for e in np.eye(model.nv)]).T


def _pinocchio_frames(pin: Any, model: Any, data: Any, perm: np.ndarray, module: Any, values: dict[str, float],
                      qs: np.ndarray, qds: np.ndarray) -> Row:
    """Frame placements, LOCAL_WORLD_ALIGNED Jacobians and classical accelerations at qdd = 0."""
    planar = module.frame_jacobian(qs[0], module.FRAMES[0], **values).shape[0] == 3
    rows = [0, 1, 5] if planar else list(range(6))
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
            k = 2 if planar else 3
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[rows]
            acceleration = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            expected = np.concatenate([acceleration.linear, acceleration.angular])[rows]
            diffs = [T[:k, :k] - placement.rotation[:k, :k], T[:k, -1] - placement.translation[:k],
                     module.frame_jacobian(q, frame, **values)[:, perm] - J,
                     module.frame_jacobian_dot_qd(q, qd, frame, **values) - expected]
            worst = max(worst, *(float(np.max(np.abs(d))) for d in diffs))
    return _row("frames agree with Pinocchio (placement, LOCAL_WORLD_ALIGNED Jacobian, classical acceleration)",
                worst < 1e-9, "numeric", worst)


def module_efforts(module: Any, u: np.ndarray) -> np.ndarray:
    return u[: len(module.EFFORTS)]
