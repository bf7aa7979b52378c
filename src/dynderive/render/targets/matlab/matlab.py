"""The MATLAB/Octave target's numeric functions (``solve --matlab``): ``+<name>/``, one function
per file.

The same straight-line programs as the NumPy and C targets (``Derivation.programs``,
``frame_programs``, a 3-D robot's ``centroidal_programs``; a small planar robot's explicit M,
C, N, V with common subexpressions eliminated), printed for MATLAB by ``matlab_print.py``'s ``MatlabPrinter`` (SymPy's ``OctaveCodePrinter``, with
numbers as exact double literals of 17 significant digits, integer powers as products and
``~`` for negation) and ``FastMatlabPrinter`` (the project's fast line printer with the same
numbers and powers). Every value is a scalar: ``*``, ``/`` and products print the same in
MATLAB as in C. Arrays are column vectors and matrices indexed from 1; parameters are fields
of the struct ``p`` (``p.m``).

Dense linear algebra is MATLAB's: forward dynamics solves ``M qdd = Y(u) - (C qd + N + F)``
with ``\\`` (M symmetric positive definite: MATLAB factors it by Cholesky), ``linearize``
solves its columns the same way, and a loop robot solves the NumPy module's constrained system
(``matlab_loops.py``); a 3-D robot's contact dynamics solve the NumPy module's Schur complement
(``matlab_contacts.py``). Free text appears only in ``%`` comments (``matlab_comment``); names must
be MATLAB names (``matlab_names.py``).
"""

from __future__ import annotations

from pathlib import Path

from ....derivation import Derivation
from ....mechanics.tidy import fold_constants
from ... import api
from ...codegen.c_syntax import parameter_note, quantity_body
from ...codegen.literals import double_literal
from ...codegen.names import refuse
from ...encode import Code
from ...environment import render
from .matlab_contacts import contact_functions, contacts_function
from .matlab_loops import loop_functions
from .matlab_names import matlab_comment, matlab_problems, matlab_string
from .matlab_print import (
    DIRECTION_LINES,
    MFunction,
    Names,
    expression_body,
    friction_slope,
    help_line,
    linearize_rhs,
    matrix_targets,
    program_body,
    prologue,
    vector_targets,
)

FUNCTION_TEMPLATE = "matlab/function.m.j2"


def _friction_body(derivation: Derivation, names: Names) -> list[str]:
    n = len(derivation.symbols.qd)
    lines = prologue(derivation, ["qd"], 2) + [f"F = zeros({n}, 1);"]
    drives = {d.coordinate: d for d in derivation.joint_drives} if derivation.robot.dissipative else {}
    if any(d.friction != 0 for d in drives.values()):
        lines += DIRECTION_LINES
    printer = names.printer()
    for i, drive in sorted(drives.items()):
        terms = ([f"({printer.doprint(fold_constants(drive.damping))})*qd({i + 1})"] if drive.damping != 0 else []) + \
            ([f"({printer.doprint(fold_constants(drive.friction))})*s({i + 1})"] if drive.friction != 0 else [])
        if terms:
            lines.append(f"F({i + 1}) = {' + '.join(terms)};")
    return lines


