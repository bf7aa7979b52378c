"""`dynderive simulate` and `solve --code --tests`.

Floating-base robots too: a free rigid body without gravity keeps its energy and momentum (Pinocchio's)
and its quaternion unit; a body under gravity falls as z0 - g t^2 / 2; the options a floating run
does not take are refused (exit 2, no output); the check rows catch a wrong module."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.commands.simulate import initial_configuration, parse_efforts, simulate
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import ENERGY_RUN, MOMENTUM, generated_module, run_checks, system_momentum

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


# -- floating base --------------------------------------------------------------------------------
# test_free_flyer and test_spherical skip themselves without Pinocchio: the tests below import
# them, so that the rest of this file runs without it.

FREE = """name: free
planar: false
parameters:
  g: 0
gravity: [0, 0, -g]
links:
  - {name: body, mass: 2.0, com: [0.05, -0.02, 0.1], inertia: [0.02, 0.03, 0.04, 0.001, 0.002, 0.003]}
joints:
  - {name: root, type: floating, parent: world, child: body, origin: {xyz: [0.1, 0.2, 0.3], rpy: [0.4, -0.2, 1.0]}}
"""


def _run_floating(tmp_path: Path, text: str, q0: list[float] | None, v0: list[float], duration: float,
                  frames: int = 41):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    derivation = dynderive.derive(robot)
    source = render_code(derivation)
    q0 = initial_configuration(robot, None if q0 is None else np.array(q0))
    trajectory = simulate(derivation, source, duration, q0, np.array(v0), parse_efforts(derivation, [], False), False,
                          1e-10, 1e-10, 10.0, frames, lambda text: None)
    return robot, generated_module(source, robot.name), trajectory


def test_a_free_body_keeps_energy_momentum_and_unit_quaternion(tmp_path):
    q0 = [0.3, -0.1, 0.2, 0.1, 0.2, -0.3, 0.927]   # normalized by initial_configuration
    robot, module, trajectory = _run_floating(tmp_path, FREE, q0, [0.3, -0.2, 0.1, 1.5, -2.0, 0.7], 4.0)
    assert trajectory.position.shape == (41, 7) and trajectory.velocity.shape == (41, 6)
    np.testing.assert_allclose(np.linalg.norm(trajectory.position[:, 3:7], axis=1), 1.0, rtol=0, atol=1e-12)
    energy = trajectory.energy
    assert energy[0] > 0.1 and np.max(np.abs(energy - energy[0])) < 1e-7 * energy[0]
    momentum = system_momentum(module, robot, trajectory.position, trajectory.velocity, {"g": 0.0})
    assert np.max(np.abs(momentum[0])) > 0.1
    np.testing.assert_allclose(momentum, np.broadcast_to(momentum[0], momentum.shape), rtol=0, atol=1e-7)
    # the body tumbles: its angular velocity in its own frame changes (Euler's equations)
    assert np.max(np.abs(trajectory.velocity[:, 3:] - trajectory.velocity[0, 3:])) > 0.1


def test_momentum_is_pinocchios(tmp_path):
    """The momentum of the box with its arm (about the world origin): Pinocchio's centroidal
    momentum moved from the centre of mass to the origin."""
    from test_free_flyer import BOX

    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_maps

    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    robot = dynderive.load_robot(path)
    values = {p.name: p.value for p in robot.parameters if p.value is not None}
    module = generated_module(render_code(dynderive.derive(robot)), robot.name)
    model, qp, vp = pinocchio_maps(robot, values)
    data = model.createData()
    pin.seed(3)
    rng = np.random.default_rng(3)
    q, v = np.empty(model.nq), np.empty(model.nv)
    q[qp], v[vp] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)), rng.normal(size=model.nv)
    hg = pin.computeCentroidalMomentum(model, data, q[qp], v[vp])
    com = pin.centerOfMass(model, data, q[qp])
    expected = np.concatenate([hg.linear, hg.angular + np.cross(com, hg.linear)])
    np.testing.assert_allclose(system_momentum(module, robot, q, v, values), expected, rtol=0, atol=1e-12)


def test_a_body_falls_as_it_should(tmp_path):
    text = FREE.replace("g: 0", "g: 9.81").replace(", origin: {xyz: [0.1, 0.2, 0.3], rpy: [0.4, -0.2, 1.0]}", "")
    _, _, trajectory = _run_floating(tmp_path, text, [0.5, -1.0, 2.0, 0, 0, 0, 1], [0.0] * 6, 1.5, frames=16)
    t = trajectory.times
    np.testing.assert_allclose(trajectory.position[:, 2], 2.0 - 9.81 * t**2 / 2, rtol=0, atol=1e-8)
    np.testing.assert_allclose(trajectory.position[:, :2], np.broadcast_to([0.5, -1.0], (16, 2)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(trajectory.velocity[:, 2], -9.81 * t, rtol=0, atol=1e-8)   # base axes = world axes
    np.testing.assert_allclose(trajectory.energy, trajectory.energy[0], rtol=0, atol=1e-7)


def test_simulate_command_of_a_floating_robot(tmp_path):
    from test_free_flyer import BOX

    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    csv, plot = tmp_path / "run.csv", tmp_path / "run.png"
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.5", "--frames", "11", "--effort",
                                 "tau2=0.1*sin(t)", "--csv", str(csv), "--plot", str(plot), "-q"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("simulated 0.5 s of box (floating base, on the manifold): largest relative energy")
    lines = csv.read_text().splitlines()
    assert lines[0] == ("t,root_x,root_y,root_z,root_qx,root_qy,root_qz,root_qw,q2,root_vx,root_vy,root_vz,root_wx,"
                        "root_wy,root_wz,qd2,energy")
    assert len(lines) == 12 and plot.read_bytes().startswith(b"\x89PNG")
    first = [float(x) for x in lines[1].split(",")]
    assert first[1:9] == [0, 0, 0, 0, 0, 0, 1, 0.5]   # the default start: neutral base, revolute joints at 0.5


@pytest.mark.parametrize("args,message", [
    (["--q0", "0,0,0,0,0,0,0.9,0"], "--q0:1:1: the quaternion root_qx, root_qy, root_qz, root_qw must be unit "
                                     "(within 0.001), its norm is 0.9"),
    (["--q0", "0,0,0,0,0,0,1"], "--q0:1:1: expected 8 numbers separated by commas"),
    (["--qd0", "0,0,0,0,0,0,0,0"], "--qd0:1:1: expected 7 numbers separated by commas"),
    (["--coordinates", "maximal"], "--coordinates:1:1: a floating-base robot is simulated in its coordinates"),
    (["--animate", "a.gif"], "--animate:1:1: --animate draws planar robots only"),
    (["--force", "x=0,0,0,0,0,0"], "--force x=0,0,0,0,0,0:1:1: expected FRAME=EXPR,EXPR,.. with FRAME one of "
                                   "(this robot declares no frames)"),
])
def test_simulate_options_a_floating_run_refuses(tmp_path, args, message):
    from test_free_flyer import BOX

    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    result = runner.invoke(app, ["simulate", str(path), "--csv", str(tmp_path / "run.csv"), *args])
    assert result.exit_code == 2, result.output
    assert message in result.stderr and "Traceback" not in result.output
    assert not (tmp_path / "run.csv").exists()


#: A configuration rate that turns the base's quaternion by its angular velocity in world axes
#: (q w instead of w q, the body-frame rate), appended to the module: the run's energy drifts.
WRONG_RATE = """

