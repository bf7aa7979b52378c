"""The 3-D planar joint (DESIGN.md section 13): x and y in the plane normal to its unit axis,
then theta about it; coordinates ``<joint>_x, <joint>_y, <joint>_theta``, velocities their
rates. Its x and y columns turn with theta, so the recursions take its bias ``c_J``.

Random trees with full-precision numbers, generic axes and full inertia tensors mix planar
joints with revolute, prismatic, helical, universal and fixed ones, on a fixed base (the sheet
path's symbolic quantities too, through ``check``), with spherical joints and below a floating
base; the generated module equals Pinocchio's composite of the three motions (crba, rnea, aba,
energies, frames, integrate and difference) to 1e-9, linearize central differences of its
``aba`` and C its bias with ``Mdot - 2 C`` skew. Against Pinocchio's own ``JointModelPlanar``
(axis z; configuration ``(x, y, cos theta, sin theta)``, local velocity ``G v`` with ``G =
diag(R(theta)^T, 1)``): ``M = G^T M_pin G``, ``N = G^T N_pin``, the energies equal."""

from __future__ import annotations

import random

import numpy as np
import pytest
import yaml

import dynderive
from joint_trees import check_passes_every_row, tree_equals_pinocchio
from test_free_flyer import _module
from test_helical import _screws
from test_spherical import _pinocchio, _tree
from test_universal import _cardans

from random_robots3d import random_spatial_tree

pin = pytest.importorskip("pinocchio")


def _planes(data: dict, rng: random.Random, count: int) -> dict:
    """``data`` with ``count`` of its revolute or prismatic joints made planar at random (their
    axis the plane's normal)."""
    scalar = [j for j in data["joints"] if j["type"] in ("revolute", "prismatic")]
    for joint in rng.sample(scalar, min(count, len(scalar))):
        joint["type"] = "planar"
    data["name"] = "plane_tree"
    return data


def _vector_space_tree(seed: int) -> str:
    rng = random.Random(6000 + seed)
    trees = (yaml.safe_load(random_spatial_tree(rng, rng.randint(4, 5)).yaml_text) for _ in range(1000))
    data = next(d for d in trees if sum(j["type"] == "revolute" for j in d["joints"]) >= 3
                and not any(j["type"] == "fixed" and j["parent"] == "world" for j in d["joints"]))
    return yaml.safe_dump(_planes(_cardans(_screws(data, rng, 1), rng, 1), rng, 1), sort_keys=False)


@pytest.mark.pinocchio
@pytest.mark.parametrize("floating", [False, True], ids=["spherical_fixed_base", "floating_base"])
@pytest.mark.parametrize("seed", range(2))
def test_random_trees_with_planar_joints_equal_pinocchio(seed, floating, tmp_path):
    rng = random.Random(7000 + seed)
    robot, module, _ = tree_equals_pinocchio(_planes(yaml.safe_load(_tree(seed, floating)), rng, 2), "planar",
                                             floating, seed, tmp_path, pinocchio_derivatives=False)
    planar = next(j for j in robot.joints if j.type == "planar")
    assert {f"{planar.name}_{s}" for s in ("x", "y", "theta")} <= set(module.COORDINATES)


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", range(2))
def test_a_vector_space_tree_with_planar_joints_checks_against_pinocchio_and_its_sheet(seed, tmp_path):
    """``check`` on a fixed-base tree with a planar, a universal and a helical joint: the
    module against the sheet path's symbolic T, V, N, the property checks and Pinocchio."""
    check_passes_every_row(_vector_space_tree(seed), tmp_path)


PUCK = """name: puck
title: A puck on a table, a pendulum on it
parameters:
  m: 0.9
  l: 0.3
gravity: [0, 0, -9.81]
links:
  - {name: puck, mass: m, com: [0.0123, -0.0311, 0.02], inertia: [0.002, 0.0021, 0.003, 0.0001, -0.0002, 0.00015]}
  - {name: bob, mass: 0.31, com: [0, 0, -l], inertia: [0.0011, 0.0012, 0.0004, 0.00002, 0, 0.00003]}
joints:
  - {name: slide, type: planar, parent: world, child: puck, effort: f}
  - {name: swing, type: revolute, parent: puck, child: bob, origin: {xyz: [0.05, 0.02, 0.1]}, axis: [0.6, 0.8, 0], effort: t}
"""


def _pinocchio_planar(model):
    """``model`` with its composite (planar) joint replaced by Pinocchio's ``JointModelPlanar``."""
    other = pin.Model()
    other.gravity = model.gravity
    for k in range(1, model.njoints):
        joint = model.joints[k]
        joint = pin.JointModelPlanar() if joint.shortname() == "JointModelComposite" else joint
        added = other.addJoint(model.parents[k], joint, model.jointPlacements[k], model.names[k])
        other.appendBodyToJoint(added, model.inertias[k], pin.SE3.Identity())
    return other


def test_a_planar_joint_equals_pinocchio_s_joint_model_planar_through_its_velocity_map(tmp_path):
    path = tmp_path / "puck.yaml"
    path.write_text(PUCK)
    robot = dynderive.load_robot(path)
    module = _module(robot, tmp_path)
    assert module.COORDINATES == ("slide_x", "slide_y", "slide_theta", "swing") and module.NQ == module.NV == 4
    assert module.EFFORTS == ("f_x", "f_y", "f_theta", "t")
    composite, qp, vp = _pinocchio(robot)
    assert list(qp) == list(vp) == [0, 1, 2, 3]
    model = _pinocchio_planar(composite)
    data, rng = model.createData(), np.random.default_rng(3)
    for _ in range(4):
        q, v = rng.uniform(-1, 1, 4), rng.uniform(-1, 1, 4)
        c, s = np.cos(q[2]), np.sin(q[2])
        q_pin = np.array([q[0], q[1], c, s, q[3]])
        G = np.eye(4)
        G[:2, :2] = [[c, s], [-s, c]]   # R(theta)^T: the local velocity
        M = pin.crba(model, data, q_pin)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(module.mass_matrix(q), G.T @ M @ G, rtol=0, atol=1e-12)
        gravity = pin.computeGeneralizedGravity(model, data, q_pin)
        np.testing.assert_allclose(module.gravity_vector(q), G.T @ gravity, rtol=0, atol=1e-12)
        pin.computeAllTerms(model, data, q_pin, G @ v)
        np.testing.assert_allclose(module.kinetic_energy(q, v), pin.computeKineticEnergy(model, data, q_pin, G @ v),
                                   rtol=0, atol=1e-13)
        np.testing.assert_allclose(module.potential_energy(q), pin.computePotentialEnergy(model, data, q_pin),
                                   rtol=0, atol=1e-12)
