"""Spherical joints (issue 30, DESIGN.md section 10): configuration a unit quaternion
``[qx, qy, qz, qw]``, velocity the link's angular velocity in its own frame (Pinocchio's
``JointModelSpherical``), anywhere in a 3-D tree, on a fixed base and on a floating one. The
generated NumPy module equals Pinocchio (crba, rnea, computeGeneralizedGravity, aba, energies,
computeCoriolisMatrix, computeABADerivatives, frame placements and Jacobians, integrate,
difference, neutral) to 1e-9 at random unit quaternions and velocities, on random trees with
full-precision numbers, generic axes and full inertia tensors. Then the input checks."""

from __future__ import annotations

import importlib.util
import random
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import MOMENTUM, run_checks
from dynderive.verify.pinocchio_model import pinocchio_maps
from test_free_flyer import _compare, _floating_tree, _module

from random_robots3d import random_spatial_tree

pin = pytest.importorskip("pinocchio")
runner = CliRunner()


def _spherical(data: dict, rng: random.Random, count: int) -> dict:
    """The robot ``data`` with ``count`` of its revolute or prismatic joints (at random, some
    scalar joint kept) made spherical (no axis; the first actuated, a torque ``ball_<joint>_tx
    ... _tz``, the others not), and a frame of random origin on every other link."""
    scalar = [j for j in data["joints"] if j["type"] in ("revolute", "prismatic")]
    for k, joint in enumerate(rng.sample(scalar, min(count, len(scalar) - 1))):
        joint["type"] = "spherical"
        joint.pop("axis", None)
        joint.pop("effort", None)
        if k == 0:
            joint["effort"] = f"ball_{joint['name']}"
    data["frames"] = [{"name": f"f_{link['name']}", "link": link["name"],
                       "origin": {"xyz": [rng.uniform(-0.5, 0.5) for _ in range(3)],
                                  "rpy": [rng.uniform(-3, 3) for _ in range(3)]}}
                      for link in data["links"][::2]]
    return data


def _tree(seed: int, floating: bool) -> str:
    """A random tree with two or three spherical joints among revolute, prismatic and fixed
    ones (``random_robots3d``), on a fixed base or below a floating base (``_floating_tree``)."""
    rng = random.Random(1000 + seed)
    if floating:   # the first of seed, seed + 100, ... with three scalar joints or more
        trees = (yaml.safe_load(_floating_tree(s)) for s in range(seed, seed + 10_000, 100))
        data = next(d for d in trees if sum(j["type"] in ("revolute", "prismatic") for j in d["joints"]) >= 3)
    else:   # no link welded to the world: Pinocchio leaves its (constant) potential energy out
        trees = (yaml.safe_load(random_spatial_tree(rng, rng.randint(4, 6), fixed=seed % 2 == 0).yaml_text)
                 for _ in range(1000))
        data = next(d for d in trees if not any(j["type"] == "fixed" and j["parent"] == "world" for j in d["joints"]))
    data = _spherical(data, rng, rng.randint(2, 3))
    data["name"] = "spherical_tree"
    return yaml.safe_dump(data, sort_keys=False)


def _pinocchio(robot):
    """Pinocchio's model (``pinocchio_maps``: spherical joints as ``JointModelSpherical``)
    with the robot's frames added, and where its q and v entries are in ours."""
    model, qp, vp = pinocchio_maps(robot, {})
    for frame in robot.frames:   # the frame's placement in its link's joint: up through the welds
        o = frame.origin
        place = pin.SE3(pin.rpy.rpyToMatrix(*(float(e) for e in o[3:])), np.array([float(e) for e in o[:3]]))
        joint = robot.parent_joint(frame.link)
        while not joint.moves and joint.parent != "world":
            o = joint.origin
            place = pin.SE3(pin.rpy.rpyToMatrix(*(float(e) for e in o[3:])), np.array([float(e) for e in o[:3]])) * place
            joint = robot.parent_joint(joint.parent)
        if not joint.moves:   # welded to the world
            o = joint.origin
            place = pin.SE3(pin.rpy.rpyToMatrix(*(float(e) for e in o[3:])), np.array([float(e) for e in o[:3]])) * place
        parent = model.getJointId(joint.name) if joint.moves else 0
        model.addFrame(pin.Frame(frame.name, parent, place, pin.FrameType.OP_FRAME))
    return model, qp, vp


