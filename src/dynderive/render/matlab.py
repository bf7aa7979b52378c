"""The MATLAB/Octave target's numeric functions (``solve --matlab``): ``+<name>/``, one function
per file.

The same straight-line programs as the NumPy and C targets (``Derivation.programs``,
``frame_programs``; a small planar robot's explicit M, C, N, V with common subexpressions
eliminated), printed for MATLAB by ``MatlabPrinter`` (SymPy's ``OctaveCodePrinter``, with
numbers as exact double literals of 17 significant digits, integer powers as products and
``~`` for negation) and ``FastMatlabPrinter`` (the project's fast line printer with the same
numbers and powers). Every value is a scalar: ``*``, ``/`` and products print the same in
MATLAB as in C. Arrays are column vectors and matrices indexed from 1; parameters are fields
of the struct ``p`` (``p.m``).

Dense linear algebra is MATLAB's: forward dynamics solves ``M qdd = Y(u) - (C qd + N + F)``
with ``\\`` (M symmetric positive definite: MATLAB factors it by Cholesky), ``linearize``
solves its columns the same way, and a loop robot solves the NumPy module's constrained system
(``matlab_loops.py``). Free text appears only in ``%`` comments (``matlab_comment``); names must
be MATLAB names (``matlab_names.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sympy
from sympy.printing.octave import OctaveCodePrinter
from sympy.printing.precedence import precedence

from ..derivation import Derivation
from ..mechanics.tidy import fold_constants
from .c import MAX_PRODUCT_POWER, double_literal
from .code import CodeGenerationError, _ProgramPrinter
from .encode import Code
from .environment import render
from .matlab_names import check_matlab_names, matlab_comment, matlab_string

FUNCTION_TEMPLATE = "matlab/function.m.j2"


class MatlabPrinter(OctaveCodePrinter):
    """``OctaveCodePrinter`` for the generated functions: symbols by ``names`` (anything else
    is an internal error), numbers as exact double literals, integer powers as products, and
    MATLAB's ``~`` (not Octave's ``!``) for negation."""

    _operators = {"and": "&&", "or": "||", "not": "~"}

    def __init__(self, names: dict[sympy.Symbol, str]):
        super().__init__({"strict": True, "inline": True})
        self.names = names

    def _print_Symbol(self, expr: sympy.Symbol) -> str:
        try:
            return self.names[expr]
        except KeyError:
            raise CodeGenerationError(f"the MATLAB code has no value for the symbol {expr}") from None

    def _print_Rational(self, expr: sympy.Rational) -> str:
        text = double_literal(float(expr))
        return f"({text})" if text.startswith("-") else text

    def _print_Integer(self, expr: sympy.Integer) -> str:
        text = double_literal(float(expr)) if abs(expr.p) >= 2 ** 53 else str(expr.p)
        return f"({text})" if text.startswith("-") else text

    def _print_Float(self, expr: sympy.Float) -> str:
        return self._print_Rational(expr)

    def _print_NumberSymbol(self, expr: sympy.Expr) -> str:
        return double_literal(float(expr))

    _print_Exp1 = _print_Pi = _print_NumberSymbol

    def _print_Not(self, expr: sympy.Basic) -> str:
        return f"~({self._print(expr.args[0])})"

    def _print_Relational(self, expr: sympy.Basic) -> str:
        operator = {"==": "==", "!=": "~=", "<": "<", "<=": "<=", ">": ">", ">=": ">="}[expr.rel_op]
        return f"({self._print(expr.lhs)} {operator} {self._print(expr.rhs)})"

    def parenthesize(self, item: Any, level: int, strict: bool = False) -> str:
        if isinstance(item, sympy.Basic) and (item.is_Rational or item.is_Float) and item >= 0:
            return self._print(item)
        return super().parenthesize(item, level, strict)

    def _print_Pow(self, expr: sympy.Pow) -> str:
        base, exponent = expr.args
        if exponent.is_Integer and 0 < abs(exponent.p) <= MAX_PRODUCT_POWER:
            factor = self.parenthesize(base, precedence(sympy.Mul(base, base, evaluate=False)))
            product = "*".join([factor] * abs(exponent.p))
            if exponent.p > 0:
                return product
            return f"1.0/{product}" if abs(exponent.p) == 1 else f"1.0/({product})"
        return super()._print_Pow(expr)


class FastMatlabPrinter(_ProgramPrinter):
    """``MatlabPrinter``'s text for program lines, fast (as ``c.FastCPrinter`` for C): sums,
    products, integer powers, numbers, names, sines and cosines by the project's line printer;
    any other node goes to ``MatlabPrinter``."""

    def __init__(self, names: dict[sympy.Symbol, str]):
        self.general = MatlabPrinter(names)
        self.names = self.general.names

    def doprint(self, expr: sympy.Basic) -> str:
        return self._text(expr)

    def _text(self, expr: sympy.Basic) -> str:
        if expr.is_Symbol:
            return self.general._print_Symbol(expr)  # type: ignore[arg-type]
        return super()._text(expr)

    @staticmethod
    def _number(expr: sympy.Basic) -> str:
        if expr.is_Integer and abs(expr.p) < 2 ** 53:   # type: ignore[attr-defined]
            return str(expr.p)   # type: ignore[attr-defined]
        if expr.is_Rational or expr.is_Float:
            return double_literal(float(expr))   # type: ignore[arg-type]
        raise CodeGenerationError(f"unexpected number {expr} in a program line")

    def _power(self, expr: sympy.Basic) -> str:
        base, exponent = expr.args
        if exponent.p < 0:   # type: ignore[attr-defined]
            return self._product(expr)
        if exponent.p > MAX_PRODUCT_POWER:   # type: ignore[attr-defined]
            return self.general.doprint(expr)
        inner = self._text(base)
        if not (base.is_Symbol or (base.is_Number and not inner.startswith("("))):
            inner = f"({inner})"
        return "*".join([inner] * exponent.p)   # type: ignore[attr-defined]


@dataclass
class MFunction:
    """One function file: ``function outputs = name(arguments)``, its help text (the first
    line is MATLAB's H1 line), its body, and local functions after it (same fields)."""

    name: str
    outputs: str
    arguments: list[str]
    help: list[str]
    body: list[str] = field(default_factory=list)
    local: list[MFunction] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.help = [matlab_comment(line) for line in self.help]
        self.body = [Code(line) for line in self.body]
        self.signature = Code(f"function {self.outputs} = {self.name}({', '.join(self.arguments)})"
                              if self.outputs else f"function {self.name}({', '.join(self.arguments)})")


class Names:
    """The MATLAB text of each symbol: ``q(i)``, ``p.m``, and locals of one function."""

    def __init__(self, derivation: Derivation, extra: dict[sympy.Symbol, str] | None = None):
        table = derivation.symbols
        self.base: dict[sympy.Symbol, str] = {s: f"p.{s.name}" for s in table.parameters.values()}
        for array, symbols in (("q", table.q), ("qd", table.qd), ("qdd", table.qdd),
                               ("u", list(table.efforts.values()))):
            self.base |= {s: f"{array}({i + 1})" for i, s in enumerate(symbols)}
        self.base |= dict(extra or {})

    def extended(self, extra: dict[sympy.Symbol, str] | None) -> Names:
        local = Names.__new__(Names)
        local.base = dict(self.base) | dict(extra or {})
        return local

    def printer(self) -> FastMatlabPrinter:
        return FastMatlabPrinter(dict(self.base))


def kept_lines(program: Any) -> list[tuple[sympy.Symbol, sympy.Expr]]:
    """The lines of ``program`` its outputs need, in order."""
    needed = set().union(*(sympy.sympify(e).free_symbols for e in program.outputs))
    kept = []
    for target, expr in reversed(program.lines):
        if target in needed:
            kept.append((target, expr))
            needed |= expr.free_symbols
    return kept[::-1]


def _lines(names: Names, lines: list[tuple[sympy.Symbol, sympy.Expr]], stores: list[tuple[str, sympy.Expr]]) -> list[str]:
    printer = names.printer()
    text = []
    for index, (target, expr) in enumerate(lines):
        printer.names[target] = f"t{index}"
        text.append(f"t{index} = {printer.doprint(fold_constants(expr, rationals=False))};")
    for target, expr in stores:
        text.append(f"{target} = {printer.doprint(fold_constants(expr, rationals=False))};")
    return text


def program_body(names: Names, program: Any, targets: list[str]) -> list[str]:
    """MATLAB lines of a straight-line program: ``tN = ...;`` per value the outputs need, then
    ``target = output;`` per output."""
    outputs = [sympy.sympify(e) for e in program.outputs]
    return _lines(names, kept_lines(program), list(zip(targets, outputs)))


def expression_body(names: Names, values: list[sympy.Expr], targets: list[str]) -> list[str]:
    """MATLAB lines of explicit expressions, common subexpressions eliminated."""
    folded = [fold_constants(sympy.sympify(v)) for v in values]
    temporaries, reduced = sympy.cse(folded, symbols=sympy.numbered_symbols("_c"), order="canonical")
    return _lines(names, temporaries, list(zip(targets, reduced)))


def matrix_targets(out: str, rows: int, columns: int) -> list[str]:
    """``out(i, j)`` for row-major entries."""
    return [f"{out}({i + 1}, {j + 1})" for i in range(rows) for j in range(columns)]


def vector_targets(out: str, size: int) -> list[str]:
    return [f"{out}({i + 1})" for i in range(size)]


def prologue(derivation: Derivation, vectors: list[str], count: int, optional: dict[str, str] | None = None) -> list[str]:
    """Column vectors of the arguments ``vectors``; ``p`` (argument number ``count``) the
    defaults when absent or empty; other optional arguments by ``optional``."""
    name = derivation.robot.name
    lines = [f"{v} = {v}(:);" for v in vectors if v not in (optional or {})]
    for position, (argument, default) in enumerate((optional or {}).items(), start=count - len(optional or {})):
        lines += [f"if nargin < {position} || isempty({argument})", f"    {argument} = {default};", "end",
                  f"{argument} = {argument}(:);"]
    return lines + [f"if nargin < {count} || isempty(p)", f"    p = {name}.parameters();", "end"]


#: ``s``: sign(qd), or tanh(qd / friction_smoothing) when that is positive (the NumPy module's).
DIRECTION_LINES = ["if p.friction_smoothing > 0", "    s = tanh(qd / p.friction_smoothing);", "else",
                   "    s = sign(qd);", "end"]


def _friction_body(derivation: Derivation, names: Names) -> list[str]:
    n = len(derivation.symbols.q)
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


def friction_slope(derivation: Derivation, names: Names, target: str) -> list[str]:
    """``target(i, n + i) -= dF_i/dqd_i``: b + fc (1 - tanh(qd/eps)^2)/eps (0 for the exact sign)."""
    if not derivation.robot.dissipative:
        return []
    n, printer, lines = len(derivation.symbols.q), names.printer(), []
    for drive in derivation.joint_drives:
        i = drive.coordinate
        entry = f"{target}({i + 1}, {n + i + 1})"
        if drive.damping != 0:
            lines.append(f"{entry} = {entry} - ({printer.doprint(fold_constants(drive.damping))});")
        if drive.friction != 0:
            fc = printer.doprint(fold_constants(drive.friction))
            lines += ["if p.friction_smoothing > 0",
                      f"    {entry} = {entry} - ({fc})*(1.0 - tanh(qd({i + 1}) / p.friction_smoothing)"
                      f"*tanh(qd({i + 1}) / p.friction_smoothing)) / p.friction_smoothing;", "end"]
    return lines


def input_matrix_lines(derivation: Derivation, names: Names, target: str, rows: int, offset: int) -> list[str]:
    """``target(i, offset + k) = dY_i/du_k`` (the efforts' generalized forces)."""
    table = derivation.symbols
    if not table.efforts:
        return []
    inputs = derivation.quantities["Y_g"].jacobian(sympy.Matrix(list(table.efforts.values())))
    nu = len(table.efforts)
    return expression_body(names, list(inputs), [f"{target}({i + 1}, {offset + k + 1})"
                                                 for i in range(rows) for k in range(nu)])


def numeric_functions(derivation: Derivation) -> list[MFunction]:
    """Every function of ``+<name>/`` (the loop functions from ``matlab_loops``)."""
    from .matlab_loops import loop_functions

    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    name, n, nu = robot.name, len(table.q), len(table.efforts)
    names = Names(derivation)
    programs, structured = derivation.programs, derivation.structured_code
    count = len(derivation.parameter_vector)

    def body(program: str, quantity: str, targets: list[str]) -> list[str]:
        if structured:
            return program_body(names, programs[program], targets)
        value = quantities[quantity]
        return expression_body(names, list(value) if isinstance(value, sympy.MatrixBase) else [value], targets)

    friction = ([f"tau = tau + {name}.friction_forces(qd, p);"] if robot.dissipative else [])
    regressor = programs["regressor"]
    regressor_names = names.extended({s: f"s({i + 1})" for i, s in enumerate(regressor.extra_inputs)})
    functions = [
        MFunction("mass_matrix", "M", ["q", "p"],
                  [f"MASS_MATRIX  Mass matrix M_g(q), {n} x {n}.", "", "   M = " + name + ".mass_matrix(q)",
                   "   M = " + name + ".mass_matrix(q, p)   (p: a struct as from parameters())"],
                  [*prologue(derivation, ["q"], 2), f"M = zeros({n}, {n});", *body("mass_matrix", "M_g",
                                                                                   matrix_targets("M", n, n))]),
        MFunction("coriolis_matrix", "C", ["q", "qd", "p"],
                  [f"CORIOLIS_MATRIX  Coriolis matrix C_g(q, qd) (Christoffel symbols), {n} x {n}.", "",
                   f"   C = {name}.coriolis_matrix(q, qd, p): C*qd are the velocity terms of the equations."],
                  [*prologue(derivation, ["q", "qd"], 3), f"C = zeros({n}, {n});",
                   *body("coriolis", "C_g", matrix_targets("C", n, n))]),
        MFunction("gravity_vector", "N", ["q", "p"],
                  [f"GRAVITY_VECTOR  Gravity vector N_g(q) = dV/dq, {n} x 1."],
                  [*prologue(derivation, ["q"], 2), f"N = zeros({n}, 1);",
                   *body("gravity", "N_g", vector_targets("N", n))]),
        MFunction("inverse_dynamics", "tau", ["q", "qd", "qdd", "p"],
                  [f"INVERSE_DYNAMICS  Y_g = M qdd + C qd + N (+ friction_forces) by recursive Newton-Euler, {n} x 1."
                   + (" The open tree's: no loop forces." if robot.loops else "")],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4), f"tau = zeros({n}, 1);",
                   *program_body(names, programs["inverse_dynamics"], vector_targets("tau", n)), *friction]),
        MFunction("generalized_forces", "Y", ["q", "u", "p"],
                  [f"GENERALIZED_FORCES  Y_g(q, u): the generalized forces of the efforts u ({nu} x 1), {n} x 1."],
                  [*prologue(derivation, ["q", "u"], 3), f"Y = zeros({n}, 1);",
                   *expression_body(names, list(quantities["Y_g"]), vector_targets("Y", n))]),
        MFunction("kinetic_energy", "T", ["q", "qd", "p"], ["KINETIC_ENERGY  Kinetic energy T_g = 1/2 qd' M(q) qd."],
                  [*prologue(derivation, ["q", "qd"], 3), f"T = 0.5*(qd' * ({name}.mass_matrix(q, p) * qd));"]),
        MFunction("potential_energy", "V", ["q", "p"],
                  ["POTENTIAL_ENERGY  Potential energy V_g(q) of gravity and the springs."],
                  [*prologue(derivation, ["q"], 2), "V = 0;", *body("potential", "V_g", ["V"])]),
        MFunction("friction_forces", "F", ["qd", "p"],
                  [f"FRICTION_FORCES  Dissipative forces F_g = b qd + fc sign(qd), {n} x 1 (tanh(qd / "
                   "p.friction_smoothing) for sign(qd) when friction_smoothing > 0)." if robot.dissipative else
                   f"FRICTION_FORCES  Dissipative forces F_g: zero, the robot declares no damping or friction, {n} x 1."],
                  _friction_body(derivation, names)),
        MFunction("regressor", "Y", ["q", "qd", "qdd", "p"],
                  [f"REGRESSOR  Regressor Y(q, qd, qdd), {n} x {count}: Y * parameter_vector(p) equals "
                   "inverse_dynamics" + (" of the open tree (no loop forces)." if robot.loops else ".")],
                  [*prologue(derivation, ["q", "qd", "qdd"], 4),
                   *(DIRECTION_LINES if regressor.extra_inputs else []), f"Y = zeros({n}, {count});",
                   *program_body(regressor_names, regressor, matrix_targets("Y", n, count))]),
        MFunction("parameter_vector", "pi_", ["p"],
                  [f"PARAMETER_VECTOR  The regressor's parameters, {count} x 1: per link mass, first moment m c, "
                   "inertia about the link frame's origin; then the drives."],
                  ["if nargin < 1 || isempty(p)", f"    p = {name}.parameters();", "end", f"pi_ = zeros({count}, 1);",
                   *expression_body(names, [v.value for v in derivation.parameter_vector], vector_targets("pi_", count))]),
        *_frame_functions(derivation, names),
    ]
    if not robot.loops:
        functions += [_forward_dynamics(derivation), _linearize(derivation, names)]
    else:
        functions += loop_functions(derivation, names)
    return functions


