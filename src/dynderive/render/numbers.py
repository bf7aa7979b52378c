"""Numbers on the sheet as the robot file wrote them, to at most 6 significant digits by default
(docs/reference/outputs.md, "Numbers on the sheet").

The loader turns every decimal of a robot file into an exact rational (``0.1234`` -> 617/5000),
so the derivation is exact; printed as SymPy prints it, a CAD number becomes a fraction of 30
digits and a normalised axis a surd of 60. The sheet's printers (LaTeX, MathML, the terminal's)
print numbers by one rule instead, with ``D`` the robot's precision (``sheet_digits``: the most
significant digits among the numbers its file wrote, at most 6, or ``--digits N``):

* an integer as it is, unless it has more than max(D, 3) significant digits;
* a short fraction (numerator and denominator of at most max(2, min(3, D)) digits: 1/3, 7/12,
  3/2) as the fraction, unless it is a decimal whose denominator has a factor 5 (0.35 = 7/20,
  0.1): that prints as the decimal;
* another rational with a decimal expansion of at most D significant digits as that decimal
  (exactly the number the file wrote);
* every other number, and every constant with such a number or a surd of a long number in
  it (a normalised CAD axis ``17573222896111212*sqrt(408...)/408...``), as a decimal rounded
  to D significant digits; the constant factors of a product fold into one decimal, a
  decimal times a sum of decimal terms is multiplied out (no ``1.8e-49 (5.3e47 x + ...)``), as
  is a decimal times a sum of integers of which one is 10 or more (``0.001 (79 x + 220 y)``, a
  power of ten factored out), and terms that differ only in such constants are collected.

Decimals print as ``printf("%.Dg")`` does: trailing zeros dropped, ``1.2 \\cdot 10^{-5}``
below 1e-4 and at or above 10^D. Exact constants (``\\sqrt{2}/2``, ``\\pi/4``) stay exact.
"""

from __future__ import annotations

from collections.abc import Callable
from decimal import ROUND_HALF_EVEN, Context, Decimal
from typing import Any

import sympy
from mpmath.libmp import to_str
from sympy.core.numbers import Float, Rational, prec_to_dps

from ..model.robot import Robot
from ..model.written import written_digits

#: D's default ceiling: a CAD file's 17 digits print as 6 (the JSON and the code keep them all).
DEFAULT_MOST_DIGITS = 6


def sheet_digits(robot: Robot, digits: int | None = None) -> int:
    """D: ``digits`` (``--digits N``) when given, else the robot's written precision (at least
    1), at most ``DEFAULT_MOST_DIGITS``."""
    if digits is not None:
        return digits
    return min(max(1, written_digits(robot)), DEFAULT_MOST_DIGITS)


def _magnitude(value: sympy.Basic) -> float:
    """|value| of a constant, roughly (0 when it has no real value)."""
    try:
        return abs(float(value.evalf(8)))  # type: ignore[union-attr]
    except (TypeError, ValueError):
        return 0.0


def _remembered(cache: dict[Any, Any], key: Any, make: Callable[[Any], Any]) -> Any:
    """``make(key)``, made once per key (``None`` included)."""
    if key not in cache:
        cache[key] = make(key)
    return cache[key]


def _terminates(denominator: int) -> bool:
    """Whether 1/denominator has a finite decimal expansion (denominator = 2^a 5^b)."""
    for prime in (2, 5):
        while denominator % prime == 0:
            denominator //= prime
    return denominator == 1