def numeric_functions(derivation: Derivation) -> list[MFunction]:
    """Every function of ``+<name>/`` (the loop functions from ``matlab_loops``; the
    configuration maps of a robot with quaternions)."""
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    name, nq, n, nu = robot.name, len(table.q), len(table.qd), len(table.efforts)
    names = Names(derivation)
    programs = derivation.programs
    count = len(derivation.parameter_vector)

    def body(program: str, quantity: str, targets: list[str]) -> list[str]:
        return quantity_body(derivation, names, program, quantity, targets)

    friction = ([f"tau = tau + {name}.friction_forces(qd, p);"] if robot.dissipative else [])
    regressor = programs["regressor"]
    regressor_names = names.extended({s: f"s({i + 1})" for i, s in enumerate(regressor.extra_inputs)})
    functions = [
        MFunction("mass_matrix", "M", ["q", "p"],
                  [help_line(derivation, "mass_matrix"), "", "   M = " + name + ".mass_matrix(q)",
                   "   M = " + name + ".mass_matrix(q, p)   (p: a struct as from parameters())"],
                  [*prologue(derivation, ["q"], 2), f"M = zeros({n}, {n});", *body("mass_matrix", "M_g",
                                                                                   matrix_targets("M", n, n))]),
        MFunction("coriolis_matrix", "C", ["q", "qd", "p"],
                  [help_line(derivation, "coriolis_matrix"), "",
                   f"   C = {name}.coriolis_matrix(q, qd, p): C*qd are the velocity terms of the equations."],
                  [*prologue(derivation, ["q", "qd"], 3), f"C = zeros({n}, {n});",
                   *body("coriolis", "C_g", matrix_targets("C", n, n))]),
        MFunction("gravity_vector", "N", ["q", "p"],
                  [help_line(derivation, "gravity_vector")],
                  [*prologue(derivation, ["q"], 2), f"N = zeros({n}, 1);",
                   *body("gravity", "N_g", vector_targets("N", n))]),
        MFunction("inverse_dynamics", "tau", ["q", "qd", "qdd", "p"],
                  [help_line(derivation, "inverse_dynamics", *(["The open tree's: no loop forces."] if robot.loops else []))],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4), f"tau = zeros({n}, 1);",
                   *program_body(names, programs["inverse_dynamics"], vector_targets("tau", n)), *friction]),
        MFunction("generalized_forces", "Y", ["q", "u", "p"],
                  [help_line(derivation, "generalized_forces", f"u: {nu} x 1.")],
                  [*prologue(derivation, ["q", "u"], 3), f"Y = zeros({n}, 1);",
                   *(expression_body(names, list(quantities["Y_g"]), vector_targets("Y", n)) if nq == n else
                     (f"Y({c + 1}) = u({k + 1});" for k, c in enumerate(robot.effort_columns())))]),
        MFunction("kinetic_energy", "T", ["q", "qd", "p"], [help_line(derivation, "kinetic_energy")],
                  [*prologue(derivation, ["q", "qd"], 3), f"T = 0.5*(qd' * ({name}.mass_matrix(q, p) * qd));"]),
        MFunction("potential_energy", "V", ["q", "p"],
                  [help_line(derivation, "potential_energy")],
                  [*prologue(derivation, ["q"], 2), "V = 0;", *body("potential", "V_g", ["V"])]),
        MFunction("friction_forces", "F", ["qd", "p"],
                  [help_line(derivation, "friction_forces") if robot.dissipative else
                   f"FRICTION_FORCES  Dissipative forces F_g: zero, the robot declares no damping or friction, {n} x 1."],
                  _friction_body(derivation, names)),
        MFunction("regressor", "Y", ["q", "qd", "qdd", "p"],
                  [help_line(derivation, "regressor", *(["The open tree's: no loop forces."] if robot.loops else []))],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4),
                   *(DIRECTION_LINES if regressor.extra_inputs else []), f"Y = zeros({n}, {count});",
                   *program_body(regressor_names, regressor, matrix_targets("Y", n, count))]),
        MFunction("parameter_vector", "pi_", ["p"],
                  [help_line(derivation, "parameter_vector", "Per link mass, first moment m c, inertia about the "
                             "link frame's origin; then the drives.")],
                  ["if nargin < 1 || isempty(p)", f"    p = {name}.parameters();", "end", f"pi_ = zeros({count}, 1);",
                   *expression_body(names, [v.value for v in derivation.parameter_vector], vector_targets("pi_", count))]),
        *_frame_functions(derivation, names),
        *_centroidal_functions(derivation, names),
    ]
    if not robot.loops:
        functions += [_forward_dynamics(derivation), _linearize(derivation, names)]
    else:
        functions += loop_functions(derivation, names)
    functions += contact_functions(derivation)
    functions += _derivatives(derivation, names)
    return functions + (_configuration_functions(derivation) if nq != n else [])


