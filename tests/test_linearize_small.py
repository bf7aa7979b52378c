"""``dynderive linearize`` on three- and four-coordinate robots: the closed form is given in
seconds (exact polynomial arithmetic at the point), or skipped with a note when its entries are
too large to read, and never hangs.

Each case runs the user's command in a fresh process in an empty working directory (which
stays empty), with a generous hang guard and no timed assertion; A and B, the closed form's
evaluated at the parameters' defaults and the generated linearize's numbers, are checked
against central differences of the generated NumPy module's ``forward_dynamics``.
Fixtures: the bundled ``planar_3r``, ``tests/linearize/cart_double_pendulum.yaml`` (a cart
with two rods, the swing-up benchmark) and ``tests/linearize/rrr_arm.yaml`` (uniform rods).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import sympy

import dynderive

from conftest import ROOT, import_code

FIXTURES = ROOT / "tests" / "linearize"
HANG_GUARD = 120   # seconds: the command takes seconds; only a hang reaches this


def _run(tmp_path, robot: str, *args: str) -> subprocess.CompletedProcess:
    work = tmp_path / "work"
    work.mkdir()
    environment = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run([sys.executable, "-m", "dynderive", "linearize", robot, *args],
                          cwd=work, env=environment, capture_output=True, text=True, timeout=HANG_GUARD)
    assert list(work.iterdir()) == []   # nothing written anywhere
    return done


def _module(robot: str, directory):
    derivation = dynderive.derive(dynderive.load_robot(robot))
    return derivation, import_code(dynderive.render_code(derivation), directory, f"{derivation.robot.name}_small")


def _central_differences(module, q, qd, u, h=1e-6):
    n = len(q)
    x = np.concatenate([q, qd])

    def f(state, effort):
        return np.concatenate([state[n:], module.forward_dynamics(state[:n], state[n:], effort)])

    A = np.array([(f(x + h * e, u) - f(x - h * e, u)) / (2 * h) for e in np.eye(2 * n)]).T
    B = np.array([(f(x, u + h * e) - f(x, u - h * e)) / (2 * h) for e in np.eye(len(u))]).T.reshape(2 * n, len(u))
    return A, B


def _assert_close(actual, expected):
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    scale = max(1.0, float(np.max(np.abs(expected))))
    assert np.max(np.abs(actual - expected)) <= 1e-6 * scale, (actual, expected)


def _symbolic_at_defaults(entry, derivation) -> np.ndarray:
    names = {p.name: sympy.Symbol(p.name) for p in derivation.robot.parameters}
    matrix = sympy.sympify(entry["sympy"], locals=names)
    values = {names[p.name]: p.value for p in derivation.robot.parameters}
    return np.array(matrix.xreplace(values).evalf(), dtype=float)


CLOSED_FORMS = [
    ("planar_3r", "q=0,0,0"),
    ("planar_3r", "q=pi/2,0,0,u=equilibrium"),
    ("planar_3r", "q=-pi/2,pi/2,0,u=equilibrium"),
    (str(FIXTURES / "cart_double_pendulum.yaml"), "q=0,0,0"),
    (str(FIXTURES / "cart_double_pendulum.yaml"), "q=0.2,pi,pi,qd=0.1,0,0"),
    (str(FIXTURES / "cart_double_pendulum.yaml"), "q=0,0,pi,F=1"),
    (str(FIXTURES / "rrr_arm.yaml"), "q=pi/2,0,0,u=equilibrium"),
]


@pytest.mark.parametrize("robot, at", CLOSED_FORMS, ids=[f"{r.rsplit('/', 1)[-1]}-{a}" for r, a in CLOSED_FORMS])
def test_closed_form_of_small_robots_equals_finite_differences(robot, at, tmp_path):
    done = _run(tmp_path, robot, "--at", at, "--json")
    assert done.returncode == 0, done.stderr
    assert "internal error" not in done.stderr and "closed form skipped" not in done.stderr
    document = json.loads(done.stdout)
    assert document["method"] == "symbolic"
    derivation, module = _module(robot, tmp_path)
    state = document["state"]
    A_fd, B_fd = _central_differences(module, *(np.array(state[k], dtype=float) for k in ("q", "qd", "u")))
    _assert_close(document["A_numeric"], A_fd)
    _assert_close(document["B_numeric"], B_fd)
    _assert_close(_symbolic_at_defaults(document["A"], derivation), A_fd)
    _assert_close(_symbolic_at_defaults(document["B"], derivation), B_fd)


SKIPPED = [
    ("planar_3r", "q=0.3,0.5,0.7"),
    (str(FIXTURES / "rrr_arm.yaml"), "q=0.1,0.2,0.3,t1=1"),
    (str(FIXTURES / "cart_double_pendulum.yaml"), "q=0,pi/4,pi/3,F=1"),
]


@pytest.mark.parametrize("robot, at", SKIPPED, ids=[f"{r.rsplit('/', 1)[-1]}-{a}" for r, a in SKIPPED])
def test_a_closed_form_too_large_to_read_falls_back_to_the_numbers_with_a_note(robot, at, tmp_path):
    done = _run(tmp_path, robot, "--at", at, "--json")
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stderr.splitlines() if "closed form skipped" in line]
    assert len(notes) == 1 and notes[0].startswith("note: closed form skipped: ") and "terms" in notes[0]
    document = json.loads(done.stdout)
    assert document["method"] == "numeric" and "A" not in document
    _, module = _module(robot, tmp_path)
    state = document["state"]
    A_fd, B_fd = _central_differences(module, *(np.array(state[k], dtype=float) for k in ("q", "qd", "u")))
    _assert_close(document["A_numeric"], A_fd)
    _assert_close(document["B_numeric"], B_fd)
    (tmp_path / "text").mkdir()
    text = _run(tmp_path / "text", robot, "--at", at)
    assert text.returncode == 0 and "(from the generated linearize; closed form skipped: " in text.stdout
    assert "A =" in text.stdout and "B =" in text.stdout


def test_planar_3r_terminal_and_latex_give_the_closed_form(tmp_path):
    text = _run(tmp_path, "planar_3r", "-q")
    assert text.returncode == 0, text.stderr
    assert "closed form and generated linearize agree to" in text.stdout and text.stderr == ""
    (tmp_path / "latex").mkdir()
    latex = _run(tmp_path / "latex", "planar_3r", "--at", "u=equilibrium", "--latex", "-q")
    assert latex.returncode == 0, latex.stderr
    assert latex.stdout.count(r"\end{document}") == 1 and r"\frac" in latex.stdout
