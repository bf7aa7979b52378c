"""``sympy.expand`` for the polynomials the derivation builds, several times faster.

Entries of M, C, N and the equations of motion are polynomials in sines and cosines,
rates and parameters with rational coefficients (17-digit ones from CAD files).
``sympy.expand`` distributes them one binary product at a time, asking the assumption system
about each partial product; here every term is a monomial (a map from factor to exponent)
with an exact coefficient, products and powers are taken on those maps, and SymPy builds
each final term once. The result is the very tree ``sympy.expand`` returns (the same
canonical ``Add`` of the same ``Mul``\\s), which ``DYNDERIVE_CHECK_EXPAND=1`` asserts on every
call. Anything else (floats, sums in denominators, symbolic exponents) goes to
``sympy.expand`` unchanged.

>>> x, y = sympy.symbols("x y")
>>> expand((x + y) ** 2 * sympy.sin(2 * (x + y)))
x**2*sin(2*x + 2*y) + 2*x*y*sin(2*x + 2*y) + y**2*sin(2*x + 2*y)
"""

from __future__ import annotations

import os
from fractions import Fraction
from typing import Any

import sympy

#: A monomial: its factors (a SymPy expression that is not a sum or product) with their
#: exponents, as a frozenset of pairs; a polynomial: ``{monomial: coefficient}``.
Monomial = frozenset
Polynomial = dict

_ONE: Monomial = frozenset()
#: Largest number of terms a power or product may produce here (beyond: ``sympy.expand``).
TERM_LIMIT = 200_000
#: ``expand``'s results by input, and the polynomials of sub-expressions (shared subtrees:
#: the sines of one angle sum, the entries of M inside the equations of motion).
_RESULTS: dict[sympy.Basic, sympy.Basic] = {}
_POLYNOMIALS: dict[sympy.Basic, Polynomial] = {}
MEMO_LIMIT = 200_000
CHECK = os.environ.get("DYNDERIVE_CHECK_EXPAND") == "1"


#: Functions whose expansion is that of their arguments (``expand`` has no rule of their own
#: under the default hints; ``exp(a + b)`` has one, so it is not here).
_FUNCTIONS = (sympy.sin, sympy.cos, sympy.tan, sympy.sign, sympy.Abs, sympy.tanh)


class _Unsupported(Exception):
    """The expression is not a polynomial this module expands like SymPy."""


def expand(expr: Any) -> sympy.Expr:
    """``sympy.expand(expr)`` (default hints), the same tree, computed on monomials."""
    expr = sympy.sympify(expr)
    if expr.is_Atom:
        return expr
    known = _RESULTS.get(expr)
    if known is not None:
        return known
    if len(_RESULTS) > MEMO_LIMIT or len(_POLYNOMIALS) > MEMO_LIMIT:
        _RESULTS.clear()
        _POLYNOMIALS.clear()
    try:
        result = _build(_polynomial(expr))
    except _Unsupported:
        result = sympy.expand(expr)
    if CHECK:
        reference = sympy.expand(expr)
        if result != reference:
            raise AssertionError(f"fast expand differs from sympy.expand on {sympy.srepr(expr)}:\n"
                                 f"{result}\n!=\n{reference}")
    _RESULTS[expr] = result
    return result


def _polynomial(expr: sympy.Expr) -> Polynomial:
    known = _POLYNOMIALS.get(expr)
    if known is not None:
        return known
    if expr.is_Rational:
        result = {_ONE: Fraction(expr.p, expr.q)} if expr.p else {}
    elif expr.is_Atom:
        if expr.is_Float or expr.is_number and not expr.is_NumberSymbol or not expr.is_commutative:
            raise _Unsupported
        result = {frozenset({(expr, 1)}): Fraction(1)}
    elif expr.is_Add:
        result = {}
        for arg in expr.args:
            for monomial, c in _polynomial(arg).items():
                total = result.get(monomial, 0) + c
                if total:
                    result[monomial] = total
                else:
                    result.pop(monomial, None)
    elif expr.is_Mul:
        result = {_ONE: Fraction(1)}
        for arg in expr.args:
            result = _product(result, _polynomial(arg))
    elif expr.is_Pow:
        result = _power(expr)
    elif isinstance(expr, _FUNCTIONS):
        args = [expand(a) for a in expr.args]
        rebuilt = expr.func(*args) if any(a is not b for a, b in zip(args, expr.args)) else expr
        if rebuilt.func is not expr.func:   # sin(-x) -> -sin(x)
            result = _polynomial(rebuilt)
        else:
            result = {frozenset({(rebuilt, 1)}): Fraction(1)}
    else:
        raise _Unsupported
    _POLYNOMIALS[expr] = result
    return result


def _power(expr: sympy.Pow) -> Polynomial:
    base, exponent = expr.base, expr.exp
    if not exponent.is_Integer:
        if exponent.is_Rational and (base.is_Symbol or base.is_Rational and base.is_positive):   # sqrt(2)
            return {frozenset({(base, exponent)}): Fraction(1)}
        raise _Unsupported
    n = int(exponent)
    if base.is_Add or base.is_Mul:
        if n < 0:
            raise _Unsupported
        polynomial = _polynomial(base)
        if len(polynomial) ** min(n, 8) > TERM_LIMIT:
            raise _Unsupported
        result = {_ONE: Fraction(1)}
        for _ in range(n):
            result = _product(result, polynomial)
        return result
    if base.is_Symbol or base.is_NumberSymbol or isinstance(base, _FUNCTIONS):
        inner = _polynomial(base)
        if len(inner) != 1 or next(iter(inner.values())) != 1:   # sin(-x)**2: expand's own way
            raise _Unsupported
        (monomial,) = inner
        ((atom, one),) = monomial
        return {frozenset({(atom, n)}): Fraction(1)}
    raise _Unsupported


def _product(a: Polynomial, b: Polynomial) -> Polynomial:
    if len(a) * len(b) > TERM_LIMIT:
        raise _Unsupported
    result: Polynomial = {}
    for m1, c1 in a.items():
        for m2, c2 in b.items():
            if not m1:
                monomial = m2
            elif not m2:
                monomial = m1
            else:
                powers = dict(m1)
                for factor, e in m2:
                    total = powers.get(factor, 0) + e
                    if total:
                        powers[factor] = total
                    else:
                        del powers[factor]
                monomial = frozenset(powers.items())
            total = result.get(monomial, 0) + c1 * c2
            if total:
                result[monomial] = total
            else:
                result.pop(monomial, None)
    return result


def _build(polynomial: Polynomial) -> sympy.Expr:
    terms = []
    for monomial, c in polynomial.items():
        factors = [factor if e == 1 else sympy.Pow(factor, e) for factor, e in monomial]
        terms.append(sympy.Mul(sympy.Rational(c.numerator, c.denominator), *factors))
    return sympy.Add(*terms)


__all__ = ["expand"]
