"""The C99 target (``solve --c``): ``<name>_dynamics.h`` and ``<name>_dynamics.c``, for every
robot: fixed-base, floating-base (a free flyer), with spherical or mimic joints.

The same straight-line programs as the NumPy module (``Derivation.programs``; a small planar
robot's explicit M, C, N, V with common subexpressions eliminated), printed by ``codegen/c_syntax.py``.
Forward dynamics solves ``M qdd = Y - (C qd + N)`` with an ``L D L^T`` factorization unrolled
for this robot's size and sparsity (``c_solve.py``), and returns 1 (``qdd`` untouched) if a
pivot is not positive; ``linearize`` solves its columns with the same factorization.

A robot whose configuration holds unit quaternions (a floating or spherical joint: NQ != NV,
Pinocchio's conventions) has ``q`` of NQ entries and ``qd``, ``qdd`` of NV; each effort acts
on its joint's velocity column (no ``generalized_forces``), ``linearize`` works on the tangent
space (A is 2 NV x 2 NV), and the configuration maps ``neutral_configuration``, ``integrate``,
``difference`` and ``configuration_rate`` are printed from the joint types' programs
(``Derivation.configuration_programs``; their branches as ``(c ? a : b)``).

A 3-D robot has the centre of mass and the centroidal momentum (``total_mass`` ...
``centroidal_inertia``), each its program of ``Derivation.centroidal_programs`` printed.

Damping and Coulomb friction are ``friction_forces``, added to inverse dynamics and taken from
the right-hand side of forward dynamics as the NumPy module does; the struct carries
``friction_smoothing`` (0: the exact sign; eps > 0: ``tanh(qd / eps)``). Closed loops and the
wrench variants are ``c_loops.py`` (``amend``). Names must be C names (``codegen/names.py``); free
text appears only in encoded comments.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import sympy

from ....derivation import Derivation
from ....mechanics.tidy import fold_constants
from ... import api
from ...codegen.c_syntax import Names, expression_body, parameter_note, program_body, quantity_body
from ...codegen.cse import common_subexpressions
from ...codegen.literals import double_literal
from ...codegen.names import c_comment, c_problems, refuse
from ...codegen.prune import live_lines
from ...encode import Code
from ...environment import render
from .c_contacts import contact_functions, contact_macros
from .c_external import external_section
from .c_join import joined_program as _joined
from .c_join import print_body as _print_body
from .c_loops import CKit, amend, loop_context
from .c_print import CFunction, void
from .c_solve import fill_in, ldl_factor, ldl_solve

HEADER_TEMPLATE = "c/dynamics.h.j2"
SOURCE_TEMPLATE = "c/dynamics.c.j2"


def c_context(derivation: Derivation) -> dict[str, Any]:
    """Every variable the C templates can use."""
    refuse(c_problems(derivation.robot))
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    name, nq, n, nu = robot.name, len(table.q), len(table.qd), len(table.efforts)
    quaternions = nq != n   # Pinocchio's conventions: M, C, N are NV x NV, the maps not q + v dt
    names = Names(derivation)
    programs = derivation.programs
    pp = f"const {name}_parameters *p"
    start = f"const {name}_parameters *const P = p ? p : &{name}_default_parameters;"
    square = [f"M[{i * n + j}]" for i in range(n) for j in range(n)]
    size = api.sizes(derivation)

    def comment(function: str, *notes: str) -> str:
        return " ".join([api.described(function, size, "{n} entries", ", row-major") + ".", *notes])

    def body(program: str, quantity: str, targets: list[str]) -> list[str]:
        return quantity_body(derivation, names, program, quantity, targets)

    coriolis = [f"C[{k}]" for k in range(n * n)]
    applied = [] if quaternions else [
        CFunction(f"void {name}_generalized_forces(const double *q, const double *u, {pp}, double *Y)",
                  comment("generalized_forces"),
                  [start, *void("q", "u", "P"), *expression_body(
                      names, list(quantities["Y_g"]), [f"Y[{i}]" for i in range(n)])])]
    functions = [
        CFunction(f"void {name}_mass_matrix(const double *q, {pp}, double *M)",
                  comment("mass_matrix"),
                  [start, *void("q", "P"), *body("mass_matrix", "M_g", square)]),
        CFunction(f"void {name}_coriolis_matrix(const double *q, const double *qd, {pp}, double *C)",
                  comment("coriolis_matrix"),
                  [start, *void("q", "qd", "P"), *body("coriolis", "C_g", coriolis)]),
        CFunction(f"void {name}_gravity_vector(const double *q, {pp}, double *N)",
                  comment("gravity_vector"),
                  [start, *void("q", "P"), *body("gravity", "N_g", [f"N[{i}]" for i in range(n)])]),
        *applied,
        CFunction(f"void {name}_inverse_dynamics(const double *q, const double *qd, const double *qdd, {pp}, "
                  "double *tau)", comment("inverse_dynamics", *(["A floating joint's entries are the wrench its child "
                                                                  "would need."] if quaternions else [])),
                  [start, *void("q", "qd", "qdd", "P"),
                   *program_body(names, programs["inverse_dynamics"], [f"tau[{i}]" for i in range(n)]),
                   *_add_friction(derivation, "tau", "+=")]),
        CFunction(f"int {name}_forward_dynamics(const double *q, const double *qd, const double *u, {pp}, "
                  "double *qdd)", comment("forward_dynamics", "M is factored as L D L^T; returns 0, or 1 (qdd "
                                          "untouched) if M is not positive definite."),
                  [] if robot.loops else _forward_body(derivation, names, start)),   # loops: c_loops.amend
        CFunction(f"double {name}_kinetic_energy(const double *q, const double *qd, {pp})",
                  comment("kinetic_energy"),
                  [f"double M[{n * n}];", f"{name}_mass_matrix(q, p, M);",
                   "return 0.5 * (" + " + ".join(f"qd[{i}]*({' + '.join(f'M[{i * n + j}]*qd[{j}]' for j in range(n))})"
                                                 for i in range(n)) + ");"]),
        CFunction(f"double {name}_potential_energy(const double *q, {pp})",
                  comment("potential_energy"),
                  [start, "double V;", *void("q", "P"), *body("potential", "V_g", ["V"]), "return V;"]),
        CFunction(f"void {name}_friction_forces(const double *qd, {pp}, double *F)",
                  comment("friction_forces") if robot.dissipative else
                  f"Dissipative forces F_g: zero, the robot declares no damping or friction, {n} entries.",
                  _friction_body(derivation, names, start)),
        CFunction(f"int {name}_linearize(const double *q, const double *qd, const double *u, {pp}, double *A, "
                  "double *B)", comment("linearize", "From Newton-Euler differentiated and one L D L^T solve; "
                                        "returns 0, or 1 (A, B untouched) if M is not positive definite.",
                                        *(["Tangent space: q perturbed as integrate(q, dq)."] if quaternions else [])),
                  [] if robot.loops else _linearize_body(derivation, names, start)),
        CFunction(f"void {name}_inverse_dynamics_derivatives(const double *q, const double *qd, "
                  f"const double *qdd, {pp}, double *dtau_dq, double *dtau_dqd)",
                  comment("inverse_dynamics_derivatives", "From Newton-Euler differentiated line by line; "
                          "dtau/dqdd is the mass matrix.",
                          *(["Tangent space: q perturbed as integrate(q, dq)."] if quaternions else []),
                          *(["Of the open tree (no loop forces)."] if robot.loops else []),
                          *(["Damping and Coulomb friction's slope (friction_smoothing > 0) are in dtau_dqd."]
                            if robot.dissipative else []), "External wrenches are not differentiated."),
                  _inverse_derivatives_body(derivation, names, start)),
        CFunction(f"int {name}_forward_dynamics_derivatives(const double *q, const double *qd, "
                  f"const double *u, {pp}, double *dqdd_dq, double *dqdd_dqd, double *dqdd_du)",
                  comment("forward_dynamics_derivatives", "The lower blocks of linearize's A and B; "
                          "returns its status: 0, or 1 (outputs untouched) if it fails."),
                  _forward_derivatives_body(name, n, nu)),
        CFunction(f"void {name}_regressor(const double *q, const double *qd, const double *qdd, {pp}, double *Y)",
                  comment("regressor"), _regressor_body(derivation, names, start)),
        CFunction(f"void {name}_parameter_vector({pp}, double *pi)",
                  comment("parameter_vector"),
                  [start, *void("P"), *expression_body(
                      names, [v.value for v in derivation.parameter_vector],
                      [f"pi[{i}]" for i in range(len(derivation.parameter_vector))])]),
        *_frame_functions(derivation, names, start, pp),
        *_centroidal_functions(derivation, names, start, pp),
        *(_configuration_functions(derivation) if quaternions else []),
        *contact_functions(derivation, _structural_pattern(derivation, n)),
    ]
    functions = amend(derivation, CKit(
        start, pp, CFunction, lambda values, targets, extra=None: expression_body(names.extended(extra), values, targets),
        lambda program, targets, extra=None: program_body(names.extended(extra), program, targets),
        fill_in(_structural_pattern(derivation, n), n), lambda: _friction_slope(derivation, names, 2 * n + nu)),
        functions)
    loops = loop_context(derivation)
    parameters = [{"name": p.name, "default": Code("NAN") if p.value is None else Code(double_literal(float(p.value))),
                   "comment": c_comment(parameter_note(p))} for p in robot.parameters]
    parameters.append({"name": "friction_smoothing", "default": Code("0.0"), "comment": c_comment(
        "Coulomb friction: 0 for sign(qd), eps > 0 for tanh(qd / eps) (negative: as 0)"
        if robot.dissipative else "unused: the robot has no Coulomb friction (every robot's struct ends with it)")})
    parameters += loops["members"]
    from ...._version import __version__

    return {
        "name": name,
        "macro": name.upper(),
        "title": c_comment(robot.title),
        "source": c_comment(Path(robot.source).name),
        "generator": c_comment(f"dynderive {__version__}"),
        "nq": nq, "nv": n, "nu": nu, "nc": loops["nc"],
        "coordinates": c_comment(", ".join(robot.configuration_names)),
        "efforts": c_comment(", ".join(robot.efforts)),
        "parameters": parameters,
        "frames": [{"index": i, "name": c_comment(f.name)} for i, f in enumerate(robot.frames)],
        "functions": functions,
        "external": [Code(line) for line in external_section(derivation)],
        "contacts": [Code(line) for line in contact_macros(derivation)],
    }


#: The output array of each configuration map (the others write ``out``), and what its comment
#: adds to the API table's summary.
OUTPUTS = {"neutral_configuration": "q", "difference": "v"}
CONFIGURATION_NOTES = {
    "integrate": "q + v dt, a floating joint's pose times exp(v dt) on SE(3) (its quaternion normalized in the "
                 "hemisphere of q's), a spherical joint's quaternion times exp(w dt), normalized.",
    "configuration_rate": "The derivative of integrate(q, v, t) at t = 0.",
}


def _configuration_functions(derivation: Derivation) -> list[CFunction]:
    """The configuration maps, each its joint types' program printed (no parameters), with the
    API table's arguments."""
    size = api.sizes(derivation)
    functions = []
    for kind in api.group("configuration"):
        entry, arguments = derivation.configuration_programs[kind], api.BY_NAME[kind].arguments
        out = OUTPUTS.get(kind, "out")
        names = Names(extra={symbol: key if key == "dt" else f"{key}[{i}]"
                             for key in arguments for i, symbol in enumerate(entry.arguments[key])})
        declared = ", ".join([*("double dt" if a == "dt" else f"const double *{a}" for a in arguments), f"double *{out}"])
        comment = f"{api.described(kind, size, '{n} entries')}. {CONFIGURATION_NOTES.get(kind, '')}".strip()
        ((count,),) = api.shapes(kind, size)
        functions.append(CFunction(f"void {derivation.robot.name}_{kind}({declared})", comment,
                                   program_body(names, entry.program, [f"{out}[{i}]" for i in range(count)])))
    return functions


