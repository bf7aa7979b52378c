"""The KanesMethod anchor of the benchmarks (``benchmarks/anchors.py``) builds the same robot.

Its mass matrix and forcing vector are compared, numerically at random states, with an
independent Pinocchio model (``dynderive.verify.pinocchio_model``) and with dynderive's own mass
matrix; the trigsimp child process and the command line are exercised on small robots.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))
import anchors  # noqa: E402

from conftest import stable_seed  # noqa: E402

ROBOTS = ["rp_arm", "cart_pole", "double_pendulum", "elbow_arm", "pendulum3", "robots/ur5.urdf"]
TOL = 1e-9


#: random trees of ``tests/random_robots*.py`` (kind, seed, moving joints) that Kane handles fast:
#: branches, fixed welds, prismatic joints, general axes, origins and inertia tensors
TREES = [("spatial", 0, 2), ("spatial", 7, 3), ("planar", 0, 3), ("planar", 2, 5)]


@cache
def kane_of(name: str):
    if name.startswith(("spatial:", "planar:")):
        import random
        import tempfile

        from random_robots import random_planar_tree
        from random_robots3d import random_spatial_tree

        kind, seed, joints = name.split(":")
        make = random_spatial_tree if kind == "spatial" else random_planar_tree
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "tree.yaml"
            path.write_text(make(random.Random(int(seed)), int(joints)).yaml_text)
            robot = dynderive.load_robot(path)
    else:
        robot = anchors.load(name)
    return robot, anchors.kane_equations(robot)


def defaults(robot) -> dict[str, float]:
    return {p.name: p.value for p in robot.parameters if p.value is not None}


def assert_close(actual: np.ndarray, expected: np.ndarray) -> None:
    scale = max(1.0, float(np.abs(expected).max()))
    np.testing.assert_allclose(actual, expected, rtol=TOL, atol=TOL * scale)


@pytest.mark.pinocchio
@pytest.mark.parametrize("name", ROBOTS + [f"{kind}:{seed}:{joints}" for kind, seed, joints in TREES])
def test_kane_matches_pinocchio(name):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    robot, result = kane_of(name)
    model, perm = pinocchio_model(robot, defaults(robot))
    data = model.createData()
    n = len(robot.coordinates)
    rng = np.random.default_rng(stable_seed(name))
    for _ in range(2):
        q = rng.uniform(-np.pi, np.pi, n)
        expected = pin.crba(model, data, q[perm])
        expected = np.triu(expected) + np.triu(expected, 1).T
        assert_close(anchors.numeric_mass_matrix(result, q)[np.ix_(perm, perm)], expected)
    q, u = rng.uniform(-np.pi, np.pi, (2, n))
    # Kane's forcing (u = qdot, efforts zero) is -(C qd + N) = -rnea(q, v, 0)
    bias = pin.rnea(model, data, q[perm], u[perm], np.zeros(n))
    assert_close(anchors.numeric_forcing(result, q, u)[perm], -bias)


@pytest.mark.parametrize("name", ["rp_arm", "cart_pole", "elbow_arm", "robots/ur5.urdf"])
def test_efforts_enter_the_forcing_at_their_joints(name):
    robot, result = kane_of(name)
    n = len(robot.coordinates)
    rng = np.random.default_rng(7)
    q, u = rng.uniform(-1, 1, (2, n))
    taus = {joint.effort: float(rng.uniform(-5, 5)) for joint in robot.joints if joint.moves and joint.effort}
    expected = np.zeros(n)
    for k, name_k in enumerate(robot.coordinates):
        effort = next(j.effort for j in robot.joints if j.name == name_k)
        expected[k] = taus.get(effort, 0.0)
    difference = anchors.numeric_forcing(result, q, u, taus) - anchors.numeric_forcing(result, q, u)
    assert_close(difference, expected)
    assert {str(s) for s in result["forcing"].free_symbols if isinstance(s, sympy.Symbol)} == set(taus) | {"t"}


@pytest.mark.parametrize("name", ["rp_arm", "elbow_arm"])
def test_kane_matches_dynderive_mass_matrix(name):
    robot, result = kane_of(name)
    derivation = dynderive.derive(robot)
    table = derivation.symbols
    mass_matrix = derivation["M_g"].xreplace({s: sympy.Float(v) for s, v in table.defaults(robot).items()})
    function = sympy.lambdify([table.q], mass_matrix, "numpy")
    rng = np.random.default_rng(3)
    for _ in range(2):
        q = rng.uniform(-np.pi, np.pi, len(table.q))
        assert_close(anchors.numeric_mass_matrix(result, q), np.array(function(q), dtype=float))


def test_the_model_is_numeric_in_the_parameters():
    robot = anchors.load("elbow_arm")
    q, u, bodies, loads, kd_eqs, frame, values = anchors.kane_model(robot)
    assert {str(s) for s in values} == {p.name for p in robot.parameters}
    assert values[sympy.Symbol("g")] == sympy.Rational(981, 100)
    _, result = kane_of("elbow_arm")
    symbols = {str(s) for s in result["mass_matrix"].free_symbols}
    assert symbols <= {"t"}
    assert len(q) == len(u) == len(kd_eqs) == 3 and len(bodies) == 3
    assert result["mass_matrix_ops"] == anchors.ops(result["mass_matrix"]) > 0
    assert result["forcing_ops"] > 0 and result["setup_s"] > 0 and result["kane_s"] > 0


def test_trigsimp_in_a_child_process():
    robot, result = kane_of("double_pendulum")
    simplified = anchors.kane_trigsimp(robot, timeout_s=60)
    assert simplified["timed_out"] is False
    assert simplified["trigsimp_s"] > 0
    assert 0 < simplified["mass_matrix_ops"] <= result["mass_matrix_ops"]
    assert 0 < simplified["forcing_ops"] <= result["forcing_ops"]


def test_trigsimp_times_out():
    simplified = anchors.kane_trigsimp(anchors.load("elbow_arm"), timeout_s=0.05)
    assert simplified == {"trigsimp_s": None, "mass_matrix_ops": None, "forcing_ops": None, "timed_out": True}


def test_trigsimp_child_failure_is_an_error():
    robot = anchors.load("rp_arm")
    broken = dataclasses.replace(robot, links=(dataclasses.replace(robot.links[0], mass="undeclared"),
                                               *robot.links[1:]))
    with pytest.raises(RuntimeError, match="trigsimp child failed"):
        anchors.kane_trigsimp(broken, timeout_s=60)


def test_one_link_robot():
    robot = anchors.load("pendulum1")
    result = anchors.kane_equations(robot)
    # a uniform rod about its end: m l**2 / 3
    assert_close(anchors.numeric_mass_matrix(result, [0.3]), np.array([[1 / 3]]))
    assert_close(anchors.numeric_forcing(result, [0.0], [0.0]), np.array([-9.81 / 2]))


def test_command_line_prints_one_json_line():
    output = subprocess.run([sys.executable, str(BENCHMARKS / "anchors.py"), "rp_arm"],
                            capture_output=True, text=True, check=True).stdout
    lines = output.strip().splitlines()
    assert len(lines) == 1
    row = json.loads(lines[0])
    assert row["robot"] == "rp_arm" and row["dof"] == 2
    assert {"setup_s", "kane_s", "mass_matrix_ops", "forcing_ops"} <= set(row)
    assert "mass_matrix" not in row and "forcing" not in row
