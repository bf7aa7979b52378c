"""Cheap, structure-preserving clean-up of derived expressions, and equality checks.

No blanket ``simplify``: each entry is offered a few inexpensive rewritings (common factors
pulled out, products expanded first) and the one with the fewest operations is kept, so the
RP arm's ``N_g`` reads ``[g m (l + q2) cos q1, g m sin q1]`` as in the reference.
"""

from __future__ import annotations

import random
from collections.abc import Iterable
from dataclasses import dataclass

import sympy

#: Entries with more operations than this are only expanded, never factored.
FACTOR_LIMIT = 400


def tidy(expr: sympy.Expr) -> sympy.Expr:
    """A compact equal form of ``expr`` (chosen by operation count, ties to the first)."""
    expr = sympy.sympify(expr)
    if expr.is_Atom:
        return expr
    candidates = [expr]
    expanded = sympy.expand(expr)
    candidates.append(expanded)
    if sympy.count_ops(expanded) <= FACTOR_LIMIT:
        candidates.append(sympy.factor_terms(expr))
        for base in _pythagoras(expanded):
            candidates.append(base)
            candidates.append(sympy.factor_terms(base))
            collected = _collect_common(base)
            if collected is not None:
                candidates.append(collected)
    best = min(candidates, key=lambda e: (sympy.count_ops(e), len(sympy.srepr(e))))
    # Keep the form the derivation built (it carries the kinematics' own groupings, such
    # as l/2 + q2) unless a rewriting is clearly shorter.
    if sympy.count_ops(expr) <= sympy.count_ops(best) + sympy.count_ops(best) // 8:
        return expr
    return best


def _pythagoras(expanded: sympy.Expr) -> list[sympy.Expr]:
    """``expanded`` and its rewritings with ``sin(a)**2 -> 1 - cos(a)**2`` (and back).

    Sums of squares of rotated components leave ``sin(a)**2 + cos(a)**2`` behind; replacing
    one square and expanding again removes them exactly, at polynomial cost.
    """
    pairs = [(f.args[0]) for f in expanded.atoms(sympy.sin) if expanded.has(sympy.cos(f.args[0]))]
    if not pairs:
        return [expanded]
    args = sorted(set(pairs), key=sympy.default_sort_key)
    sin_first = expanded.xreplace({sympy.sin(a) ** 2: 1 - sympy.cos(a) ** 2 for a in args})
    cos_first = expanded.xreplace({sympy.cos(a) ** 2: 1 - sympy.sin(a) ** 2 for a in args})
    out = [expanded]
    for candidate in (sin_first, cos_first):
        if candidate != expanded:
            out.append(sympy.expand(candidate))
    return out


def _collect_common(expr: sympy.Expr) -> sympy.Expr | None:
    """Group an expanded sum by its trigonometric factors, e.g. ``(a + b) sin(q)``."""
    if not expr.is_Add:
        return None
    trig = sorted({f for f in expr.atoms(sympy.sin, sympy.cos)}, key=sympy.default_sort_key)
    if not trig:
        return None
    return sympy.collect(expr, trig, func=sympy.factor_terms)


def tidy_matrix(matrix: sympy.Matrix) -> sympy.Matrix:
    return matrix.applyfunc(tidy)


@dataclass(frozen=True)
class Check:
    """Result of one consistency check of a derivation."""

    name: str
    description: str
    passed: bool
    method: str      # "symbolic" or "numeric"
    residual: float  # largest absolute difference seen (0.0 when proven symbolically)

    def summary(self) -> str:
        verdict = "pass" if self.passed else "FAIL"
        detail = "exact" if self.method == "symbolic" and self.passed else f"max residual {self.residual:.3g}"
        return f"[{verdict}] {self.description} ({self.method}, {detail})"


def check_zero(name: str, description: str, difference: sympy.Matrix,
               symbols: Iterable[sympy.Symbol], seed: int = 0, samples: int = 8,
               tolerance: float = 1e-9) -> Check:
    """Prove ``difference == 0`` symbolically if cheap, else test it at random points."""
    difference = sympy.Matrix(difference)
    if all(sympy.expand(e) == 0 for e in difference):
        return Check(name, description, True, "symbolic", 0.0)
    small = sum(sympy.count_ops(e) for e in difference) < 300
    if small and all(sympy.simplify(e) == 0 for e in difference):
        return Check(name, description, True, "symbolic", 0.0)
    free = sorted(difference.free_symbols | set(symbols), key=lambda s: s.name)
    rng = random.Random(seed)
    worst = 0.0
    for _ in range(samples):
        point = {s: sympy.Float(rng.uniform(0.3, 1.7), 30) for s in free}
        values = difference.xreplace(point).evalf(30)
        worst = max([worst] + [abs(complex(v)) for v in values])
    return Check(name, description, worst <= tolerance, "numeric", worst)