def _aba_differences(model, q_pin, v_pin, tau, h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of Pinocchio's ``aba`` along each tangent direction of q
    (``integrate``) and of v: the references of ABA's derivatives where Pinocchio's own are
    not (its ``computeABADerivatives`` and ``computeCoriolisMatrix`` leave out a universal
    joint's own column rates: against its own ``aba`` and ``rnea``, 2.7 and 0.29 off)."""
    data, nv = model.createData(), model.nv
    step = lambda q, dv: pin.aba(model, data, pin.integrate(model, q, dv), v_pin, tau)  # noqa: E731
    dq = np.array([(step(q_pin, h * e) - step(q_pin, -h * e)) / (2 * h) for e in np.eye(nv)]).T
    dv = np.array([(pin.aba(model, data, q_pin, v_pin + h * e, tau) - pin.aba(model, data, q_pin, v_pin - h * e, tau))
                   / (2 * h) for e in np.eye(nv)]).T
    return dq, dv


def _coriolis_properties(model, C: np.ndarray, q_pin, v_pin, h: float = 1e-6) -> None:
    """``C v`` is Pinocchio's bias ``rnea(q, v, 0) - g(q)``, and ``Mdot - 2 C`` is
    skew-symmetric (Mdot by central differences of ``crba`` along ``integrate(q, v t)``)."""
    data = model.createData()
    bias = pin.rnea(model, data, q_pin, v_pin, np.zeros(model.nv)) - pin.computeGeneralizedGravity(model, data, q_pin)
    np.testing.assert_allclose(C @ v_pin, bias, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(bias))))

    def mass(t: float) -> np.ndarray:
        M = pin.crba(model, data, pin.integrate(model, q_pin, v_pin * t))
        return np.triu(M) + np.triu(M, 1).T

    S = (mass(h) - mass(-h)) / (2 * h) - 2 * C
    np.testing.assert_allclose(S + S.T, 0, rtol=0, atol=1e-6 * max(1.0, np.max(np.abs(C))))


def _compare_more(robot, module, model, qp, vp, seed: int, pinocchio_derivatives: bool = True) -> None:
    """What ``_compare`` does not: the Coriolis matrix, linearize (computeABADerivatives), the
    regressor (against inverse dynamics) and the frames' placements and LOCAL_WORLD_ALIGNED
    Jacobians. ``pinocchio_derivatives`` False (a model with universal joints): C by its
    properties against Pinocchio's ``rnea`` and ``crba``, linearize against central differences
    of its ``aba`` (``_aba_differences``)."""
    data = model.createData()
    rng = np.random.default_rng(seed)
    pin.seed(seed)
    nq, nv = model.nq, model.nv
    columns = list(robot.effort_columns())
    assert module.FRAMES == tuple(f.name for f in robot.frames) and module.FRAMES
    for _ in range(2):
        q_pin = pin.randomConfiguration(model, -np.ones(nq), np.ones(nq))
        v_pin = rng.normal(size=nv)
        q, v = np.empty(nq), np.empty(nv)
        q[qp], v[vp] = q_pin, v_pin
        u = rng.normal(size=len(module.EFFORTS))
        applied = np.zeros(nv)
        applied[columns] = u
        pin.computeABADerivatives(model, data, q_pin, v_pin, applied[vp])
        A, B = module.linearize(q, v, u)
        ours = module.coriolis_matrix(q, v)[np.ix_(vp, vp)]
        if pinocchio_derivatives:
            C = pin.computeCoriolisMatrix(model, data, q_pin, v_pin)
            np.testing.assert_allclose(ours, C, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(C))))
            dq, dv, tolerance = data.ddq_dq, data.ddq_dv, 1e-9
        else:
            _coriolis_properties(model, ours, q_pin, v_pin)
            (dq, dv), tolerance = _aba_differences(model, q_pin, v_pin, applied[vp]), 1e-6
        scale = max(1.0, np.max(np.abs(dq)), np.max(np.abs(dv)))
        np.testing.assert_allclose(A[nv:, :nv][np.ix_(vp, vp)], dq, rtol=0, atol=tolerance * scale)
        np.testing.assert_allclose(A[nv:, nv:][np.ix_(vp, vp)], dv, rtol=0, atol=tolerance * scale)
        Minv = data.Minv
        Minv = np.triu(Minv) + np.triu(Minv, 1).T
        np.testing.assert_allclose(B[nv:][vp], Minv[:, [list(vp).index(c) for c in columns]], rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(Minv))))
        a = rng.normal(size=nv)
        tau = module.inverse_dynamics(q, v, a)
        np.testing.assert_allclose(module.regressor(q, v, a) @ module.parameter_vector(), tau, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(tau))))
        pin.computeJointJacobians(model, data, q_pin)
        pin.updateFramePlacements(model, data)
        for frame in module.FRAMES:
            fid = model.getFrameId(frame)
            T = module.frame_transform(q, frame)
            np.testing.assert_allclose(T[:3, :3], data.oMf[fid].rotation, rtol=0, atol=1e-12)
            np.testing.assert_allclose(T[:3, 3], data.oMf[fid].translation, rtol=0, atol=1e-12)
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(module.frame_jacobian(q, frame)[:, vp], J, rtol=0, atol=1e-12)