def _derivatives(derivation: Derivation, names: Names) -> list[MFunction]:
    """``inverse_dynamics_derivatives`` (the differentiated Newton-Euler program, the drives'
    slope on dtau_dqd's diagonal) and ``forward_dynamics_derivatives`` (linearize's lower blocks)."""
    robot = derivation.robot
    name, n, nu = robot.name, len(derivation.symbols.qd), len(derivation.symbols.efforts)
    notes = [*(["Tangent space: q perturbed as integrate(q, dq)."] if len(derivation.symbols.q) != n else []),
             *(["The open tree's: no loop forces."] if robot.loops else [])]
    derivatives = [
        MFunction("inverse_dynamics_derivatives", "[dtau_dq, dtau_dqd]", ["q", "qd", "qdd", "p"],
                  [help_line(derivation, "inverse_dynamics_derivatives", *notes), "",
                   "   From Newton-Euler differentiated line by line; dtau/dqdd is the mass matrix."
                   + (" Damping and Coulomb" if robot.dissipative else ""),
                   *(["   friction's slope (p.friction_smoothing > 0) are in dtau_dqd."]
                     if robot.dissipative else []),
                   "   External wrenches are not differentiated."],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4), f"D = zeros({2 * n * n}, 1);",
                   *program_body(names, derivation.programs["inverse_dynamics_derivatives"],
                                 vector_targets("D", 2 * n * n)),
                   f"dtau_dq = reshape(D(1:{n * n}), {n}, {n})';",
                   f"dtau_dqd = reshape(D({n * n + 1}:{2 * n * n}), {n}, {n})';",
                   *friction_slope(derivation, names, "dtau_dqd", 0, "+")]),
        MFunction("forward_dynamics_derivatives", "[dqdd_dq, dqdd_dqd, dqdd_du]", ["q", "qd", "u", "p"],
                  [help_line(derivation, "forward_dynamics_derivatives"), "",
                   f"   [A, B] = {name}.linearize(q, qd, u, p): A = [0, I; dqdd_dq, dqdd_dqd],",
                   "   B = [0; dqdd_du].",
                   "   u may be [] (no effort)."],
                  [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
                   f"[A, B] = {name}.linearize(q, qd, u, p);",
                   f"dqdd_dq = A({n + 1}:end, 1:{n});", f"dqdd_dqd = A({n + 1}:end, {n + 1}:end);",
                   f"dqdd_du = B({n + 1}:end, :);"]),
    ]
    return derivatives


def _forward_dynamics(derivation: Derivation) -> MFunction:
    name, n, nu = derivation.robot.name, len(derivation.symbols.qd), len(derivation.symbols.efforts)
    return MFunction(
        "forward_dynamics", "qdd", ["q", "qd", "u", "p"],
        [help_line(derivation, "forward_dynamics"), "",
         f"   qdd = {name}.forward_dynamics(q, qd, u, p); u ({nu} x 1) may be [] (no effort).",
         "   M is solved with MATLAB's \\ (Cholesky: M is symmetric positive definite).",
         f"   ode45(@(t, x) [x({n + 1}:{2 * n}); {name}.forward_dynamics(x(1:{n}), x({n + 1}:{2 * n}), u, p)], tspan, x0)"],
        [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
         f"M = {name}.mass_matrix(q, p);",
         f"rhs = {name}.generalized_forces(q, u, p) - {name}.inverse_dynamics(q, qd, zeros({n}, 1), p);",
         "qdd = M \\ rhs;"])


def _linearize(derivation: Derivation, names: Names) -> MFunction:
    name, n, nu = derivation.robot.name, len(derivation.symbols.qd), len(derivation.symbols.efforts)
    return MFunction(
        "linearize", "[A, B]", ["q", "qd", "u", "p"],
        [help_line(derivation, "linearize"), "",
         "   A = [0, I; dqdd/dq, dqdd/dqd], B = [0; dqdd/du], from Newton-Euler differentiated line by line",
         "   and one solve with M (M dqdd/dx = dY/dx - dtau/dx at the state's own qdd)."],
        [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
         f"qdd0 = {name}.forward_dynamics(q, qd, u, p);", *linearize_rhs(derivation, names, "qdd0"),
         f"X = {name}.mass_matrix(q, p) \\ R;",
         f"A = [zeros({n}, {n}), eye({n}); X(:, 1:{2 * n})];", f"B = [zeros({n}, {nu}); X(:, {2 * n + 1}:end)];"])


#: Each configuration map's output, and its help lines after the API table's.
CONFIGURATION_FUNCTIONS = {
    "neutral_configuration": ("q", []),
    "integrate": ("out", ["", "   q + v dt for the joints, a floating joint's pose times exp(v dt) on SE(3), a spherical joint's",
                          "   quaternion times exp(w dt); quaternions normalized, in the hemisphere of q's. dt: 1 if omitted.",
                          "   q1 = {name}.integrate(q, v, dt)"]),
    "difference": ("v", []),
    "configuration_rate": ("out", ["", "   The derivative of integrate(q, v, t) at t = 0:",
                                   "   ode45(@(t, x) [{name}.configuration_rate(x(1:{nq}), x({nq1}:end)); "
                                   "{name}.forward_dynamics(x(1:{nq}), x({nq1}:end), u, p)], tspan, x0)"]),
}

