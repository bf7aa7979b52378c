"""The shortcuts taken for speed (issue 26, item 6) give what the general routes give: the
tree evaluator of the numeric checks agrees with ``lambdify`` (mpmath), the products-to-sums
proof of the checks proves identities and never a non-identity, the sine and cosine angle
expansion equals ``expand_trig``, lambda's adjugate from the upper triangle equals SymPy's,
and the remembered ``trig_linear`` equals a fresh one."""

from __future__ import annotations

import random

import mpmath
import pytest
import sympy

from dynderive.mechanics import tidy as tidy_module
from dynderive.mechanics.evaluate import Unsupported, evaluator
from dynderive.mechanics.maximal import _symmetric_adjugate
from dynderive.mechanics.tidy import _expand_angles, _fourier_zero, check_zero, tidy, trig_linear
from test_exact_fast import QD, P, Q, random_exprs


@pytest.mark.parametrize("seed", range(3))
def test_evaluator_agrees_with_lambdify(seed):
    exprs = [e for e in random_exprs(seed, 40) if e.free_symbols]
    exprs += [sympy.atan2(Q[0], P[0]) * sympy.exp(Q[1]) - sympy.pi * sympy.sign(Q[2]) + sympy.Float("0.1") * Q[0] ** -2]
    free = sorted(set().union(*(e.free_symbols for e in exprs)), key=lambda s: s.name)
    ours = evaluator(exprs, free)
    reference = sympy.lambdify(free, exprs, modules="mpmath")
    rng = random.Random(seed)
    with mpmath.workdps(30):
        for _ in range(3):
            point = [mpmath.mpf(rng.uniform(0.3, 1.7)) for _ in free]
            for a, b, e in zip(ours(*point), reference(*point), exprs):
                assert abs(a - b) <= mpmath.mpf(10) ** -22 * max(1, abs(b)), e


def test_evaluator_refuses_what_it_cannot_evaluate():
    with pytest.raises(Unsupported):
        evaluator([sympy.Piecewise((Q[0], Q[0] > 0), (Q[1], True))], list(Q))


def test_numeric_check_fails_on_a_small_difference():
    """Past the symbolic limits (or where they fail) a difference of 1e-6 must be seen."""
    big = sympy.Add(*(sympy.sin(Q[0] + k * Q[1]) * sympy.cos(k * Q[2]) * P[k % 5] for k in range(1, 40)))
    identity = sympy.Matrix([big - sympy.expand(big) + sympy.sqrt(P[0]) ** 2 - P[0]])
    wrong = identity + sympy.Matrix([sympy.Rational(1, 10**6) * sympy.cos(Q[0]) * sympy.Abs(Q[1])])
    check = check_zero("x", "", wrong, Q)
    assert not check.passed and check.method == "numeric" and check.residual > 1e-7


def test_fourier_zero_proves_identities_only():
    a, b, c = Q
    identity = (sympy.sin(a + b) * sympy.cos(c) - sympy.sin(a) * sympy.cos(b) * sympy.cos(c)
                - sympy.cos(a) * sympy.sin(b) * sympy.cos(c))
    assert _fourier_zero(identity * P[0] / P[2] + (sympy.sin(a) ** 2 + sympy.cos(a) ** 2 - 1) * QD[0])
    assert not _fourier_zero(identity + sympy.Rational(1, 10**12) * sympy.sin(a) * sympy.sin(b))
    assert not _fourier_zero(sympy.sin(2 * a) - sympy.sin(a) * sympy.cos(a))
    # a sine in a denominator is left to the canonical form (True only when proven)
    assert not _fourier_zero(identity / (1 + sympy.cos(a) ** 2) + 1)
    check = check_zero("x", "", sympy.Matrix([identity, sympy.cos(a + b) ** 2 + sympy.sin(a + b) ** 2 - 1]), Q)
    assert check.passed and check.method == "symbolic"


@pytest.mark.parametrize("seed", range(3))
def test_expand_angles_is_expand_trig(seed):
    rng = random.Random(seed)
    for _ in range(20):
        angle = sympy.Add(*rng.sample(Q, rng.randint(1, 3))) * rng.choice([1, 2, 3]) + rng.choice([0, sympy.Rational(253, 100)])
        expr = rng.choice([sympy.sin, sympy.cos])(angle) * rng.choice(P) + sympy.cos(rng.choice(Q) - angle) ** 2
        assert sympy.expand(_expand_angles(expr) - sympy.expand_trig(expr)) == 0, expr
    assert _expand_angles(sympy.tan(Q[0] + Q[1])) == sympy.expand_trig(sympy.tan(Q[0] + Q[1]))


@pytest.mark.parametrize("seed", range(3))
def test_symmetric_adjugate_is_sympys(seed):
    rng = random.Random(seed)
    n = rng.choice([2, 3, 4])
    W = sympy.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            if rng.random() < 0.8:
                entry = rng.choice(P) * rng.choice([sympy.sin, sympy.cos])(rng.choice(Q)) + rng.randint(-3, 3)
                W[i, j] = W[j, i] = tidy(entry / rng.choice(P))
    ours = _symmetric_adjugate(W)
    assert ours == W.adjugate(method="berkowitz").applyfunc(tidy)


def test_remembered_trig_linear_equals_a_fresh_one():
    a, b, c = Q
    entry = P[0] * sympy.cos(b) * sympy.cos(b + c) + P[1] * sympy.sin(b) * sympy.sin(b + c) + P[2] * sympy.cos(c)
    first = trig_linear(entry)
    tidy_module._LINEAR.clear()
    assert trig_linear(entry) == first and trig_linear(entry) is trig_linear(entry)
    assert tidy_module.trig_canonical(first - entry) == 0


