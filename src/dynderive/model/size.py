"""How large an expression becomes once expanded, estimated without expanding it.

A 30-character expression can expand to millions of terms (``(a+b+c+d+e+f+h+i+j+k)**12``
has 293 930): the loader refuses such input before any work, and the engine's tidying skips
an expansion that would explode. The estimate is an upper bound on the number of terms of
``sympy.expand(expr)`` (like terms may still combine): a sum adds its parts' counts, a
product multiplies them, an integer power ``p**k`` of a sum of ``t`` terms has at most
``C(t + k - 1, k)`` (a negative power, a denominator, is one term with that many inside). A function's argument or a fractional power's base is expanded in place,
so it counts as a term of its own, and its own size is the ``inner`` count.

>>> import sympy
>>> a, b = sympy.symbols("a b")
>>> expanded_terms((a + b)**3 * (a - 1))
8
"""

from __future__ import annotations

import sympy


def expanded_terms(expr: sympy.Basic, cap: int = 10**12,
                   memo: dict[sympy.Basic, tuple[int, int]] | None = None) -> int:
    """Upper bound on the terms of ``expand(expr)`` (outer sum or largest inner argument),
    counted up to ``cap`` (larger counts are returned as ``cap``). ``memo`` may be shared by
    calls with the same ``cap`` on growing expressions (a parser's)."""
    outer, inner = _terms(expr, {} if memo is None else memo, cap)
    return min(max(outer, inner), cap)


def _terms(expr: sympy.Basic, memo: dict[sympy.Basic, tuple[int, int]], cap: int) -> tuple[int, int]:
    """``(terms of the expansion, largest expansion of a function argument inside)``."""
    known = memo.get(expr)
    if known is not None:
        return known
    args = expr.args
    if not args or expr.is_Number:
        result = (1, 0)
    elif isinstance(expr, sympy.Add):
        parts = [_terms(a, memo, cap) for a in args]
        result = (min(sum(p[0] for p in parts), cap), max(p[1] for p in parts))
    elif isinstance(expr, sympy.Mul):
        parts = [_terms(a, memo, cap) for a in args]
        product = 1
        for outer, _ in parts:
            product = min(product * outer, cap)
        result = (product, max(p[1] for p in parts))
    elif isinstance(expr, sympy.Pow) and expr.exp.is_Integer:
        base, inner = _terms(expr.base, memo, cap)
        k = abs(int(expr.exp)) if abs(expr.exp) < cap else cap
        expanded = base if base == 1 else _multisets(base, k, cap)
        # a denominator is expanded in place: one term outside, its expansion inside
        result = (expanded, inner) if expr.exp > 0 else (1, max(inner, expanded))
    else:   # a function, or a power with a fractional or symbolic exponent
        parts = [_terms(a, memo, cap) for a in args]
        result = (1, max(max(p) for p in parts))
    memo[expr] = result
    return result


def _multisets(t: int, k: int, cap: int) -> int:
    """``C(t + k - 1, k)`` (monomials of degree k in t terms), or ``cap`` when larger."""
    n, m = t + k - 1, min(k, t - 1)
    count = 1
    for j in range(1, m + 1):   # C(n - m + j, j): integers, growing, so stop at the cap
        count = count * (n - m + j) // j
        if count >= cap:
            return cap
    return count
