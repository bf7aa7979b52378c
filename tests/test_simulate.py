"""`dynderive simulate` and `solve --code --tests`."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.commands.simulate import simulate
from dynderive.render.targets.numpy.code import render_code

pytest.importorskip("scipy")
pytest.importorskip("matplotlib")
runner = CliRunner()


def _run(robot, maximal, duration, q0, qd0, rtol=1e-11, atol=1e-11, frames=61):
    d = dynderive.derive(dynderive.load_robot(robot))
    zero = lambda t, q, qd: np.zeros(len(d.robot.efforts))  # noqa: E731
    return d, simulate(d, render_code(d), duration, np.array(q0), np.array(qd0), zero, maximal,
                       rtol, atol, 10.0, frames, lambda s: None)


def test_unforced_double_pendulum_conserves_energy():
    _, trajectory = _run("double_pendulum", False, 10.0, [0.9, -0.4], [0.0, 1.0], rtol=1e-12, atol=1e-12)
    relative = np.max(np.abs(trajectory.energy - trajectory.energy[0])) / abs(trajectory.energy[0])
    assert relative < 1e-6


def test_maximal_and_generalized_rp_arm_agree(tmp_path):
    d, generalized = _run("rp_arm", False, 3.0, [0.3, 0.2], [0.0, 0.1])
    _, maximal = _run("rp_arm", True, 3.0, [0.3, 0.2], [0.0, 0.1])
    module = dynderive.verify.checks.generated_module(render_code(d), "rp_arm")
    mapped = module.to_maximal(generalized.position)
    assert np.max(np.abs(maximal.position - mapped)) < 1e-5
    assert np.max(maximal.drift) < 1e-6


def test_plot_csv_and_animation_files(tmp_path):
    from PIL import Image

    result = runner.invoke(app, ["simulate", "double_pendulum", "--duration", "2", "--frames", "21",
                                 "--plot", str(tmp_path / "p.png"), "--csv", str(tmp_path / "t.csv"),
                                 "--animate", str(tmp_path / "a.gif"), "-q"])
    assert result.exit_code == 0, result.output
    assert "largest relative energy change" in result.stdout
    with Image.open(tmp_path / "p.png") as image:
        assert image.format == "PNG" and image.size[0] > 400
    with Image.open(tmp_path / "a.gif") as image:
        assert image.format == "GIF" and image.n_frames >= 10
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == "t,q1,q2,qd1,qd2,energy" and len(lines) == 22


def test_maximal_plot_has_drift_panel(tmp_path):
    result = runner.invoke(app, ["simulate", "rp_arm", "--coordinates", "maximal", "--duration", "1",
                                 "--effort", "tau1=0.5*sin(t)", "--csv", str(tmp_path / "m.csv"), "-q"])
    assert result.exit_code == 0, result.output
    assert "constraint_drift" in (tmp_path / "m.csv").read_text().splitlines()[0]


def test_effort_expressions_are_parsed_safely(tmp_path):
    marker = tmp_path / "pwned"
    result = runner.invoke(app, ["simulate", "rp_arm", "--duration", "0.1", "--effort",
                                 f"tau1=__import__('os').system('touch {marker}')", "-q"])
    assert result.exit_code == 2
    assert result.stderr.startswith("--effort tau1=")
    assert "only calls of plain function names" in result.stderr
    assert not marker.exists()
    result = runner.invoke(app, ["simulate", "rp_arm", "--effort", "nope=1", "-q"])
    assert result.exit_code == 2 and "NAME one of tau1, F2" in result.stderr


def test_solve_tests_option_writes_passing_checks(tmp_path):
    result = runner.invoke(app, ["solve", "double_pendulum", "--code", "--tests", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "test_double_pendulum_dynamics.py"], cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-2000:]
    assert "passed" in run.stdout


def test_closed_loop_simulation_stays_on_the_constraints_and_conserves_energy(tmp_path):
    """A four-bar without effort: started on the loop (assembled from --q0), integrated with
    projection at every frame, energy is conserved and the drift stays tiny; the GIF draws it."""
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    gif = tmp_path / "four_bar.gif"
    result = CliRunner().invoke(app, ["simulate", "four_bar", "--duration", "1", "--q0", "0.4,0,0",
                                      "--animate", str(gif), "--frames", "21", "-q"])
    assert result.exit_code == 0, result.output
    energy = float(result.stdout.split("largest relative energy change ")[1].split(",")[0])
    drift = float(result.stdout.split("largest constraint drift ")[1])
    assert energy < 1e-7 and drift < 1e-8
    assert gif.read_bytes()[:6] == b"GIF89a"