def _forward_dynamics(derivation: Derivation) -> MFunction:
    name, n, nu = derivation.robot.name, len(derivation.symbols.q), len(derivation.symbols.efforts)
    return MFunction(
        "forward_dynamics", "qdd", ["q", "qd", "u", "p"],
        [f"FORWARD_DYNAMICS  Accelerations qdd solving M(q) qdd = Y_g(u) - C qd - N - F, {n} x 1.", "",
         f"   qdd = {name}.forward_dynamics(q, qd, u, p); u ({nu} x 1) may be [] (no effort).",
         "   M is solved with MATLAB's \\ (Cholesky: M is symmetric positive definite).",
         f"   ode45(@(t, x) [x({n + 1}:{2 * n}); {name}.forward_dynamics(x(1:{n}), x({n + 1}:{2 * n}), u, p)], tspan, x0)"],
        [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
         f"M = {name}.mass_matrix(q, p);",
         f"rhs = {name}.generalized_forces(q, u, p) - {name}.inverse_dynamics(q, qd, zeros({n}, 1), p);",
         "qdd = M \\ rhs;"])


def linearize_rhs(derivation: Derivation, names: Names, qdd: str) -> list[str]:
    """``R = [-dtau/dq, -dtau/dqd - dF/dqd, dY/du]`` (n x 2n+nu) at accelerations ``qdd``."""
    table = derivation.symbols
    n, nu = len(table.q), len(table.efforts)
    local = names.extended({s: f"{qdd}({i + 1})" for i, s in enumerate(table.qdd)})
    lines = [f"D = zeros({2 * n * n}, 1);",
             *program_body(local, derivation.programs["inverse_dynamics_derivatives"], vector_targets("D", 2 * n * n)),
             f"R = zeros({n}, {2 * n + nu});",
             f"R(:, 1:{n}) = -reshape(D(1:{n * n}), {n}, {n})';",
             f"R(:, {n + 1}:{2 * n}) = -reshape(D({n * n + 1}:{2 * n * n}), {n}, {n})';"]
    return lines + friction_slope(derivation, names, "R") + input_matrix_lines(derivation, names, "R", n, 2 * n)


