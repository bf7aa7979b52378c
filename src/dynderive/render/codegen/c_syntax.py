"""Printing for the languages of C's expression syntax (the C target; MATLAB's
``matlab_print.py`` builds on it): SymPy's ``C99CodePrinter`` with three changes (``CPrinter``): integer powers as
multiplications, every fraction and float as a double literal of 17 significant digits, and
each symbol as its place in the generated function (``q[0]``, ``P->m1``, a temporary ``t12``);
branches (``sympy.Piecewise``, the configuration maps') as ``(c ? a : b)``. ``FastCPrinter``
prints the common nodes of program lines the same way without SymPy's slow precedence rules.
Then the names of symbols (``Names``) and the bodies of straight-line programs and of explicit
expressions.
"""

from __future__ import annotations

from typing import Any

import sympy
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import precedence

from ...derivation import Derivation
from ...mechanics.tidy import fold_constants
from ..python_module import CodeGenerationError
from .cse import common_subexpressions
from .fold import folded
from .literals import double_literal
from .printer import _ProgramPrinter
from .prune import live_lines

#: Powers up to this exponent are written as products (``x*x*x``); higher ones call ``pow``.
MAX_PRODUCT_POWER = 8


class DoublePrinting:
    """The number and symbol rules of every compiled target's SymPy printer, mixed in before
    the language's own printer (``CPrinter``; ``matlab_print.MatlabPrinter``): symbols by
    ``names`` (anything else is an internal error), numbers as exact double literals,
    integer powers as products."""

    #: the language named in the internal error of a symbol without a value
    language = "C"
    #: comparisons as the language writes them
    relations: dict[str, str] = {}
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

    def _part(self, expr: sympy.Basic) -> str:
        """A branch's or a comparison's operand: by the fast printer that made this one, if any
        (its products; SymPy's ``_print_Mul`` would divide by ``t*t`` unparenthesized)."""
        fast = getattr(self, "fast", None)
        return fast._text(expr) if fast is not None else self._print(expr)  # type: ignore[attr-defined]

    def _choice(self, condition: str, value: str, otherwise: str) -> str:
        return f"({condition} ? {value} : {otherwise})"

    def _print_Piecewise(self, expr: sympy.Piecewise) -> str:
        """``(c0 ? e0 : (c1 ? e1 : e2))`` on one line (the last condition is True), by ``_choice``."""
        (last, _), *rest = reversed(expr.args)
        text = self._part(last)
        for value, condition in rest:
            text = self._choice(self._part(condition), self._part(value), text)
        return text

    def _print_Relational(self, expr: sympy.Basic) -> str:
        operator = self.relations.get(expr.rel_op, expr.rel_op)  # type: ignore[attr-defined]
        return f"{self._part(expr.lhs)} {operator} {self._part(expr.rhs)}"  # type: ignore[attr-defined]

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
        self.general.fast = self   # its branches' operands printed here
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


class Names:
    """The C text of each symbol in one function: arguments, parameters, temporaries (``extra``:
    more, or all of them without a derivation). A language of C's expressions (MATLAB's
    ``matlab_print.Names``) changes the class attributes."""

    #: a parameter's text, an array entry's, the first index, a temporary's declaration, the printer
    parameter, entry, first, declaration = "P->{}", "{}[{}]", 0, "const double "
    fast_printer: type = FastCPrinter

    def __init__(self, derivation: Derivation | None = None, extra: dict[sympy.Symbol, str] | None = None):
        self.base: dict[sympy.Symbol, str] = {}
        if derivation is not None:
            table = derivation.symbols
            self.base |= {s: self.parameter.format(s.name) for s in table.parameters.values()}
            for array, symbols in (("q", table.q), ("qd", table.qd), ("qdd", table.qdd),
                                   ("u", list(table.efforts.values()))):
                self.base |= {s: self.entry.format(array, i + self.first) for i, s in enumerate(symbols)}
        self.base |= dict(extra or {})

    def extended(self, extra: dict[sympy.Symbol, str] | None) -> Names:
        """These names and ``extra`` (locals of one function: ``qdd[i]``, ``lambda[i]``)."""
        return type(self)(extra=self.base | dict(extra or {}))

    def printer(self) -> FastCPrinter:
        return self.fast_printer(dict(self.base))


def program_body(names: Names, program: Any, targets: list[str]) -> list[str]:
    """The lines of a straight-line program: ``const double tN = ...;`` (MATLAB: ``tN = ...;``)
    for each value the outputs need (in order), then ``target = output;`` for each output."""
    outputs = [sympy.sympify(e) for e in program.outputs]
    needed = set().union(*(e.free_symbols for e in outputs))
    lines = [(target, expr) for target, expr, _ in live_lines(program.lines, needed)]
    return _lines(names, lines, list(zip(targets, outputs)))


def _lines(names: Names, lines: list[tuple[sympy.Symbol, sympy.Expr]],
           stores: list[tuple[str, sympy.Expr]]) -> list[str]:
    printer = names.printer()
    text = []
    for index, (target, expr) in enumerate(lines):
        printer.names[target] = f"t{index}"
        text.append(f"{names.declaration}t{index} = {printer.doprint(folded(expr))};")
    for target, expr in stores:
        text.append(f"{target} = {printer.doprint(folded(expr))};")
    return text


def expression_body(names: Names, values: list[sympy.Expr], targets: list[str]) -> list[str]:
    """The lines of explicit expressions (a small planar robot's M, C, N, V), with common
    subexpressions eliminated."""
    temporaries, reduced = common_subexpressions([fold_constants(sympy.sympify(v)) for v in values], "_c")
    return _lines(names, temporaries, list(zip(targets, reduced)))


def quantity_body(derivation: Derivation, names: Names, program: str, quantity: str, targets: list[str]) -> list[str]:
    """The lines of ``derivation.programs[program]``, or for a small planar robot (no structured
    code) of the explicit ``quantities[quantity]``."""
    if derivation.structured_code:
        return program_body(names, derivation.programs[program], targets)
    value = derivation.quantities[quantity]
    return expression_body(names, list(value) if isinstance(value, sympy.MatrixBase) else [value], targets)


def parameter_note(parameter: Any) -> str:
    """A parameter's description, unit and missing default, for the comment beside its value."""
    parts = [parameter.description or "", f"[{parameter.unit}]" if parameter.unit else "",
             "(no default in the robot file: NaN)" if parameter.value is None else ""]
    return " ".join(p for p in parts if p)