class Numbers:
    """The rule for one precision ``digits`` (D): which numbers print as decimals, and their
    text. Decimal numbers are handed to the printers as SymPy Floats ("markers") of exactly
    the digits to show, so SymPy lays out products and fractions as it does for any Float."""

    def __init__(self, digits: int):
        self.digits = digits
        self.short = max(2, min(3, digits))
        self._exact: dict[sympy.Basic, bool] = {}
        self._shown: dict[sympy.Basic, sympy.Basic] = {}   # products as ``mul`` shows them
        self._kinds: dict[Rational, tuple[str, Decimal | None]] = {}
        self._split: dict[sympy.Basic, tuple[sympy.Basic, sympy.Basic]] = {}
        self._added: dict[sympy.Basic, sympy.Basic] = {}   # sums as ``add`` shows them
        self._constants: dict[sympy.Basic, Float | None] = {}

    # --- rationals -----------------------------------------------------------------------
    def _kind(self, r: Rational) -> tuple[str, Decimal | None]:
        """("fraction", None): SymPy prints it; ("exact", d) / ("rounded", d): the decimal d."""
        return _remembered(self._kinds, r, self._classify)

    def _classify(self, r: Rational) -> tuple[str, Decimal | None]:
        numerator, denominator = int(r.p), int(r.q)
        if denominator == 1:
            if len(str(abs(numerator)).rstrip("0")) <= max(self.digits, 3):
                return "fraction", None
            return "rounded", self.rounded(Decimal(numerator))
        terminates = _terminates(denominator)
        if len(str(abs(numerator))) <= self.short and len(str(denominator)) <= self.short and (denominator % 5 or not terminates):
            return "fraction", None
        if terminates:
            exact = Context(prec=len(str(abs(numerator))) + len(str(denominator)) * 4 + 8).divide(Decimal(numerator), Decimal(denominator)).normalize()
            if len(exact.as_tuple().digits) <= self.digits:
                return "exact", exact
        return "rounded", Context(prec=self.digits, rounding=ROUND_HALF_EVEN).divide(Decimal(numerator), Decimal(denominator)).normalize()

    def rounded(self, value: Decimal) -> Decimal:
        """``value`` to D significant digits (ties to even), trailing zeros dropped."""
        return Context(prec=self.digits, rounding=ROUND_HALF_EVEN).plus(value).normalize()

    def marker(self, value: Decimal) -> Float:
        """A Float printing exactly as ``value``."""
        return Float(str(value), max(1, len(value.as_tuple().digits)))

    def decimal(self, r: Rational) -> Float | None:
        """The marker of a rational (an integer) that prints as a decimal, or None."""
        kind, value = self._kind(r)
        return None if value is None else self.marker(value)

    # --- constants -----------------------------------------------------------------------
    def exact(self, expr: sympy.Basic) -> bool:
        """Whether a constant prints exactly: its rationals as integers, short fractions or
        decimals of at most D digits, its roots of short rationals only, no Float."""
        return _remembered(self._exact, expr, self._exact_uncached)

    def _exact_uncached(self, expr: sympy.Basic) -> bool:
        if expr.is_Rational:
            return self._kind(expr)[0] != "rounded"
        if expr.is_Pow and not expr.exp.is_Integer:
            base, exp = expr.args
            return bool(base.is_Rational and self._kind(base)[0] == "fraction" and self.exact(exp))
        return not expr.is_Float and all(self.exact(a) for a in expr.args)

    def constant(self, expr: sympy.Basic) -> Float | None:
        """The marker of a constant that does not print exactly (its value to D digits), or None."""
        return _remembered(self._constants, expr, self._constant)

    def _constant(self, expr: sympy.Basic) -> Float | None:
        if not expr.is_number or self.exact(expr):
            return None
        value = expr.evalf(self.digits + 10)  # type: ignore[union-attr]
        if not isinstance(value, Float):
            return None
        return self.marker(self.rounded(Decimal(to_str(value._mpf_, self.digits + 10))))

    def split(self, term: sympy.Basic) -> tuple[sympy.Basic, sympy.Basic]:
        """A term as (its constant part, exact: coefficient and constant factors; the rest)."""
        return _remembered(self._split, term, self._split_term)

    def _split_term(self, term: sympy.Basic) -> tuple[sympy.Basic, sympy.Basic]:
        coefficient, rest = term.as_coeff_Mul()
        factors = sympy.Mul.make_args(rest)
        constants = [f for f in factors if f.is_number]
        if not constants:
            return coefficient, rest
        return coefficient * sympy.Mul(*constants), sympy.Mul(*(f for f in factors if not f.is_number))

    def shown(self, value: sympy.Basic) -> Float | None:
        """The marker of a term's constant part when it prints as a decimal, else None."""
        return self.decimal(value) if value.is_Rational else self.constant(value)

    def mul(self, expr: sympy.Basic) -> sympy.Basic:
        """A product whose constant part prints as a decimal, with that decimal's marker in
        front (its constant factors folded into it); a decimal times a sum of decimal terms,
        multiplied out: ``c (a x + b y)`` as ``(c a) x + (c b) y``, one decimal a term, not
        ``1.8e-49 (5.3e47 x + ...)`` (a CAD robot's exact factoring). Others as they are."""
        if not isinstance(expr, sympy.Mul):
            return expr
        return _remembered(self._shown, expr, self._mul)

    def _mul(self, expr: sympy.Mul) -> sympy.Basic:
        value, symbolic = self.split(expr)
        others = [f for f in sympy.Mul.make_args(symbolic) if f != 1]
        decimal = not value.is_Integer and self.shown(value) is not None

        def scaled(total: sympy.Basic) -> bool:   # a sum to multiply out or scale to its largest term
            return self._decimal_sum(total) or (decimal and self._scaled_sum(total))

        powers = [f for f in others if f.is_Pow and f.exp.is_Integer and f.exp > 0 and scaled(f.base)]
        if powers:   # (1.6e32 x + ...)^2 as 2.4e64 (0.15 x + ...)^2
            scaled_powers = []
            for power in powers:
                scale = self._scale(power.base)
                scaled_powers.append(sympy.Add(*(t / scale for t in power.base.args)) ** power.exp)
                value *= scale ** power.exp
            others = [f for f in others if all(f is not p for p in powers)] + scaled_powers
        sums = [f for f in others if f.is_Add and scaled(f)]
        if sums:
            # each such sum scaled to its largest constant (1.3e16 x + 2e15 -> 1.3e16 (x + 0.15)),
            # the scales and the coefficient multiplied into the first
            rest, scaled = [f for f in others if all(f is not s for s in sums)], []
            for total in sums:
                scale = self._scale(total)
                scaled.append(sympy.Add(*(t / scale for t in total.args)) if scale != 0 else total)
                value *= scale if scale != 0 else 1
            first = sympy.Add(*(value * t for t in scaled[0].args))
            return sympy.Mul(*rest, first, *scaled[1:])
        marker = self.shown(value)
        if marker is None:
            # the constants print exactly, but a decimal coefficient must print as one (SymPy's
            # product would set p/q as a fraction: 2029996247402721/50000000000000000 cos(1.1))
            coefficient, rest = expr.as_coeff_Mul()
            decimal = self.decimal(coefficient) if coefficient.is_Rational and coefficient != 1 else None
            return expr if decimal is None else sympy.Mul(decimal, *sympy.Mul.make_args(rest), evaluate=False)
        nested = [f for f in others if f.is_Add and any(self._decimal_sums(t) for t in f.args)]
        if len(nested) == 1:
            # c (A B + 5 C D) with sums A ... D of decimal terms: c A B + 5 c C D, each product
            # then scaled as above (no 7.3e-50 ((6.2e48 x + ...) (...) + ...))
            rest = [f for f in others if f is not nested[0]]
            inner = sympy.Add(*(value * t for t in nested[0].args))
            return sympy.Mul(*rest, inner) if rest else inner
        return sympy.Mul(marker, *others, evaluate=False) if others else marker

    def _decimal_sum(self, expr: sympy.Basic) -> bool:
        """Whether ``expr`` is a sum with a term whose constant prints as a decimal."""
        return expr.is_Add and any(self.shown(self.split(t)[0]) is not None for t in expr.args)

    def _scale(self, total: sympy.Add) -> sympy.Basic:
        """What a sum is divided by (and its product's coefficient multiplied by): its largest
        constant; for a sum of integers (``_scaled_sum``) the power of ten at or above the largest,
        so that its terms become decimals again (``79 x + 220 y`` -> ``0.079 x + 0.22 y``), not
        fractions of its integers."""
        if not self._decimal_sum(total):
            largest = max(abs(int(t.as_coeff_Mul()[0])) for t in total.args)
            return sympy.Integer(10) ** len(str(largest))
        return max((self.split(t)[0] for t in total.args), key=_magnitude)

    def _scaled_sum(self, expr: sympy.Basic) -> bool:
        """Whether ``expr`` is a sum of terms with integer coefficients, one of them at least 10:
        the integers left when a decimal was factored out (``0.001 (79 x + 220 y)``), which the
        sheet multiplies back in (a decimal in front of it), as it does for a sum of decimals."""
        if not expr.is_Add:
            return False
        coefficients = [t.as_coeff_Mul()[0] for t in expr.args]   # 71 of 71 sin(0.38): an exact constant's
        return all(c.is_Integer for c in coefficients) and max(abs(int(c)) for c in coefficients) >= 10

    def _decimal_sums(self, term: sympy.Basic) -> bool:
        """Whether a term has a sum among its factors with a decimal term."""
        return any(self._decimal_sum(f) for f in sympy.Mul.make_args(self.split(term)[1]))

    def add(self, expr: sympy.Basic) -> sympy.Basic:
        """A sum with terms that differ only in constants printing as rounded decimals, those
        terms collected (``2.1 x + 0.3 x`` as ``2.4 x``: SymPy keeps ``sin(0.12) x`` and
        ``cos(0.12) x`` apart), and every term whose constant prints as a rounded decimal
        written with that decimal in front, so that its sign is the decimal's (SymPy sees none in ``(sin(c) - 1) x`` and a
        wrong one in ``-(1 - 2 sin(c)) x``); others as they are."""
        if not isinstance(expr, sympy.Add):
            return expr
        return _remembered(self._added, expr, self._add)

    def _add(self, expr: sympy.Add) -> sympy.Basic:
        args: list[sympy.Basic] = []
        for term in expr.args:   # a term that prints as a sum (``mul``) joins this one
            shown = self.mul(term)
            args += shown.args if shown.is_Add else [term]
        groups: dict[sympy.Basic, list[tuple[sympy.Basic, sympy.Basic]]] = {}
        for term in args:
            value, symbolic = self.split(term)
            groups.setdefault(symbolic, []).append((value, term))
        terms, changed = [], len(args) != len(expr.args)
        for symbolic, group in groups.items():
            if len(group) > 1 and any(not self.exact(value) for value, _ in group):
                total = sympy.Add(*(value for value, _ in group))
                marker = self.shown(total)   # the sum as one decimal, its sign in front
                terms.append((total if marker is None else marker) * symbolic)
                changed = True
                continue
            for value, term in group:   # the decimal in front: its sign is the term's sign
                marker = None if value.is_Float or self.exact(value) else self.shown(value)
                if marker is not None:
                    terms.append(marker * symbolic)
                    changed = True
                else:
                    terms.append(term)
        return sympy.Add(*terms) if changed else expr

    # --- text ----------------------------------------------------------------------------
    def parts(self, value: Float) -> tuple[str, int | None]:
        """A Float as (mantissa, power of ten or None), at most D significant digits."""
        dps = max(1, prec_to_dps(value._prec))
        number = Decimal(to_str(value._mpf_, dps))
        if not number:
            return "0", None
        number = Context(prec=min(dps, self.digits), rounding=ROUND_HALF_EVEN).plus(number).normalize()
        exponent = number.adjusted()
        if -4 <= exponent < self.digits:
            return format(number, "f"), None
        sign, digits, _ = number.as_tuple()
        text = "".join(map(str, digits))
        mantissa = ("-" if sign else "") + text[0] + ("." + text[1:] if len(text) > 1 else "")
        return mantissa, exponent

    def value_parts(self, value: float) -> tuple[str, int | None]:
        """A parameter's value (a float, as written: its shortest form) to at most D digits."""
        return self.parts(self.marker(Decimal(repr(float(value))).normalize()))