@pytest.mark.parametrize("seed", range(3))
def test_diff_is_sympys(seed):
    """The same tree as ``sympy.diff`` (compared by ``srepr``), for every symbol, on random
    expressions with 17-digit fractions, floats, sines and cosines of sums, powers."""
    from dynderive.mechanics.exact_fast import diff

    exprs = random_exprs(seed + 10, 30)
    exprs += [sympy.expand(e) for e in exprs[:5] if sympy.count_ops(e) < 60] + [sympy.tan(Q[0] * Q[1]) * P[0], sympy.Abs(Q[0] - P[1]) ** 3]
    for e in exprs:
        for s in (*Q, QD[0], P[0], P[2]):
            assert sympy.srepr(diff(e, s)) == sympy.srepr(sympy.diff(e, s)), (e, s)


def test_template_cache_is_transparent(monkeypatch, tmp_path):
    """Compiled templates come from Jinja's bytecode cache; a corrupt cache file is compiled
    afresh, and DYNDERIVE_NO_TEMPLATE_CACHE turns the cache off; the text is the same."""
    import jinja2.bccache

    from dynderive.render import environment as env_module

    (tmp_path / "t.py.j2").write_text("x = {{ 1 + 2 }}\n")
    ours = env_module._BytecodeCache
    monkeypatch.setattr(env_module, "_BytecodeCache", lambda pattern: ours(str(tmp_path / "cache"), pattern))
    (tmp_path / "cache").mkdir()
    texts = []
    for corrupt in (False, True):
        env_module.environment.cache_clear()
        if corrupt:
            for f in (tmp_path / "cache").iterdir():
                f.write_bytes(jinja2.bccache.bc_magic + b"not a pickle")   # past Jinja's own check
        texts.append(env_module.render("code", "t.py.j2", {}, tmp_path))
    assert len(list((tmp_path / "cache").iterdir())) >= 1
    monkeypatch.setenv("DYNDERIVE_NO_TEMPLATE_CACHE", "1")
    env_module.environment.cache_clear()
    assert env_module.environment("code", str(tmp_path)).bytecode_cache is None
    texts.append(env_module.render("code", "t.py.j2", {}, tmp_path))
    env_module.environment.cache_clear()
    assert texts == ["x = 3\n"] * 3


def _fold_by_free_symbols(expr):
    """``fold_constants`` as first written: a sub-tree is constant when it has no free symbols."""
    if expr.is_Rational:
        return expr if abs(expr.p) <= tidy_module.EXACT_INTEGER and expr.q <= tidy_module.EXACT_INTEGER \
            else tidy_module._to_float(expr)
    if expr.is_Float or expr.is_Symbol:
        return expr
    if not expr.free_symbols:
        return tidy_module._to_float(expr)
    args = [_fold_by_free_symbols(a) for a in expr.args]
    return expr.func(*args) if any(a is not b and a != b for a, b in zip(args, expr.args)) else expr


@pytest.mark.parametrize("seed", range(3))
def test_fold_constants_equals_the_free_symbols_fold(seed):
    """The one-walk test of constant sub-trees folds what ``free_symbols`` says is constant:
    the same trees, remembered or not (a constant met again, inside a larger constant)."""
    rng = random.Random(seed)
    constants = [sympy.sqrt(2), sympy.sin(sympy.Rational(6061728394506173, 5000000000000000)), sympy.pi / 7,
                 sympy.Rational(2**60 + 1, 3), sympy.cos(sympy.sqrt(3)) * sympy.exp(sympy.Rational(1, 9))]
    exprs = []
    for e in random_exprs(seed, 30):
        c = rng.choice(constants)
        exprs += [e * c + rng.choice(constants) * c, sympy.sin(e + c) * (c + 1), (c * rng.choice(constants)) ** 2 * e]
    tidy_module._FOLDED[True].clear()
    folded = 0
    for e in exprs + exprs[::-1]:
        try:
            expected = _fold_by_free_symbols(e)
        except ValueError:   # a complex constant (the square root of a negative number)
            with pytest.raises(ValueError):
                tidy_module.fold_constants(e)
            continue
        assert tidy_module.fold_constants(e) == expected, e
        folded += expected != e
    assert folded > len(exprs)


def _cache_size(prelude: str, **environment: str) -> str:
    """SymPy's cache size in a fresh interpreter that runs ``prelude`` first."""
    import os
    import subprocess
    import sys

    code = f"{prelude}import sympy.core.cache as c; print(c.SYMPY_CACHE_SIZE)"
    env = {k: v for k, v in os.environ.items() if k != "SYMPY_CACHE_SIZE"} | environment
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout.strip()


def test_the_command_line_gives_sympy_a_larger_cache_unless_told_otherwise():
    """The command line's SymPy cache (``__main__.SYMPY_CACHE_SIZE``) is set before SymPy is
    imported; a user's ``SYMPY_CACHE_SIZE`` wins, and a SymPy imported before keeps its own."""
    from dynderive.__main__ import SYMPY_CACHE_SIZE

    ours = "import dynderive.__main__ as m; m.use_command_line_sympy_cache(); "
    default = _cache_size("")
    assert _cache_size(ours) == SYMPY_CACHE_SIZE != default
    assert _cache_size(ours, SYMPY_CACHE_SIZE="500") == "500"
    assert _cache_size("import sympy; " + ours) == default
