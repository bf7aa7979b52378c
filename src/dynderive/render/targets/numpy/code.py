"""The generated NumPy module: CSE per function, a NumPy printer, blocks into a template.

Numbers: constant sub-expressions (``sqrt(2)/2``, ``E``, a square root of a 17-digit
rational from a CAD file's axis) are folded to correctly rounded floats, printed with
``repr`` (17 significant digits, exact round trip); only integers and rationals that a double
holds exactly stay as they were written. Free text reaches the module only through the
encoders of ``encode.py``, and the rendered module is parsed back and checked before anyone
can write or import it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sympy
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence
from sympy.printing.str import StrPrinter

from ....derivation import Derivation
from ....mechanics.tidy import fold_constants, operation_count
from ...encode import Code, python_literal
from ...python_module import CodeGenerationError, render_module, render_test_module

#: Functions the printed code may call, as the straight-line bodies receive them: from
#: ``math`` (one state on floats) or NumPy (a batch). SymPy's ``Abs`` prints as ``abs``.
BODY_FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
                  "exp", "log", "sqrt", "abs")
_CALL = re.compile(r"\b(" + "|".join(BODY_FUNCTIONS) + r")\(")

CODE_TEMPLATE = "dynamics.py.j2"


class _Printer(NumPyPrinter):
    """NumPy printer that writes ``np.sin`` rather than ``numpy.sin``."""

    def _module_format(self, fqn: str, register: bool = True) -> str:
        text = super()._module_format(fqn, register)
        return "np." + text[len("numpy."):] if text.startswith("numpy.") else text

    def _print_Float(self, expr: sympy.Float) -> str:
        return repr(float(expr))

    def _print_Function(self, expr: sympy.Function) -> str:   # anything NumPy has no name for
        raise CodeGenerationError(f"no NumPy function for {type(expr).__name__}")


@dataclass
class Argument:
    """An array argument: its name and the symbols it carries along its last axis."""

    name: str
    symbols: list[sympy.Symbol]
    doc: str

    def __post_init__(self) -> None:
        self.doc = Code(self.doc)   # built from validated identifiers only


@dataclass
class ExpressionFunction:
    """A generated function whose result is one SymPy matrix, evaluated entry by entry."""

    name: str
    doc: str
    arguments: list[Argument]
    shape: tuple[int, ...]
    unpack: list[tuple[str, str, int]]   # (symbol, argument, index)
    lines: list[tuple[str, str]]          # CSE temporaries
    entries: list[tuple[str, str]]        # (index text, expression)

    @property
    def shape_text(self) -> str:
        return repr(tuple(self.shape))


class _LinePrinter(StrPrinter):
    """Plain Python for straight-line programs: ``sin(x)`` (bound to ``math`` or NumPy by the
    caller), numbers as float literals (``0.333*x``: one multiplication at run time), each
    symbol under its name in ``names``."""

    def __init__(self, names: dict[sympy.Symbol, str]):
        super().__init__({"order": "none"})
        self.names = names

    def _print_Symbol(self, expr: sympy.Symbol) -> str:
        return self.names.get(expr, expr.name)

    def _print_Float(self, expr: sympy.Float) -> str:
        text = repr(float(expr))
        return f"({text})" if text.startswith("-") else text

    def _print_Rational(self, expr: sympy.Rational) -> str:
        return str(expr.p) if expr.q == 1 else repr(float(expr))

    def _print_Abs(self, expr: sympy.Abs) -> str:
        return f"abs({self._print(expr.args[0])})"

    def _print_Function(self, expr: sympy.Function) -> str:
        name = type(expr).__name__
        if name not in BODY_FUNCTIONS:
            raise CodeGenerationError(f"no function {name} in generated bodies")
        return f"{name}({', '.join(self._print(a) for a in expr.args)})"

    def _print_NumberSymbol(self, expr: sympy.Expr) -> str:   # pi, E: folded before printing
        return repr(float(expr))

    def _print_Mul(self, expr: sympy.Mul) -> str:
        coeff, rest = expr.as_coeff_Mul()
        if coeff.is_Rational and not coeff.is_Integer:
            value = float(coeff)
            text = self.parenthesize(rest, precedence(expr))
            return f"{value!r}*{text}" if value >= 0 else f"-{-value!r}*{text}"
        return super()._print_Mul(expr)


class _ProgramPrinter:
    """Python for the lines of a straight-line program, fast: the lines are sums, products
    and integer powers of names and numbers, and sines and cosines, and SymPy's general
    printer spends half a millisecond on each (its precedence rules ask the assumptions
    system about signs): 13 s for a 30-joint chain's Coriolis body. Any other node goes to
    ``_LinePrinter``, whose output this one matches in meaning (tests compare the two)."""

    def __init__(self, names: dict[sympy.Symbol, str]):
        self.names = names
        self.general = _LinePrinter(names)

    def __call__(self, expr: sympy.Basic) -> str:
        return self._text(expr)

    def _text(self, expr: sympy.Basic) -> str:
        if expr.is_Symbol:
            return self.names.get(expr, expr.name)  # type: ignore[call-overload]
        if expr.is_Number:
            text = self._number(expr)
            return f"({text})" if text.startswith("-") else text
        if expr.is_Add:
            return self._sum(expr)
        if expr.is_Mul:
            return self._product(expr)
        if expr.is_Pow and expr.exp.is_Integer:
            return self._power(expr)
        if expr.is_Function and type(expr).__name__ in BODY_FUNCTIONS:
            return f"{type(expr).__name__}({', '.join(self._text(a) for a in expr.args)})"
        return self.general.doprint(expr)

    @staticmethod
    def _number(expr: sympy.Basic) -> str:
        if expr.is_Integer:
            return str(expr.p)   # type: ignore[attr-defined]
        if expr.is_Rational or expr.is_Float:
            return repr(float(expr))
        raise CodeGenerationError(f"unexpected number {expr} in a program line")

    @staticmethod
    def _negative(expr: sympy.Basic) -> bool:
        """A negative number, or a product with a negative coefficient (read off the number
        itself: SymPy's ``is_negative`` consults the assumptions system)."""
        number = expr if expr.is_Number else expr.args[0] if expr.is_Mul else None
        if number is None or not number.is_Number:
            return False
        return number.p < 0 if number.is_Rational else float(number) < 0

    def _sum(self, expr: sympy.Basic) -> str:
        parts = []
        for index, term in enumerate(expr.args):
            negative = self._negative(term)
            text = self._product(term, negate=True) if negative and term.is_Mul else (
                self._number(-term) if negative else self._text(term))
            if index == 0 and negative and term.is_Float:
                parts.append(f"(-{text})")
            elif index == 0:
                parts.append(f"-{text}" if negative else text)
            else:
                parts.append(f" - {text}" if negative else f" + {text}")
        return "".join(parts)

    def _product(self, expr: sympy.Basic, negate: bool = False) -> str:
        coefficient, rest = expr.as_coeff_Mul()
        if negate:
            coefficient = -coefficient
        numerator, denominator = [], []
        for factor in sympy.Mul.make_args(rest):
            if factor.is_Pow and factor.exp.is_Integer and factor.exp.p < 0:
                denominator.append(factor.base if factor.exp == -1 else sympy.Pow(factor.base, -factor.exp))
            else:
                numerator.append(factor)
        text = "*".join(self._power_factor(f) for f in numerator) or "1"
        if denominator:
            below = "*".join(self._power_factor(f) for f in denominator)
            text = f"{text}/{below}" if len(denominator) == 1 and not denominator[0].is_Pow else f"{text}/({below})"
        sign = ""
        if coefficient is sympy.S.NegativeOne:
            sign = "-"
        elif coefficient is not sympy.S.One:
            number = self._number(coefficient)
            if number.startswith("-"):
                sign, number = "-", number[1:]
            if coefficient.is_Rational and not coefficient.is_Integer and not sign and not negate \
                    and len(numerator) + len(denominator) > 1:
                text = f"({text})"   # a positive fraction times the rest, as it was always printed
            text = f"{number}*{text}" if text != "1" else number
        return sign + text

    def _power_factor(self, expr: sympy.Basic) -> str:
        if expr.is_Add:
            return f"({self._sum(expr)})"
        return self._text(expr)

    def _power(self, expr: sympy.Basic) -> str:
        base, exponent = expr.args
        if exponent.p < 0:
            return self._product(expr)
        inner = self._text(base)
        if not (base.is_Symbol or (base.is_Number and not inner.startswith("("))):
            inner = f"({inner})"
        return f"{inner}**{exponent}"


@dataclass
class ProgramFunction:
    """A straight-line body (see ``recursive.py``) printed with reused local names."""

    name: str
    doc: str
    arguments: list[Argument]
    lines: list[tuple[str, str]]
    outputs: list[str]
    operations: int
    #: Names of the functions the body calls (its parameters after the argument rows).
    functions: tuple[str, ...] = ()


def program_function(name: str, doc: str, arguments: list[Argument], program: Any) -> ProgramFunction:
    """Print ``program``, giving each value a local name that is reused once the value is dead.

    Reuse keeps the live arrays few (a batch chunk stays in cache); the same body then runs
    on floats for one state.
    """
    # each line's names, found once (SymPy walks the whole tree for every free_symbols)
    output_names = [sympy.sympify(e).free_symbols for e in program.outputs]
    needed = set().union(*output_names)
    kept = []
    for target, expr in reversed(program.lines):   # drop values nothing reads
        if target in needed:
            names = expr.free_symbols
            kept.append((target, expr, names))
            needed |= names
    body = kept[::-1]
    last_use: dict[sympy.Symbol, int] = {}
    for position, (_, _, names) in enumerate(body):
        for symbol in names:
            last_use[symbol] = position
    end = len(body)
    for names in output_names:
        for symbol in names:
            last_use[symbol] = end
    targets = {target for target, _, _ in body}
    slot: dict[sympy.Symbol, str] = {}
    printer = _ProgramPrinter(slot)
    free: list[str] = []
    count = 0
    lines = []
    for position, (target, expr, names) in enumerate(body):
        text = Code(printer(fold_constants(expr, rationals=False)))
        for symbol in sorted(names & targets, key=lambda s: s.name):
            if last_use[symbol] == position:
                free.append(slot[symbol])
        if free:
            slot[target] = free.pop()
        else:
            slot[target] = f"_r{count}"
            count += 1
        lines.append((slot[target], text))
    outputs = [Code(printer(fold_constants(e, rationals=False))) for e in program.outputs]
    operations = sum(operation_count(e) for _, e, _ in body) + operation_count(sympy.Matrix(program.outputs))
    used = {m.group(1) for text in [*(t for _, t in lines), *outputs] for m in _CALL.finditer(text)}
    functions = tuple(f for f in BODY_FUNCTIONS if f in used)
    return ProgramFunction(name, Code(doc), arguments, lines, outputs, operations, functions)


#: Quantities that stay matrices even with one column (a 1-DOF robot's M is 1 x 1).
MATRICES = {"M_g", "C_g", "M_m", "C_m", "A_m", "Adot_m", "H"}


def expression_function(name: str, doc: str, arguments: list[Argument], value: Any,
                        printer: NumPyPrinter, parameters: set[sympy.Symbol],
                        matrix_result: bool = False) -> ExpressionFunction:
    """Eliminate common subexpressions of ``value`` and print it as NumPy code.

    A column matrix becomes a vector ``(..., n)`` unless ``matrix_result`` keeps it ``(..., n, 1)``.
    """
    matrix = value if isinstance(value, sympy.MatrixBase) else sympy.Matrix([[value]])
    scalar = not isinstance(value, sympy.MatrixBase)
    column = not scalar and matrix.shape[1] == 1 and not matrix_result
    cells = [(i, j) for i in range(matrix.shape[0]) for j in range(matrix.shape[1])
             if matrix[i, j] != 0]
    exprs = [fold_constants(matrix[i, j]) for i, j in cells]
    temporaries, reduced = sympy.cse(exprs, symbols=sympy.numbered_symbols("_t"), order="canonical")
    used = set().union(*(e.free_symbols for e in reduced), *(e.free_symbols for _, e in temporaries)) if exprs else set()
    unpack = []
    for arg in arguments:
        for index, symbol in enumerate(arg.symbols):
            if symbol in used:
                unpack.append((str(symbol), arg.name, index))
    lines = [(str(t), Code(printer.doprint(e))) for t, e in temporaries]
    entries = []
    for (i, j), expr in zip(cells, reduced):
        index = "" if scalar else (f"{i}" if column else f"{i}, {j}")
        entries.append((index, Code(printer.doprint(expr))))
    shape = () if scalar else ((matrix.shape[0],) if column else tuple(matrix.shape))
    return ExpressionFunction(name, Code(doc), arguments, shape, unpack, lines, entries)


def code_context(derivation: Derivation, printer: NumPyPrinter | None = None) -> dict[str, Any]:
    """Every variable the code template can use (documented in docs/templates.md); ``printer``
    prints the expression functions (default: NumPy's, ``np.sin``; the JAX target passes its own)."""
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    printer = printer or _Printer({"fully_qualified_modules": True, "strict": False})
    params = set(table.parameters.values())
    n = len(table.q)
    q = Argument("q", table.q, f"joint coordinates {tuple(robot.coordinates)}, shape (..., {n})")
    qd = Argument("qd", table.qd, f"joint velocities, shape (..., {n})")
    u = Argument("u", list(table.efforts.values()), f"efforts {tuple(robot.efforts)}, shape (..., {len(table.efforts)})")
    structured = derivation.structured_code
    functions = _expression_functions(derivation, q, qd, u, printer, params, structured)
    programs = _programs(derivation, q, qd, u)
    if robot.loops:
        k = quantities["a_g"].shape[0]
        for name, doc, args, quantity in [
            ("loop_constraints", f"Loop constraints a_g(q) (zero when the loops are closed), shape (..., {k}).", [q], "a_g"),
            ("loop_jacobian", f"Loop constraint Jacobian A_g(q) = da_g/dq, shape (..., {k}, {n}).", [q], "A_g"),
            ("loop_jacobian_dot", f"Its time derivative Adot_g(q, qd), shape (..., {k}, {n}).", [q, qd], "Adot_g"),
        ]:
            functions.append(expression_function(name, doc, args, quantities[quantity], printer, params,
                                                 matrix_result=quantity != "a_g"))
        functions += _loop_derivatives(derivation, q, qd, printer, params)
    maximal = robot.planar
    if maximal:
        m = len(table.qm)
        qm = Argument("qm", table.qm, f"maximal coordinates (x, y, phi of each link's COM frame), shape (..., {m})")
        qmd = Argument("qmd", table.qmd, f"maximal velocities, shape (..., {m})")
        k = quantities["a_m"].shape[0]
        specs = [
            ("maximal_mass_matrix", f"Mass matrix M_m(qm) in maximal coordinates, shape (..., {m}, {m}).", [qm], "M_m"),
            ("maximal_coriolis_matrix", f"Coriolis matrix C_m(qm, qmd), shape (..., {m}, {m}).", [qm, qmd], "C_m"),
            ("maximal_gravity_vector", f"Gravity vector N_m(qm), shape (..., {m}).", [qm], "N_m"),
            ("maximal_efforts", f"Joint efforts as forces on the links, Y_m(qm, u), shape (..., {m}).", [qm, u], "Y_m"),
            ("constraints", f"Holonomic constraints a_m(qm) (zero when they hold), shape (..., {k}).", [qm], "a_m"),
            ("constraint_jacobian", f"Constraint Jacobian A_m(qm) = da/dqm, shape (..., {k}, {m}).", [qm], "A_m"),
            ("constraint_jacobian_dot", f"Time derivative Adot_m(qm, qmd), shape (..., {k}, {m}).", [qm, qmd], "Adot_m"),
            ("maximal_kinetic_energy", "Kinetic energy T_m(qm, qmd), shape (...).", [qm, qmd], "T_m"),
            ("maximal_potential_energy", "Potential energy V_m(qm), shape (...).", [qm], "V_m"),
            ("to_maximal", f"Change of basis qm = h(q), shape (..., {m}).", [q], "h"),
            ("to_maximal_jacobian", f"Its Jacobian H(q) = dh/dq (qmd = H qd), shape (..., {m}, {n}).", [q], "H"),
        ]
        if robot.dissipative:
            specs.append(("maximal_friction_forces", "Dissipative forces F_m(qm, qmd) of the joints' damping and "
                          f"friction on the links (exact sign), shape (..., {m}).", [qm, qmd], "F_m"))
        for name, doc, args, quantity in specs:
            functions.append(expression_function(name, doc, args, quantities[quantity], printer, params,
                                                 matrix_result=quantity in MATRICES))
    identification = derivation.parameter_vector
    forward = derivation.programs.get("forward_dynamics")
    functions.append(expression_function(
        "parameter_vector", f"The parameter vector pi of ``regressor`` (names: PARAMETER_VECTOR), shape ({len(identification)},).",
        [], sympy.Matrix([p.value for p in identification]), printer, params))
    parameters = []
    for p in robot.parameters:
        parameters.append({"name": p.name, "default": None if p.value is None else python_literal(float(p.value)),
                           "unit": p.unit, "description": p.description})
    from ...._version import __version__

    keywords = [p["name"] if p["default"] is None else f"{p['name']}={p['default']}" for p in parameters]
    return {
        "params_keywords": ("*, " + ", ".join(keywords)) if keywords else "",
        "params_pass": ", ".join(f"{p['name']}={p['name']}" for p in parameters),
        "generator": f"dynderive {__version__}",
        "source": Path(robot.source).name,
        "robot": {"name": robot.name, "title": robot.title},
        "parameters": parameters,
        "coordinates": list(robot.coordinates),
        "coordinates_tuple": _tuple(robot.coordinates),
        "efforts": list(robot.efforts),
        "efforts_tuple": _tuple(robot.efforts),
        "dof": n,
        "functions": functions,
        "structured": structured,
        "dissipative": robot.dissipative,
        "maximal_dissipative": robot.planar and robot.dissipative,
        "programs": programs,
        "frames": [{"name": f.name, "body": f"_frame{i}"} for i, f in enumerate(robot.frames)],
        "frames_tuple": _tuple(tuple(f.name for f in robot.frames)),
        "frame_size": 3 if robot.planar else 4,
        "twist_size": 3 if robot.planar else 6,
        # the forward-dynamics body takes F_g - J^T w where its program says so (damping, friction, frames)
        "forward_extra": forward is not None and bool(forward.extra_inputs),
        "parameter_vector_tuple": _tuple(tuple(p.name for p in identification)),
        "parameter_count": len(identification),
        "regressor_sign": bool(derivation.programs["regressor"].extra_inputs),
        "maximal": maximal,
        "maximal_coordinates_tuple": _tuple(tuple(str(s) for s in table.qm)),
        "maximal_size": len(table.qm),
        "constraint_count": quantities["a_m"].shape[0] if maximal else 0,
        "loops": bool(robot.loops),
        "loop_count": quantities["a_g"].shape[0] if robot.loops else 0,
        "loop_rank": derivation.steps["loops"].rank if robot.loops else 0,
        "redundant_loops": bool(robot.loops) and derivation.steps["loops"].redundant,
        "loops_tuple": _tuple(tuple(lp.name for lp in robot.loops)),
        "independent_tuple": _tuple(tuple(robot.coordinates[i] for i in derivation.steps["loops"].independent))
        if robot.loops else Code("()"),
        "dependent_list": Code(repr(derivation.steps["loops"].dependent)) if robot.loops else Code("[]"),
        "independent_list": Code(repr(derivation.steps["loops"].independent)) if robot.loops else Code("[]"),
        "independent_count": len(derivation.steps["loops"].independent) if robot.loops else 0,
        "assembled_tuple": python_literal(tuple(derivation.steps["loops"].assembled or ()))
        if robot.loops else Code("()"),
    }


def _expression_functions(derivation: Derivation, q: Argument, qd: Argument, u: Argument,
                          printer: _Printer, params: set[sympy.Symbol],
                          structured: bool) -> list[ExpressionFunction]:
    """Functions printed as explicit expressions: Y_g and V_g always; M, C, N and T_g for
    planar robots (short, readable beside the sheet). A 3-D robot's M, C, N are programs
    (``_programs``): their explicit entries are far too large to print for a 6-7 DOF arm."""
    quantities, n = derivation.quantities, len(derivation.symbols.q)
    functions = []
    if not structured:
        functions += [
            expression_function("mass_matrix", f"Mass matrix M_g(q), shape (..., {n}, {n}).", [q],
                                quantities["M_g"], printer, params, matrix_result=True),
            expression_function("coriolis_matrix", f"Coriolis matrix C_g(q, qd) (Christoffel symbols), shape (..., {n}, {n}).",
                                [q, qd], quantities["C_g"], printer, params, matrix_result=True),
            expression_function("gravity_vector", f"Gravity vector N_g(q) = dV/dq, shape (..., {n}).", [q],
                                quantities["N_g"], printer, params),
        ]
    functions.append(expression_function("generalized_forces", f"Applied generalized forces Y_g(u), shape (..., {n}).",
                                          [q, u], quantities["Y_g"], printer, params))
    if not structured:
        functions.append(expression_function("kinetic_energy", "Kinetic energy T_g(q, qd), shape (...).", [q, qd],
                                             quantities["T_g"], printer, params))
        functions.append(expression_function("potential_energy", "Potential energy V_g(q), shape (...).", [q],
                                             quantities["V_g"], printer, params))
    if derivation.robot.dissipative:   # F_g = b qd + fc sign(qd): the coefficients, per coordinate
        drives = derivation.joint_drives
        for name, what, attribute in (("_damping_coefficients", "Viscous damping b", "damping"),
                                      ("_friction_coefficients", "Coulomb friction fc", "friction")):
            value = sympy.zeros(n, 1)
            for drive in drives:
                value[drive.coordinate] = getattr(drive, attribute)
            functions.append(expression_function(name, f"{what} of each coordinate, shape (..., {n}).", [qd],
                                                 value, printer, params))
    return functions


def _loop_derivatives(derivation: Derivation, q: Argument, qd: Argument, printer: _Printer,
                      params: set[sympy.Symbol]) -> list[ExpressionFunction]:
    """What ``linearize`` of a closed-loop robot needs beyond Newton-Euler's derivatives: the
    loop force's ``d(A_g^T lambda_g)/dq`` at fixed multipliers and the constraint
    acceleration's ``d(A_g qdd + Adot_g qd)/dq`` at fixed qdd (``d(Adot_g qd)/dqd`` is
    ``2 Adot_g``: ``A_g`` is a Hessian's rows)."""
    table, quantities = derivation.symbols, derivation.quantities
    n, k = len(table.q), quantities["a_g"].shape[0]
    qdd = Argument("qdd", table.qdd, f"joint accelerations, shape (..., {n})")
    multipliers = Argument("_multipliers", table.loop_multipliers, f"loop multipliers lambda_g, shape (..., {k})")
    force, acceleration = derivation.loop_linearization
    return [
        expression_function("_loop_force_jacobian", f"d(A_g^T lambda_g)/dq at fixed lambda_g, shape (..., {n}, {n}).",
                            [q, multipliers], force, printer, params, matrix_result=True),
        expression_function("_loop_acceleration_jacobian", "d(A_g qdd + Adot_g qd)/dq at fixed qdd, "
                            f"shape (..., {k}, {n}).", [q, qd, qdd], acceleration, printer, params, matrix_result=True),
    ]


def _programs(derivation: Derivation, q: Argument, qd: Argument, u: Argument) -> list[ProgramFunction]:
    """The straight-line programs the derivation holds (``Derivation.programs``), printed:
    inverse and forward dynamics and the regressor for every robot, M, C, N for 3-D robots."""
    n = len(derivation.symbols.q)
    qdd = Argument("qdd", derivation.symbols.qdd, f"joint accelerations, shape (..., {n})")
    effort_args = [q, qd, u]
    forward = derivation.programs.get("forward_dynamics")
    if forward is not None and forward.extra_inputs:   # damping, friction: F_g computed outside the body
        opposing = "dissipative forces F_g" if derivation.robot.dissipative else "no dissipative force"
        external = " minus the external forces J^T w" if derivation.robot.frames else ""
        effort_args.append(Argument("_friction", forward.extra_inputs, f"{opposing}{external}, shape (..., {n})"))
    regressor = derivation.programs["regressor"]
    regressor_args = [q, qd, qdd]
    if regressor.extra_inputs:   # Coulomb friction: sign(qd) (or its smoothed form) computed outside the body
        regressor_args.append(Argument("_sign", regressor.extra_inputs, f"sign(qd) or tanh(qd / eps), shape (..., {n})"))
    specs = {
        "mass_matrix": ("_mass_matrix_body", "M(q), row by row: composite-rigid-body algorithm.", [q]),
        "coriolis": ("_coriolis_body", "C(q, qd), row by row: Christoffel symbols of the differentiated CRBA.", [q, qd]),
        "gravity": ("_gravity_body", "N(q): Newton-Euler at rest.", [q]),
        "potential": ("_potential_body", "V(q): gravity along the tree, and the springs.", [q]),
        "inverse_dynamics": ("_inverse_dynamics_body", "M qdd + C qd + N: recursive Newton-Euler.", [q, qd, qdd]),
        "inverse_dynamics_derivatives": ("_inverse_dynamics_derivatives_body",
                                         "dtau/dq, then dtau/dqd, row by row: Newton-Euler differentiated line by line.",
                                         [q, qd, qdd]),
        "forward_dynamics": ("_forward_dynamics_body",
                             "qdd: CRBA, Newton-Euler and an LDL^T solve of M qdd = Y - C qd - N"
                             + (" - F" if derivation.robot.dissipative else "")
                             + (" + J^T w." if derivation.robot.frames else "."), effort_args),
        "regressor": ("_regressor_body", "Y(q, qd, qdd) with Y pi = M qdd + C qd + N (+ F), row by row: each joint's "
                      "axis carried down the tree, dotted with each link's force per unit parameter.", regressor_args),
    }
    functions = [program_function(*specs[key], program) for key, program in derivation.programs.items()]
    for index, frame in enumerate(derivation.frame_programs):
        functions += [
            program_function(f"_frame{index}_transform_body", f"Pose of frame {frame.name!r} (homogeneous, row by row).",
                             [q], frame.transform),
            program_function(f"_frame{index}_jacobian_body", f"World-frame Jacobian of frame {frame.name!r}, row by row.",
                             [q], frame.jacobian),
            program_function(f"_frame{index}_jacobian_dot_qd_body", f"Jdot qd of frame {frame.name!r}.",
                             [q, qd], frame.jacobian_dot_qd),
        ]
    return functions


def _tuple(names: tuple[str, ...]) -> Code:
    """Python source of a tuple of strings, with double quotes as ruff formats them."""
    return python_literal(tuple(names))


def render_code(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    return render_module(derivation, CODE_TEMPLATE, code_context(derivation), template_dir)


def render_code_tests(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """A pytest file of property checks for the generated module (``solve --code --tests``)."""
    return render_test_module(derivation, "dynamics_test.py.j2", template_dir,
                              maximal=derivation.robot.planar, loops=bool(derivation.robot.loops))
