"""The Python printers of the generated modules: SymPy's NumPy printer for the explicit
expressions (``np.sin``), and the straight-line programs' line printer (``_ProgramPrinter``,
fast; ``_LinePrinter`` for any other node), whose functions (``sin``, ``where``...) are the
bodies' parameters, bound to ``math`` or NumPy (or ``jax.numpy``) by the module."""

from __future__ import annotations

import re

import sympy
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence
from sympy.printing.str import StrPrinter

from ..python_module import CodeGenerationError

#: Functions the printed code may call, as the straight-line bodies receive them: from
#: ``math`` (one state on floats) or NumPy (a batch). SymPy's ``Abs`` prints as ``abs``, a
#: ``Piecewise`` (the configuration maps' branches) as ``where(condition, then, otherwise)``:
#: both branches are evaluated, none divides by zero (``joint_types/quaternion.py``).
BODY_FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
                  "exp", "log", "sqrt", "abs", "where")
_CALL = re.compile(r"\b(" + "|".join(BODY_FUNCTIONS) + r")\(")

class _Printer(NumPyPrinter):
    """NumPy printer that writes ``np.sin`` rather than ``numpy.sin``, floats as exact ``repr``
    literals (17 significant digits); the JAX module's (``jax.py``) sets its own ``_short``."""

    _short = ("numpy.", "np.", "NumPy")   # the module's full name, its name in the code, its title

    def _module_format(self, fqn: str, register: bool = True) -> str:
        text = super()._module_format(fqn, register)
        full, short, _ = self._short
        return short + text[len(full):] if text.startswith(full) else text

    def _print_Float(self, expr: sympy.Float) -> str:
        return repr(float(expr))

    def _print_Function(self, expr: sympy.Function) -> str:   # anything the library has no name for
        raise CodeGenerationError(f"no {self._short[2]} function for {type(expr).__name__}")


class _LinePrinter(StrPrinter):
    """Plain Python for straight-line programs: ``sin(x)`` (bound to ``math`` or NumPy by the
    caller), numbers as float literals (``0.333*x``: one multiplication at run time), each
    symbol under its name in ``names``."""

    def __init__(self, names: dict[sympy.Symbol, str]):
        super().__init__({"order": "none"})
        self.names = names
        self.guards: dict[sympy.Symbol, str] = {}   # see _print_Piecewise

    def _print_Symbol(self, expr: sympy.Symbol) -> str:
        return self.guards.get(expr) or self.names.get(expr, expr.name)

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

    def _print_Piecewise(self, expr: sympy.Piecewise) -> str:
        """``where(condition, then, otherwise)``: both are evaluated, so past ``Eq(x, 0)`` the
        name ``x`` reads ``where(x == 0, 1, x)`` (SymPy turns ``y / Piecewise((1, Eq(x, 0)),
        (x, True))`` into ``y * Piecewise((1, ...), (1/x, True))``): no division by zero, in
        values or derivatives."""
        (value, condition), rest = expr.args[0], expr.args[1:]
        if condition == sympy.true:
            return self._print(value)
        if not rest:
            raise CodeGenerationError("a Piecewise without an otherwise branch")
        then, test = self._print(value), self._print(condition)
        guarded = condition.lhs if isinstance(condition, sympy.Eq) and condition.rhs == 0 else None
        if guarded is not None and guarded.is_Symbol and guarded not in self.guards:
            self.guards[guarded] = f"where({test}, 1, {self._print(guarded)})"
            otherwise = self._print(sympy.Piecewise(*rest))
            del self.guards[guarded]
        else:
            otherwise = self._print(sympy.Piecewise(*rest))
        return f"where({test}, {then}, {otherwise})"

    def _print_Relational(self, expr: sympy.Basic) -> str:   # Eq, Ne, Lt, ...: Python's operators
        return f"{self._print(expr.lhs)} {expr.rel_op} {self._print(expr.rhs)}"

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


__all__ = ["BODY_FUNCTIONS", "_CALL", "_LinePrinter", "_Printer", "_ProgramPrinter"]
