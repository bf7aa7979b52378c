"""Bounded work (issue 27, item 8): what is too large is refused before any work, with the
limit and what to do; what is accepted shows progress in every stage of over a second."""

from __future__ import annotations

import io
import random
import time

import pytest
import sympy
from typer.testing import CliRunner

from dynderive.commands import progress as progress_module
from dynderive.commands.cli import app
from dynderive.mechanics import tidy as tidy_module
from dynderive.model.expressions import MAX_EXPANDED_TERMS
from dynderive.model.size import expanded_terms

from conftest import ROBOTS

runner = CliRunner()

BOMB = "(a+b+c+d+e+f+h+i+j+k)**12"


def _pendulum_with_mass(tmp_path, mass: str):
    text = (ROBOTS / "double_pendulum.yaml").read_text()
    declared = "".join(f"  {s}: {{value: 0.1}}\n" for s in "abcdefhijk")
    text = text.replace("parameters:\n", "parameters:\n" + declared).replace("    mass: m1", f"    mass: {mass}")
    path = tmp_path / "bomb.yaml"
    path.write_text(text)
    line = next(i for i, row in enumerate(text.splitlines(), 1) if mass in row)
    return path, line


def test_an_expression_that_expands_to_millions_of_terms_is_refused_at_its_position(tmp_path):
    path, line = _pendulum_with_mass(tmp_path, BOMB)
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    message = result.stderr.strip()
    assert "\n" not in message and "Traceback" not in message
    assert message.startswith(f"{path}:{line}:11: links[0].mass: ")
    assert "293930 terms" in message and f"limit {MAX_EXPANDED_TERMS}" in message
    assert not (tmp_path / "out").exists()


def test_an_expression_within_the_limit_is_accepted(tmp_path):
    path, _ = _pendulum_with_mass(tmp_path, "(a+b+c+d)**2*m1")   # 10 terms
    assert runner.invoke(app, ["solve", str(path), "-q"]).exit_code == 0


def _random_expression(rng: random.Random, symbols, depth: int) -> sympy.Expr:
    if depth == 0 or rng.random() < 0.3:
        return rng.choice(list(symbols) + [sympy.Rational(rng.randint(1, 9), rng.randint(1, 9))])
    kind = rng.choice(["add", "mul", "pow", "div", "sin"])
    if kind == "add":
        return sympy.Add(*[_random_expression(rng, symbols, depth - 1) for _ in range(rng.randint(2, 3))])
    if kind == "mul":
        return sympy.Mul(*[_random_expression(rng, symbols, depth - 1) for _ in range(2)])
    if kind == "pow":
        return _random_expression(rng, symbols, depth - 1) ** rng.randint(2, 4)
    if kind == "div":
        return _random_expression(rng, symbols, depth - 1) / _random_expression(rng, symbols, depth - 1)
    return sympy.sin(_random_expression(rng, symbols, depth - 1))


def test_the_estimate_bounds_every_expansion():
    """The estimate is an upper bound on the terms of the expansion and of every argument
    expanded inside it (a bound that is exact for a power of a sum of symbols)."""
    symbols = sympy.symbols("a b c d e")
    rng = random.Random(7)
    for _ in range(200):
        expr = _random_expression(rng, symbols, 4)
        expanded = sympy.expand(expr)
        inner = [len(sympy.Add.make_args(f.args[0])) for f in expanded.atoms(sympy.sin)]
        inner += [len(sympy.Add.make_args(p.base)) for p in expanded.atoms(sympy.Pow)]
        assert expanded_terms(expr) >= max([len(sympy.Add.make_args(expanded))] + inner), expr
    assert expanded_terms(sum(symbols[:4]) ** 5) == len(sympy.expand(sum(symbols[:4]) ** 5).args) == 56


def test_the_engine_never_expands_what_would_explode(monkeypatch):
    """An entry whose expansion is too large is kept as built by the tidying (which would
    otherwise expand it for minutes): no expansion is even attempted."""
    symbols = sympy.symbols("a b c d e f h i j k")
    entry = sympy.Symbol("m") * sympy.cos(sympy.Symbol("q")) * sum(symbols) ** 12

    def refuse(*args, **kwargs):
        raise AssertionError("expanded")

    monkeypatch.setattr(sympy, "expand", refuse)
    assert not tidy_module.expandable(entry)
    assert tidy_module.tidy(entry) == entry
    assert tidy_module.quick_tidy(entry) == entry
    assert tidy_module.trig_linear(entry) == entry


