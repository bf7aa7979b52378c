"""The helical (screw) joint (DESIGN.md section 13): one angle about its unit axis, moving
``pitch`` along it per radian, Pinocchio's ``JointModelHelicalUnaligned(axis, pitch)``.

Random trees with full-precision numbers, generic axes and full inertia tensors mix helical
joints with revolute, prismatic and fixed ones, on a fixed base (vector-space: the sheet path's
symbolic quantities too, through ``check``), with spherical joints and below a floating base;
the generated module equals Pinocchio (crba, rnea, aba, energies, Coriolis, ABA derivatives,
frames, integrate and difference) to 1e-9. Then the robot file's ``pitch``."""

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
from test_spherical import _tree

from random_robots3d import random_spatial_tree

pin = pytest.importorskip("pinocchio")
runner = CliRunner()


def _screws(data: dict, rng: random.Random, count: int) -> dict:
    """``data`` with ``count`` of its revolute (or, if none is left, prismatic) joints made
    helical at random, each with a full-precision pitch of either sign, the first one's a
    parameter's expression."""
    revolute = [j for j in data["joints"] if j["type"] == "revolute"] or \
        [j for j in data["joints"] if j["type"] == "prismatic"]
    for k, joint in enumerate(rng.sample(revolute, min(count, len(revolute)))):
        joint["type"] = "helical"
        pitch = rng.uniform(0.01, 0.2) * rng.choice((-1, 1))
        if k == 0:
            data.setdefault("parameters", {})["lead"] = pitch * 2
            joint["pitch"] = "lead/2"
        else:
            joint["pitch"] = pitch
    data["name"] = "screw_tree"
    return data


def _vector_space_tree(seed: int) -> str:
    """A random tree of revolute, prismatic, helical and fixed joints, none welded to the world."""
    rng = random.Random(2000 + seed)
    trees = (yaml.safe_load(random_spatial_tree(rng, rng.randint(3, 5)).yaml_text) for _ in range(1000))
    data = next(d for d in trees if sum(j["type"] == "revolute" for j in d["joints"]) >= 2
                and not any(j["type"] == "fixed" and j["parent"] == "world" for j in d["joints"]))
    return yaml.safe_dump(_screws(data, rng, 2), sort_keys=False)


@pytest.mark.pinocchio
@pytest.mark.parametrize("floating", [False, True], ids=["spherical_fixed_base", "floating_base"])
@pytest.mark.parametrize("seed", range(2))
def test_random_trees_with_helical_joints_equal_pinocchio(seed, floating, tmp_path):
    rng = random.Random(3000 + seed)
    _, _, model = tree_equals_pinocchio(_screws(yaml.safe_load(_tree(seed, floating)), rng, 2), "helical", floating,
                                        seed, tmp_path)
    assert "JointModelHelicalUnaligned" in [j.shortname() for j in model.joints]


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", range(2))
def test_a_vector_space_tree_with_helical_joints_checks_against_pinocchio_and_its_sheet(seed, tmp_path):
    """``check`` on a fixed-base tree with helical joints: the generated module against the
    sheet path's symbolic T, V, N (and M, C where small enough), the property checks and
    Pinocchio (crba, rnea, aba; the centroidal functions), every row passing."""
    check_passes_every_row(_vector_space_tree(seed), tmp_path, CHECK_ROWS + (
        "centroidal: A_G qd, center_of_mass, total_mass = sum over the links (own kinematics)",))


@pytest.mark.pinocchio
def test_a_vector_space_tree_with_helical_joints_equals_pinocchio_by_the_module(tmp_path):
    module_equals_pinocchio(_vector_space_tree(7), "helical", tmp_path)


SCREW = """name: screw
title: A nut on a screw
parameters:
  m: 0.7
  h: 0.004
gravity: [0, 0, -9.81]
links:
  - {name: nut, mass: m, com: [0, 0, 0], inertia: [0.001, 0.001, 0.002, 0, 0, 0]}
joints:
  - {name: turn, type: helical, parent: world, child: nut, axis: [0, 0, 1], PITCH}
"""


@pytest.mark.parametrize("pitch, message", [
    ("", "joints[0].type: a helical joint needs 'pitch' (translation along the axis per radian, an expression)"),
    ("pitch: [1, 2]", "joints[0].pitch: expected a number or an expression, got list"),
    ("pitch: h*q", "joints[0].pitch: undeclared symbol 'q'"),
])
def test_a_helical_joint_needs_a_pitch_expression(pitch, message, tmp_path):
    path = tmp_path / "screw.yaml"
    path.write_text(SCREW.replace(", PITCH", f", {pitch}" if pitch else ""))
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and message in lines[0] and lines[0].startswith(f"{path}:"), result.output
    assert not (tmp_path / "out").exists()


def test_only_a_helical_joint_takes_a_pitch(tmp_path):
    path = tmp_path / "screw.yaml"
    path.write_text(SCREW.replace("type: helical", "type: revolute").replace("PITCH", "pitch: h"))
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "joints[0].pitch: a revolute joint takes no pitch" in result.output


def test_a_nut_on_a_screw_falls_as_its_closed_form(tmp_path):
    """One helical joint on a vertical axis: the nut's effective inertia is I_zz + m h^2, and
    gravity pulls along the axis, N = m g h (the textbook screw; pitch h per radian)."""
    path = tmp_path / "screw.yaml"
    path.write_text(SCREW.replace("PITCH", "pitch: h"))
    module = _module(dynderive.load_robot(path), tmp_path)
    m, h, izz, g = 0.7, 0.004, 0.002, 9.81
    q = np.array([0.3])
    np.testing.assert_allclose(module.mass_matrix(q), [[izz + m * h * h]], rtol=1e-14)
    np.testing.assert_allclose(module.gravity_vector(q), [m * g * h], rtol=1e-14)
    np.testing.assert_allclose(module.forward_dynamics(q, np.array([0.5]), np.zeros(0)),
                               [-m * g * h / (izz + m * h * h)], rtol=1e-13)
