"""The faster equivalents of SymPy functions that ``tidy`` and the renderers use give exactly
SymPy's results (the same tree, compared by ``srepr``, or the same text) on random
expressions of the kinds a derivation builds: sums and products of symbols, sines and cosines
of coordinate sums and of constants, full-precision (17-digit) fractions, floats, powers."""

from __future__ import annotations

import random
from collections import defaultdict

import pytest
import sympy
from sympy.core import exprtools
from sympy.core.expr import Expr

from dynderive.mechanics import exact_fast
from dynderive.mechanics.tidy import tidy
from dynderive.render.printers import RememberingLatexPrinter, RememberingStrPrinter

Q = sympy.symbols("q1 q2 q3", real=True)
QD = sympy.symbols("qd1 qd2", real=True)
P = sympy.symbols("m1 m2 l1 l2 g")


def _number(rng: random.Random) -> sympy.Expr:
    kind = rng.random()
    if kind < 0.4:   # a CAD number: 17 significant digits, exact
        return sympy.Rational(f"{rng.uniform(-3, 3):.17g}")
    if kind < 0.7:
        return sympy.Rational(rng.randint(-9, 9), rng.randint(1, 12))
    if kind < 0.85:
        return sympy.Float(rng.uniform(-3, 3))
    return sympy.Integer(rng.randint(-5, 5))


def _angle(rng: random.Random) -> sympy.Expr:
    if rng.random() < 0.2:
        return _number(rng)
    chosen = rng.sample(Q, rng.randint(1, 3))
    return sympy.Add(*chosen, *([_number(rng)] if rng.random() < 0.3 else []))


def _atom(rng: random.Random) -> sympy.Expr:
    kind = rng.random()
    if kind < 0.35:
        return rng.choice(P + QD)
    if kind < 0.7:
        return rng.choice([sympy.sin, sympy.cos])(_angle(rng))
    if kind < 0.8:
        return sympy.sqrt(rng.choice(P))
    return _number(rng)


def random_expr(rng: random.Random, depth: int = 3) -> sympy.Expr:
    if depth == 0 or rng.random() < 0.25:
        return _atom(rng)
    kind = rng.random()
    parts = [random_expr(rng, depth - 1) for _ in range(rng.randint(2, 4))]
    if kind < 0.45:
        return sympy.Add(*parts)
    if kind < 0.85:
        return sympy.Mul(*parts)
    base = random_expr(rng, depth - 1)
    return base ** rng.choice([2, 3, -1, -2, sympy.Rational(1, 2)])


def random_exprs(seed: int, count: int, depth: int = 3) -> list[sympy.Expr]:
    rng = random.Random(seed)
    return [random_expr(rng, depth) for _ in range(count)]


@pytest.mark.parametrize("seed", range(4))
def test_count_ops_is_sympys(seed):
    exprs = random_exprs(seed, 60)
    exprs += [sympy.expand(e) for e in exprs[:30]] + [-e for e in exprs[:30]]
    for e in exprs:
        assert exact_fast.count_ops(e) == sympy.count_ops(e), e


@pytest.mark.parametrize("seed", range(4))
def test_factor_terms_is_sympys(seed):
    exprs = random_exprs(100 + seed, 50)
    exprs += [sympy.expand(e) for e in exprs]
    exact_fast._FACTOR_TERMS.clear()
    for _ in range(2):   # the second round from the memo
        for e in exprs:
            assert sympy.srepr(exact_fast.factor_terms(e)) == sympy.srepr(sympy.factor_terms(e)), e


@pytest.mark.parametrize("seed", range(4))
def test_collect_trig_is_sympys(seed):
    exprs = [sympy.expand(e) for e in random_exprs(200 + seed, 50)]
    checked = 0
    for e in exprs:
        trig = sorted(e.atoms(sympy.sin, sympy.cos), key=sympy.default_sort_key)
        if not e.is_Add or not trig or len(e.args) > 40:   # as tidy: small sums only
            continue
        expected = sympy.collect(e, trig, func=sympy.factor_terms)
        assert sympy.srepr(exact_fast.collect_trig(e, trig)) == sympy.srepr(expected), e
        checked += 1
    assert checked >= 10


@pytest.mark.parametrize("seed", range(3))
def test_remembered_expand_is_sympys(seed, monkeypatch):
    exprs = random_exprs(300 + seed, 40)
    exprs += [a * b for a, b in zip(random_exprs(400 + seed, 20, 2), random_exprs(450 + seed, 20, 2))]
    remembered = [sympy.srepr(sympy.expand(e)) for e in exprs]
    monkeypatch.setattr(Expr, "_expand_hint", staticmethod(exact_fast._expand_hint))   # SymPy's own
    sympy.core.cache.clear_cache()
    assert [sympy.srepr(sympy.expand(e)) for e in exprs] == remembered


def test_factors_from_dictionaries_as_sympy_builds_them():
    original = exact_fast._factors_init.__defaults__[1]
    x, y = sympy.symbols("x y")
    inputs = [{}, {x: 2, y: -1}, {sympy.S.NegativeOne: 1, x: 3}, {sympy.S.One: 2, x: 1},
              {sympy.I: 3, x: sympy.Rational(1, 2)}, {sympy.Integer(-1): sympy.Rational(3, 2), y: 1}]
    for d in inputs:
        for build in (dict, lambda items: defaultdict(int, items)):
            ours = exprtools.Factors(build(d))
            theirs = exprtools.Factors.__new__(exprtools.Factors)
            original(theirs, build(d))
            assert ours.factors == theirs.factors
            assert type(ours.factors) is type(theirs.factors)


@pytest.mark.parametrize("seed", range(3))
def test_remembering_printers_print_as_sympy(seed):
    exprs = random_exprs(500 + seed, 60)
    exprs += [sympy.sin(Q[0]) ** 2 * P[0], sympy.Float(2.5) * (P[1] + sympy.Float(0.125)), sympy.Float(1.5)]
    names = {Q[0]: r"\theta_{1}", QD[0]: r"\dot{q}_{1}"}
    settings = {"symbol_names": names, "mat_delim": "[", "mat_str": "matrix", "mul_symbol": None,
                "long_frac_ratio": 2, "order": None}
    latex = RememberingLatexPrinter(settings)
    text = RememberingStrPrinter({"order": "lex"})
    for _ in range(2):   # the second round from the memos
        for e in exprs:
            assert latex.doprint(e) == sympy.latex(e, **settings)
            assert text.doprint(e) == sympy.sstr(e, order="lex")


def test_tidy_is_remembered_and_equal():
    for e in random_exprs(600, 30):
        first = tidy(e)
        assert tidy(e) is first
        assert sympy.expand(first - e) == 0 or abs(complex(
            (first - e).subs({s: 0.37 + 0.11 * i for i, s in enumerate(sorted(e.free_symbols, key=str))}).evalf())) < 1e-9


def test_is_small_counts_the_nodes_preorder_traversal_visits():
    from dynderive.mechanics.tidy import is_small

    exprs = random_exprs(700, 80) + [sympy.Tuple(*random_exprs(701, 10))]
    for e in exprs:
        nodes = sum(1 for _ in sympy.preorder_traversal(e))
        assert is_small(e, nodes) and not is_small(e, nodes - 1)