def _linearize(derivation: Derivation, names: Names) -> MFunction:
    name, n, nu = derivation.robot.name, len(derivation.symbols.q), len(derivation.symbols.efforts)
    return MFunction(
        "linearize", "[A, B]", ["q", "qd", "u", "p"],
        [f"LINEARIZE  (A, B) of xdot = A dx + B du about x = [q; qd] and u: A {2 * n} x {2 * n}, B {2 * n} x {nu}.", "",
         "   A = [0, I; dqdd/dq, dqdd/dqd], B = [0; dqdd/du], from Newton-Euler differentiated line by line",
         "   and one solve with M (M dqdd/dx = dY/dx - dtau/dx at the state's own qdd)."],
        [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
         f"qdd0 = {name}.forward_dynamics(q, qd, u, p);", *linearize_rhs(derivation, names, "qdd0"),
         f"X = {name}.mass_matrix(q, p) \\ R;",
         f"A = [zeros({n}, {n}), eye({n}); X(:, 1:{2 * n})];", f"B = [zeros({n}, {nu}); X(:, {2 * n + 1}:end)];"])


def _frame_functions(derivation: Derivation, names: Names) -> list[MFunction]:
    """Pose, Jacobian and Jdot qd of a frame: ``frame`` its name (a character vector) or its
    1-based number in the robot file's order; anything else is an error."""
    robot, n = derivation.robot, len(derivation.symbols.q)
    if not robot.frames:
        return []
    size, twist = (3, 3) if robot.planar else (4, 6)
    pkg = robot.name
    listing = ", ".join(f.name for f in robot.frames)
    lookup = ["if ischar(frame)", "    index = 0;"]
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
            lines = program_body(names, getattr(frame, kind), targets)
            body += [f"{'if' if index == 0 else 'elseif'} isequal(index, {index + 1})", *("    " + x for x in lines)]
        body += ["else", f"    error('{pkg}:frame', 'no such frame: give its name or a number from 1 to {len(robot.frames)}');",
                 "end"]
        functions.append(MFunction(f"frame_{kind}", out, [*vectors, "frame", "p"],
                                   [summary, "", f"   frame: its name, or its number in the robot file's order: {listing}"],
                                   body))
    return functions