class DecimalNumbers:
    """Printer mixin (before the SymPy printer in the bases): numbers by ``self.numbers``'s
    rule. The printer gives ``_decimal(mantissa, exponent)``, a decimal's printed form."""

    numbers: Numbers

    def _decimal(self, mantissa: str, exponent: int | None) -> Any:
        raise NotImplementedError

    def _print_Float(self, expr: Float) -> Any:
        return self._decimal(*self.numbers.parts(expr))

    def _print_Rational(self, expr: Rational) -> Any:
        marker = self.numbers.decimal(expr)
        return super()._print_Rational(expr) if marker is None else self._print_Float(marker)  # type: ignore[misc]

    def _print_Mul(self, expr: Any, *args: Any, **kwargs: Any) -> Any:
        rewritten = self.numbers.mul(expr)
        if rewritten is not expr and not rewritten.is_Mul:
            return self._print(rewritten)  # type: ignore[attr-defined]
        return super()._print_Mul(rewritten, *args, **kwargs)  # type: ignore[misc]

    def _print_Pow(self, expr: Any, *args: Any, **kwargs: Any) -> Any:
        marker = self.numbers.constant(expr)
        return super()._print_Pow(expr, *args, **kwargs) if marker is None else self._print_Float(marker)  # type: ignore[misc]

    def _print_Add(self, expr: Any, *args: Any, **kwargs: Any) -> Any:
        marker = self.numbers.constant(expr)
        if marker is not None:
            return self._print_Float(marker)
        collected = self.numbers.add(expr)
        if collected is not expr:
            return self._print(collected)  # type: ignore[attr-defined]
        return super()._print_Add(expr, *args, **kwargs)  # type: ignore[misc]


def latex_decimal(mantissa: str, exponent: int | None) -> str:
    return mantissa if exponent is None else rf"{mantissa} \cdot 10^{{{exponent}}}"


__all__ = ["DecimalNumbers", "Numbers", "latex_decimal", "sheet_digits"]