def _frame_functions(derivation: Derivation, names: Names, start: str, pp: str) -> list[CFunction]:
    """Pose, Jacobian and Jdot qd of the frame numbered ``frame`` (the order of the robot
    file's frames); each returns 0, or 1 (output untouched) for a number that is no frame.
    The Jacobian has a column per velocity (NV); a floating-base robot's frames are tuples
    ``(name, pose, Jacobian, Jdot qd)``."""
    robot, n = derivation.robot, len(derivation.symbols.qd)
    size, twist = (3, 3) if robot.planar else (4, 6)
    name = robot.name
    specs = [
        ("transform", "const double *q", ("q",), "T", size * size,
         f"Pose of frame number `frame` in the world, [[R, p], [0, 1]], {size} x {size}, row-major."),
        ("jacobian", "const double *q", ("q",), "J", twist * n,
         f"World-frame Jacobian of frame number `frame`, {twist} x {n}, row-major: linear rows, then angular."),
        ("jacobian_dot_qd", "const double *q, const double *qd", ("q", "qd"), "a", twist,
         f"Jdot(q, qd) qd of frame number `frame`, {twist} entries (its acceleration at qdd = 0)."),
    ]
    functions = []
    for kind, arguments, used, out, count, comment in specs:
        body = [start, *void(*used, "frame", "P", out)]
        for index, frame in enumerate(derivation.frame_programs):
            program = getattr(frame, kind)
            lines = program_body(names, program, [f"{out}[{k}]" for k in range(count)])
            body += [f"if (frame == {index}) {{", *(f"    {line}" for line in lines), "    return 0;", "}"]
        body.append("return 1;")
        functions.append(CFunction(f"int {name}_frame_{kind}({arguments}, int frame, {pp}, double *{out})",
                                   comment + " Returns 0, or 1 if there is no such frame.", body))
    return functions


