"""The universal (Cardan) joint (DESIGN.md section 13): a turn about ``axis``, then about
``axis2`` (orthogonal to it), Pinocchio's ``JointModelUniversal(axis, axis2)``; coordinates
``<joint>_1, <joint>_2``, velocities their rates. Its first motion column turns with the
second angle, so the recursions take the joint's bias acceleration ``c_J`` (``base.Product``).

Random trees with full-precision numbers, generic axes and full inertia tensors mix universal
joints with revolute, prismatic, helical and fixed ones, on a fixed base (vector-space: the
sheet path's symbolic quantities too, through ``check``), with spherical joints and below a
floating base; the generated module equals Pinocchio (crba, rnea, aba, energies, Coriolis, ABA
derivatives, frames, integrate and difference) to 1e-9, but where Pinocchio 4's own
``computeABADerivatives`` and ``computeCoriolisMatrix`` leave out the joint's column rates
(against its own ``aba`` and ``rnea``: 2.7 and 0.29 off): there linearize against central
differences of its ``aba`` (1e-6) and C by its properties (``C v`` its bias, ``Mdot - 2 C``
skew). Then the robot file's ``axis2``."""

from __future__ import annotations

import random

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from joint_trees import CHECK_ROWS, check_passes_every_row, module_equals_pinocchio, tree_equals_pinocchio
from test_free_flyer import _module
from test_helical import _screws
from test_spherical import _tree

from random_robots3d import random_spatial_tree

pin = pytest.importorskip("pinocchio")
runner = CliRunner()


def _orthogonal(axis: list[float], rng: random.Random) -> list[float]:
    """A full-precision unit vector orthogonal to ``axis`` (the file's axis, any length)."""
    a = np.array(axis, dtype=float) / np.linalg.norm(axis)
    other = np.cross(a, [rng.uniform(-1, 1) for _ in range(3)])
    return [float(x) for x in other / np.linalg.norm(other)]


def _cardans(data: dict, rng: random.Random, count: int) -> dict:
    """``data`` with ``count`` of its revolute (or, if none is left, prismatic) joints made
    universal at random, each with a full-precision second axis orthogonal to its first."""
    revolute = [j for j in data["joints"] if j["type"] == "revolute"] or \
        [j for j in data["joints"] if j["type"] == "prismatic"]
    for joint in rng.sample(revolute, min(count, len(revolute))):
        joint["type"] = "universal"
        joint["axis2"] = _orthogonal(joint.get("axis", [0, 0, 1]), rng)
    data["name"] = "cardan_tree"
    return data


def _vector_space_tree(seed: int) -> str:
    """A random tree of universal, revolute, prismatic, helical and fixed joints, none welded
    to the world."""
    rng = random.Random(4000 + seed)
    trees = (yaml.safe_load(random_spatial_tree(rng, rng.randint(3, 5)).yaml_text) for _ in range(1000))
    data = next(d for d in trees if sum(j["type"] == "revolute" for j in d["joints"]) >= 3
                and not any(j["type"] == "fixed" and j["parent"] == "world" for j in d["joints"]))
    data = _cardans(_screws(data, rng, 1), rng, 2)
    return yaml.safe_dump(data, sort_keys=False)


@pytest.mark.pinocchio
@pytest.mark.parametrize("floating", [False, True], ids=["spherical_fixed_base", "floating_base"])
@pytest.mark.parametrize("seed", range(2))
def test_random_trees_with_universal_joints_equal_pinocchio(seed, floating, tmp_path):
    rng = random.Random(5000 + seed)
    robot, module, model = tree_equals_pinocchio(_cardans(yaml.safe_load(_tree(seed, floating)), rng, 2), "universal",
                                                 floating, seed, tmp_path, pinocchio_derivatives=False)
    assert "JointModelUniversal" in [j.shortname() for j in model.joints]
    cardan = next(j for j in robot.joints if j.type == "universal")
    assert {f"{cardan.name}_1", f"{cardan.name}_2"} <= set(module.COORDINATES)


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", range(2))
def test_a_vector_space_tree_with_universal_joints_checks_against_pinocchio_and_its_sheet(seed, tmp_path):
    """``check`` on a fixed-base tree with universal joints: the generated module against the
    sheet path's symbolic T, V, N, the property checks and Pinocchio, every row passing."""
    check_passes_every_row(_vector_space_tree(seed), tmp_path, CHECK_ROWS + (
        "centroidal: A_G qd, center_of_mass, total_mass = sum over the links (own kinematics)",))


@pytest.mark.pinocchio
def test_a_vector_space_tree_with_universal_joints_equals_pinocchio_by_the_module(tmp_path):
    module_equals_pinocchio(_vector_space_tree(7), "universal", tmp_path)


CARDAN = """name: cardan
title: A rod on a Cardan joint
parameters:
  m: 0.8
  l: 0.5
gravity: [0, 0, -9.81]
links:
  - {name: rod, mass: m, com: [0, 0, -l], inertia: [0.01, 0.01, 0.001, 0, 0, 0]}
joints:
  - {name: cardan, type: universal, parent: world, child: rod, axis: [1, 0, 0], AXIS2}
"""


def test_a_rod_on_a_cardan_joint_is_a_spherical_pendulum_in_two_angles(tmp_path):
    """A rod hanging from a universal joint about x, then y: M = diag(I_xx + m l^2 cos^2 ... )
    in closed form: the first angle's inertia (I_xx + m l^2) cos^2 q2 + (I_zz) sin^2 q2, the
    second's I_yy + m l^2; gravity m g l (sin q1 cos q2, cos q1 sin q2)."""
    path = tmp_path / "cardan.yaml"
    path.write_text(CARDAN.replace("AXIS2", "axis2: [0, 1, 0]"))
    robot = dynderive.load_robot(path)
    module = _module(robot, tmp_path)
    assert list(module.COORDINATES) == ["cardan_1", "cardan_2"] and module.NQ == module.NV == 2
    m, l, g, ixx, iyy, izz = 0.8, 0.5, 9.81, 0.01, 0.01, 0.001
    q = np.array([0.3, -0.7])
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    M11 = (ixx + m * l * l) * c2 * c2 + izz * s2 * s2
    np.testing.assert_allclose(module.mass_matrix(q), [[M11, 0], [0, iyy + m * l * l]], rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(module.gravity_vector(q), [m * g * l * np.sin(q[0]) * c2,
                                                          m * g * l * np.cos(q[0]) * s2], rtol=1e-13)


@pytest.mark.parametrize("axis2, message", [
    ("", "joints[0].type: a universal joint needs 'axis2'"),
    ("axis2: [1, 0]", "joints[0].axis2"),
])
def test_a_universal_joint_needs_a_second_axis(axis2, message, tmp_path):
    path = tmp_path / "cardan.yaml"
    path.write_text(CARDAN.replace(", AXIS2", f", {axis2}" if axis2 else ""))
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and message in lines[0] and lines[0].startswith(f"{path}:"), result.output
    assert not (tmp_path / "out").exists()