#: The local function of a file whose program branches (``MatlabPrinter._choice``).
IF_ELSE = MFunction("if_else", "y", ["condition", "yes", "no"],
                    ["IF_ELSE  yes if condition, else no (a branch of the program)."],
                    ["if condition", "    y = yes;", "else", "    y = no;", "end"])


def _configuration_functions(derivation: Derivation) -> list[MFunction]:
    """The configuration maps, each its joint types' program printed (no parameters), with the
    API table's arguments."""
    size = api.sizes(derivation)
    text = {"name": derivation.robot.name, "nq": size["NQ"], "nq1": size["NQ"] + 1}
    functions = []
    for kind, (out, help_lines) in CONFIGURATION_FUNCTIONS.items():
        entry, arguments = derivation.configuration_programs[kind], list(api.BY_NAME[kind].arguments)
        names = Names(extra={symbol: key if key == "dt" else f"{key}({i + 1})"
                             for key in arguments for i, symbol in enumerate(entry.arguments[key])})
        ((count,),) = api.shapes(kind, size)
        body = [f"{a} = {a}(:);" for a in arguments if a != "dt"]
        body += ["if nargin < 3", "    dt = 1;", "end"] if "dt" in arguments else []
        body += [f"{out} = zeros({count}, 1);", *program_body(names, entry.program, vector_targets(out, count))]
        branches = any("if_else(" in line for line in body)
        functions.append(MFunction(kind, out, arguments, [help_line(derivation, kind),
                                                          *(line.format(**text) for line in help_lines)],
                                   body, [IF_ELSE] if branches else []))
    return functions


def _frame_functions(derivation: Derivation, names: Names) -> list[MFunction]:
    """Pose, Jacobian and Jdot qd of a frame: ``frame`` its name (a character vector) or its
    1-based number in the robot file's order; anything else is an error. A floating-base
    robot's frame programs are tuples ``(name, transform, jacobian, jacobian_dot_qd)`` and its
    Jacobians have one column per velocity (NV), like a fixed-base robot's (n = NV)."""
    robot, n = derivation.robot, len(derivation.symbols.qd)
    if not robot.frames:
        return []
    size, twist = (3, 3) if robot.planar else (4, 6)
    pkg = robot.name
    listing = ", ".join(f.name for f in robot.frames)
    lookup = ["if ischar(frame) || isstring(frame)", "    index = 0;"]
    for i, f in enumerate(robot.frames):
        lookup += [f"    if strcmp(frame, {matlab_string(f.name)})", f"        index = {i + 1};", "    end"]
    lookup += ["else", "    index = frame;", "end"]
    rows = "(vx, vy, omega)" if twist == 3 else "(vx, vy, vz, wx, wy, wz)"
    specs = [
        ("transform", "T", ["q"], matrix_targets("T", size, size), f"zeros({size}, {size})",
         f"FRAME_TRANSFORM  Pose of a frame in the world, [R, p; 0, 1], {size} x {size}."),
        ("jacobian", "J", ["q"], matrix_targets("J", twist, n), f"zeros({twist}, {n})",
         f"FRAME_JACOBIAN  World-frame geometric Jacobian of a frame, {twist} x {n}: rows {rows}."),
        ("jacobian_dot_qd", "a", ["q", "qd"], vector_targets("a", twist), f"zeros({twist}, 1)",
         f"FRAME_JACOBIAN_DOT_QD  Jdot(q, qd) qd of a frame, {twist} x 1 (its acceleration at qdd = 0)."),
    ]
    functions = []
    for kind, out, vectors, targets, empty, summary in specs:
        body = [*prologue(derivation, vectors, len(vectors) + 2), *lookup, f"{out} = {empty};"]
        for index, frame in enumerate(derivation.frame_programs):
            program = getattr(frame, kind)
            lines = program_body(names, program, targets)
            body += [f"{'if' if index == 0 else 'elseif'} isequal(index, {index + 1})", *("    " + x for x in lines)]
        body += ["else", f"    error('{pkg}:frame', 'no such frame: give its name or a number from 1 to {len(robot.frames)}');",
                 "end"]
        functions.append(MFunction(f"frame_{kind}", out, [*vectors, "frame", "p"],
                                   [summary, "", f"   frame: its name, or its number in the robot file's order: {listing}"],
                                   body))
    return functions