#: The output array of each centroidal function (the inertia's not ``I``, <complex.h>'s macro),
#: and what its comment adds to the API table's.
CENTROIDAL_OUTPUTS = {"center_of_mass": "c", "center_of_mass_velocity": "v", "center_of_mass_jacobian": "J",
                      "center_of_mass_acceleration_bias": "a", "centroidal_momentum_matrix": "A",
                      "centroidal_momentum": "h", "centroidal_momentum_bias": "dh", "centroidal_inertia": "Ig"}
CENTROIDAL_NOTES = {
    "total_mass": "Links welded to the world are left out (Pinocchio's universe).",
    "center_of_mass_acceleration_bias": "The centre of mass accelerates by J qdd + this.",
    "centroidal_momentum_bias": "The centroidal momentum changes by A_G qdd + this.",
}


def _centroidal_functions(derivation: Derivation, names: Names, start: str, pp: str) -> list[CFunction]:
    """The centre of mass and the centroidal momentum of a 3-D robot (none for a planar one):
    each ``Derivation.centroidal_programs`` program printed, with the API table's arguments;
    ``total_mass`` returns its value."""
    programs = derivation.centroidal_programs
    if programs is None:
        return []
    size, name = api.sizes(derivation), derivation.robot.name
    functions = []
    for kind in api.group("centroidal"):
        program, arguments = getattr(programs, kind), api.BY_NAME[kind].arguments
        comment = " ".join([api.described(kind, size, "{n} entries", ", row-major") + ".",
                            *([CENTROIDAL_NOTES[kind]] if kind in CENTROIDAL_NOTES else [])])
        if kind not in CENTROIDAL_OUTPUTS:   # total_mass: the one value
            functions.append(CFunction(f"double {name}_{kind}({pp})", comment,
                                       [start, "double m;", *void("P"), *program_body(names, program, ["m"]),
                                        "return m;"]))
            continue
        out = CENTROIDAL_OUTPUTS[kind]
        count = math.prod(*api.shapes(kind, size))
        declared = ", ".join([*(f"const double *{a}" for a in arguments), pp, f"double *{out}"])
        functions.append(CFunction(f"void {name}_{kind}({declared})", comment,
                                   [start, *void(*arguments, "P"),
                                    *program_body(names, program, [f"{out}[{k}]" for k in range(count)])]))
    return functions


