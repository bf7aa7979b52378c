"""Cheap, structure-preserving clean-up of derived expressions, and equality checks.

No blanket ``simplify``: each entry is offered a few inexpensive rewritings (common factors
pulled out, products expanded first) and the one with the fewest operations is kept, so the
RP arm's ``N_g`` reads ``[g m (l + q2) cos q1, g m sin q1]`` as in the reference.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import sympy

from ..model.size import expanded_terms
from . import exact_fast
from .exact_fast import count_ops, factor_terms
from .polynomial import expand

#: Entries larger than this are left as built: expanding them costs more than it saves.
TIDY_LIMIT = 1200  # tree nodes
#: Entries with more operations than this are only expanded, never factored.
FACTOR_LIMIT = 400
#: Largest difference (in operations) that a check tries to prove symbolically.
SYMBOLIC_CHECK_LIMIT = 6000
#: Largest residual (in operations) put into trigonometric canonical form.
CANONICAL_LIMIT = 20000
#: Grouping by trigonometric factors is the costliest candidate; only for small entries.
COLLECT_LIMIT = 150
#: Entries whose expansion may exceed this many terms (``model.size``) are never expanded:
#: a small tree such as ``m*(a + b + c)**12`` would expand for minutes.
EXPAND_LIMIT = 20_000


#: Integers (and numerators, denominators) above this are not exact in a double.
EXACT_INTEGER = 2**53


def fold_constants(expr: Any, rationals: bool = True) -> Any:
    """``expr`` with every constant sub-expression that a double cannot hold exactly
    (irrational constants, ``E``, huge rationals, functions of numbers) folded to a
    correctly rounded ``Float``; small integers and rationals stay exact. Code printers and
    numeric checks use it: NumPy has no ``sqrt`` of a 30-digit integer.

    With ``rationals`` False, fractions of any size stay (for a printer that rounds each
    fraction itself, like the straight-line programs': rebuilding every line of a program
    with full-precision parameters costs a second per thousand lines).

    >>> fold_constants(sympy.sqrt(2) * sympy.Symbol("x") / 2)
    0.707106781186548*x
    """
    memo = _FOLDED[rationals]
    if len(memo) > exact_fast.MEMO_LIMIT:
        memo.clear()
    if isinstance(expr, sympy.MatrixBase):
        return expr.applyfunc(lambda e: _fold(sympy.sympify(e), memo, rationals))
    return _fold(sympy.sympify(expr), memo, rationals)


#: ``fold_constants``' results by sub-expression, with and without folding fractions: every
#: generated function and check folds the same entries of M, C and N again.
_FOLDED: dict[bool, dict[sympy.Basic, sympy.Basic]] = {True: {}, False: {}}


def _fold(expr: sympy.Basic, memo: dict[sympy.Basic, sympy.Basic], rationals: bool = True) -> sympy.Basic:
    if expr.is_Integer:
        return expr if abs(expr.p) <= EXACT_INTEGER else _to_float(expr)
    if expr.is_Rational:
        return expr if not rationals or abs(expr.p) <= EXACT_INTEGER and expr.q <= EXACT_INTEGER else _to_float(expr)
    if expr.is_Float or expr.is_Symbol or not expr.args and expr.free_symbols:
        return expr
    if expr in memo:
        return memo[expr]
    if _constant(expr, memo):
        result = _to_float(expr)
    else:
        args = [_fold(a, memo, rationals) for a in expr.args]
        # equal is enough: a remembered argument may be an equal copy, and rebuilding would
        # distribute a number over a sum (Mul(1/2, x + y) is x/2 + y/2)
        result = expr.func(*args) if any(a is not b and a != b for a, b in zip(args, expr.args)) else expr
    memo[expr] = result
    return result


def _constant(expr: sympy.Basic, memo: dict[sympy.Basic, sympy.Basic]) -> bool:
    """``not expr.free_symbols``, in one walk: ``free_symbols`` walks the whole sub-tree at
    every node ``_fold`` visits, quadratic in a deep entry of C. A sub-tree ``_fold`` has
    remembered is constant exactly when it was folded to a number, so the walk stops there."""
    if not expr.args or isinstance(expr, (sympy.Lambda, sympy.Derivative, sympy.Integral, sympy.Subs)):
        return not expr.free_symbols   # atoms, and bound variables
    if expr in memo:
        return memo[expr].is_Number
    return all(_constant(a, memo) for a in expr.args)


def _to_float(expr: sympy.Expr) -> sympy.Float:
    value = expr.evalf(30)
    if not (value.is_Float or value.is_Integer or value.is_Rational):
        raise ValueError(f"constant {sympy.sstr(expr)[:60]} has no real floating-point value")
    number = float(value)
    if number != number or number in (float("inf"), float("-inf")):
        raise ValueError(f"constant {sympy.sstr(expr)[:60]} is out of the range of a double")
    return sympy.Float(number)


def expandable(expr: sympy.Expr) -> bool:
    """Whether ``sympy.expand(expr)`` stays within ``EXPAND_LIMIT`` terms (estimated)."""
    return expanded_terms(expr, EXPAND_LIMIT + 1) <= EXPAND_LIMIT


def is_small(expr: sympy.Expr, limit: int) -> bool:
    """Whether ``expr`` has at most ``limit`` nodes (those ``sympy.preorder_traversal``
    visits); stops early, so it is cheap on big trees."""
    if not isinstance(expr, sympy.Basic):
        return sum(1 for _ in zip(sympy.preorder_traversal(expr), range(limit + 1))) <= limit
    count, stack = 0, [expr]
    while stack:
        count += 1
        if count > limit:
            return False
        stack.extend(stack.pop().args)
    return True


#: ``tidy``'s results by input: a quantity's entries come back inside the equations built
#: from them, and the sheet, the JSON and the checks ask for the same entries.
_TIDIED: dict[sympy.Basic, sympy.Basic] = {}


def tidy(expr: sympy.Expr) -> sympy.Expr:
    """A compact equal form of ``expr`` (chosen by operation count, ties to the first)."""
    expr = sympy.sympify(expr)
    if expr.is_Atom or not is_small(expr, TIDY_LIMIT):
        return expr
    known = _TIDIED.get(expr)
    if known is None and not expandable(expr):
        return expr
    if known is None:
        if len(_TIDIED) > exact_fast.MEMO_LIMIT:
            _TIDIED.clear()
        known = _TIDIED[expr] = _tidy(expr)
    return known


def _tidy(expr: sympy.Expr) -> sympy.Expr:
    expanded = expand(expr)
    candidates = [expr, expanded]
    size = count_ops(expanded)
    if size <= FACTOR_LIMIT:
        candidates.append(factor_terms(expr))
        for base in _pythagoras(expanded):
            candidates.append(base)
            candidates.append(factor_terms(base))
            if size <= COLLECT_LIMIT and base.is_Add:   # grouped by trigonometric factor: (a + b) sin(q)
                trig = sorted(base.atoms(sympy.sin, sympy.cos), key=sympy.default_sort_key)
                if trig:
                    candidates.append(exact_fast.collect_trig(base, trig))
    ops = [count_ops(c) for c in candidates]
    best = min(range(len(candidates)), key=lambda i: ops[i])
    # Keep the form the derivation built (it carries the kinematics' own groupings, such
    # as l/2 + q2) unless a rewriting is clearly shorter.
    if ops[0] <= ops[best] + ops[best] // 8:
        return expr
    return candidates[best]


def operation_count(value: sympy.Expr | sympy.MatrixBase) -> int:
    """Operations of an expression tree (a matrix's entries summed): n - 1 per n-ary sum or
    product, one per power or function call. ``count_ops`` without its separate counting of
    signs and divisions; each shared subtree is visited once, so it is fast on huge entries."""
    memo: dict[int, int] = {}

    def count(expr: sympy.Basic) -> int:
        key = id(expr)
        if key not in memo:
            args = expr.args
            own = (len(args) - 1 if isinstance(expr, (sympy.Add, sympy.Mul)) else 1) if args else 0
            memo[key] = own + sum(count(a) for a in args)
        return memo[key]

    entries = list(value) if isinstance(value, sympy.MatrixBase) else [value]
    return sum(count(sympy.sympify(e)) for e in entries)


def quick_tidy(expr: sympy.Expr) -> sympy.Expr:
    """A cheaper ``tidy`` for many small pieces (3-D kinematics): expand, drop sin^2 + cos^2.

    Picks the smallest of the built form, the expanded one and its Pythagorean reductions,
    by node count.
    """
    expr = sympy.sympify(expr)
    if expr.is_Atom or not is_small(expr, TIDY_LIMIT) or not expandable(expr):
        return expr
    candidates = _pythagoras(expand(expr))
    best = min(candidates, key=_nodes)
    return best if _nodes(best) < _nodes(expr) else expr


def _nodes(expr: sympy.Expr) -> int:
    return sum(1 for _ in sympy.preorder_traversal(expr))


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
    return [expanded] + [expand(candidate) for candidate in (sin_first, cos_first) if candidate != expanded]


#: Entries larger than this (tree nodes) are not put into Fourier form or regrouped.
FOURIER_LIMIT = 1500


def trig_linear(expr: sympy.Expr) -> sympy.Expr:
    """Products of sines and cosines turned into sines and cosines of angle sums (product to
    sum), then grouped by trigonometric factor with common factors pulled out.

    The Fourier form of an entry: for planar chains with relative angles it is what a person
    would write, ``(l1 l2 m2/2 + ...) cos(q2) + ... cos(q2 + q3)``, and the products such as
    ``sin(q3) cos(q2 + q3) - sin(q2 + q3) cos(q3)`` that Christoffel symbols leave disappear.
    Entries over FOURIER_LIMIT nodes are returned unchanged.
    """
    from sympy.simplify.fu import TR8

    if not is_small(expr, FOURIER_LIMIT) or not expandable(expr):
        return expr
    known = _LINEAR.get(expr)   # a symmetric M's entries come twice
    if known is None:
        if len(_LINEAR) > exact_fast.MEMO_LIMIT:
            _LINEAR.clear()
        # sines and cosines of constants (cos(253/100) from a joint origin) stay coefficients
        constants = {f: sympy.Dummy() for f in expr.atoms(sympy.sin, sympy.cos) if not f.free_symbols}
        linear = trig_group(TR8(expand(expr.xreplace(constants))))
        known = _LINEAR[expr] = linear.xreplace({d: f for f, d in constants.items()})
    return known


#: ``trig_linear``'s results by input.
_LINEAR: dict[sympy.Basic, sympy.Basic] = {}


def trig_group(expr: sympy.Expr) -> sympy.Expr:
    """``expr`` expanded, then grouped by trigonometric factor (of the coordinates), common
    factors pulled out (``sympy.collect`` does the same, several times slower). Entries over
    FOURIER_LIMIT nodes are returned unchanged."""
    if not is_small(expr, FOURIER_LIMIT) or not expandable(expr):
        return expr
    expanded = expand(expr)
    if not expanded.is_Add:
        return expanded
    return group_terms(expanded.args,
                       lambda base: isinstance(base, (sympy.sin, sympy.cos)) and bool(base.free_symbols),
                       factor_terms)


def group_terms(terms: Iterable[sympy.Expr], selects: Callable[[sympy.Expr], bool],
                coefficient: Callable[[sympy.Expr], sympy.Expr] = lambda sum_: sum_) -> sympy.Expr:
    """The sum of ``terms``, grouped by the product of each term's factors whose base
    ``selects`` picks: one ``coefficient(sum of the other factors) * product`` per group."""
    groups: dict[sympy.Expr, list[sympy.Expr]] = {}
    for term in terms:
        chosen, rest = [], []
        for factor in sympy.Mul.make_args(term):
            (chosen if selects(factor.base if factor.is_Pow else factor) else rest).append(factor)
        groups.setdefault(sympy.Mul(*chosen), []).append(sympy.Mul(*rest))
    return sympy.Add(*(coefficient(sympy.Add(*coefficients)) * key for key, coefficients in groups.items()))


def fewest_operations(expr: sympy.Expr, *rewritings) -> sympy.Expr:
    """``expr`` or the first rewriting with strictly fewer operations than it (and all others)."""
    best, fewest = expr, count_ops(expr)
    for rewrite in rewritings:
        candidate = rewrite(expr)
        ops = count_ops(candidate)
        if ops < fewest:
            best, fewest = candidate, ops
    return best


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

    @property
    def skipped(self) -> bool:
        return self.method == "skipped"

    def summary(self) -> str:
        if self.skipped:
            return f"[skip] {self.description}"
        verdict = "pass" if self.passed else "FAIL"
        detail = "exact" if self.method == "symbolic" and self.passed else f"max residual {self.residual:.3g}"
        return f"[{verdict}] {self.description} ({self.method}, {detail})"


def trig_canonical(expr: sympy.Expr) -> sympy.Expr:
    """A canonical form of a polynomial in sines and cosines: zero iff it is identically zero.

    Angle sums are expanded (``sin(a + b)``), then every ``sin(x)**2`` becomes
    ``1 - cos(x)**2``, leaving a polynomial at most linear in each ``sin(x)``.
    """
    expr = expand(_expand_angles(expr))
    for _ in range(4):
        angles = {f.args[0] for f in expr.atoms(sympy.sin)}
        if not angles:
            break
        reduced = expand(expr.replace(
            lambda e: e.is_Pow and isinstance(e.base, sympy.sin) and e.exp.is_Integer and e.exp >= 2,
            lambda e: (1 - sympy.cos(e.base.args[0]) ** 2) ** (e.exp // 2) * e.base ** (e.exp % 2)))
        if reduced == expr:
            break
        expr = reduced
    return expr


def _fourier_zero(expr: sympy.Expr) -> bool:
    """Whether ``expr`` is zero once expanded with products of sines and cosines turned into
    sums (``TR8``), each of an angle combination in SymPy's canonical order. Every step is an
    identity, so True proves ``expr == 0``; False proves nothing (nor is it tried where a
    sine or cosine stands in a denominator)."""
    from sympy.simplify.fu import TR8

    expanded = expand(expr)
    if any(p.exp.is_negative and p.base.has(sympy.sin, sympy.cos) for p in expanded.atoms(sympy.Pow)):
        return False   # a quotient of trigonometric sums (R_g): TR8 grows it for minutes
    return expand(TR8(expanded)) == 0


def _expand_angles(expr: sympy.Expr) -> sympy.Expr:
    """``sympy.expand_trig(expr)`` for sines and cosines: each of an angle sum or an integer
    multiple replaced by its expansion in the single angles (SymPy's rules), the rest of the
    tree untouched (``expand_trig`` rebuilds every node, several times slower)."""
    if any(f.func not in (sympy.sin, sympy.cos) and hasattr(f, "_eval_expand_trig")
           for f in expr.atoms(sympy.Function)):   # tan, sinh, ...: SymPy's
        return sympy.expand_trig(expr)
    memo: dict[sympy.Expr, sympy.Expr] = {}
    replacements = {f: _expanded_trig(f, memo) for f in expr.atoms(sympy.sin, sympy.cos)}
    return expr.xreplace({f: e for f, e in replacements.items() if e != f})


def _expanded_trig(f: sympy.Expr, memo: dict[sympy.Expr, sympy.Expr]) -> sympy.Expr:
    """``f._eval_expand_trig()`` of a sine or cosine, remembered: ``sin(x + y)`` by the
    addition theorems (x the first term), ``sin(n x)`` by Chebyshev polynomials."""
    known = memo.get(f)
    if known is not None:
        return known
    arg = f.args[0]
    if arg.is_Add:
        x, y = arg.as_two_terms()
        sx, sy = _expanded_trig(sympy.sin(x, evaluate=False), memo), _expanded_trig(sympy.sin(y, evaluate=False), memo)
        cx, cy = _expanded_trig(sympy.cos(x, evaluate=False), memo), _expanded_trig(sympy.cos(y, evaluate=False), memo)
        result = sx * cy + cx * sy if f.func is sympy.sin else cx * cy - sx * sy
    else:
        result = f._eval_expand_trig()
    memo[f] = result
    return result


def check_zero(name: str, description: str, difference: sympy.Matrix,
               symbols: Iterable[sympy.Symbol], seed: int = 0, samples: int = 4,
               tolerance: float = 1e-9) -> Check:
    """Prove ``difference == 0`` symbolically when cheap, else test it at random points."""
    difference = sympy.Matrix(difference)
    remaining = list(difference)
    if all(is_small(e, SYMBOLIC_CHECK_LIMIT // len(remaining) + 1) and expandable(e) for e in remaining):
        remaining = [e for e in remaining if expand(e) != 0]
        # products to sums first (cheap, and enough when both sides are trigonometric
        # polynomials), the canonical form for what that leaves
        if sum(count_ops(e) for e in remaining) < CANONICAL_LIMIT and all(
                _fourier_zero(e) or trig_canonical(sympy.together(e).as_numer_denom()[0]) == 0
                for e in remaining):
            remaining = []
    remaining = [e for e in remaining if e != 0]
    if not remaining:
        return Check(name, description, True, "symbolic", 0.0)
    return Check(name, description, *_numeric_residual(remaining, seed, samples, tolerance))


def _numeric_residual(exprs: list[sympy.Expr], seed: int, samples: int,
                      tolerance: float) -> tuple[bool, str, float]:
    """Largest |expr| at random points, evaluated with 30 significant digits."""
    import mpmath

    from .evaluate import Unsupported, evaluator

    free = sorted(set().union(*(e.free_symbols for e in exprs)), key=lambda s: s.name)
    try:   # a walk over the tree per point: lambdify's code generation costs far more here
        function = evaluator(exprs, free)
    except Unsupported:
        function = sympy.lambdify(free, exprs, modules="mpmath", cse=True)
    rng = random.Random(seed)
    worst = 0.0
    with mpmath.workdps(30):
        for _ in range(samples):
            values = function(*[mpmath.mpf(rng.uniform(0.3, 1.7)) for _ in free])
            worst = max([worst] + [float(abs(v)) for v in values])
    return worst <= tolerance, "numeric", worst