@pytest.mark.pinocchio
@pytest.mark.parametrize("floating", [False, True], ids=["fixed_base", "floating_base"])
@pytest.mark.parametrize("seed", range(3))
def test_random_trees_with_spherical_joints_equal_pinocchio(seed, floating, tmp_path):
    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_tree(seed, floating))
    robot = dynderive.load_robot(path)
    kinds = [j.type for j in robot.joints]
    assert kinds.count("spherical") >= 2 and ("floating" in kinds) == floating
    assert {"revolute", "prismatic"} & set(kinds)
    assert robot.floating and robot.floating_base == floating
    model, qp, vp = _pinocchio(robot)
    spherical = [model.joints[model.getJointId(j.name)] for j in robot.joints if j.type == "spherical"]
    assert all(j.shortname() == "JointModelSpherical" for j in spherical)
    module = _module(robot, tmp_path)
    _compare(robot, module, model, qp, vp, seed)
    _compare_more(robot, module, model, qp, vp, seed)


PENDULUM = """name: ball_arm
title: An arm on a ball joint
planar: false
parameters:
  m: {value: 1.5, unit: kg}
  l: {value: 0.8, unit: m}
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: rod, mass: m, com: [0, 0, -l/2], inertia: [0.08, 0.08, 0.002, 0, 0, 0]}
  - {name: hand, mass: m/3, com: [0.1, 0, 0], inertia: [0.001, 0.004, 0.004, 0, 0, 0]}
joints:
  - {name: ball, type: spherical, parent: world, child: rod, origin: {xyz: [0, 0, 1]}}
  - {name: wrist, type: revolute, parent: rod, child: hand, origin: {xyz: [0, 0, -l]}, axis: [0, 1, 0], effort: tau}
"""


def _solve(tmp_path: Path, text: str, *args: str):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    return path, runner.invoke(app, ["solve", str(path), *args, "--out", str(tmp_path / "out")])


