"""Linearization (issue 19): ``dynderive linearize`` and the generated ``linearize``.

The closed form of the cart-pole about upright against the textbook's (a uniform pole of
length L on a cart: theta'' = 6 g (M + m) theta / (L (4 M + m)) + ...), the generated function
against central differences of ``forward_dynamics`` on random planar and 3-D robots and a
robot with drives, and against Pinocchio's ``computeABADerivatives``.
"""

from __future__ import annotations

import json
import random
import shutil
import subprocess

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

from dynderive.commands.cli import app

from conftest import ROOT, text_derivation
from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

runner = CliRunner()


def _finite_differences(module, q, qd, u, **keywords):
    n, h = len(q), 1e-6
    x = np.concatenate([q, qd])

    def f(state, effort):
        return np.concatenate([state[n:], module.forward_dynamics(state[:n], state[n:], effort, **keywords)])

    A = np.array([(f(x + h * e, u) - f(x - h * e, u)) / (2 * h) for e in np.eye(2 * n)]).T
    B = np.array([(f(x, u + h * e) - f(x, u - h * e)) / (2 * h) for e in np.eye(len(u))]).T.reshape(2 * n, len(u))
    return A, B


def test_cart_pole_about_upright_is_the_textbook_one():
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", "q=0,0", "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document["method"] == "symbolic" and document["agreement"] < 1e-12
    mc, mp, lp, g = sympy.symbols("mc mp lp g")
    names = {"mc": mc, "mp": mp, "lp": lp, "g": g}
    A = sympy.sympify(document["A"]["sympy"], locals=names)
    B = sympy.sympify(document["B"]["sympy"], locals=names)
    # theta turns counterclockwise from the upward vertical (the pole tips towards -x), so the
    # couplings have the opposite signs of the textbook's theta measured towards +x
    expected_A = sympy.Matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                               [0, 3 * g * mp / (4 * mc + mp), 0, 0],
                               [0, 6 * g * (mc + mp) / (lp * (4 * mc + mp)), 0, 0]])
    expected_B = sympy.Matrix([0, 0, 4 / (4 * mc + mp), 6 / (lp * (4 * mc + mp))])
    assert sympy.simplify(A - expected_A) == sympy.zeros(4, 4)
    assert sympy.simplify(B - expected_B) == sympy.zeros(4, 1)
    numbers = np.array(document["A_numeric"])
    assert numbers[3, 1] == pytest.approx(6 * 9.81 * 1.1 / 4.1)   # upright is unstable
    hanging = json.loads(runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=pi", "--json", "-q"]).stdout)
    assert np.array(hanging["A_numeric"])[3, 1] == pytest.approx(-6 * 9.81 * 1.1 / 4.1)   # hanging is stable


HOSTILE = '\x1b[2J\x1b]0;owned\x07 """\\ $x$ \\end{document} %{}#&_^~ \u2603\u202e'


def test_hostile_titles_are_encoded_in_every_output(tmp_path):
    """A title with terminal escapes, quotes, LaTeX commands and bidi controls reaches the
    terminal with its control characters escaped and the LaTeX document escaped."""
    text = (ROOT / "robots" / "cart_pole.yaml").read_text().replace("title: Cart-pole", f"title: {json.dumps(HOSTILE)}")
    path = tmp_path / "hostile.yaml"
    path.write_text(text)
    terminal = runner.invoke(app, ["linearize", str(path), "-q"])
    assert terminal.exit_code == 0, terminal.output
    assert "\x1b" not in terminal.stdout and "\x07" not in terminal.stdout and "\u202e" not in terminal.stdout
    latex = runner.invoke(app, ["linearize", str(path), "--latex", "-q"])
    assert latex.exit_code == 0, latex.output
    assert r"\end{document}" in latex.stdout and latex.stdout.count(r"\end{document}") == 1
    assert "\x1b" not in latex.stdout and "$x$" not in latex.stdout
    document = json.loads(runner.invoke(app, ["linearize", str(path), "--json", "-q"]).stdout)
    assert document["robot"] == "cart_pole"


def test_terminal_and_latex_outputs(tmp_path):
    text = runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=pi/2,F=1", "-q"])
    assert text.exit_code == 0, text.output
    assert "A =" in text.stdout and "agree to" in text.stdout
    latex = runner.invoke(app, ["linearize", "rp_arm", "--at", "q=0.3,0.2", "--latex", "-q"])
    assert latex.exit_code == 0, latex.output
    assert r"\begin{document}" in latex.stdout and "A = " in latex.stdout
    if shutil.which("pdflatex"):
        (tmp_path / "lin.tex").write_text(latex.stdout)
        run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-no-shell-escape", "lin.tex"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stdout[-2000:]


@pytest.mark.parametrize("at, message", [
    ("q=0", "--at:1:1: q: expected 2 values, got 1"),
    ("speed=1", "--at:1:1: unknown name 'speed'"),
    ("1,2", "--at:1:1: expected KEY=VALUE"),
    ("theta=sqrt(-1)", "--at:1:1: theta:"),
])
def test_bad_operating_points_are_refused(at, message):
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", at, "-q"])
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output


def test_closed_loops_are_linearized_on_their_constraints(generated):
    """The command puts the state on the loops (independent coordinates kept); the generated
    function is the tangent of the constrained accelerations (central differences of
    ``forward_dynamics`` with alpha = beta = 0)."""
    result = runner.invoke(app, ["linearize", "four_bar", "--at", "q1=0.5,q2=1", "--json"])
    assert result.exit_code == 0, result.output
    assert "note: q2 = " in result.stderr and "follows from the loops" in result.stderr
    document = json.loads(result.stdout)
    assert document["method"] == "numeric" and document["state"]["q"][0] == 0.5
    module = generated("four_bar")
    np.testing.assert_allclose(module.loop_constraints(document["state"]["q"]), 0, atol=1e-10)
    for name in ("four_bar", "slider_crank", "spatial_four_bar"):
        module = generated(name)
        n = len(module.COORDINATES)
        rng = np.random.default_rng(4)
        guess = np.array(module.ASSEMBLED_CONFIGURATION) + rng.uniform(-0.2, 0.2, n)
        q = module.assemble(guess)
        qd = module.reduced_basis(q) @ rng.uniform(-1, 1, len(module.INDEPENDENT_COORDINATES))
        u = rng.uniform(-1, 1, len(module.EFFORTS))
        A, B = module.linearize(q, qd, u)
        A_fd, B_fd = _finite_differences(module, q, qd, u)
        scale = max(1.0, float(np.max(np.abs(A))))
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * scale)
        np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6 * scale)