def _friction_body(derivation: Derivation, names: Names, start: str) -> list[str]:
    """F_g = b qd + fc direction(qd) per coordinate with a drive (the NumPy module's order of
    operations); zero elsewhere."""
    n = len(derivation.symbols.qd)
    lines = [start, *void("qd", "P")]
    drives = {d.coordinate: d for d in derivation.joint_drives} if derivation.robot.dissipative else {}
    printer = names.printer()
    for i in range(n):
        drive = drives.get(i)
        if drive is None or (drive.damping == 0 and drive.friction == 0):
            lines.append(f"F[{i}] = 0.0;")
            continue
        direction = _direction(i)
        terms = ([f"({printer.doprint(fold_constants(drive.damping))})*qd[{i}]"] if drive.damping != 0 else []) + \
            ([f"({printer.doprint(fold_constants(drive.friction))})*{direction}"] if drive.friction != 0 else [])
        lines.append(f"F[{i}] = {' + '.join(terms)};")
    return lines


def _add_friction(derivation: Derivation, target: str, operator: str) -> list[str]:
    """``target operator F`` with F from ``friction_forces`` (nothing for a robot without drives)."""
    if not derivation.robot.dissipative:
        return []
    n, name = len(derivation.symbols.qd), derivation.robot.name
    return [f"double F[{n}];", f"{name}_friction_forces(qd, p, F);",
            *(f"{target}[{i}] {operator} F[{i}];" for i in range(n))]