_rate = configuration_rate


def configuration_rate(q, v):
    out = np.array(_rate(q, v))
    v = np.asarray(v, dtype=float)
    a, b = np.concatenate([v[..., 3:6], np.zeros_like(v[..., :1])], axis=-1), np.asarray(q, dtype=float)[..., 3:7]
    out[..., 3:7] = 0.5 * np.concatenate([a[..., 3:] * b[..., :3] + b[..., 3:] * a[..., :3] + np.cross(a[..., :3], b[..., :3]),
                                          a[..., 3:] * b[..., 3:] - np.sum(a[..., :3] * b[..., :3], axis=-1, keepdims=True)], axis=-1)
    return out
"""


@pytest.mark.parametrize("break_module,row", [
    (lambda source: source + WRONG_RATE, ENERGY_RUN),
    # gravity left out of gravity_vector: the gravity-free accelerations push the whole robot
    (lambda source: source.replace("return _evaluate(_gravity_body, [q], (NV,)",
                                   "return 0.0 * _evaluate(_gravity_body, [q], (NV,)"), MOMENTUM),
])
def test_the_check_rows_catch_a_wrong_module(tmp_path, break_module, row):
    from test_free_flyer import BOX

    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(path))
    source = render_code(derivation)
    assert {r.name: r.status for r in run_checks(derivation, source)}[row] == "pass"
    broken = break_module(source)
    assert broken != source
    assert {r.name: r.status for r in run_checks(derivation, broken)}[row] == "FAIL"
