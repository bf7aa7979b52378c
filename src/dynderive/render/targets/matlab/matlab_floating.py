"""The MATLAB/Octave package of a floating-base robot (``solve --floating-base --matlab``):
``+<name>/``, the NumPy floating module's functions on Pinocchio's conventions
(``q`` NQ x 1, ``qd``, ``qdd``, ``v`` NV x 1), printed from the free-flyer programs
(``mechanics/floating.py``) by ``matlab_print.py`` as the fixed-base package is; M is solved
with ``\\`` (Cholesky). The configuration space (``neutral_configuration``, ``integrate``,
``difference``, ``configuration_rate``) is written per joint with local functions for the
quaternion algebra and the exponential and logarithm of SE(3) and of rotations, the same
formulas as the NumPy module's. Damping and Coulomb friction are the fixed-base package's
``friction_forces`` (NV x 1, zero on a floating or spherical joint's rows), in
``inverse_dynamics``, ``forward_dynamics``, ``linearize`` and the regressor's columns. Not
built: the derivation script (the symbolic path does not apply to quaternion coordinates), and
wrenches at frames (as for a fixed-base robot's package).
"""

from __future__ import annotations

from pathlib import Path

from ....derivation import Derivation
from ..c.c_floating import manifold_joints
from .matlab import _frame_functions, _friction_body, render_matlab
from .matlab_print import (
    DIRECTION_LINES,
    MFunction,
    Names,
    expression_body,
    friction_slope,
    matrix_targets,
    program_body,
    prologue,
    vector_targets,
)

#: Below this angle the exponentials and logarithms use their series (as the NumPy module).
SMALL = "1e-4"


def _local_functions() -> list[MFunction]:
    """Quaternions (x, y, z, w) as 4 x 1 columns; twists (v; w) as 6 x 1."""
    return [
        MFunction("quaternion_multiply", "c", ["a", "b"], ["The quaternion product a b, (x, y, z, w)."],
                  ["c = [a(4)*b(1:3) + b(4)*a(1:3) + cross(a(1:3), b(1:3)); a(4)*b(4) - dot(a(1:3), b(1:3))];"]),
        MFunction("quaternion_rotate", "r", ["a", "x"], ["x rotated by the unit quaternion a."],
                  ["t = 2*cross(a(1:3), x);", "r = x + a(4)*t + cross(a(1:3), t);"]),
        MFunction("rotation_exp", "[e, theta]", ["w"], ["The unit quaternion of exp(w), and |w|."],
                  ["theta = norm(w);", "if theta < " + SMALL, "    half_sinc = 0.5 - theta^2/48;", "else",
                   "    half_sinc = sin(theta/2)/theta;", "end", "e = [half_sinc*w; cos(theta/2)];"]),
        MFunction("rotation_log", "[w, theta]", ["r"], ["The rotation vector w whose exponential is the unit "
                                                       "quaternion r, and its angle."],
                  ["if r(4) < 0", "    r = -r;", "end", "s = norm(r(1:3));", "theta = 2*atan2(s, r(4));",
                   "if theta < " + SMALL, "    w = (2 + theta^2/12)*r(1:3);", "elseif s == 0",
                   "    w = theta*r(1:3);", "else", "    w = (theta/s)*r(1:3);", "end"]),
        MFunction("moved", "m", ["a", "e"], ["a e normalized, in the hemisphere of a (SE(3), as Pinocchio)."],
                  ["m = quaternion_multiply(a, e);", "m = m / norm(m);", "if dot(m, a) < 0", "    m = -m;", "end"]),
        MFunction("se3_exp", "[e, translation]", ["twist"], ["The rotation and translation of exp(twist), "
                                                             "twist = (v; w) in the moving frame."],
                  ["v = twist(1:3);", "w = twist(4:6);", "[e, theta] = rotation_exp(w);", "if theta < " + SMALL,
                   "    a = 0.5 - theta^2/24;", "    b = 1/6 - theta^2/120;", "else",
                   "    a = (1 - cos(theta))/theta^2;", "    b = (theta - sin(theta))/theta^3;", "end",
                   "wv = cross(w, v);", "translation = v + a*wv + b*cross(w, wv);"]),
        MFunction("se3_log", "twist", ["r", "translation"], ["The twist (v; w) whose exponential is the "
                                                             "rotation r and the translation."],
                  ["[w, theta] = rotation_log(r);", "if theta < " + SMALL, "    k = 1/12 + theta^2/720;", "else",
                   "    k = (1 - theta*sin(theta)/(2*(1 - cos(theta))))/theta^2;", "end",
                   "wp = cross(w, translation);", "twist = [translation - 0.5*wp + k*cross(w, wp); w];"]),
    ]


