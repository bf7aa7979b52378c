"""``dynderive check``: every consistency check that applies to a derivation.

Symbolic checks where they are cheap, numeric ones at random states otherwise; the
generated code is checked against the symbolic result, and against Pinocchio when ``pin`` is
installed. Each row says how it was checked and its worst residual.
"""

from __future__ import annotations

import types
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..mechanics.tidy import Check, check_zero, is_small
from ..model.robot import Robot
from .motions import allowed_motions as _allowed_motions
from .motions import allowed_velocity
from .rows import Row, _row, applied, peak

#: Quantities larger than this (tree nodes) are not evaluated symbolically against the code.
SYMBOLIC_EVALUATION_NODES = 60_000
#: The rows of a robot with quaternions that tie its velocity convention (``integrate``) to its dynamics.
POWER_BALANCE = "energy balance along integrate: d(T + V)/dt = qd . (inverse_dynamics(q, qd, qdd) - friction_forces(qd))"
MOMENTUM = "momentum conserved without gravity: d(linear, angular momentum)/dt = 0 under the joints' efforts"
#: ``check``'s linearize row on a manifold (with loops, `` along the motions the loops allow`` added).
LINEARIZE_ALONG_INTEGRATE = "linearize matches central differences of forward_dynamics through integrate"
ENERGY_RUN = "energy conserved without efforts (simulate on the manifold; with damping or friction, energy + dissipated work)"


def generated_module(source: str, name: str) -> types.ModuleType:
    """Execute generated source (ours, never user text) as a fresh module."""
    module = types.ModuleType(f"{name}_dynamics")
    exec(compile(source, f"<{name}_dynamics.py>", "exec"), module.__dict__)  # noqa: S102
    return module


def _from_check(check: Check, method: str = "engine, ") -> Row:
    """A ``Check``'s row: the engine's own (``derivation.checks``), or one of ours (``method`` "")."""
    if check.skipped:
        return Row(check.name, "skip", "not derived (too large)", float("nan"))
    return _row(check.name, check.passed, method + check.method, check.residual)


