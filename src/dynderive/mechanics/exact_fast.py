"""Faster drop-in equivalents of the SymPy functions that ``tidy`` calls for every candidate:
``count_ops`` and ``collect``, giving exactly SymPy's results (tests compare them on the
bundled robots' expressions and random ones), and a memo of ``factor_terms``.

SymPy's ``count_ops`` walks the whole tree of each candidate although the candidates of an
entry share most of their subtrees; ``collect`` by sines and cosines substitutes, pattern-
matches and rebuilds every term. Both costs grow with the size of the numbers in a tree
(every ``-a`` and every rebuilt product multiplies full-precision fractions again), which is
what made small robots written with CAD numbers slow.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import sympy
from sympy.core import exprtools
from sympy.core.assumptions import assumptions
from sympy.core.expr import Expr
from sympy.core.mul import _keep_coeff
from sympy.core.operations import LatticeOp
from sympy.ntheory.multinomial import multinomial_coefficients_iterator
from sympy.simplify.radsimp import fraction
from sympy.utilities.iterables import iterable

#: Memo entries kept before a memo is emptied (bounds memory on large robots).
MEMO_LIMIT = 200_000

_OPS: dict[sympy.Basic, int] = {}
_FACTOR_TERMS: dict[sympy.Basic, sympy.Basic] = {}


def count_ops(expr: sympy.Expr) -> int:
    """``sympy.count_ops(expr)`` (visual=False) of an expression, each distinct subtree
    counted once per process and remembered."""
    expr = sympy.sympify(expr)
    if not isinstance(expr, sympy.Expr) or expr.is_Relational:
        return sympy.count_ops(expr)
    if len(_OPS) > MEMO_LIMIT:
        _OPS.clear()
    return _ops(expr)


def _ops(a: sympy.Basic) -> int:
    """What ``count_ops`` adds for ``a`` when it pops it off its stack, descendants included."""
    known = _OPS.get(a)
    if known is None:
        known = _OPS[a] = _count(a)
    return known


def _count(node: sympy.Basic) -> int:
    """``_ops`` of ``node``, not remembered yet."""
    if node.is_Rational and node is not sympy.S.One:
        return (node.p < 0) + (node.q != 1)
    if node.is_Mul:
        total = 0
        if _negative_coefficient(node):
            total = 1
            node = node.as_two_terms()[1] if node.args[0] is sympy.S.NegativeOne else _negated(node)
        if _numerator_only(node):   # what fraction(node) gives as (node, 1), without rebuilding it
            return total + _tail(node)
        n, d = fraction(node)
        if n.is_Integer:
            return total + 1 + bool(n < 0) + _ops(d)
        if d is not sympy.S.One:
            return total + 1 + _ops(n) + (0 if d.is_Integer else _ops(d))
        return total + _tail(node)
    if node.is_Add:
        total = negative = 0
        for i, term in enumerate(node.args):
            if _negative_coefficient(term):
                negative += 1
                total += _ops(_negated(term))
            else:
                total += _ops(term)
            total += i > 0
        return total + (negative == len(node.args))
    return _tail(node)


def _negative_coefficient(a: sympy.Basic) -> bool:
    """``sympy.core.function._coeff_isneg(a)`` without asking a new number's assumptions
    (each 17-digit coefficient is a new number, whose first question deduces all its facts)."""
    if a.is_Mul:
        a = a.args[0]
    if a.is_Rational:
        return a.p < 0
    return a.is_Number and bool(a.is_extended_negative)


_NEGATED: dict[sympy.Basic, sympy.Basic] = {}


def _negated(a: sympy.Basic) -> sympy.Basic:
    """``-a``, remembered (``count_ops`` negates every negative term of every sum it meets)."""
    known = _NEGATED.get(a)
    if known is None:
        if len(_NEGATED) > MEMO_LIMIT:
            _NEGATED.clear()
        known = _NEGATED[a] = -a
    return known


def _numerator_only(mul: sympy.Mul) -> bool:
    """Whether ``fraction(mul)`` is ``(mul, 1)``: no factor with a negative or unknown
    exponent and no fraction among its numbers."""
    for factor in mul.args:
        if factor.is_Pow:
            if not (factor.exp.is_Rational and factor.exp.p > 0) or not factor.is_commutative:
                return False
        elif factor.is_Rational:
            if factor.q != 1:
                return False
        elif isinstance(factor, sympy.exp) or not factor.is_commutative:
            return False
    return True


def _tail(a: sympy.Basic) -> int:
    """``count_ops``' cases after the rational, product and sum branches (``a`` may be the
    negated product)."""
    if a.is_Pow and a.exp is sympy.S.NegativeOne:
        return 1 + _ops(a.base)
    if a == sympy.S.Exp1:
        return 1
    if a.is_Pow and a.base == sympy.S.Exp1:
        return 1 + _ops(a.exp)
    total = 0
    if a.is_Mul or isinstance(a, LatticeOp):
        total += len(a.args) - 1
    elif a.args and (a.is_Pow or a.is_Function or isinstance(a, (sympy.Derivative, sympy.Integral, sympy.Sum))):
        total += 1
    if not a.is_Symbol:
        total += sum(_ops(arg) for arg in a.args)
    return total


def factor_terms(expr: sympy.Expr) -> sympy.Expr:
    """``sympy.factor_terms(expr)`` (its defaults: ``radical=False, clear=False,
    fraction=False, sign=True``): SymPy's own steps, each sub-expression's result remembered.
    The candidates of an entry, and the entries of a matrix and of the equations built from
    it, share most of their terms, and SymPy factors each term (and each sum inside a sine)
    again every time."""
    if len(_FACTOR_TERMS) > MEMO_LIMIT:
        _FACTOR_TERMS.clear()
    return _do(sympy.sympify(expr))


def _do(expr):
    """``do`` of ``sympy.factor_terms`` (SymPy 1.12-1.14), remembered for SymPy objects."""
    if not isinstance(expr, sympy.Basic) or expr.is_Atom:
        if iterable(expr):
            return type(expr)([_do(i) for i in expr])
        return expr
    known = _FACTOR_TERMS.get(expr)
    if known is not None:
        return known
    if expr.is_Pow or expr.is_Function or iterable(expr) or not hasattr(expr, "args_cnc"):
        args = expr.args
        newargs = tuple([_do(i) for i in args])
        result = expr if newargs == args else expr.func(*newargs)
    elif isinstance(expr, (sympy.Sum, sympy.Integral)):
        result = exprtools._factor_sum_int(expr, radical=False, clear=False, fraction=False, sign=True)
    else:
        cont, p = expr.as_content_primitive(radical=False, clear=False)
        if p.is_Add:
            list_args = [_do(a) for a in sympy.Add.make_args(p)]
            # get a common negative (if there) which gcd_terms does not remove
            if not any(a.as_coeff_Mul()[0].extract_multiplicatively(-1) is None for a in list_args):
                cont = -cont
                list_args = [-a for a in list_args]
            # watch out for exp(-(x+2)) which gcd_terms will change to exp(-x-2)
            special = {}
            for i, a in enumerate(list_args):
                b, e = a.as_base_exp()
                if e.is_Mul and e != sympy.Mul(*e.args):
                    list_args[i] = sympy.Dummy()
                    special[list_args[i]] = a
            # rebuild p not worrying about the order which gcd_terms will fix
            p = sympy.Add._from_args(list_args)
            p = exprtools.gcd_terms(p, isprimitive=True, clear=False, fraction=False).xreplace(special)
        elif p.args:
            p = p.func(*[_do(a) for a in p.args])
        result = _keep_coeff(cont, p, clear=False, sign=True)
    _FACTOR_TERMS[expr] = result
    return result


def collect_trig(expr: sympy.Expr, trig: list[sympy.Expr]) -> sympy.Expr:
    """``sympy.collect(expr, trig, func=sympy.factor_terms)`` of an expanded sum, for
    ``trig`` a list of distinct sines and cosines: each term goes to the power of the first
    of ``trig`` it contains (the rest of the term to its coefficient), or stays alone; each
    coefficient sum is passed through ``factor_terms``. Terms of another shape (a sum or a
    function of something other than a number or symbol inside) are left to SymPy."""
    reps = {f: sympy.Dummy(**assumptions(f)) for f in trig}
    dummies = [reps[f] for f in trig]
    rank = {d: i for i, d in enumerate(dummies)}
    replaced = expr.xreplace(reps)
    collected: dict[sympy.Expr, list[sympy.Expr]] = defaultdict(list)
    disliked: list[sympy.Expr] = []
    for term in sympy.Add.make_args(replaced):
        factors = sympy.Mul.make_args(term)
        first, where = None, -1
        for i, factor in enumerate(factors):
            base, exponent = (factor.base, factor.exp) if factor.is_Pow else (factor, sympy.S.One)
            if not (base.is_Symbol or base.is_Number) or not exponent.is_Number or not factor.is_commutative:
                return sympy.collect(expr, trig, func=sympy.factor_terms)
            if base in rank and (first is None or rank[base] < rank[first]):
                first, where = base, i
        if first is None:
            disliked.append(term)
            continue
        rest = sympy.Mul(*(f for i, f in enumerate(factors) if i != where))
        collected[factors[where]].append(rest)
    groups = {key: sympy.Add(*values) for key, values in collected.items()}
    if disliked:
        groups[sympy.S.One] = sympy.Add(*disliked)
    back = {d: f for f, d in reps.items()}
    return sympy.Add(*[key * factor_terms(value) for key, value in groups.items()]).xreplace(back)


class _FactorDict(dict):
    """A plain ``dict`` of factors that SymPy's ``_sympify`` refuses at once: its
    ``__sympy__`` is neither None nor True, so a comparison with a SymPy number is False
    without converting the dictionary (``dict.copy`` gives a plain ``dict`` back)."""

    __slots__ = ()
    __sympy__ = False


class _FactorDefaultDict(defaultdict):
    """The same for a ``defaultdict`` (its copy keeps this type: turned back afterwards)."""

    __sympy__ = False


_FACTORS_INIT = getattr(exprtools, "Factors", object).__init__


def _factors_init(self, factors=None, _init=_FACTORS_INIT):
    # ``Factors.__init__`` first asks ``factors in (None, S.One)``; for a dict that makes
    # ``S.One == factors`` sympify the whole dictionary into a SymPy ``Dict`` (always unequal,
    # so wasted): a third of ``factor_terms``' time. The same constructor, without that.
    kind = type(factors)
    if kind is dict:
        _init(self, _FactorDict(factors))
    elif kind is defaultdict:
        _init(self, _FactorDefaultDict(factors.default_factory, factors))
        if type(self.factors) is _FactorDefaultDict:
            self.factors = defaultdict(self.factors.default_factory, self.factors)
    else:
        _init(self, factors)


# Only where SymPy still has the pieces this relies on (a later release may not): a speed-up
# only, the results are SymPy's own either way.
if hasattr(exprtools, "Factors") and not getattr(exprtools.Factors.__init__, "dynderive", False):
    _factors_init.dynderive = True  # type: ignore[attr-defined]
    exprtools.Factors.__init__ = _factors_init  # type: ignore[method-assign]


_DIFF: dict[tuple[sympy.Basic, sympy.Symbol], sympy.Basic] = {}


def diff(expr: sympy.Expr, symbol: sympy.Symbol) -> sympy.Expr:
    """``sympy.diff(expr, symbol)``, the same tree, for a symbol. SymPy builds a
    ``Derivative`` for every node it differentiates (the chain and product rules call
    ``diff`` on each argument) and walks each result for unevaluated derivatives, which
    makes differentiating a tree cost far more than the tree's size; here the same rules are
    applied directly: sums term by term, products by SymPy's Leibniz rule (its order of
    terms), powers and sines and cosines by their own formulas; anything else by SymPy.
    Each (node, symbol) is differentiated once per process."""
    if len(_DIFF) > MEMO_LIMIT:
        _DIFF.clear()
    return _diff(sympy.sympify(expr), symbol)


def _diff(expr: sympy.Basic, s: sympy.Symbol) -> sympy.Basic:
    if s not in expr.free_symbols:
        return sympy.S.Zero
    if expr.is_Symbol:
        return sympy.S.One   # expr is s
    key = (expr, s)
    known = _DIFF.get(key)
    if known is not None:
        return known
    if expr.is_Add:
        result = expr.func(*[_diff(a, s) for a in expr.args])
    elif expr.is_Mul and expr.is_commutative:
        # Mul._eval_derivative_n_times(s, 1): the general Leibniz rule's terms in its order
        args = expr.args
        result = sympy.Add(*[c * sympy.Mul(*[_diff(a, s) if k else a for k, a in zip(orders, args)])
                             for orders, c in multinomial_coefficients_iterator(len(args), 1)])
    elif expr.is_Pow:
        # Pow._eval_derivative
        dbase, dexp = _diff(expr.base, s), _diff(expr.exp, s)
        result = expr * (dexp * sympy.log(expr.base) + dbase * expr.exp / expr.base)
    elif isinstance(expr, (sympy.sin, sympy.cos)):
        # Function._eval_derivative
        da = _diff(expr.args[0], s)
        result = sympy.Add(*([] if da.is_zero else [expr.fdiff(1) * da]))
    else:
        result = sympy.diff(expr, s)
    _DIFF[key] = result
    return result


def matmul(*factors: sympy.MatrixBase) -> sympy.Matrix:
    """The product of SymPy matrices, entry for entry what ``A * B`` gives (each entry the
    ``Add`` of the products of non-zero pairs). SymPy's sparse product also asks whether
    ``0 * a_ik == 0`` for every non-zero entry, a walk of the assumptions over the whole
    entry: the change of basis ``H^T M H`` spent most of its time there."""
    result = factors[0]
    for factor in factors[1:]:
        if result.cols != factor.rows:
            raise sympy.ShapeError(f"matrix size mismatch: {result.shape} * {factor.shape}")
        columns = [[(k, x) for k, x in enumerate(column) if x != 0] for column in factor.T.tolist()]
        entries = [sympy.Add(*[row[k] * x for k, x in column if row[k] != 0])
                   for row in result.tolist() for column in columns]
        result = sympy.Matrix(result.rows, factor.cols, entries)
    return result


def jacobian(vector: sympy.MatrixBase, variables: list[sympy.Symbol]) -> sympy.Matrix:
    """``vector.jacobian(variables)``, the same entries, by ``diff`` (a column or row vector)."""
    entries = list(vector)
    return sympy.Matrix(len(entries), len(variables), [diff(e, v) for e in entries for v in variables])


_EXPAND: dict[tuple[Any, ...], tuple[Any, bool]] = {}
_expand_hint = getattr(Expr, "_expand_hint", None)


def _remembered_expand_hint(expr, hint, deep=True, **hints):
    # ``Expr._expand_hint`` (one pass of ``expand`` over a tree) is a pure function of its
    # arguments, and ``tidy`` expands sums whose terms it expanded before (the entries of M
    # inside the equations of motion, an expanded entry with sin^2 replaced): remembered.
    try:
        key = (type(expr), expr, hint, deep, tuple(hints.items()))
        known = _EXPAND.get(key)
    except TypeError:   # an unhashable argument
        return _expand_hint(expr, hint, deep=deep, **hints)
    if known is None:
        if len(_EXPAND) > MEMO_LIMIT:
            _EXPAND.clear()
        known = _EXPAND[key] = _expand_hint(expr, hint, deep=deep, **hints)
    return known


if _expand_hint is not None and not getattr(_expand_hint, "dynderive", False):
    _remembered_expand_hint.dynderive = True  # type: ignore[attr-defined]
    Expr._expand_hint = staticmethod(_remembered_expand_hint)  # type: ignore[method-assign]


__all__ = ["collect_trig", "count_ops", "diff", "factor_terms", "jacobian", "matmul"]