CASES = [("planar", 1, 3), ("planar", 2, 5), ("spatial", 3, 4), ("spatial", 5, 6)]


def _module(kind, seed, n, directory):
    rng = random.Random(seed)
    tree = random_planar_tree(rng, n) if kind == "planar" else random_spatial_tree(rng, n)
    return text_derivation(f"lin_{kind}_{seed}_{n}", tree.yaml_text, directory)


@pytest.fixture(scope="module")
def directory(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("linearize"))


@pytest.mark.parametrize("kind, seed, n", CASES)
def test_generated_linearize_matches_finite_differences(kind, seed, n, directory):
    _, module = _module(kind, seed, n, directory)
    rng = np.random.default_rng(seed)
    q, qd, u = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, len(module.EFFORTS))
    A, B = module.linearize(q, qd, u)
    A_fd, B_fd = _finite_differences(module, q, qd, u)
    scale = max(1.0, float(np.max(np.abs(A))))
    np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * scale)
    np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6)
    batch_A, batch_B = module.linearize(np.array([q, -q]), np.array([qd, qd]), u)
    assert batch_A.shape == (2, 2 * n, 2 * n) and batch_B.shape == (2, 2 * n, len(module.EFFORTS))
    np.testing.assert_allclose(batch_A[0], A, rtol=1e-12, atol=1e-12)


def test_linearize_with_drives_and_smoothed_friction(generated):
    module = generated("cart_pole_damped")
    q, qd, u = np.array([0.2, 0.4]), np.array([0.3, -0.7]), np.array([0.5])
    for smoothing in (0.0, 0.05):
        A, B = module.linearize(q, qd, u, friction_smoothing=smoothing)
        A_fd, B_fd = _finite_differences(module, q, qd, u, friction_smoothing=smoothing)
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6)


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, seed, n", CASES)
def test_generated_linearize_matches_pinocchio(kind, seed, n, directory):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    derivation, module = _module(kind, seed, n, directory)
    model, perm = pinocchio_model(derivation.robot, {})
    data = model.createData()
    rng = np.random.default_rng(seed + 100)
    for _ in range(3):
        q, qd, u = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, len(module.EFFORTS))
        A, B = module.linearize(q, qd, u)
        tau = module.generalized_forces(q, u)
        pin.computeABADerivatives(model, data, q[perm], qd[perm], tau[perm])
        np.testing.assert_allclose(A[n:, :n][np.ix_(perm, perm)], data.ddq_dq, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(A[n:, n:][np.ix_(perm, perm)], data.ddq_dv, rtol=1e-8, atol=1e-8)
        inverse = np.asarray(data.Minv)
        inverse = np.triu(inverse) + np.triu(inverse, 1).T
        effort_map = module.generalized_forces(np.zeros(n), np.eye(len(module.EFFORTS))).T
        np.testing.assert_allclose(B[n:][perm], inverse @ effort_map[perm], rtol=1e-8, atol=1e-8)