def run_checks(derivation: Derivation, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    """Every check that applies to ``derivation``'s robot, at ``states`` random states
    (``random_configurations``): M, then ``_along_integrate`` for a configuration on a manifold
    (NQ != NV), ``_generalized_rows`` for any other, a 3-D robot's centre of mass and centroidal
    momentum (``centroidal_checks``) and its contact dynamics (``contact_checks``), MuJoCo for a
    robot read from MJCF (``mujoco_checks``), then Pinocchio (``pinocchio_checks``)."""
    from .centroidal_checks import centroidal_rows
    from .contact_checks import contact_rows
    from .mujoco_checks import mujoco_rows
    from .pinocchio_checks import pinocchio_rows

    robot = derivation.robot
    module = generated_module(source, robot.name)
    values = {p.name: (p.value if p.value is not None else 1.0) for p in robot.parameters}
    rng = np.random.default_rng(seed)
    qs = random_configurations(robot, rng, states)
    qds = rng.uniform(-1.0, 1.0, (states, robot.velocity_count))
    us = rng.uniform(-1.0, 1.0, (states, len(robot.efforts)))
    rows: list[Row] = []
    if robot.loops:   # states on the loop constraints, velocities the loops allow
        qs, qds, loop_rows = _loop_states(derivation, module, values, qs, qds)
        us = us[: len(qs)]
        rows += loop_rows
    rows += _mass_matrix(derivation, module, values, qs, states)
    if robot.floating:
        rows += _along_integrate(derivation, module, values, qs, qds, us, rng)
    else:
        rows += _generalized_rows(derivation, module, values, qs, qds, us, rng)
    rows += _guarded("centre of mass and centroidal momentum", centroidal_rows, derivation, module, values,
                     qs[:4], qds[:4])
    rows += _guarded("contact dynamics", contact_rows, derivation, module, values, qs[:4], qds[:4], us[:4])
    rows += _guarded("agrees with MuJoCo", mujoco_rows, derivation, module, values, 5, rng)
    return rows + _guarded("agrees with Pinocchio", pinocchio_rows, derivation, module, values, qs[:5], qds[:5],
                           us[:5])


def _guarded(name: str, comparison: Any, *args: Any) -> list[Row]:
    """A comparison's rows; if it raises (a reference engine refusing a model, one of its
    bugs, one of ours), one failed row saying why, so that the other comparisons still show."""
    try:
        return comparison(*args)
    except Exception as exc:   # noqa: BLE001  (reported as the row's failure, never lost)
        said = " ".join(str(exc).split())
        return [Row(name, "FAIL", f"could not run: {type(exc).__name__}: {said[:200]}", float("nan"))]


def random_configurations(robot: Robot, rng: np.random.Generator, states: int) -> np.ndarray:
    """``states`` configurations: random unit quaternions (floating and spherical joints),
    every other coordinate uniform in [-1.5, 1.5]."""
    qs = rng.uniform(-1.5, 1.5, (states, len(robot.configuration_names)))
    for start in robot.quaternion_starts:
        quaternion = rng.normal(size=(states, 4))
        qs[:, start:start + 4] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    return qs


def _mass_matrix(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                 states: int) -> list[Row]:
    """M symmetric (symbolically where the symbolic M is small) and positive definite."""
    mats = module.mass_matrix(qs, **values)
    M = None if derivation.robot.floating else derivation.quantities["M_g"]   # with quaternions: no Lagrange M
    if M is not None and is_small(M, SYMBOLIC_EVALUATION_NODES):
        rows = [_from_check(check_zero("M symmetric", "", M - M.T, []), "")]
    else:
        worst = peak(mats - np.swapaxes(mats, -1, -2))
        rows = [_row("M symmetric", worst < 1e-9 * max(1.0, peak(mats)), "numeric", worst)]
    eig = np.linalg.eigvalsh(mats)
    return rows + [_row(f"M positive definite ({states} random states)", bool(np.all(eig[..., 0] > 0)),
                        "numeric, smallest eigenvalue", float(np.min(eig[..., 0])))]


def _generalized_rows(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                      qds: np.ndarray, us: np.ndarray, rng: np.random.Generator) -> list[Row]:
    """The generalized quantities: Mdot - 2C, the power balance, the loops' reduced form, the
    engine's own checks, the maximal model, the code against the symbolic quantities, and the
    module's linearization, regressor and frames."""
    robot = derivation.robot
    rows = [_skew_check(derivation, module, values, qs, qds),
            _power_balance(module, values, qs, qds, us, robot.dissipative)]
    if robot.loops:
        rows.append(_reduced_agrees(module, values, qs, qds, us))
    rows += [_from_check(c) for c in derivation.checks]
    if "M_m" in derivation.quantities:
        rows += _maximal_checks(module, values, qs, qds, us)
    rows += _code_matches_symbolic(derivation, module, values, qs[:3], qds[:3], us[:3])
    return rows + _derived_functions(module, values, qs[:4], qds[:4], us[:4], rng)


def _derived_functions(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray, us: np.ndarray,
                       rng: np.random.Generator) -> list[Row]:
    """The module's linearization, regressor and frames against what they differentiate or
    factor: central differences of ``forward_dynamics`` and of the frames' poses, and
    ``inverse_dynamics`` itself."""
    n, h = qs.shape[1], 1e-6
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        A, B = module.linearize(q, qd, u, **values)
        x = np.concatenate([q, qd])

        def xdot(state: np.ndarray, effort: np.ndarray) -> np.ndarray:
            return np.concatenate([state[n:], module.forward_dynamics(state[:n], state[n:], effort, **values)])

        numeric = np.array([(xdot(x + h * e, u) - xdot(x - h * e, u)) / (2 * h) for e in np.eye(2 * n)]).T
        inputs = np.array([(xdot(x, u + h * e) - xdot(x, u - h * e)) / (2 * h) for e in np.eye(len(u))]).T
        worst = max(worst, peak(A - numeric), peak(B - inputs.reshape(B.shape)))
        scale = max(scale, peak(A))
    qdds = rng.uniform(-1.0, 1.0, qs.shape)
    Y = module.regressor(qs, qds, qdds, **values)
    tau = module.inverse_dynamics(qs, qds, qdds, **values)
    residual = peak(Y @ module.parameter_vector(**values) - tau)
    rows = [_row("linearize matches central differences of forward_dynamics", worst < 1e-5 * scale,
                 "numeric (h = 1e-6)", worst),
            _row("regressor(q, qd, qdd) @ parameter_vector() = inverse_dynamics (the tree's)",
                 residual < 1e-9 * max(1.0, peak(tau)), "numeric", residual)]
    if module.FRAMES:
        worst, scale = 0.0, 1.0
        for q, qd in zip(qs, qds):
            for frame in module.FRAMES:
                J = module.frame_jacobian(q, frame, **values)
                ahead, behind = (module.frame_transform(q + s * h * qd, frame, **values) for s in (1, -1))
                linear = (ahead[:-1, -1] - behind[:-1, -1]) / (2 * h)
                rate = (module.frame_jacobian(q + h * qd, frame, **values)
                        - module.frame_jacobian(q - h * qd, frame, **values)) @ qd / (2 * h)
                worst = max(worst, peak(J[: len(linear)] @ qd - linear),
                            peak(module.frame_jacobian_dot_qd(q, qd, frame, **values) - rate))
                scale = max(scale, peak(J))
        rows.append(_row(f"frames ({len(module.FRAMES)}): J qd = dp/dt and Jdot qd = d(J qd)/dt", worst < 1e-5 * scale,
                         "numeric (h = 1e-6)", worst))
    return rows


def _loop_states(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                 qds: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[Row]]:
    """Random configurations assembled by the generated ``assemble`` (independent coordinates
    near the default assembly), and velocities projected onto the null space of A_g."""
    # quaternions in q: assemble moves every coordinate, from q itself
    model = None if derivation.robot.floating else derivation.loop_model
    start = None if model is None else np.array(model.assembled if model.assembled is not None
                                                else np.zeros(qs.shape[1]))
    states, rates = [], []
    for q, qd in zip(qs, qds):
        if model is None or start is None:
            guess = q
        else:
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
    residual = peak(module.loop_constraints(qs, **values))
    rows.append(_row(f"loop constraints a_g = 0 at {len(qs)} assembled states", residual < 1e-9, "numeric", residual))
    velocity = peak(np.einsum("...ij,...j->...i", module.loop_jacobian(qs, **values), qds))
    rows.append(_row("A_g qd = 0 for the velocities the loops allow", velocity < 1e-9, "numeric", velocity))
    return qs, qds, rows


def _reduced_agrees(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                    us: np.ndarray) -> Row:
    """The reduced form R^T (M qdd + C qd + N - Y) = 0 (R: a basis of the motions the loops
    allow) holds for the constrained accelerations of the multiplier form."""
    worst, scale = 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        qdd = module.forward_dynamics(q, qd, u, **values)
        forces = module.mass_matrix(q, **values) @ qdd + module.inverse_dynamics(q, qd, np.zeros(len(q)), **values) \
            - module.generalized_forces(q, u, **values)
        worst = max(worst, peak(module.reduced_forward_dynamics(q, qd, u, **values) - qdd),
                    peak(_allowed_motions(module, q, values) @ forces))
        scale = max(scale, peak(forces))
    return _row("reduced form R_g^T (M qdd + C qd + N - Y) = 0, reduced_forward_dynamics == forward_dynamics",
                worst < 1e-9 * scale, "numeric", worst)


def _skew_check(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                qds: np.ndarray) -> Row:
    name = "Mdot - 2C skew-symmetric"
    table, M, C = derivation.symbols, derivation["M_g"], derivation["C_g"]
    if is_small(M, 2000) and is_small(C, 4000) and not derivation.intermediate_form:
        S = sum((M.diff(qk) * qdk for qk, qdk in zip(table.q, table.qd)), sympy.zeros(*M.shape)) - 2 * C
        return _from_check(check_zero(name, "", S + S.T, []), "")
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, qd in zip(qs, qds):
        Mdot = (module.mass_matrix(q + h * qd, **values) - module.mass_matrix(q - h * qd, **values)) / (2 * h)
        S = Mdot - 2 * module.coriolis_matrix(q, qd, **values)
        worst = max(worst, peak(S + S.T))
        scale = max(scale, peak(Mdot))
    return _row(name, worst < 1e-6 * scale, "numeric (central differences)", worst)


def _power_balance(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                   us: np.ndarray, dissipative: bool) -> Row:
    """dE/dt = qd . Y - qd . F along the dynamics, E = T + V (springs in V, armature in T): the
    dissipated power qd . F of damping and friction is measured, not ignored."""
    h, worst, scale = 1e-5, 0.0, 1.0
    for q, qd, u in zip(qs, qds, us):
        qdd = module.forward_dynamics(q, qd, u, **values)
        ahead, behind = (_energy(module, values, q + qd * t + qdd * t**2 / 2, qd + qdd * t) for t in (h, -h))
        rate = (ahead - behind) / (2 * h)
        dissipated = float(qd @ module.friction_forces(qd, **values))
        power = float(qd @ module.generalized_forces(q, u, **values)) - dissipated
        worst = max(worst, abs(rate - power))
        scale = max(scale, abs(power), abs(dissipated))
    name = "power balance dE/dt = qd . Y - qd . F" if dissipative else "power balance dE/dt = qd . Y"
    return _row(name, worst < 1e-5 * scale, "numeric (central differences)", worst)


def _energy(module: Any, values: dict[str, float], q: np.ndarray, qd: np.ndarray) -> Any:
    """The energy T + V at ``(q, qd)`` (one state or a batch)."""
    return module.kinetic_energy(q, qd, **values) + module.potential_energy(q, **values)


def _maximal_checks(module: Any, values: dict[str, float], qs: np.ndarray, qds: np.ndarray,
                    us: np.ndarray) -> list[Row]:
    """The maximal form through ``H = d(to_maximal)/dq`` against the generalized one, and the
    constraint forces against the maximal equations of motion and the constraints' acceleration."""
    worst: dict[str, float] = {}
    h = 1e-6
    for q, qd, u in zip(qs, qds, us):
        hq = module.to_maximal(q, **values)
        H = module.to_maximal_jacobian(q, **values)
        Hdot = (module.to_maximal_jacobian(q + h * qd, **values) - module.to_maximal_jacobian(q - h * qd, **values)) / (2 * h)
        v = H @ qd
        Mm = module.maximal_mass_matrix(hq, **values)
        Cm = module.maximal_coriolis_matrix(hq, v, **values)
        Nm = module.maximal_gravity_vector(hq, **values)
        Ym = module.maximal_efforts(hq, u, **values)
        frictional = hasattr(module, "maximal_friction_forces")
        friction = module.maximal_friction_forces(hq, v, **values) if frictional else np.zeros(len(v))
        qmdd = module.maximal_forward_dynamics(hq, v, u, **values)
        lam = module.constraint_forces(hq, v, u, **values)
        A = module.constraint_jacobian(hq, **values)
        residual = Mm @ qmdd + Cm @ v + Nm + friction + A.T @ lam - Ym
        acceleration = A @ qmdd + module.constraint_jacobian_dot(hq, v, **values) @ v
        differences = {
            "H^T M_m H = M_g": H.T @ Mm @ H - module.mass_matrix(q, **values),
            "H^T (M_m Hdot + C_m H) qd = C_g qd": (H.T @ (Mm @ Hdot + Cm @ H) @ qd
                                                   - module.coriolis_matrix(q, qd, **values) @ qd),
            "H^T N_m = N_g": H.T @ Nm - module.gravity_vector(q, **values),
            "H^T Y_m = Y_g": H.T @ Ym - module.generalized_forces(q, u, **values),
            "constraint forces consistent": np.concatenate([residual, acceleration]),
        }
        if frictional:
            differences["H^T F_m = F_g"] = H.T @ friction - module.friction_forces(qd, **values)
        for key, difference in differences.items():
            worst[key] = max(worst.get(key, 0.0), peak(difference))
    tolerance = {"H^T (M_m Hdot + C_m H) qd = C_g qd": 1e-5}
    return [_row(k, w < tolerance.get(k, 1e-8), "numeric", w) for k, w in worst.items()]


def _code_matches_symbolic(derivation: Derivation, module: Any, values: dict[str, float],
                           qs: np.ndarray, qds: np.ndarray, us: np.ndarray) -> list[Row]:
    table = derivation.symbols
    params = [table.parameters[p.name] for p in derivation.robot.parameters]
    specs = [("M_g", "mass_matrix", "q"), ("C_g", "coriolis_matrix", "q qd"), ("N_g", "gravity_vector", "q"),
             ("T_g", "kinetic_energy", "q qd"), ("V_g", "potential_energy", "q")]
    if "F_g" in derivation:
        specs.append(("F_g", "friction_forces", "qd"))
    rows = []
    for quantity, function, arguments in specs:
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
            got = np.asarray(getattr(module, function)(*({"q": q, "qd": qd}[a] for a in arguments.split()), **values),
                             dtype=float)
            worst = max(worst, peak(expected.reshape(got.shape) - got))
            scale = max(scale, peak(expected))
        rows.append(_row(name, worst <= 1e-10 * scale, "numeric", worst))
    return rows


def _along_integrate(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                     vs: np.ndarray, us: np.ndarray, rng: np.random.Generator) -> list[Row]:
    """A configuration on a manifold (NQ != NV): the module's functions against each other, and
    along its ``integrate``: the energy balance, the momentum of a floating base, the energy of
    a run, ``integrate`` and ``difference``, the frames."""
    robot = derivation.robot
    M = module.mass_matrix(qs, **values)
    zero = np.zeros_like(vs)
    bias = module.inverse_dynamics(qs, vs, zero, **values)
    qdds = module.forward_dynamics(qs, vs, us, **values)
    forces = np.einsum("...ij,...j->...i", M, qdds) + bias
    worst = peak(module.inverse_dynamics(qs, vs, qdds, **values) - forces)
    loop_force, with_loops = 0.0, ""
    if robot.loops:   # forward_dynamics closes the loops: Y + A^T lambda
        loop_force = np.einsum("...ji,...j->...i", module.loop_jacobian(qs, **values),
                               module.loop_forces(qs, vs, us, **values))
        with_loops = " + A^T loop_forces"
    worst = max(worst, peak(forces - np.array([applied(robot, u) for u in us]) - loop_force))
    rows = [_row(f"inverse_dynamics = M qdd + inverse_dynamics(q, qd, 0), and = Y{with_loops} at forward_dynamics' qdd",
                 worst < 1e-9 * max(1.0, peak(M), peak(forces)), "numeric", worst)]
    gravity = peak(module.gravity_vector(qs, **values) - module.inverse_dynamics(qs, zero, zero, **values))
    rows.append(_row("gravity_vector = inverse_dynamics(q, 0, 0)", gravity < 1e-12 * max(1.0, peak(bias)),
                     "numeric", gravity))
    rows.append(_energy_balance(module, values, qs, vs, rng))
    if robot.floating_base:   # a fixed base (spherical joints only) takes the world's reaction
        rows.append(_momentum(module, robot, values, qs[:6], vs[:6], us[:6]))
    rows.append(_energy_along_a_run(module, values, qs[0], vs[0]))
    rows.append(_linearize_along_integrate(module, values, qs[:3], vs[:3], us[:3], bool(robot.loops)))
    rows += _manifold(module, robot, qs, vs)
    if module.FRAMES:
        rows.append(_frames_along_integrate(module, values, qs[:4], vs[:4]))
    return rows


def _linearize_along_integrate(module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
                               us: np.ndarray, loops: bool) -> Row:
    """linearize on the tangent space against central differences of forward_dynamics through
    ``integrate`` (q perturbed as integrate(q, dq)), of qd and of u; with loops (states on them)
    dq along the motions they allow: across them a redundant row's rank found at the state can
    change."""
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, v, u in zip(qs, vs, us):
        nv = len(v)
        A, B = module.linearize(q, v, u, **values)
        directions = _allowed_motions(module, q, values).T if loops else np.eye(nv)

        def rate(q_: np.ndarray, v_: np.ndarray, u_: np.ndarray) -> np.ndarray:
            return module.forward_dynamics(q_, v_, u_, **values)

        columns = [(rate(module.integrate(q, h * d), v, u) - rate(module.integrate(q, -h * d), v, u)) / (2 * h)
                   for d in directions.T]
        columns += [(rate(q, v + h * e, u) - rate(q, v - h * e, u)) / (2 * h) for e in np.eye(nv)]
        columns += [(rate(q, v, u + h * e) - rate(q, v, u - h * e)) / (2 * h) for e in np.eye(len(u))]
        numeric = np.array(columns).reshape(len(columns), nv).T
        analytic = np.hstack([A[nv:, :nv] @ directions, A[nv:, nv:], B[nv:]])
        upper = np.hstack([np.zeros((nv, nv)), np.eye(nv), np.zeros((nv, B.shape[1]))]) - np.hstack([A[:nv], B[:nv]])
        worst = max(worst, peak(analytic - numeric), peak(upper))
        scale = max(scale, peak(numeric))
    along = " along the motions the loops allow" if loops else ""
    return _row(f"{LINEARIZE_ALONG_INTEGRATE}{along}",
                worst < 1e-5 * scale, "numeric (h = 1e-6)", worst)


def _energy_balance(module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
                   rng: np.random.Generator) -> Row:
    """Along ``q(t) = integrate(q, v, t)``, ``v(t) = v + t a``: ``d(T + V)/dt = v . (tau - F)`` with
    ``tau`` the inverse dynamics at ``a`` and ``F`` the joints' damping and friction, by central
    differences: ties the module's velocity convention (integrate) to its dynamics, and
    gravity_vector to potential_energy."""
    h, worst, scale = 1e-5, 0.0, 1.0
    for q, v in zip(qs, vs):
        a = rng.uniform(-1.0, 1.0, v.shape)
        ahead, behind = (_energy(module, values, module.integrate(q, v, t), v + t * a) for t in (h, -h))
        rate = (ahead - behind) / (2 * h)   # damping and friction take power out: F is not in d(T + V)/dt
        power = float(v @ (module.inverse_dynamics(q, v, a, **values) - module.friction_forces(v, **values)))
        worst, scale = max(worst, abs(rate - power)), max(scale, abs(power))
    return _row(POWER_BALANCE, worst < 1e-6 * scale, f"numeric (h = {h:g})", worst)


def _momentum(module: Any, robot: Robot, values: dict[str, float], qs: np.ndarray, vs: np.ndarray,
              us: np.ndarray) -> Row:
    """Without gravity and without the efforts of the floating base's own joint (a wrench from
    the world, zeroed here) the efforts are internal: the whole robot's linear and angular
    momentum (``system_momentum``) stays constant. Its rate along ``q(t) = integrate(q, v, t)``,
    ``v(t) = v + t a``, with ``a`` the accelerations the efforts give without gravity
    (``M a = Y - (inverse_dynamics(q, v, 0) - gravity_vector(q))``), by central differences,
    against the size of the gravity-free accelerations' momentum change."""
    h, worst, scale = 1e-5, 0.0, 1.0
    external = [k for k, name in enumerate(robot.efforts)
                for j in robot.joints if j.parent == "world" and name in j.effort_names]
    for q, v, u in zip(qs, vs, us):
        u = np.array(u, dtype=float)
        u[external] = 0.0
        bias = module.inverse_dynamics(q, v, np.zeros_like(v), **values) - module.gravity_vector(q, **values)
        mass = module.mass_matrix(q, **values)
        a = np.linalg.solve(mass, applied(robot, u) - bias)
        ahead, behind = (system_momentum(module, robot, module.integrate(q, v, s * h), v + s * h * a, values)
                         for s in (1, -1))
        worst = max(worst, peak(ahead - behind) / (2 * h))
        scale = max(scale, peak(mass @ a), peak(ahead))
    return _row(MOMENTUM, worst < 1e-6 * scale, f"numeric (h = {h:g})", worst)


def _energy_along_a_run(module: Any, values: dict[str, float], q: np.ndarray, v: np.ndarray,
                        duration: float = 0.5) -> Row:
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

    nq, nv, zero, smoothing = len(q), len(v), np.zeros(len(module.EFFORTS)), 0.01

    def rhs(time: float, y: np.ndarray) -> np.ndarray:   # the module's own rates: quaternions stay unit
        qd = y[nq:nq + nv]
        return np.concatenate([module.configuration_rate(y[:nq], qd),
                               module.forward_dynamics(y[:nq], qd, zero, friction_smoothing=smoothing, **values),
                               [qd @ module.friction_forces(qd, friction_smoothing=smoothing, **values)]])

    run = solve_ivp(rhs, (0.0, duration), np.concatenate([q, v, [0.0]]), method="DOP853", rtol=1e-10, atol=1e-10,
                    t_eval=np.linspace(0.0, duration, 3))
    position, velocity, work = run.y[:nq].T, run.y[nq:nq + nv].T, run.y[nq + nv]
    energy = _energy(module, values, position, velocity) + work
    potential = float(module.potential_energy(q, **values))
    scale = max(1.0, abs(energy[0] - potential) + abs(potential))
    worst = peak(energy - energy[0])
    return _row(ENERGY_RUN, worst < 1e-6 * scale, f"numeric ({duration:g} s simulated)", worst)


def _frames_along_integrate(module: Any, values: dict[str, float], qs: np.ndarray, vs: np.ndarray) -> Row:
    """Each frame's Jacobian times qd against the central difference of its position and
    rotation along ``integrate`` (the angular part from ``dR/dt R^T``)."""
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, v in zip(qs, vs):
        for frame in module.FRAMES:
            ahead, behind = (module.frame_transform(module.integrate(q, v, s * h), frame, **values) for s in (1, -1))
            twist = module.frame_jacobian(q, frame, **values) @ v
            spin = (ahead[:3, :3] - behind[:3, :3]) / (2 * h) @ module.frame_transform(q, frame, **values)[:3, :3].T
            numeric = np.concatenate([(ahead[:3, 3] - behind[:3, 3]) / (2 * h), [spin[2, 1], spin[0, 2], spin[1, 0]]])
            worst, scale = max(worst, peak(twist - numeric)), max(scale, peak(twist))
    return _row(f"frames ({len(module.FRAMES)}): frame_jacobian qd = d(pose)/dt along integrate", worst < 1e-5 * scale,
                f"numeric (h = {h:g})", worst)


def _manifold(module: Any, robot: Robot, qs: np.ndarray, vs: np.ndarray) -> list[Row]:
    """``integrate`` keeps quaternions unit; ``difference`` inverts it."""
    moved = module.integrate(qs, vs, 0.7)
    norms = [np.linalg.norm(moved[:, start:start + 4], axis=1) for start in robot.quaternion_starts]
    unit = peak(np.array(norms) - 1.0)
    back = peak(module.difference(qs, moved) - 0.7 * vs)
    return [_row("integrate keeps the quaternions unit", unit < 1e-12, "numeric", unit),
            _row("difference(q, integrate(q, v, dt)) = v dt", back < 1e-9, "numeric", back)]


def _rotate(quaternion: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """The vector rotated by the unit quaternion (x, y, z, w)."""
    u, w = quaternion[..., :3], quaternion[..., 3:]
    t = 2.0 * np.cross(u, vector)
    return vector + w * t + np.cross(u, t)


def system_momentum(module: Any, robot: Robot, q: np.ndarray, v: np.ndarray, values: dict[str, float]) -> np.ndarray:
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