def _manifold_functions(derivation: Derivation) -> list[MFunction]:
    name = derivation.robot.name
    nq, nv = len(derivation.symbols.q), len(derivation.symbols.qd)
    joints = manifold_joints(derivation)
    neutral = [f"q = zeros({nq}, 1);", *(f"q({j.q + (7 if j.kind == 'floating' else 4)}) = 1;"
                                         for j in joints if j.kind != "scalar")]
    integrate, difference, rate = ["q = q(:);", "v = v(:);", "if nargin < 3", "    dt = 1;", "end",
                                   "out = zeros(" + str(nq) + ", 1);"], \
        ["q0 = q0(:);", "q1 = q1(:);", f"v = zeros({nv}, 1);"], ["q = q(:);", "v = v(:);", f"out = zeros({nq}, 1);"]
    for joint in joints:
        qi, vi = joint.q + 1, joint.v + 1   # 1-based
        if joint.kind == "scalar":
            integrate.append(f"out({qi}) = q({qi}) + v({vi})*dt;")
            difference.append(f"v({vi}) = q1({qi}) - q0({qi});")
            rate.append(f"out({qi}) = v({vi});")
        elif joint.kind == "floating":
            quaternion = f"q({qi + 3}:{qi + 6})"
            integrate += [f"[e, translation] = se3_exp(v({vi}:{vi + 5})*dt);",
                          f"out({qi}:{qi + 2}) = q({qi}:{qi + 2}) + quaternion_rotate({quaternion}, translation);",
                          f"out({qi + 3}:{qi + 6}) = moved({quaternion}, e);"]
            difference += [f"inverse = [-q0({qi + 3}:{qi + 5}); q0({qi + 6})] / sum(q0({qi + 3}:{qi + 6}).^2);",
                           f"r = quaternion_multiply(inverse, q1({qi + 3}:{qi + 6}));", "r = r / norm(r);",
                           f"v({vi}:{vi + 5}) = se3_log(r, quaternion_rotate(inverse, q1({qi}:{qi + 2}) - "
                           f"q0({qi}:{qi + 2})));"]
            rate += [f"out({qi}:{qi + 2}) = quaternion_rotate({quaternion}, v({vi}:{vi + 2}));",
                     f"out({qi + 3}:{qi + 6}) = 0.5*quaternion_multiply({quaternion}, [v({vi + 3}:{vi + 5}); 0]);"]
        else:   # spherical
            quaternion = f"q({qi}:{qi + 3})"
            integrate += [f"m = quaternion_multiply({quaternion}, rotation_exp(v({vi}:{vi + 2})*dt));",
                          f"out({qi}:{qi + 3}) = m / norm(m);   % SO(3): no change of hemisphere, as Pinocchio"]
            difference += [f"inverse = [-q0({qi}:{qi + 2}); q0({qi + 3})] / sum(q0({qi}:{qi + 3}).^2);",
                           f"r = quaternion_multiply(inverse, q1({qi}:{qi + 3}));", "r = r / norm(r);",
                           f"v({vi}:{vi + 2}) = rotation_log(r);"]
            rate += [f"out({qi}:{qi + 3}) = 0.5*quaternion_multiply({quaternion}, [v({vi}:{vi + 2}); 0]);"]
    local = _local_functions()
    return [
        MFunction("neutral_configuration", "q", [], [f"NEUTRAL_CONFIGURATION  The neutral configuration, {nq} x 1: "
                                                     "zeros, and identity quaternions (Pinocchio's neutral)."], neutral),
        MFunction("integrate", "out", ["q", "v", "dt"],
                  [f"INTEGRATE  The configuration reached from q ({nq} x 1) moving at v ({nv} x 1) for dt (default 1), "
                   "Pinocchio's integrate(q, v dt).", "",
                   "   q + v dt for the joints, a floating joint's pose times exp(v dt) on SE(3), a spherical joint's",
                   "   quaternion times exp(w dt); quaternions normalized, in the hemisphere of q's.",
                   f"   q1 = {name}.integrate(q, v, dt)"], integrate, local),
        MFunction("difference", "v", ["q0", "q1"],
                  [f"DIFFERENCE  The velocity v ({nv} x 1) that integrate turns q0 into q1 in unit time "
                   "(Pinocchio's difference)."], difference, local),
        MFunction("configuration_rate", "out", ["q", "v"],
                  [f"CONFIGURATION_RATE  dq/dt ({nq} x 1) of q moving at v: the derivative of integrate(q, v, t) "
                   "at t = 0.", "", f"   ode45(@(t, x) [{name}.configuration_rate(x(1:{nq}), x({nq + 1}:end)); "
                   f"{name}.forward_dynamics(x(1:{nq}), x({nq + 1}:end), u, p)], tspan, x0)"], rate, local),
    ]


