"""``check --backend c`` and ``simulate --backend c``: the compiled extension judged against
the NumPy module, function by function, and integrated in place of it.

Needs a C compiler: skipped locally without one, required in CI (CI=true).
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import types

import numpy as np
import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.backends import backends
from dynderive.verify.checks import generated_module
from dynderive.verify.compiled import compiled_rows

from conftest import derivation_of

if shutil.which("cc") is None and shutil.which("gcc") is None:
    if os.environ.get("CI"):
        raise RuntimeError("CI must check the compiled backend, but no C compiler (cc or gcc) was found")
    pytest.skip("no C compiler", allow_module_level=True)

runner = CliRunner()


@pytest.mark.parametrize("robot", ["cart_pole_damped", "elbow_arm"])
def test_check_backend_c_compares_every_compiled_function(robot):
    result = runner.invoke(app, ["check", robot, "--backend", "c", "--json", "--states", "5", "-q"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)["checks"]
    compiled = {r["name"]: r for r in rows if r["name"].startswith("compiled ")}
    for name in ("mass_matrix", "coriolis_matrix", "gravity_vector", "inverse_dynamics", "forward_dynamics",
                 "kinetic_energy", "potential_energy", "friction_forces", "linearize", "regressor"):
        row = compiled[f"compiled {name} == NumPy module"]
        assert row["status"] == "pass" and row["residual"] <= 1e-12, row
    if robot == "cart_pole_damped":   # Coulomb friction: the smoothed sign is compared too
        assert compiled["compiled forward_dynamics (friction_smoothing 0.001) == NumPy module"]["status"] == "pass"
    assert compiled["compiled generalized_forces == NumPy module"]["status"] == "pass"
    # the NumPy module's functions the extension does not offer are listed as not built, with the reason
    assert not any(r["name"] == "compiled module offers every function" for r in rows)
    skipped = [r for r in rows if r["name"].startswith("compiled not built:")]
    # a robot of vector-space joints: the configuration maps (q + v dt, q_to - q_from) are the
    # Python modules' only
    maps = [r for r in skipped if "vector-space joints" in r["method"]]
    assert len(maps) == 1 and maps[0]["status"] == "skip" and "integrate" in maps[0]["method"], skipped
    skipped = [r for r in skipped if r not in maps]
    if robot == "cart_pole_damped":   # planar: the maximal-coordinate functions
        assert len(skipped) == 1 and skipped[0]["status"] == "skip", skipped
        assert "maximal-coordinate" in skipped[0]["method"] and "maximal_forward_dynamics" in skipped[0]["method"]
    else:
        assert skipped == []


def test_a_missing_function_not_listed_as_not_built_fails():
    from dynderive.verify.compiled import missing_rows

    rows = missing_rows(["maximal_mass_matrix", "generalized_forces"], "c-extension", "compiled")
    assert [r.status for r in rows] == ["skip", "FAIL"], rows
    assert rows[0].name == "compiled not built: maximal_mass_matrix" and "maximal-coordinate" in rows[0].method
    assert "generalized_forces" in rows[1].method and "not listed" in rows[1].method


def test_compiled_rows_fail_on_a_wrong_function():
    """A compiled function off by 1e-9 relative, or with the wrong shape, is a FAIL row."""
    derivation = derivation_of("double_pendulum")
    module = generated_module(render_code(derivation), "double_pendulum")
    wrong = types.SimpleNamespace(
        mass_matrix=lambda q, **p: module.mass_matrix(q, **p) * (1 + 1e-9),
        gravity_vector=lambda q, **p: module.gravity_vector(q, **p)[..., :1],
        coriolis_matrix=module.coriolis_matrix)
    rng = np.random.default_rng(3)
    states = {k: rng.uniform(-1, 1, (4, 2)) for k in ("q", "qd", "qdd", "u")}
    values = {p.name: p.value for p in derivation.robot.parameters}
    rows = {r.name: r for r in compiled_rows(module, wrong, values, states)}
    assert rows["compiled mass_matrix == NumPy module"].status == "FAIL"
    assert rows["compiled gravity_vector == NumPy module"].status == "FAIL"
    assert rows["compiled coriolis_matrix == NumPy module"].status == "pass"
    assert "inverse_dynamics" in rows["compiled module offers every function"].method


def _trajectory(path):
    with open(path) as handle:
        table = list(csv.reader(handle))
    return table[0], np.array(table[1:], dtype=float)


def test_simulate_backend_c_follows_the_numpy_run(tmp_path):
    common = ["simulate", "cart_pole_damped", "--duration", "0.5", "--frames", "11", "-q",
              "--effort", "F=0.3*sin(t)"]
    numpy_run = runner.invoke(app, [*common, "--csv", str(tmp_path / "numpy.csv")])
    c_run = runner.invoke(app, [*common, "--backend", "c", "--csv", str(tmp_path / "c.csv")])
    assert numpy_run.exit_code == 0 and c_run.exit_code == 0, numpy_run.output + c_run.output
    header, expected = _trajectory(tmp_path / "numpy.csv")
    header_c, got = _trajectory(tmp_path / "c.csv")
    assert header == header_c
    assert np.abs(got - expected).max() < 1e-7 * max(1.0, np.abs(expected).max())


@pytest.mark.parametrize(("arguments", "message"), [
    (["--backend", "fortran"], f"--backend:1:1: expected one of {', '.join(backends())}, got 'fortran'"),
    (["--backend", "c", "--coordinates", "maximal"], "--backend:1:1: the compiled module has no maximal"),
])
def test_simulate_backend_refusals(arguments, message, tmp_path):
    result = runner.invoke(app, ["simulate", "rp_arm", "--duration", "0.1", "--csv", str(tmp_path / "t.csv"),
                                 *arguments])
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (tmp_path / "t.csv").exists()


def test_backend_c_without_a_compiler_is_refused_before_any_work(monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    for command in (["check", "rp_arm"], ["simulate", "rp_arm", "--duration", "0.1"]):
        result = runner.invoke(app, [*command, "--backend", "c"])
        assert result.exit_code == 2, result.output
        assert result.output.startswith("--backend:1:1: the C compiler CC='/nonexistent/cc' was not found")