@pytest.mark.progress
def test_a_long_stage_is_shown_while_it_runs(monkeypatch):
    """A stage that runs over a second is printed without waiting for the next one, and a
    stage still running is reported again (here every 1.5 s instead of every minute)."""
    monkeypatch.setattr(progress_module, "STILL_EVERY", 1.5)
    stream = io.StringIO()
    progress = progress_module.Progress(quiet=False, stream=stream)
    try:
        progress("loading")
        progress("energies")
        assert stream.getvalue() == ""   # quick so far: nothing shown
        deadline = time.monotonic() + 10
        while "still running" not in stream.getvalue() and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        progress_module.Progress.close_all()
    lines = stream.getvalue().splitlines()
    assert lines[0].endswith("] loading") and lines[1].endswith("] energies")
    assert "energies: still running" in lines[2]
    shown = stream.getvalue()
    time.sleep(0.5)
    assert stream.getvalue() == shown   # closed: nothing more


@pytest.mark.progress
def test_a_quiet_or_quick_run_prints_no_progress():
    stream = io.StringIO()
    progress = progress_module.Progress(quiet=True, stream=stream)
    progress("loading")
    quick = progress_module.Progress(quiet=False, stream=stream)
    quick("loading")
    progress_module.Progress.close_all()
    time.sleep(1.3)
    assert stream.getvalue() == ""


def test_yaml_nested_too_deep_is_refused_at_once_in_either_style(tmp_path):
    """Flow style is caught by one pass over the text (PyYAML's scanner would look ahead over
    every open bracket), block style as it is composed; brackets in quotes and comments do not
    count."""
    block = "name: arm\ntitle:\n" + "".join("  " * k + "-\n" for k in range(1, 150))
    (tmp_path / "block.yaml").write_text(block)
    result = runner.invoke(app, ["solve", str(tmp_path / "block.yaml")])
    assert result.exit_code == 2 and result.stderr.strip().endswith("YAML nesting is too deep")
    assert result.stderr.count("\n") == 1
    text = (ROBOTS / "rp_arm.yaml").read_text().replace(
        "title: Two-link RP arm (revolute + prismatic)\n", "title: \"" + "[" * 300 + "\"  # " + "{" * 300 + "\n")
    (tmp_path / "quoted.yaml").write_text(text)
    assert runner.invoke(app, ["solve", str(tmp_path / "quoted.yaml"), "-q"]).exit_code == 0


def _planar_chain(n: int) -> str:
    links = "".join(f"  - {{name: b{k}, mass: 1.2345678901234567, com: [0.4321987654321, 0.0123456789], "
                    f"inertia: 0.087654321}}\n" for k in range(1, n + 1))
    joints = "".join(f"  - {{name: q{k}, type: revolute, parent: {'world' if k == 1 else f'b{k - 1}'}, "
                     f"child: b{k}, origin: [{0 if k == 1 else 0.9876543210987}, 0]}}\n" for k in range(1, n + 1))
    return f"name: chain\nplanar: true\ngravity: [0, -9.81]\nlinks:\n{links}joints:\n{joints}"


def test_a_robot_over_the_coordinate_limit_is_refused_by_the_commands_before_any_work(tmp_path):
    import dynderive
    from dynderive.input.limits import MAX_PLANAR_COORDINATES

    path = tmp_path / "chain.yaml"
    path.write_text(_planar_chain(MAX_PLANAR_COORDINATES + 1))
    line = path.read_text().splitlines().index("joints:") + 1
    for command in (["solve", "--code", "--out", str(tmp_path / "out")], ["check"], ["simulate"], ["linearize"]):
        result = runner.invoke(app, [command[0], str(path), *command[1:]])
        assert result.exit_code == 2, (command, result.output)
        message = result.stderr.strip()
        assert message.startswith(f"{path}:{line}:1: joints: {MAX_PLANAR_COORDINATES + 1} coordinates exceed "
                                  f"the limit of {MAX_PLANAR_COORDINATES} for a planar robot"), message
        assert "\n" not in message and "weld the joints" in message
    assert not (tmp_path / "out").exists()
    # the library leaves it to the caller (the programs alone do not grow like n^3)
    assert len(dynderive.load_robot(path).coordinates) == MAX_PLANAR_COORDINATES + 1
    path.write_text(_planar_chain(MAX_PLANAR_COORDINATES))
    assert len(dynderive.load_robot(path, size_limits=True).coordinates) == MAX_PLANAR_COORDINATES