def parameters_function(derivation: Derivation) -> MFunction:
    """``parameters()``: the struct of the robot file's defaults (NaN where it gives none)."""
    robot = derivation.robot
    help_lines = [f"PARAMETERS  The parameters of {robot.title}: a struct of the robot file's defaults.", ""]
    body = ["p = struct();"]
    for parameter in robot.parameters:
        value = "NaN" if parameter.value is None else double_literal(float(parameter.value))
        note = " ".join(x for x in [parameter.description or "", f"[{parameter.unit}]" if parameter.unit else "",
                                    "(no default in the robot file: NaN)" if parameter.value is None else ""] if x)
        help_lines.append(f"   {parameter.name}: {note}" if note else f"   {parameter.name}")
        body.append(f"p.{parameter.name} = {value};")
    help_lines.append("   friction_smoothing: 0 for sign(qd) in Coulomb friction, eps > 0 for tanh(qd / eps)")
    body.append("p.friction_smoothing = 0;")
    if robot.loops:
        help_lines += ["   alpha, beta: Baumgarte gains of forward_dynamics (0: none)"]
        body += ["p.alpha = 0;", "p.beta = 0;"]
    return MFunction("parameters", "p", [], help_lines, body)


def render_matlab(derivation: Derivation, template_dir: str | Path | None = None) -> dict[str, str]:
    """The package ``+<name>/``: {relative path: text}, nothing written."""
    check_matlab_names(derivation.robot)
    from .._version import __version__

    robot = derivation.robot
    context = {"title": matlab_comment(robot.title), "source": matlab_comment(Path(robot.source).name),
               "generator": matlab_comment(f"dynderive {__version__}"), "name": Code(robot.name)}
    files = {}
    for function in [parameters_function(derivation), *numeric_functions(derivation)]:
        files[f"+{robot.name}/{function.name}.m"] = render("code", FUNCTION_TEMPLATE, context | {"f": function},
                                                            template_dir)
    return dict(sorted(files.items()))
