"""The C99 target (``solve --c``): ``<name>_dynamics.h`` and ``<name>_dynamics.c``.

The same straight-line programs as the NumPy module (``Derivation.programs``; a small planar
robot's explicit M, C, N, V with common subexpressions eliminated), printed by SymPy's
``C99CodePrinter`` with three changes (``CPrinter``): integer powers as multiplications,
every fraction and float as a double literal of 17 significant digits, and each symbol as its
place in the generated function (``q[0]``, ``P->m1``, a temporary ``t12``); ``FastCPrinter``
prints the common nodes of program lines the same way without SymPy's slow precedence rules. Forward dynamics
solves ``M qdd = Y - (C qd + N)`` with an ``L D L^T`` factorization unrolled for this robot's
size and sparsity, and returns 1 (``qdd`` untouched) if a pivot is not positive; ``linearize``
solves its columns with the same factorization.

Damping and Coulomb friction are ``friction_forces``, added to inverse dynamics and taken from
the right-hand side of forward dynamics as the NumPy module does; the struct carries
``friction_smoothing`` (0: the exact sign; eps > 0: ``tanh(qd / eps)``). Closed loops and the
wrench variants are ``c_loops.py`` (``amend``); what a target cannot build is refused
(``unsupported``), never printed half. Names must be C names (``c_names.py``); free text
appears only in encoded comments.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sympy
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import precedence

from ....derivation import Derivation
from ....errors import InputError, Problem
from ....mechanics.tidy import fold_constants
from ...encode import Code
from ...environment import render
from ..numpy.code import CodeGenerationError, _ProgramPrinter
from .c_join import joined_program as _joined
from .c_join import print_body as _print_body
from .c_loops import CKit, amend, loop_context
from .c_names import c_comment, check_c_names

HEADER_TEMPLATE = "c/dynamics.h.j2"
SOURCE_TEMPLATE = "c/dynamics.c.j2"

#: Powers up to this exponent are written as products (``x*x*x``); higher ones call ``pow``.
MAX_PRODUCT_POWER = 8


def double_literal(value: float) -> str:
    """A C double literal that reads back as ``value`` exactly (17 significant digits)."""
    text = format(value, ".17g")
    if text in ("inf", "-inf", "nan"):
        raise CodeGenerationError(f"no C literal for the number {value}")
    return text if any(c in text for c in ".en") else text + ".0"


class DoublePrinting:
    """The number and symbol rules of every compiled target's SymPy printer, mixed in before
    the language's own printer (``CPrinter``; ``matlab_print.MatlabPrinter``): symbols by
    ``names`` (anything else is an internal error), numbers as exact double literals,
    integer powers as products."""

    #: the language named in the internal error of a symbol without a value
    language = "C"
    names: dict[sympy.Symbol, str]

    def _print_Symbol(self, expr: sympy.Symbol) -> str:
        try:
            return self.names[expr]
        except KeyError:
            raise CodeGenerationError(f"the {self.language} code has no value for the symbol {expr}") from None

    def _print_Rational(self, expr: sympy.Rational) -> str:
        text = double_literal(float(expr))
        return f"({text})" if text.startswith("-") else text

    def _print_Integer(self, expr: sympy.Integer) -> str:
        text = double_literal(float(expr)) if abs(expr.p) >= 2 ** 53 else str(expr.p)
        return f"({text})" if text.startswith("-") else text

    def _print_Float(self, expr: sympy.Float) -> str:
        return self._print_Rational(expr)

    def _print_NumberSymbol(self, expr: sympy.Expr) -> str:   # pi, E: no M_PI (not C99)
        return double_literal(float(expr))

    _print_Exp1 = _print_Pi = _print_NumberSymbol

    def parenthesize(self, item: Any, level: int, strict: bool = False) -> str:
        if isinstance(item, sympy.Basic) and (item.is_Rational or item.is_Float) and item >= 0:
            return self._print(item)  # type: ignore[attr-defined]   # a positive literal needs no parentheses
        return super().parenthesize(item, level, strict)  # type: ignore[misc]

    def _print_Pow(self, expr: sympy.Pow, rational: bool = False) -> str:
        base, exponent = expr.args
        if exponent.is_Integer and 0 < abs(exponent.p) <= MAX_PRODUCT_POWER:
            factor = self.parenthesize(base, precedence(sympy.Mul(base, base, evaluate=False)))
            product = "*".join([factor] * abs(exponent.p))
            if exponent.p > 0:
                return product
            return f"1.0/{product}" if abs(exponent.p) == 1 else f"1.0/({product})"
        return super()._print_Pow(expr)  # type: ignore[misc]


class CPrinter(DoublePrinting, C99CodePrinter):
    """``C99CodePrinter`` with ``DoublePrinting``'s symbols, numbers and powers."""

    def __init__(self, names: dict[sympy.Symbol, str]):
        super().__init__({"strict": True, "contract": False})
        self.names = names