def floating_numeric_functions(derivation: Derivation) -> list[MFunction]:
    """Every function of a floating-base robot's ``+<name>/``."""
    robot, table, programs = derivation.robot, derivation.symbols, derivation.programs
    name, nv, nu = robot.name, len(table.qd), len(table.efforts)
    names = Names(derivation)
    count = len(derivation.parameter_vector)
    columns = robot.effort_columns()
    applied = [f"Y = zeros({nv}, 1);", *(f"Y({c + 1}) = u({k + 1});" for k, c in enumerate(columns))]
    friction = [f"tau = tau + {name}.friction_forces(qd, p);"] if robot.dissipative else []
    regressor = programs["regressor"]
    regressor_names = names.extended({s: f"s({i + 1})" for i, s in enumerate(regressor.extra_inputs)})
    return [
        MFunction("mass_matrix", "M", ["q", "p"], [f"MASS_MATRIX  Mass matrix M(q), {nv} x {nv} (Pinocchio's crba)."],
                  [*prologue(derivation, ["q"], 2), f"M = zeros({nv}, {nv});",
                   *program_body(names, programs["mass_matrix"], matrix_targets("M", nv, nv))]),
        MFunction("coriolis_matrix", "C", ["q", "qd", "p"],
                  [f"CORIOLIS_MATRIX  Coriolis matrix C(q, qd), {nv} x {nv} (Pinocchio's computeCoriolisMatrix)."],
                  [*prologue(derivation, ["q", "qd"], 3), f"C = zeros({nv}, {nv});",
                   *program_body(names, programs["coriolis"], matrix_targets("C", nv, nv))]),
        MFunction("gravity_vector", "N", ["q", "p"], [f"GRAVITY_VECTOR  Gravity vector N(q), {nv} x 1."],
                  [*prologue(derivation, ["q"], 2), f"N = zeros({nv}, 1);",
                   *program_body(names, programs["gravity"], vector_targets("N", nv))]),
        MFunction("inverse_dynamics", "tau", ["q", "qd", "qdd", "p"],
                  [f"INVERSE_DYNAMICS  M qdd + C qd + N (+ friction_forces) by recursive Newton-Euler, {nv} x 1 "
                   "(Pinocchio's rnea): the floating joint's rows are the wrench the base would need."],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4), f"tau = zeros({nv}, 1);",
                   *program_body(names, programs["inverse_dynamics"], vector_targets("tau", nv)), *friction]),
        MFunction("friction_forces", "F", ["qd", "p"],
                  [f"FRICTION_FORCES  Dissipative forces F = b qd + fc sign(qd), {nv} x 1, zero on a floating or "
                   "spherical joint's rows (tanh(qd / p.friction_smoothing) for sign(qd) when friction_smoothing > 0)."
                   if robot.dissipative else
                   f"FRICTION_FORCES  Dissipative forces F: zero, the robot declares no damping or friction, {nv} x 1."],
                  _friction_body(derivation, names)),
        MFunction("generalized_forces", "Y", ["q", "u", "p"],
                  [f"GENERALIZED_FORCES  Y(u): each effort at its joint's velocity column ({nu} efforts), {nv} x 1; "
                   "a floating joint's six are the wrench on its child in its frame."],
                  [*prologue(derivation, ["q", "u"], 3), *applied]),
        MFunction("forward_dynamics", "qdd", ["q", "qd", "u", "p"],
                  [f"FORWARD_DYNAMICS  Accelerations qdd solving M(q) qdd = Y(u) - C qd - N - F, {nv} x 1 (Pinocchio's "
                   "aba); u may be [] (no effort)."],
                  [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
                   f"rhs = {name}.generalized_forces(q, u, p) - {name}.inverse_dynamics(q, qd, zeros({nv}, 1), p);",
                   f"qdd = {name}.mass_matrix(q, p) \\ rhs;"]),
        MFunction("kinetic_energy", "T", ["q", "qd", "p"], ["KINETIC_ENERGY  Kinetic energy T = 1/2 qd' M(q) qd."],
                  [*prologue(derivation, ["q", "qd"], 3), f"T = 0.5*(qd' * ({name}.mass_matrix(q, p) * qd));"]),
        MFunction("potential_energy", "V", ["q", "p"], ["POTENTIAL_ENERGY  Potential energy V(q) of gravity and the "
                                                        "springs."],
                  [*prologue(derivation, ["q"], 2), "V = 0;", *program_body(names, programs["potential"], ["V"])]),
        MFunction("linearize", "[A, B]", ["q", "qd", "u", "p"],
                  [f"LINEARIZE  (A, B) of xdot = A dx + B du on the tangent space (q perturbed as integrate(q, dq)): "
                   f"A {2 * nv} x {2 * nv}, B {2 * nv} x {nu} (Pinocchio's computeABADerivatives)."],
                  [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
                   f"qdd0 = {name}.forward_dynamics(q, qd, u, p);",
                   f"D = zeros({2 * nv * nv}, 1);",
                   *program_body(names.extended({s: f"qdd0({i + 1})" for i, s in enumerate(table.qdd)}),
                                 programs["inverse_dynamics_derivatives"], vector_targets("D", 2 * nv * nv)),
                   f"R = zeros({nv}, {2 * nv + nu});",
                   f"R(:, 1:{nv}) = -reshape(D(1:{nv * nv}), {nv}, {nv})';",
                   f"R(:, {nv + 1}:{2 * nv}) = -reshape(D({nv * nv + 1}:{2 * nv * nv}), {nv}, {nv})';",
                   *(f"R({c + 1}, {2 * nv + k + 1}) = 1;" for k, c in enumerate(columns)),
                   *friction_slope(derivation, names, "R"),
                   f"X = {name}.mass_matrix(q, p) \\ R;",
                   f"A = [zeros({nv}, {nv}), eye({nv}); X(:, 1:{2 * nv})];",
                   f"B = [zeros({nv}, {nu}); X(:, {2 * nv + 1}:end)];"]),
        MFunction("regressor", "Y", ["q", "qd", "qdd", "p"],
                  [f"REGRESSOR  Regressor Y(q, qd, qdd), {nv} x {count}: Y * parameter_vector(p) equals inverse_dynamics."],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4),
                   *(DIRECTION_LINES if regressor.extra_inputs else []), f"Y = zeros({nv}, {count});",
                   *program_body(regressor_names, regressor, matrix_targets("Y", nv, count))]),
        MFunction("parameter_vector", "pi_", ["p"],
                  [f"PARAMETER_VECTOR  The regressor's parameters, {count} x 1: per link mass, first moment m c, "
                   "inertia about the link frame's origin; then the drives."],
                  ["if nargin < 1 || isempty(p)", f"    p = {name}.parameters();", "end", f"pi_ = zeros({count}, 1);",
                   *expression_body(names, [v.value for v in derivation.parameter_vector], vector_targets("pi_", count))]),
        *_frame_functions(derivation, names),
        *_manifold_functions(derivation),
    ]


def render_floating_matlab(derivation: Derivation, template_dir: str | Path | None = None) -> dict[str, str]:
    """A floating-base robot's package ``+<name>/``: {relative path: text}, nothing written."""
    return render_matlab(derivation, template_dir, floating_numeric_functions(derivation))


__all__ = ["floating_numeric_functions", "render_floating_matlab"]