def _forward_body(derivation: Derivation, names: Names, start: str) -> list[str]:
    """The forward-dynamics program (CRBA, Newton-Euler at qdd = 0 on the same kinematics,
    Y_g(u) and an L D L^T solve: the NumPy module's ``_forward_dynamics_body``) as one body;
    ``return 1`` before any store if a pivot is not positive."""
    local, friction = _forward_names(derivation, names)
    lines, (outputs,), pivots = _joined([_forward_part(derivation)])
    return [start, *void("q", "qd", "u", "P"), *friction,
            *_print_body(local, lines, [(f"qdd[{i}]", e) for i, e in enumerate(outputs)], pivots), "return 0;"]


def _forward_part(derivation: Derivation) -> tuple[list, list, dict, bool]:
    """The forward-dynamics program as a part of ``_joined``: its extra inputs (F - J^T w)
    are zero for a robot without damping or friction (the C functions take no wrenches)."""
    program = derivation.programs["forward_dynamics"]
    zero = {} if derivation.robot.dissipative else {s: sympy.S.Zero for s in program.extra_inputs}
    return program.lines, [sympy.sympify(e) for e in program.outputs], zero, True


def _mass_part(derivation: Derivation) -> tuple[list, list]:
    """M's lines and entries: the mass-matrix program, or the explicit M_g with common
    subexpressions eliminated (a small planar robot)."""
    if derivation.structured_code:
        program = derivation.programs["mass_matrix"]
        return program.lines, [sympy.sympify(e) for e in program.outputs]
    return common_subexpressions([fold_constants(sympy.sympify(v)) for v in derivation.quantities["M_g"]], "_c")


def _forward_names(derivation: Derivation, names: Names) -> tuple[Names, list[str]]:
    """Names with the forward program's extra inputs as ``F[i]``, and the lines computing F."""
    if not derivation.robot.dissipative:
        return names, []
    program, n = derivation.programs["forward_dynamics"], len(derivation.symbols.qd)
    local = names.extended({symbol: f"F[{i}]" for i, symbol in enumerate(program.extra_inputs)})
    return local, [f"double F[{n}];", f"{derivation.robot.name}_friction_forces(qd, p, F);"]


def _direction(i: int) -> str:
    """sign(qd_i), or tanh(qd_i / friction_smoothing) when that is positive (as the NumPy module)."""
    return (f"(P->friction_smoothing > 0.0 ? tanh(qd[{i}] / P->friction_smoothing)"
            f" : (double)((qd[{i}] > 0.0) - (qd[{i}] < 0.0)))")