class FastCPrinter(_ProgramPrinter):
    """``CPrinter``'s text for program lines, fast: sums, products, integer powers, numbers,
    names and sines and cosines without SymPy's precedence rules (which ask the assumptions
    system about signs: 5 ms a line, a minute for a 7-DOF arm's linearization); any other node
    goes to ``CPrinter``. The project's fast line printer (``code._ProgramPrinter``), with C's
    numbers and powers."""

    #: The SymPy printer of anything else (a subclass for a language of C's expression syntax,
    #: as MATLAB's scalars, names its own: ``matlab_print.FastMatlabPrinter``).
    general_printer: type = CPrinter

    def __init__(self, names: dict[sympy.Symbol, str]):
        self.general = self.general_printer(names)
        self.names = self.general.names   # one dictionary: temporaries added as they are printed

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
class CFunction:
    """One generated function: its prototype (without ``;``), a one-line comment, its body."""

    prototype: str
    comment: str
    body: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.prototype = Code(self.prototype)
        self.comment = c_comment(self.comment)
        self.body = [Code(line) for line in self.body]


def unsupported(derivation: Derivation) -> list[Problem]:
    """What of this robot the C target cannot print yet, each at its place in the robot file:
    nothing today (closed loops and wrenches are ``c_loops.py``; what is not built for any
    robot is listed in the README)."""
    del derivation
    return []


class _Names:
    """The C text of each symbol in one function: arguments, parameters, temporaries."""

    def __init__(self, derivation: Derivation):
        table = derivation.symbols
        self.base: dict[sympy.Symbol, str] = {s: f"P->{s.name}" for s in table.parameters.values()}
        for array, symbols in (("q", table.q), ("qd", table.qd), ("qdd", table.qdd),
                               ("u", list(table.efforts.values()))):
            self.base |= {s: f"{array}[{i}]" for i, s in enumerate(symbols)}

    def extended(self, extra: dict[sympy.Symbol, str] | None) -> _Names:
        """These names and ``extra`` (locals of one function: ``qdd[i]``, ``lambda[i]``)."""
        local = _Names.__new__(_Names)
        local.base = dict(self.base) | dict(extra or {})
        return local

    def printer(self) -> FastCPrinter:
        return FastCPrinter(dict(self.base))


def _program_body(names: _Names, program: Any, targets: list[str]) -> list[str]:
    """The C lines of a straight-line program: ``const double tN = ...;`` for each value the
    outputs need (in order), then ``target = output;`` for each output."""
    outputs = [sympy.sympify(e) for e in program.outputs]
    return _lines(names, _kept(program)[0], list(zip(targets, outputs)))


def _kept(program: Any) -> tuple[list[tuple[sympy.Symbol, sympy.Expr]], set[sympy.Symbol]]:
    """The lines of ``program`` its outputs need, in order, and every symbol they read."""
    needed = set().union(*(sympy.sympify(e).free_symbols for e in program.outputs))
    kept = []
    for target, expr in reversed(program.lines):
        if target in needed:
            kept.append((target, expr))
            needed |= expr.free_symbols
    return kept[::-1], needed


def _lines(names: _Names, lines: list[tuple[sympy.Symbol, sympy.Expr]],
           stores: list[tuple[str, sympy.Expr]]) -> list[str]:
    printer = names.printer()
    text = []
    for index, (target, expr) in enumerate(lines):
        printer.names[target] = f"t{index}"
        text.append(f"const double t{index} = {printer.doprint(fold_constants(expr, rationals=False))};")
    for target, expr in stores:
        text.append(f"{target} = {printer.doprint(fold_constants(expr, rationals=False))};")
    return text


