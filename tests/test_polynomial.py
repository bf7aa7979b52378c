"""The fast ``expand`` (``mechanics/polynomial.py``) and ``matmul`` give SymPy's own trees."""

from __future__ import annotations

import random

import pytest
import sympy

from dynderive.mechanics import exact_fast, polynomial
from test_exact_fast import QD, P, Q, random_exprs


def _fresh():
    polynomial._RESULTS.clear()
    polynomial._POLYNOMIALS.clear()


@pytest.mark.parametrize("seed", range(4))
def test_expand_is_sympys_on_random_expressions(seed):
    """Random trees with 17-digit fractions, floats, square roots, negative and fractional
    powers of sums (those go to sympy.expand): the same tree, compared by srepr."""
    exprs = random_exprs(700 + seed, 60)
    exprs += [a * b for a, b in zip(random_exprs(800 + seed, 30, 2), random_exprs(850 + seed, 30, 2))]
    _fresh()
    for _ in range(2):   # the second round from the memo
        for e in exprs:
            assert sympy.srepr(polynomial.expand(e)) == sympy.srepr(sympy.expand(e)), e


def test_expand_takes_the_fast_path_on_polynomials_in_sines():
    """The derivation's entries (no floats, no sums in denominators) never fall back."""
    rng = random.Random(5)
    c = [sympy.Rational(f"{rng.uniform(-2, 2):.17g}") for _ in range(6)]
    q1, q2, q3 = Q
    expr = ((c[0] * sympy.cos(q1) + c[1] * sympy.sin(q1 + q2) * P[0]) ** 2
            * (QD[0] + c[2] * sympy.cos(-q3) * QD[1]) + sympy.sqrt(2) * c[3] * sympy.sin(2 * (q1 + q3))
            - c[4] * sympy.cos(q2) ** 2 / P[2] * (P[3] + c[5]))
    _fresh()
    calls = []
    original = sympy.expand
    try:
        polynomial.sympy.expand = lambda e, **k: calls.append(e) or original(e, **k)
        result = polynomial.expand(expr)
    finally:
        polynomial.sympy.expand = original
    assert calls == []
    assert result == sympy.expand(expr)
    assert result.is_Add and len(result.args) == 9


def test_expand_falls_back_where_sympy_has_its_own_rules():
    x, y = sympy.symbols("x y")
    for expr in (x / (x + y) ** 2 * (x + 1), sympy.exp(x + y) * (x + 1), sympy.Float(0.1) * (x + y) ** 2,
                 sympy.sqrt(x + y) * (x + y), (x + y) ** x):
        _fresh()
        assert sympy.srepr(polynomial.expand(expr)) == sympy.srepr(sympy.expand(expr)), expr


@pytest.mark.parametrize("seed", range(3))
def test_matmul_is_sympys_product(seed):
    rng = random.Random(seed)
    exprs = random_exprs(900 + seed, 40, 2)

    def matrix(rows, cols):
        return sympy.Matrix(rows, cols, [0 if rng.random() < 0.4 else rng.choice(exprs) for _ in range(rows * cols)])

    a, b, c = matrix(3, 4), matrix(4, 2), matrix(2, 5)
    assert exact_fast.matmul(a, b) == a * b
    assert exact_fast.matmul(a, b, c) == a * b * c
    assert [sympy.srepr(e) for e in exact_fast.matmul(a.T, a)] == [sympy.srepr(e) for e in a.T * a]
    with pytest.raises(sympy.ShapeError):
        exact_fast.matmul(a, c)


@pytest.mark.parametrize("robot", ["four_bar.yaml", "planar_3r.yaml"])
def test_bundled_robots_expand_as_sympy(robot, tmp_path):
    """Every expansion of a whole run (sheet, code, JSON; the four-bar's reduced form has sums
    in denominators) checked against sympy.expand on the spot (DYNDERIVE_CHECK_EXPAND=1)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, DYNDERIVE_CHECK_EXPAND="1",
               PYTHONPATH=os.pathsep.join([str(root / "src"), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(root / "robots" / robot), "--latex",
                             "--code", "--json", "--out", str(tmp_path), "--quiet"],
                            capture_output=True, text=True, env=env, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "fast expand differs" not in result.stderr
    assert any(tmp_path.glob("*.json"))
