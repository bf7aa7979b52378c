"""``dynderive linearize`` and ``dynderive identify`` of floating-base robots (issue 30): A and
B on the tangent space equal Pinocchio's ``computeABADerivatives`` through the command line, a
configuration off the unit sphere is normalized with a note (a zero quaternion refused), and the
base parameters' count equals the rank of Pinocchio's stacked joint-torque regressor."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from test_free_flyer import urdf_in_pinocchio

pin = pytest.importorskip("pinocchio")
runner = CliRunner()
ELBOW = Path(__file__).parent / "floating_elbow.urdf"


def _pinocchio_order():
    """The floating elbow (a revolute shoulder, a free body below it) and Pinocchio's model of it."""
    return urdf_in_pinocchio(ELBOW)


def _at(names, values):
    return ",".join(f"{n}={float(v)!r}" for n, v in zip(names, values))


@pytest.mark.pinocchio
def test_linearize_equals_pinocchio_on_the_tangent_space():
    robot, model, qp, vp = _pinocchio_order()
    rng = np.random.default_rng(30)
    quaternion = rng.normal(size=4)
    quaternion /= np.linalg.norm(quaternion)
    q = np.concatenate([[rng.uniform(-np.pi, np.pi)], rng.uniform(-1, 1, 3), quaternion])
    v, u = rng.normal(size=7), rng.normal(size=1)
    derivation = dynderive.derive(robot)
    coordinates = [str(s) for s in derivation.symbols.q]
    velocities = [str(s) for s in derivation.symbols.qd]
    at = ",".join([_at(coordinates, q), _at(velocities, v), f"u={float(u[0])!r}"])
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", at, "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document["method"] == "numeric" and document["state"]["velocities"] == velocities
    A, B = np.array(document["A_numeric"]), np.array(document["B_numeric"])
    assert A.shape == (14, 14) and B.shape == (14, 1)

    data = model.createData()
    tau = np.zeros(7)
    tau[0] = u[0]   # the shoulder's effort
    q_pin, v_pin = np.empty(8), np.empty(7)
    q_pin[:], v_pin[:] = q[qp], v[vp]
    pin.computeABADerivatives(model, data, q_pin, v_pin, tau[vp])
    inverse = np.argsort(vp)
    ddq_dq = np.asarray(data.ddq_dq)[np.ix_(inverse, inverse)]
    ddq_dv = np.asarray(data.ddq_dv)[np.ix_(inverse, inverse)]
    Minv = np.asarray(data.Minv)
    Minv = np.triu(Minv) + np.triu(Minv, 1).T
    Minv = Minv[np.ix_(inverse, inverse)]
    expected_A = np.block([[np.zeros((7, 7)), np.eye(7)], [ddq_dq, ddq_dv]])
    expected_B = np.vstack([np.zeros((7, 1)), Minv[:, [0]]])
    scale = max(1.0, np.abs(expected_A).max())
    assert np.max(np.abs(A - expected_A)) <= 1e-9 * scale
    assert np.max(np.abs(B - expected_B)) <= 1e-9 * max(1.0, np.abs(expected_B).max())


def test_linearize_fills_the_neutral_configuration_and_normalizes_quaternions():
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", "elbow_qx=1,elbow_qw=1,elbow_vx=0.3", "--json"])
    assert result.exit_code == 0, result.output
    assert "note: joint 'elbow': its quaternion (norm 1.41421) normalized to [0.707107, 0, 0, 0.707107]" in result.stderr
    assert "qd is not 0" in result.stderr
    state = json.loads(result.stdout)["state"]
    assert state["q"][4:] == pytest.approx([2 ** -0.5, 0, 0, 2 ** -0.5], abs=1e-15)
    assert state["q"][:4] == [0.0, 0.0, 0.0, 0.0]
    text = runner.invoke(app, ["linearize", str(ELBOW), "-q"])
    assert text.exit_code == 0, text.output
    assert "x = (dq, qd) on the tangent space" in text.stdout and "not built for floating-base robots" in text.stdout
    assert "q = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]" in text.stdout   # neutral: identity quaternion


def test_linearize_refuses_a_zero_quaternion():
    at = "elbow_qx=0,elbow_qy=0,elbow_qz=0,elbow_qw=0"
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", at])
    assert result.exit_code == 2
    assert result.stderr.strip() == ("--at:1:1: joint 'elbow': its quaternion (qx, qy, qz, qw) is zero; "
                                     "give a unit quaternion")
    assert result.stdout == ""


@pytest.mark.pinocchio
def test_identify_counts_the_base_parameters_of_pinocchios_regressor():
    pytest.importorskip("scipy")
    robot, model, qp, vp = _pinocchio_order()
    result = runner.invoke(app, ["identify", str(ELBOW), "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    data = model.createData()
    rng = np.random.default_rng(4)
    rows = []
    for _ in range(60):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        rows.append(pin.computeJointTorqueRegressor(model, data, q, rng.normal(size=7), rng.normal(size=7)).copy())
    rank = np.linalg.matrix_rank(np.vstack(rows), tol=1e-9 * np.abs(np.vstack(rows)).max())
    assert document["rank"] == rank == 13   # the shoulder's pendulum: 3; the free body: all 10
    pi = np.concatenate([model.inertias[i].toDynamicParameters() for i in range(1, model.njoints)])
    assert np.max(np.abs(np.array([p["value"] for p in document["parameters"]]) - pi)) <= 1e-12
    text = runner.invoke(app, ["identify", str(ELBOW), "-q"])
    assert text.exit_code == 0 and "regressor Y(q, qd, qdd) of shape (7, 20)" in text.stdout


def test_linearize_latex_of_a_floating_robot_compiles(tmp_path):
    """The LaTeX document says what the state is (tangent space) and compiles: required in CI."""
    import os
    import shutil
    import subprocess

    result = runner.invoke(app, ["linearize", str(ELBOW), "--latex", "-q"])
    assert result.exit_code == 0, result.output
    assert "linearized on the tangent space" in result.stdout and "8 coordinates" in result.stdout
    assert result.stdout.count(r"\\") >= 13 * 2   # two 14 x 14 matrices of numbers
    if shutil.which("latexmk") is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must compile the LaTeX document, but latexmk is missing")
        pytest.skip("latexmk not installed")
    (tmp_path / "lin.tex").write_text(result.stdout)
    run = subprocess.run(["latexmk", "-pdf", "-interaction=nonstopmode", "-halt-on-error", "lin.tex"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:]
    assert (tmp_path / "lin.pdf").stat().st_size > 1000