#: Each centroidal function's output (the CasADi module's names) and its help lines after the
#: API table's.
CENTROIDAL_FUNCTIONS = {
    "total_mass": ("m", ["   Links welded to the world are left out (Pinocchio's universe)."]),
    "center_of_mass": ("c", ["   Links welded to the world are left out (Pinocchio's universe)."]),
    "center_of_mass_velocity": ("cdot", []),
    "center_of_mass_jacobian": ("J_G", ["   cdot = J_G*qd."]),
    "center_of_mass_acceleration_bias": ("Jdot_G_qd", ["   The centre of mass accelerates by J_G*qdd + Jdot_G_qd."]),
    "centroidal_momentum_matrix": ("A_G", []),
    "centroidal_momentum": ("h_G", []),
    "centroidal_momentum_bias": ("Adot_G_qd", ["   The centroidal momentum changes at A_G*qdd + Adot_G_qd."]),
    "centroidal_inertia": ("I_G", []),
}


def _centroidal_functions(derivation: Derivation, names: Names) -> list[MFunction]:
    """Centre of mass and centroidal momentum of a 3-D robot (``Derivation.centroidal_programs``,
    matrices row by row; none for a planar robot), with the API table's arguments."""
    programs = derivation.centroidal_programs
    if programs is None:
        return []
    name, size = derivation.robot.name, api.sizes(derivation)
    functions = []
    for kind, (out, help_lines) in CENTROIDAL_FUNCTIONS.items():
        vectors = list(api.BY_NAME[kind].arguments)
        (shape,) = api.shapes(kind, size)
        if len(shape) == 2:
            targets, empty = matrix_targets(out, *shape), [f"{out} = zeros({shape[0]}, {shape[1]});"]
        elif shape:
            targets, empty = vector_targets(out, shape[0]), [f"{out} = zeros({shape[0]}, 1);"]
        else:   # total_mass: one number
            targets, empty = [out], []
        call = f"   {out} = {name}.{kind}({', '.join([*vectors, 'p'])})"
        functions.append(MFunction(kind, out, [*vectors, "p"],
                                   [help_line(derivation, kind), *help_lines, "", call],
                                   [*prologue(derivation, vectors, len(vectors) + 1), *empty,
                                    *program_body(names, getattr(programs, kind), targets)]))
    return functions


def parameters_function(derivation: Derivation) -> MFunction:
    """``parameters()``: the struct of the robot file's defaults (NaN where it gives none)."""
    robot = derivation.robot
    help_lines = [f"PARAMETERS  The parameters of {robot.title}: a struct of the robot file's defaults.", ""]
    body = ["p = struct();"]
    for parameter in robot.parameters:
        value = "NaN" if parameter.value is None else double_literal(float(parameter.value))
        note = parameter_note(parameter)
        help_lines.append(f"   {parameter.name}: {note}" if note else f"   {parameter.name}")
        body.append(f"p.{parameter.name} = {value};")
    help_lines.append("   friction_smoothing: 0 for sign(qd) in Coulomb friction, eps > 0 for tanh(qd / eps)")
    body.append("p.friction_smoothing = 0;")
    if robot.loops:
        help_lines += ["   alpha, beta: Baumgarte gains of forward_dynamics (0: none)"]
        body += ["p.alpha = 0;", "p.beta = 0;"]
    return MFunction("parameters", "p", [], help_lines, body)


def render_matlab(derivation: Derivation, template_dir: str | Path | None = None,
                  functions: list[MFunction] | None = None) -> dict[str, str]:
    """The package ``+<name>/``: {relative path: text}, nothing written. ``functions``: the
    numeric functions (default ``numeric_functions``)."""
    refuse(matlab_problems(derivation.robot))
    from ...._version import __version__

    robot = derivation.robot
    context = {"title": matlab_comment(robot.title), "source": matlab_comment(Path(robot.source).name),
               "generator": matlab_comment(f"dynderive {__version__}"), "name": Code(robot.name)}
    files = {}
    numeric = numeric_functions(derivation) if functions is None else functions
    for function in [parameters_function(derivation), *contacts_function(derivation), *numeric]:
        files[f"+{robot.name}/{function.name}.m"] = render("code", FUNCTION_TEMPLATE, context | {"f": function},
                                                            template_dir)
    return dict(sorted(files.items()))
