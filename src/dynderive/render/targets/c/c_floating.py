"""The C99 target of a floating-base robot (``solve --floating-base --c``): the same
header and source templates as a fixed-base robot's (``c/dynamics.h.j2``, ``c/dynamics.c.j2``),
with NQ != NV, the free-flyer programs (``mechanics/floating.py``: CRBA, Newton-Euler, the
L^T D L solve, the Coriolis matrix, the derivatives of Newton-Euler, the regressor, the
frames) printed by ``c.py``'s printer, and the configuration space (``c_manifold.py``).

The functions are the NumPy floating module's, on Pinocchio's conventions: ``q`` has NQ
entries, ``qd``, ``qdd`` and ``v`` NV, ``u`` the efforts (none on the floating joint);
``linearize`` works on the tangent space (A is 2 NV x 2 NV). Damping and Coulomb friction
(``friction_forces``, NV entries, zero on a floating or spherical joint's) and the wrench
variants (``inverse_dynamics_wrenches``, ``forward_dynamics_wrenches``: ``c_loops.amend``) are
the fixed-base target's functions, with NV for n.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import sympy

from ....derivation import Derivation
from ...encode import Code
from ...environment import render
from .c import (
    CFunction,
    _add_friction,
    _expression_body,
    _fill_in,
    _forward_names,
    _frame_functions,
    _friction_body,
    _friction_slope,
    _Names,
    _parameter_note,
    _program_body,
    _regressor_body,
    _void,
    double_literal,
    negated_derivatives,
    solved_into_a_and_b,
)
from .c_join import joined_program, print_body
from .c_loops import CKit, amend
from .c_manifold import ManifoldJoint, difference_lines, integrate_lines, neutral_lines, rate_lines
from .c_names import c_comment, check_c_names

HEADER_TEMPLATE = "c/dynamics.h.j2"
SOURCE_TEMPLATE = "c/dynamics.c.j2"


def manifold_joints(derivation: Derivation) -> list[ManifoldJoint]:
    """The moving joints in file order: their kind and where they start in q and v."""
    where_q, where_v = derivation.robot.offsets()
    return [ManifoldJoint(j.type if j.type in ("floating", "spherical") else "scalar", where_q[j.name], where_v[j.name])
            for j in derivation.robot.joints if j.owns]


def _effort_columns(derivation: Derivation) -> list[int]:
    return list(derivation.robot.effort_columns())


def _forward_part(derivation: Derivation) -> tuple[list, list, dict, bool]:
    """Its extra inputs (F - J^T w) are ``friction_forces``' F (``_forward_names``) for a robot
    with damping or friction, else zero (the C functions take wrenches in their own variants)."""
    program = derivation.programs["forward_dynamics"]
    zero = {} if derivation.robot.dissipative else {s: sympy.S.Zero for s in program.extra_inputs}
    return program.lines, [sympy.sympify(e) for e in program.outputs], zero, True


def _mass_pattern(derivation: Derivation, nv: int) -> list[list[bool]]:
    outputs = [sympy.sympify(e) for e in derivation.programs["mass_matrix"].outputs]
    return [[outputs[i * nv + j] != 0 for j in range(nv)] for i in range(nv)]


def _linearize_body(derivation: Derivation, names: _Names, start: str) -> list[str]:
    """qdd from forward dynamics, M and the derivatives of Newton-Euler at that qdd in one
    body; R = [-dtau/dq, -dtau/dqd, dY/du]; M X = R by L D L^T; A = [[0, I], X_q, X_qd],
    B = [[0], X_u] (the NumPy floating module's ``linearize``)."""
    table = derivation.symbols
    nv, nu = len(table.qd), len(table.efforts)
    width = 2 * nv + nu
    mass = derivation.programs["mass_matrix"]
    derivatives = derivation.programs["inverse_dynamics_derivatives"]
    joined, (_, mass_entries, derived), pivots = joined_program([
        _forward_part(derivation),
        (mass.lines, [sympy.sympify(e) for e in mass.outputs], {}, False),
        (derivatives.lines, [sympy.sympify(e) for e in derivatives.outputs],
         lambda outputs: dict(zip(table.qdd, outputs[0])), False)])
    local, friction = _forward_names(derivation, names)
    lines = [start, *_void("q", "qd", "u", "P", "B"), f"double M[{nv * nv}];", f"double D[{2 * nv * nv}];",
             f"double R[{nv * width}];", *friction]
    lines += print_body(local, joined, [*((f"M[{k}]", e) for k, e in enumerate(mass_entries)),
                                        *((f"D[{k}]", e) for k, e in enumerate(derived))], pivots)
    lines += negated_derivatives(nv, width, inputs=bool(nu))
    lines += [f"R[{column * width + 2 * nv + k}] = 1.0;" for k, column in enumerate(_effort_columns(derivation))]
    lines += _friction_slope(derivation, names, width)
    return lines + solved_into_a_and_b(_mass_pattern(derivation, nv), nv, nu)


def floating_c_context(derivation: Derivation) -> dict[str, Any]:
    """Every variable the C templates use, for a floating-base robot."""
    check_c_names(derivation.robot)
    robot, table, programs = derivation.robot, derivation.symbols, derivation.programs
    name, nq, nv, nu = robot.name, len(table.q), len(table.qd), len(table.efforts)
    names = _Names(derivation)
    pp = f"const {name}_parameters *p"
    start = f"const {name}_parameters *const P = p ? p : &{name}_default_parameters;"
    count = len(derivation.parameter_vector)
    joints = manifold_joints(derivation)
    forward_lines, (forward_outputs,), pivots = joined_program([_forward_part(derivation)])
    forward_names, friction = _forward_names(derivation, names)

    def program(key: str, targets: list[str]) -> list[str]:
        return _program_body(names, programs[key], targets)

    functions = [
        CFunction(f"void {name}_mass_matrix(const double *q, {pp}, double *M)",
                  f"Mass matrix M(q) by the composite-rigid-body algorithm, {nv} x {nv}, row-major (Pinocchio's crba).",
                  [start, *_void("q", "P"), *program("mass_matrix", [f"M[{k}]" for k in range(nv * nv)])]),
        CFunction(f"void {name}_coriolis_matrix(const double *q, const double *qd, {pp}, double *C)",
                  f"Coriolis matrix C(q, qd), {nv} x {nv}, row-major (Pinocchio's computeCoriolisMatrix).",
                  [start, *_void("q", "qd", "P"), *program("coriolis", [f"C[{k}]" for k in range(nv * nv)])]),
        CFunction(f"void {name}_gravity_vector(const double *q, {pp}, double *N)",
                  f"Gravity vector N(q) (Newton-Euler at rest), {nv} entries.",
                  [start, *_void("q", "P"), *program("gravity", [f"N[{i}]" for i in range(nv)])]),
        CFunction(f"void {name}_inverse_dynamics(const double *q, const double *qd, const double *qdd, {pp}, "
                  "double *tau)", f"M qdd + C qd + N + F by recursive Newton-Euler, {nv} entries (Pinocchio's rnea); "
                  "the floating joint's entries are the wrench the base would need.",
                  [start, *_void("q", "qd", "qdd", "P"), *program("inverse_dynamics", [f"tau[{i}]" for i in range(nv)]),
                   *_add_friction(derivation, "tau", "+=")]),
        CFunction(f"int {name}_forward_dynamics(const double *q, const double *qd, const double *u, {pp}, double *qdd)",
                  "qdd solving M qdd = Y(u) - C qd - N - F by L^T D L (each effort at its velocity column); returns 0, "
                  "or 1 (qdd untouched) if M is not positive definite.",
                  [start, *_void("q", "qd", "u", "P"), *friction,
                   *print_body(forward_names, forward_lines, [(f"qdd[{i}]", e) for i, e in enumerate(forward_outputs)],
                               pivots),
                   "return 0;"]),
        CFunction(f"void {name}_friction_forces(const double *qd, {pp}, double *F)",
                  f"Dissipative forces F = b qd + fc sign(qd) (tanh(qd / friction_smoothing) when it is positive), "
                  f"{nv} entries, zero on a floating or spherical joint's." if robot.dissipative else
                  f"Dissipative forces F: zero, the robot declares no damping or friction, {nv} entries.",
                  _friction_body(derivation, names, start)),
        CFunction(f"double {name}_kinetic_energy(const double *q, const double *qd, {pp})",
                  "Kinetic energy T = 1/2 qd^T M(q) qd.",
                  [f"double M[{nv * nv}];", f"{name}_mass_matrix(q, p, M);",
                   "double T = 0.0;", f"for (int i = 0; i < {nv}; ++i) {{",
                   f"    for (int j = 0; j < {nv}; ++j) T += qd[i] * M[i * {nv} + j] * qd[j];", "}",
                   "return 0.5 * T;"]),
        CFunction(f"double {name}_potential_energy(const double *q, {pp})",
                  "Potential energy V(q) of gravity and the springs.",
                  [start, "double V;", *_void("q", "P"), *program("potential", ["V"]), "return V;"]),
        CFunction(f"int {name}_linearize(const double *q, const double *qd, const double *u, {pp}, double *A, double *B)",
                  f"(A, B) of xdot = A dx + B du about x = (q, qd) and u on the tangent space (q perturbed as "
                  f"integrate(q, dq)): A {2 * nv} x {2 * nv}, B {2 * nv} x {nu}, row-major; returns 0, or 1 "
                  "(A, B untouched) if M is not positive definite.", _linearize_body(derivation, names, start)),
        CFunction(f"void {name}_regressor(const double *q, const double *qd, const double *qdd, {pp}, double *Y)",
                  f"Regressor Y(q, qd, qdd), {nv} x {count}, row-major: Y pi = inverse_dynamics.",
                  _regressor_body(derivation, names, start)),
        CFunction(f"void {name}_parameter_vector({pp}, double *pi)", f"The regressor's parameters pi, {count} entries.",
                  [start, *_void("P"), *_expression_body(names, [v.value for v in derivation.parameter_vector],
                                                         [f"pi[{i}]" for i in range(count)])]),
        *_frame_functions(derivation, names, start, pp, nv),
        CFunction(f"void {name}_neutral_configuration(double *q)",
                  f"The neutral configuration, {nq} entries: zeros, and identity quaternions (Pinocchio's neutral).",
                  neutral_lines(joints, nq)),
        CFunction(f"void {name}_integrate(const double *q, const double *v, double dt, double *out)",
                  f"The configuration reached from q moving at v for dt, {nq} entries (Pinocchio's integrate(q, v dt)): "
                  "q + v dt, a floating joint's pose times exp(v dt) on SE(3) (its quaternion normalized in the "
                  "hemisphere of q's), a spherical joint's quaternion times exp(w dt), normalized.",
                  integrate_lines(joints)),
        CFunction(f"void {name}_difference(const double *q0, const double *q1, double *v)",
                  f"The velocity v, {nv} entries, that integrate turns q0 into q1 in unit time (Pinocchio's "
                  "difference).", difference_lines(joints)),
        CFunction(f"void {name}_configuration_rate(const double *q, const double *v, double *out)",
                  f"dq/dt of q moving at v, {nq} entries: the derivative of integrate(q, v, t) at t = 0.",
                  rate_lines(joints)),
    ]
    functions = amend(derivation, CKit(
        start, pp, CFunction, lambda values, targets, extra=None: _expression_body(names.extended(extra), values, targets),
        lambda program, targets, extra=None: _program_body(names.extended(extra), program, targets),
        _fill_in(_mass_pattern(derivation, nv), nv), lambda: _friction_slope(derivation, names, 2 * nv + nu)),
        functions)
    parameters = [{"name": p.name, "default": Code("NAN") if p.value is None else Code(double_literal(float(p.value))),
                   "comment": c_comment(_parameter_note(p))} for p in robot.parameters]
    parameters.append({"name": "friction_smoothing", "default": Code("0.0"), "comment": c_comment(
        "Coulomb friction: 0 for sign(qd), eps > 0 for tanh(qd / eps) (negative: as 0)"
        if robot.dissipative else "unused: the robot has no Coulomb friction (every robot's struct ends with it)")})
    from ...._version import __version__

    return {
        "name": name, "macro": name.upper(), "title": c_comment(robot.title),
        "source": c_comment(Path(robot.source).name), "generator": c_comment(f"dynderive {__version__}"),
        "nq": nq, "nv": nv, "nu": nu, "nc": 0,
        "coordinates": c_comment(", ".join(str(s) for s in table.q)),
        "efforts": c_comment(", ".join(robot.efforts)),
        "parameters": parameters,
        "frames": [{"index": i, "name": c_comment(f.name)} for i, f in enumerate(robot.frames)],
        "functions": functions,
    }


def render_floating_c(derivation: Derivation, template_dir: str | Path | None = None) -> tuple[str, str]:
    """The header and the source of a floating-base robot's C target, as text."""
    context = floating_c_context(derivation)
    return (render("code", HEADER_TEMPLATE, context, template_dir),
            render("code", SOURCE_TEMPLATE, context, template_dir))


__all__ = ["floating_c_context", "manifold_joints", "render_floating_c"]