def _regressor_body(derivation: Derivation, names: Names, start: str) -> list[str]:
    program = derivation.programs["regressor"]
    n, count = len(derivation.symbols.qd), len(derivation.parameter_vector)
    lines = [start, *void("q", "qd", "qdd", "P")]
    local = names
    if program.extra_inputs:   # Coulomb friction's columns: the direction of each velocity
        read = set().union(*(sympy.sympify(e).free_symbols for e in program.outputs))
        live_lines(program.lines, read)   # read: every name the lines its outputs need read
        lines += [f"const double s{i} = {_direction(i)};" for i, symbol in enumerate(program.extra_inputs)
                  if symbol in read]
        local = names.extended({symbol: f"s{i}" for i, symbol in enumerate(program.extra_inputs)})
    return lines + program_body(local, program, [f"Y[{k}]" for k in range(n * count)])


def _linearize_body(derivation: Derivation, names: Names, start: str) -> list[str]:
    """One body: qdd from the forward-dynamics program, M, and the differentiated Newton-Euler
    program at that qdd (their sines, cosines and common values computed once); R = [-dtau/dq,
    -dtau/dqd - dF/dqd, dY/du]; M X = R column by column (L D L^T); A = [[0, I], X_q, X_qd],
    B = [[0], X_u]. With quaternions each effort is 1 at its velocity column of dY/du."""
    table = derivation.symbols
    n, nu = len(table.qd), len(table.efforts)
    quaternions = len(table.q) != n
    width = 2 * n + nu
    local, friction = _forward_names(derivation, names)
    lines = [start, *void("q", "qd", "u", "P", "B"), f"double M[{n * n}];", f"double D[{2 * n * n}];",
             f"double R[{n * width}];", *friction]
    derivatives = derivation.programs["inverse_dynamics_derivatives"]
    joined, (_, mass, derived), pivots = _joined([
        _forward_part(derivation), (*_mass_part(derivation), {}, False),
        (derivatives.lines, derivatives.outputs, lambda outputs: dict(zip(table.qdd, outputs[0])), False)])
    lines += _print_body(local, joined, [*((f"M[{k}]", e) for k, e in enumerate(mass)),
                                         *((f"D[{k}]", e) for k, e in enumerate(derived))], pivots)
    lines += negated_derivatives(n, width, inputs=quaternions and bool(nu))
    lines += _friction_slope(derivation, names, width)
    if quaternions:
        lines += [f"R[{column * width + 2 * n + k}] = 1.0;" for k, column in enumerate(derivation.robot.effort_columns())]
    elif nu:
        lines += expression_body(names, list(derivation.effort_jacobian),
                                  [f"R[{i * width + 2 * n + k}]" for i in range(n) for k in range(nu)])
    return lines + solved_into_a_and_b(_structural_pattern(derivation, n), n, nu)


def negated_derivatives(n: int, width: int, inputs: bool = False) -> list[str]:
    """``R``'s first 2 n columns (of ``width``) as ``-D``, the derivatives of inverse dynamics
    by q and by qd; with ``inputs``, its effort columns zeroed too (filled afterwards)."""
    return [f"for (int i = 0; i < {n}; ++i) {{",
            f"    for (int k = 0; k < {2 * n}; ++k) R[i * {width} + k] = -D[(k / {n}) * {n * n} + i * {n} + k % {n}];",
            *([f"    for (int k = {2 * n}; k < {width}; ++k) R[i * {width} + k] = 0.0;"] if inputs else []),
            "}"]


def solved_into_a_and_b(pattern: list[list[bool]], n: int, nu: int) -> list[str]:
    """``M X = R`` column by column (L D L^T on ``pattern``'s fill-in), then A = [[0, I], X_q,
    X_qd] and B = [[0], X_u]: the end of ``linearize`` (fixed and floating base, n = NV)."""
    width = 2 * n + nu
    nonzero = fill_in(pattern, n)
    lines = ldl_factor(lambda i, j: f"M[{i * n + j}]", n, nonzero, "", "return 1;")
    lines += [f"for (int i = 0; i < {4 * n * n}; ++i) A[i] = 0.0;",
              *(f"A[{i * 2 * n + n + i}] = 1.0;" for i in range(n)),
              *([f"for (int i = 0; i < {n * nu}; ++i) B[i] = 0.0;"] if nu else []),
              f"for (int c = 0; c < {width}; ++c) {{"]
    solve = ldl_solve(n, nonzero, "", [f"R[{i * width} + c]" for i in range(n)])
    lines += [f"    {line}" for line in solve]
    lines += [f"    if (c < {2 * n}) {{", *(f"        A[{(n + i) * 2 * n} + c] = x{i};" for i in range(n))]
    if nu:
        lines += ["    } else {", *(f"        B[{(n + i) * nu} + c - {2 * n}] = x{i};" for i in range(n))]
    return lines + ["    }", "}", "return 0;"]