def _expression_body(names: _Names, values: list[sympy.Expr], targets: list[str]) -> list[str]:
    """C lines of explicit expressions (a small planar robot's M, C, N, V), with common
    subexpressions eliminated."""
    folded = [fold_constants(sympy.sympify(v)) for v in values]
    temporaries, reduced = sympy.cse(folded, symbols=sympy.numbered_symbols("_c"), order="canonical")
    return _lines(names, temporaries, list(zip(targets, reduced)))


def _void(*arguments: str) -> list[str]:
    """Casts that mark every argument used (``-Wextra -Werror``: a constant M reads no ``q``)."""
    return [f"(void){a};" for a in arguments]


def c_context(derivation: Derivation) -> dict[str, Any]:
    """Every variable the C templates can use."""
    problems = unsupported(derivation)
    if problems:
        raise InputError(problems)
    check_c_names(derivation.robot)
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    name, n, nu = robot.name, len(table.q), len(table.efforts)
    names = _Names(derivation)
    programs = derivation.programs
    structured = derivation.structured_code
    pp = f"const {name}_parameters *p"
    start = f"const {name}_parameters *const P = p ? p : &{name}_default_parameters;"
    square = [f"M[{i * n + j}]" for i in range(n) for j in range(n)]

    def body(program: str, quantity: str, targets: list[str]) -> list[str]:
        if structured:
            return _program_body(names, programs[program], targets)
        value = quantities[quantity]
        entries = list(value) if isinstance(value, sympy.MatrixBase) else [value]
        return _expression_body(names, entries, targets)

    coriolis = [f"C[{k}]" for k in range(n * n)]
    functions = [
        CFunction(f"void {name}_mass_matrix(const double *q, {pp}, double *M)",
                  f"Mass matrix M_g(q), {n} x {n}, row-major.",
                  [start, *_void("q", "P"), *body("mass_matrix", "M_g", square)]),
        CFunction(f"void {name}_coriolis_matrix(const double *q, const double *qd, {pp}, double *C)",
                  f"Coriolis matrix C_g(q, qd) (Christoffel symbols), {n} x {n}, row-major.",
                  [start, *_void("q", "qd", "P"), *body("coriolis", "C_g", coriolis)]),
        CFunction(f"void {name}_gravity_vector(const double *q, {pp}, double *N)",
                  f"Gravity vector N_g(q) = dV/dq, {n} entries.",
                  [start, *_void("q", "P"), *body("gravity", "N_g", [f"N[{i}]" for i in range(n)])]),
        CFunction(f"void {name}_generalized_forces(const double *q, const double *u, {pp}, double *Y)",
                  f"Applied generalized forces Y_g(q, u) of the efforts, {n} entries.",
                  [start, *_void("q", "u", "P"), *_expression_body(
                      names, list(quantities["Y_g"]), [f"Y[{i}]" for i in range(n)])]),
        CFunction(f"void {name}_inverse_dynamics(const double *q, const double *qd, const double *qdd, {pp}, "
                  "double *tau)", f"Y_g = M qdd + C qd + N by recursive Newton-Euler, {n} entries.",
                  [start, *_void("q", "qd", "qdd", "P"),
                   *_program_body(names, programs["inverse_dynamics"], [f"tau[{i}]" for i in range(n)]),
                   *_add_friction(derivation, "tau", "+=")]),
        CFunction(f"int {name}_forward_dynamics(const double *q, const double *qd, const double *u, {pp}, "
                  "double *qdd)", "qdd solving M qdd = Y_g(u) - C qd - N by L D L^T; returns 0, or 1 "
                  "(qdd untouched) if M is not positive definite.",
                  [] if robot.loops else _forward_body(derivation, names, start)),   # loops: c_loops.amend
        CFunction(f"double {name}_kinetic_energy(const double *q, const double *qd, {pp})",
                  "Kinetic energy T_g = 1/2 qd^T M(q) qd.",
                  [f"double M[{n * n}];", f"{name}_mass_matrix(q, p, M);",
                   "return 0.5 * (" + " + ".join(f"qd[{i}]*({' + '.join(f'M[{i * n + j}]*qd[{j}]' for j in range(n))})"
                                                 for i in range(n)) + ");"]),
        CFunction(f"double {name}_potential_energy(const double *q, {pp})",
                  "Potential energy V_g(q) of gravity and the springs.",
                  [start, "double V;", *_void("q", "P"), *body("potential", "V_g", ["V"]), "return V;"]),
        CFunction(f"void {name}_friction_forces(const double *qd, {pp}, double *F)",
                  f"Dissipative forces F_g = b qd + fc sign(qd) (tanh(qd / friction_smoothing) when it is "
                  f"positive), {n} entries." if robot.dissipative else
                  f"Dissipative forces F_g: zero, the robot declares no damping or friction, {n} entries.",
                  _friction_body(derivation, names, start)),
        CFunction(f"int {name}_linearize(const double *q, const double *qd, const double *u, {pp}, double *A, "
                  "double *B)", f"(A, B) of xdot = A dx + B du about x = (q, qd) and u: A {2 * n} x {2 * n}, B {2 * n} x "
                  f"{nu}, row-major, from Newton-Euler differentiated and one L D L^T solve; returns 0, or 1 "
                  "(A, B untouched) if M is not positive definite.",
                  [] if robot.loops else _linearize_body(derivation, names, start)),
        CFunction(f"void {name}_regressor(const double *q, const double *qd, const double *qdd, {pp}, double *Y)",
                  f"Regressor Y(q, qd, qdd), {n} x {len(derivation.parameter_vector)}, row-major: Y pi = "
                  "inverse_dynamics (pi from parameter_vector).", _regressor_body(derivation, names, start)),
        CFunction(f"void {name}_parameter_vector({pp}, double *pi)",
                  f"The regressor's parameters pi, {len(derivation.parameter_vector)} entries.",
                  [start, *_void("P"), *_expression_body(
                      names, [v.value for v in derivation.parameter_vector],
                      [f"pi[{i}]" for i in range(len(derivation.parameter_vector))])]),
        *_frame_functions(derivation, names, start, pp),
    ]
    functions = amend(derivation, CKit(
        start, pp, CFunction, lambda values, targets, extra=None: _expression_body(names.extended(extra), values, targets),
        lambda program, targets, extra=None: _program_body(names.extended(extra), program, targets),
        _fill_in(_structural_pattern(derivation, n), n), lambda: _friction_slope(derivation, names, 2 * n + nu)),
        functions)
    loops = loop_context(derivation)
    parameters = [{"name": p.name, "default": Code("NAN") if p.value is None else Code(double_literal(float(p.value))),
                   "comment": c_comment(_parameter_note(p))} for p in robot.parameters]
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
        "nq": n, "nv": n, "nu": nu, "nc": loops["nc"],
        "coordinates": c_comment(", ".join(robot.coordinates)),
        "efforts": c_comment(", ".join(robot.efforts)),
        "parameters": parameters,
        "frames": [{"index": i, "name": c_comment(f.name)} for i, f in enumerate(robot.frames)],
        "functions": functions,
    }