def test_a_fixed_base_robot_with_a_ball_joint_takes_the_floating_module(tmp_path):
    path, result = _solve(tmp_path, PENDULUM, "--code")
    assert result.exit_code == 0, result.output
    robot = dynderive.load_robot(path)
    assert robot.configuration_names == ("ball_qx", "ball_qy", "ball_qz", "ball_qw", "wrist")
    assert robot.velocity_count == 4 and robot.offsets() == ({"ball": 0, "wrist": 4}, {"ball": 0, "wrist": 3})
    assert robot.floating and not robot.floating_base and robot.quaternion_starts == (0,)
    text = (tmp_path / "out" / "ball_arm_dynamics.py").read_text()
    assert "NQ = 5" in text and "NV = 4" in text and "robot with quaternion joints" in text
    assert 'VELOCITIES = ("ball_wx", "ball_wy", "ball_wz", "wristd")' in text
    spec = importlib.util.spec_from_file_location("ball_arm_dynamics", tmp_path / "out" / "ball_arm_dynamics.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    np.testing.assert_array_equal(module.neutral_configuration(), [0, 0, 0, 1, 0])
    # a quarter turn about x at 1 rad/s: the quaternion (sin(pi/8), 0, 0, cos(pi/8)), the wrist moved
    moved = module.integrate(module.neutral_configuration(), [1.0, 0, 0, 0.5], np.pi / 4)
    np.testing.assert_allclose(moved, [np.sin(np.pi / 8), 0, 0, np.cos(np.pi / 8), np.pi / 8], atol=1e-15)
    rate = module.configuration_rate(moved, [0, 0, 2.0, 1.0])
    assert abs(float(rate[:4] @ moved[:4])) < 1e-15   # tangent to the unit sphere


def test_check_runs_the_rows_of_a_fixed_base_robot_with_a_ball_joint(tmp_path):
    """``check``'s rows pass (Pinocchio with a JointModelSpherical among them), and the momentum
    row is left out: a fixed base takes the world's reaction."""
    path, result = _solve(tmp_path, PENDULUM, "--code")
    assert result.exit_code == 0, result.output
    rows = run_checks(dynderive.derive(dynderive.load_robot(path)),
                               (tmp_path / "out" / "ball_arm_dynamics.py").read_text(), states=4)
    assert MOMENTUM not in [row.name for row in rows]
    assert any("Pinocchio" in row.name and row.status == "pass" for row in rows)
    assert all(row.status in ("pass", "skip") for row in rows), [(r.name, r.status) for r in rows]
    floating = _tree(5, True)
    (tmp_path / "floating.yaml").write_text(floating)
    robot = dynderive.load_robot(tmp_path / "floating.yaml")
    rows = run_checks(dynderive.derive(robot), render_code(dynderive.derive(robot)), states=3)
    assert [row.status for row in rows if row.name == MOMENTUM] == ["pass"]


def test_simulate_keeps_the_ball_joints_quaternion_unit(tmp_path):
    path = tmp_path / "ball_arm.yaml"
    path.write_text(PENDULUM)
    csv = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.3", "--qd0", "1, -2, 0.5, 1", "--csv",
                                 str(csv)])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("simulated 0.3 s of ball_arm (spherical joints, on the manifold)")
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    norms = np.linalg.norm(rows[:, 1:5], axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-9)
    assert np.max(np.abs(rows[-1, 1:4])) > 1e-3   # it moved


def _bad(tmp_path: Path, text: str) -> list[str]:
    path, result = _solve(tmp_path, text, "--code")
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
    return [line.removeprefix(f"{path}:") for line in result.stderr.splitlines()]


def test_spherical_joint_fields_that_are_refused(tmp_path):
    ball = "{name: ball, type: spherical, parent: world, child: rod, origin: {xyz: [0, 0, 1]}"
    assert _bad(tmp_path, PENDULUM.replace(ball, ball + ", axis: [0, 0, 1]")) == [
        "13:94: joints[0].axis: a spherical joint takes no axis (it turns about all three)"]
    assert _bad(tmp_path, PENDULUM.replace(ball, ball + ", stiffness: 2")) == [
        "13:88: joints[0].stiffness: drive terms on a spherical joint are not built yet"]
    assert _bad(tmp_path, PENDULUM.replace("  g: 9.81", "  g: 9.81\n  integrate: 1")) == [
        "8:3: parameters.integrate: name 'integrate' is reserved by the generated module of a robot with "
        "spherical joints"]
    assert _bad(tmp_path, PENDULUM.replace("  g: 9.81", "  g: 9.81\n  ball_qw: 1")) == [
        "14:12: joints[0].name (coordinate 'ball_qw'): name 'ball_qw' clashes with parameters.ball_qw (first at 8:3)"]