def _inverse_derivatives_body(derivation: Derivation, names: Names, start: str) -> list[str]:
    """The differentiated Newton-Euler program into dtau_dq and dtau_dqd (n x n each,
    row-major), then dF/dqd on dtau_dqd's diagonal."""
    n = len(derivation.symbols.qd)
    targets = [f"dtau_dq[{k}]" for k in range(n * n)] + [f"dtau_dqd[{k}]" for k in range(n * n)]
    slope = [f"dtau_dqd[{i * n + i}] += {terms};" for i, terms in _slope_terms(derivation, names)]
    return [start, *void("q", "qd", "qdd", "P"),
            *program_body(names, derivation.programs["inverse_dynamics_derivatives"], targets), *slope]


def _forward_derivatives_body(name: str, n: int, nu: int) -> list[str]:
    """linearize into local A and B, their lower blocks copied out (nothing written on failure)."""
    return [f"double A[{4 * n * n}];", f"double B[{max(2 * n * nu, 1)}];",
            f"if ({name}_linearize(q, qd, u, p, A, B) != 0) return 1;",
            f"for (int i = 0; i < {n}; ++i) {{",
            f"    for (int k = 0; k < {n}; ++k) {{",
            f"        dqdd_dq[i * {n} + k] = A[({n} + i) * {2 * n} + k];",
            f"        dqdd_dqd[i * {n} + k] = A[({n} + i) * {2 * n} + {n} + k];",
            "    }",
            *([f"    for (int k = 0; k < {nu}; ++k) dqdd_du[i * {nu} + k] = B[({n} + i) * {nu} + k];"]
              if nu else []),
            "}", *([] if nu else ["(void)dqdd_du;"]), "return 0;"]


def _friction_slope(derivation: Derivation, names: Names, width: int) -> list[str]:
    """``R[i, n + i] -= dF_i/dqd_i`` in linearize's right-hand side R (``width`` columns)."""
    n = len(derivation.symbols.qd)
    return [f"R[{i * width + n + i}] -= {terms};" for i, terms in _slope_terms(derivation, names)]


def _slope_terms(derivation: Derivation, names: Names) -> list[tuple[int, str]]:
    """(i, dF_i/dqd_i) of each coordinate with a drive: b + fc (1 - tanh(qd/eps)^2)/eps (zero
    for the exact sign)."""
    if not derivation.robot.dissipative:
        return []
    printer, lines = names.printer(), []
    for drive in derivation.joint_drives:
        i = drive.coordinate
        terms = []
        if drive.damping != 0:
            terms.append(f"({printer.doprint(fold_constants(drive.damping))})")
        if drive.friction != 0:
            fc = printer.doprint(fold_constants(drive.friction))
            terms.append(f"(P->friction_smoothing > 0.0 ? ({fc})*(1.0 - tanh(qd[{i}] / P->friction_smoothing)"
                         f"*tanh(qd[{i}] / P->friction_smoothing)) / P->friction_smoothing : 0.0)")
        if terms:
            lines.append((i, " + ".join(terms)))
    return lines


def _structural_pattern(derivation: Derivation, n: int) -> list[list[bool]]:
    """Which entries of M can be nonzero: the mass-matrix program's outputs (or the explicit
    M_g) that are not the number zero."""
    if derivation.structured_code:
        outputs = [sympy.sympify(e) for e in derivation.programs["mass_matrix"].outputs]
    else:
        outputs = list(derivation.quantities["M_g"])
    return [[outputs[i * n + j] != 0 for j in range(n)] for i in range(n)]


def render_c(derivation: Derivation, template_dir: str | Path | None = None) -> tuple[str, str]:
    """The header and the source of the C target, as text (nothing written)."""
    context = c_context(derivation)
    return (render("code", HEADER_TEMPLATE, context, template_dir),
            render("code", SOURCE_TEMPLATE, context, template_dir))