def _frame_functions(derivation: Derivation, names: _Names, start: str, pp: str,
                     columns: int | None = None) -> list[CFunction]:
    """Pose, Jacobian and Jdot qd of the frame numbered ``frame`` (the order of the robot
    file's frames); each returns 0, or 1 (output untouched) for a number that is no frame.
    ``columns``: the Jacobian's (NV of a floating-base robot, whose frames are tuples
    ``(name, pose, Jacobian, Jdot qd)``; else the coordinates)."""
    robot, n = derivation.robot, columns or len(derivation.symbols.q)
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
        body = [start, *_void(*used, "frame", "P", out)]
        for index, frame in enumerate(derivation.frame_programs):
            program = frame[1 + [s[0] for s in specs].index(kind)] if isinstance(frame, tuple) else getattr(frame, kind)
            lines = _program_body(names, program, [f"{out}[{k}]" for k in range(count)])
            body += [f"if (frame == {index}) {{", *(f"    {line}" for line in lines), "    return 0;", "}"]
        body.append("return 1;")
        functions.append(CFunction(f"int {name}_frame_{kind}({arguments}, int frame, {pp}, double *{out})",
                                   comment + " Returns 0, or 1 if there is no such frame.", body))
    return functions


def _friction_body(derivation: Derivation, names: _Names, start: str) -> list[str]:
    """F_g = b qd + fc direction(qd) per coordinate with a drive (the NumPy module's order of
    operations); zero elsewhere."""
    n = len(derivation.symbols.qd)
    lines = [start, *_void("qd", "P")]
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


def _parameter_note(parameter: Any) -> str:
    parts = [parameter.description or ""]
    if parameter.unit:
        parts.append(f"[{parameter.unit}]")
    if parameter.value is None:
        parts.append("(no default in the robot file: NaN)")
    return " ".join(p for p in parts if p)


def _forward_body(derivation: Derivation, names: _Names, start: str) -> list[str]:
    """The forward-dynamics program (CRBA, Newton-Euler at qdd = 0 on the same kinematics,
    Y_g(u) and an L D L^T solve: the NumPy module's ``_forward_dynamics_body``) as one body;
    ``return 1`` before any store if a pivot is not positive."""
    local, friction = _forward_names(derivation, names)
    lines, (outputs,), pivots = _joined([_forward_part(derivation)])
    return [start, *_void("q", "qd", "u", "P"), *friction,
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
    folded = [fold_constants(sympy.sympify(v)) for v in derivation.quantities["M_g"]]
    return sympy.cse(folded, symbols=sympy.numbered_symbols("_c"), order="canonical")


def _forward_names(derivation: Derivation, names: _Names) -> tuple[_Names, list[str]]:
    """Names with the forward program's extra inputs as ``F[i]``, and the lines computing F."""
    local = _Names.__new__(_Names)
    local.base = dict(names.base)
    if not derivation.robot.dissipative:
        return local, []
    program, n = derivation.programs["forward_dynamics"], len(derivation.symbols.qd)
    local.base |= {symbol: f"F[{i}]" for i, symbol in enumerate(program.extra_inputs)}
    return local, [f"double F[{n}];", f"{derivation.robot.name}_friction_forces(qd, p, F);"]


def _direction(i: int) -> str:
    """sign(qd_i), or tanh(qd_i / friction_smoothing) when that is positive (as the NumPy module)."""
    return (f"(P->friction_smoothing > 0.0 ? tanh(qd[{i}] / P->friction_smoothing)"
            f" : (double)((qd[{i}] > 0.0) - (qd[{i}] < 0.0)))")


def _regressor_body(derivation: Derivation, names: _Names, start: str) -> list[str]:
    program = derivation.programs["regressor"]
    n, count = len(derivation.symbols.qd), len(derivation.parameter_vector)
    lines = [start, *_void("q", "qd", "qdd", "P")]
    local = _Names.__new__(_Names)
    local.base = dict(names.base)
    if program.extra_inputs:   # Coulomb friction's columns: the direction of each velocity
        read = _kept(program)[1]
        lines += [f"const double s{i} = {_direction(i)};" for i, symbol in enumerate(program.extra_inputs)
                  if symbol in read]
        local.base |= {symbol: f"s{i}" for i, symbol in enumerate(program.extra_inputs)}
    return lines + _program_body(local, program, [f"Y[{k}]" for k in range(n * count)])


def _linearize_body(derivation: Derivation, names: _Names, start: str) -> list[str]:
    """One body: qdd from the forward-dynamics program, M, and the differentiated Newton-Euler
    program at that qdd (their sines, cosines and common values computed once); R = [-dtau/dq,
    -dtau/dqd - dF/dqd, dY/du]; M X = R column by column (L D L^T); A = [[0, I], X_q, X_qd],
    B = [[0], X_u]."""
    table = derivation.symbols
    n, nu = len(table.q), len(table.efforts)
    width = 2 * n + nu
    local, friction = _forward_names(derivation, names)
    lines = [start, *_void("q", "qd", "u", "P", "B"), f"double M[{n * n}];", f"double D[{2 * n * n}];",
             f"double R[{n * width}];", *friction]
    derivatives = derivation.programs["inverse_dynamics_derivatives"]
    joined, (_, mass, derived), pivots = _joined([
        _forward_part(derivation), (*_mass_part(derivation), {}, False),
        (derivatives.lines, derivatives.outputs, lambda outputs: dict(zip(table.qdd, outputs[0])), False)])
    lines += _print_body(local, joined, [*((f"M[{k}]", e) for k, e in enumerate(mass)),
                                         *((f"D[{k}]", e) for k, e in enumerate(derived))], pivots)
    lines += negated_derivatives(n, width)
    lines += _friction_slope(derivation, names, width)
    if nu:
        inputs = derivation.quantities["Y_g"].jacobian(sympy.Matrix(list(table.efforts.values())))
        lines += _expression_body(names, list(inputs),
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
    nonzero = _fill_in(pattern, n)
    lines = _factor_lines(nonzero, n)
    lines += [f"for (int i = 0; i < {4 * n * n}; ++i) A[i] = 0.0;",
              *(f"A[{i * 2 * n + n + i}] = 1.0;" for i in range(n)),
              *([f"for (int i = 0; i < {n * nu}; ++i) B[i] = 0.0;"] if nu else []),
              f"for (int c = 0; c < {width}; ++c) {{"]
    solve = _solve_lines(nonzero, n, [f"R[{i * width} + c]" for i in range(n)])
    lines += [f"    {line}" for line in solve]
    lines += [f"    if (c < {2 * n}) {{", *(f"        A[{(n + i) * 2 * n} + c] = x{i};" for i in range(n))]
    if nu:
        lines += ["    } else {", *(f"        B[{(n + i) * nu} + c - {2 * n}] = x{i};" for i in range(n))]
    return lines + ["    }", "}", "return 0;"]


def _friction_slope(derivation: Derivation, names: _Names, width: int) -> list[str]:
    """``R[i, n + i] -= dF_i/dqd_i`` in linearize's right-hand side R (``width`` columns):
    b + fc (1 - tanh(qd/eps)^2)/eps (zero for the exact sign)."""
    if not derivation.robot.dissipative:
        return []
    n, printer, lines = len(derivation.symbols.qd), names.printer(), []
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
            lines.append(f"R[{i * width + n + i}] -= {' + '.join(terms)};")
    return lines


def _fill_in(mass: list[list[bool]], n: int) -> list[list[bool]]:
    """Which entries of L can be nonzero: those of M, and the fill-in (L_ij where L_ik and
    L_jk are for some k < j)."""
    nonzero = [[mass[i][j] for j in range(n)] for i in range(n)]
    for j in range(n):
        for i in range(j + 1, n):
            nonzero[i][j] = nonzero[i][j] or any(nonzero[i][k] and nonzero[j][k] for k in range(j))
    return nonzero


def _factor_lines(nonzero: list[list[bool]], n: int) -> list[str]:
    """M = L D L^T unrolled (M a row-major local array ``M``): ``d<j>`` and ``L<i>_<j>``;
    ``return 1`` at a pivot that is not positive (or NaN)."""
    lines = []
    for j in range(n):   # d_j = M_jj - sum_k L_jk^2 d_k; L_ij = (M_ij - sum_k L_ik L_jk d_k) / d_j
        terms = "".join(f" - L{j}_{k}*L{j}_{k}*d{k}" for k in range(j) if nonzero[j][k])
        lines += [f"const double d{j} = M[{j * n + j}]{terms};", f"if (!(d{j} > 0.0)) return 1;"]
        for i in range(j + 1, n):
            if nonzero[i][j]:
                terms = "".join(f" - L{i}_{k}*L{j}_{k}*d{k}" for k in range(j) if nonzero[i][k] and nonzero[j][k])
                lines.append(f"const double L{i}_{j} = (M[{i * n + j}]{terms}) / d{j};")
    return lines


def _solve_lines(nonzero: list[list[bool]], n: int, rhs: list[str]) -> list[str]:
    """``x<i>`` solving L D L^T x = rhs (C expressions), by ``w<i>`` (L w = rhs; not ``y0``,
    ``y1``: Bessel functions of POSIX's ``<math.h>``, which a local would shadow)."""
    lines = []
    for i in range(n):
        terms = "".join(f" - L{i}_{k}*w{k}" for k in range(i) if nonzero[i][k])
        lines.append(f"const double w{i} = {rhs[i]}{terms};")
    for i in reversed(range(n)):   # D L^T x = w
        terms = "".join(f" - L{k}_{i}*x{k}" for k in range(i + 1, n) if nonzero[k][i])
        lines.append(f"const double x{i} = w{i} / d{i}{terms};")
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
