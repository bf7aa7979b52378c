"""Frames (issue 19): pose, world-frame Jacobian, ``Jdot qd`` and external wrenches.

The generated functions are compared with Pinocchio (``updateFramePlacements``,
``getFrameJacobian`` in ``LOCAL_WORLD_ALIGNED``, ``getFrameClassicalAcceleration``, ``rnea``
and ``aba`` with external forces) on random planar and 3-D trees with frames at
full-precision origins on random links, with the symbolic quantities (``p_f``, ``J_f``,
``Jdot_f``) and with finite differences; the URDF reader's frames against Pinocchio's own
URDF parser.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.errors import InputError

from conftest import import_code, text_derivation
from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

ROOT = Path(__file__).resolve().parents[1]
TOL = {"rtol": 1e-9, "atol": 1e-9}


def _with_frames(yaml_text: str, links: list[str], planar: bool, rng: random.Random) -> str:
    """The robot file with a frame on each of ``links``, at full-precision origins."""
    lines = [yaml_text.rstrip("\n"), "frames:"]
    for i, link in enumerate(links):
        if planar:
            origin = "[" + ", ".join(repr(rng.uniform(-1, 1)) for _ in range(3)) + "]"
        else:
            xyz = ", ".join(repr(rng.uniform(-1, 1)) for _ in range(3))
            rpy = ", ".join(repr(rng.uniform(-3, 3)) for _ in range(3))
            origin = f"{{xyz: [{xyz}], rpy: [{rpy}]}}"
        lines += [f"  - name: f{i}", f"    link: {link}", f"    origin: {origin}"]
    return "\n".join(lines) + "\n"


def _robot(kind: str, seed: int, n: int, directory: str):
    rng = random.Random(seed)
    tree = random_planar_tree(rng, n) if kind == "planar" else random_spatial_tree(rng, n)
    names = [link.name for link in tree.links]
    chosen = [names[-1], *rng.sample(names, 2)]
    text = _with_frames(tree.yaml_text, chosen, kind == "planar", rng)
    return text_derivation(f"frames_{kind}_{seed}_{n}", text, directory)


CASES = [("planar", 0, 3), ("planar", 3, 4), ("spatial", 1, 3), ("spatial", 4, 5)]


@pytest.fixture(scope="module")
def directory(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("frames"))


def _states(n: int, count: int = 4, seed: int = 7):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)) for _ in range(count)]


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, seed, n", CASES)
def test_frames_match_pinocchio(kind, seed, n, directory):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    derivation, module = _robot(kind, seed, n, directory)
    robot = derivation.robot
    model, perm = pinocchio_model(robot, {})
    data = model.createData()
    rows = [0, 1, 5] if robot.planar else list(range(6))
    for q, qd, _ in _states(n):
        qp, vp = q[perm], qd[perm]
        pin.forwardKinematics(model, data, qp, vp, np.zeros(n))
        pin.computeJointJacobians(model, data, qp)
        pin.updateFramePlacements(model, data)
        for name in module.FRAMES:
            fid = model.getFrameId(name)
            placement = data.oMf[fid]
            transform = module.frame_transform(q, name)
            if robot.planar:
                np.testing.assert_allclose(transform[:2, :2], placement.rotation[:2, :2], **TOL)
                np.testing.assert_allclose(transform[:2, 2], placement.translation[:2], **TOL)
                np.testing.assert_allclose(transform[2], [0, 0, 1], **TOL)
            else:
                np.testing.assert_allclose(transform[:3, :3], placement.rotation, **TOL)
                np.testing.assert_allclose(transform[:3, 3], placement.translation, **TOL)
                np.testing.assert_allclose(transform[3], [0, 0, 0, 1], **TOL)
            jacobian = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[rows]
            np.testing.assert_allclose(module.frame_jacobian(q, name)[:, perm], jacobian, **TOL)
            acceleration = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            expected = np.concatenate([acceleration.linear, acceleration.angular])[rows]
            np.testing.assert_allclose(module.frame_jacobian_dot_qd(q, qd, name), expected, **TOL)


def _pinocchio_forces(pin, model, data, robot, module, q, wrenches):
    """The wrenches (world axes, moment about the frame origin) as Pinocchio's per-joint
    external forces, each in its joint's local frame."""
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    forces = [pin.Force.Zero() for _ in range(model.njoints)]
    for name, w in wrenches.items():
        fid = model.getFrameId(name)
        joint = model.frames[fid].parentJoint
        if robot.planar:
            f, n = np.array([w[0], w[1], 0.0]), np.array([0.0, 0.0, w[2]])
        else:
            f, n = np.asarray(w[:3]), np.asarray(w[3:])
        origin = data.oMi[joint]
        about_joint = n + np.cross(data.oMf[fid].translation - origin.translation, f)
        local = pin.Force(origin.rotation.T @ f, origin.rotation.T @ about_joint)
        forces[joint] = forces[joint] + local
    return forces


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, seed, n", CASES)
def test_wrenches_match_pinocchio(kind, seed, n, directory):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    derivation, module = _robot(kind, seed, n, directory)
    robot = derivation.robot
    model, perm = pinocchio_model(robot, {})
    data = model.createData()
    rng = np.random.default_rng(3)
    size = 3 if robot.planar else 6
    for q, qd, qdd in _states(n):
        wrenches = {name: rng.uniform(-5, 5, size) for name in module.FRAMES}
        forces = _pinocchio_forces(pin, model, data, robot, module, q[perm], wrenches)
        tau = module.inverse_dynamics(q, qd, qdd, wrenches)
        np.testing.assert_allclose(tau[perm], pin.rnea(model, data, q[perm], qd[perm], qdd[perm], forces), **TOL)
        u = rng.uniform(-3, 3, len(module.EFFORTS))
        qdd_ours = module.forward_dynamics(q, qd, u, wrenches)
        effort = module.generalized_forces(q, u)
        expected = pin.aba(model, data, q[perm], qd[perm], effort[perm], forces)
        np.testing.assert_allclose(qdd_ours[perm], expected, **TOL)
        # the round trip: the efforts that give qdd under the wrenches
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd_ours, wrenches), effort, **TOL)


@pytest.mark.parametrize("kind, seed, n", CASES[:3])
def test_jacobian_dot_qd_is_the_time_derivative(kind, seed, n, directory):
    _, module = _robot(kind, seed, n, directory)
    h = 1e-6
    for q, qd, _ in _states(n, count=2):
        for name in module.FRAMES:
            ahead = module.frame_jacobian(q + h * qd, name) @ qd
            behind = module.frame_jacobian(q - h * qd, name) @ qd
            np.testing.assert_allclose(module.frame_jacobian_dot_qd(q, qd, name), (ahead - behind) / (2 * h),
                                       rtol=1e-6, atol=1e-6)
            # the position's derivative is the linear rows
            linear = slice(0, 2) if len(ahead) == 3 else slice(0, 3)
            p_ahead = module.frame_transform(q + h * qd, name)[linear, -1]
            p_behind = module.frame_transform(q - h * qd, name)[linear, -1]
            np.testing.assert_allclose((module.frame_jacobian(q, name) @ qd)[linear], (p_ahead - p_behind) / (2 * h),
                                       rtol=1e-6, atol=1e-6)


def test_frame_functions_broadcast_over_batches(directory):
    _, module = _robot("spatial", 1, 3, directory)
    states = _states(3, count=5)
    q = np.array([s[0] for s in states])
    qd = np.array([s[1] for s in states])
    batch = module.frame_jacobian_dot_qd(q, qd, "f0")
    assert batch.shape == (5, 6)
    assert module.frame_transform(q.reshape(5, 1, 3), "f1").shape == (5, 1, 4, 4)
    for k in range(5):
        np.testing.assert_allclose(batch[k], module.frame_jacobian_dot_qd(q[k], qd[k], "f0"), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.frame_jacobian(q, "f2")[k], module.frame_jacobian(q[k], "f2"),
                                   rtol=1e-12, atol=1e-12)


RP_TOOL = (ROOT / "robots" / "rp_arm.yaml").read_text().replace(
    "maximal:", "frames:\n  - name: tool\n    link: link2\n    origin: [l, 0.1, 0.3]\nmaximal:")


def test_symbolic_frame_quantities_match_the_generated_functions(directory):
    derivation, module = text_derivation("rp_tool", RP_TOOL, directory)
    table = derivation.symbols
    l, q1, q2 = table.parameters["l"], *table.q
    # by hand: link 2's frame sits q2 along link 1's direction (angle q1), the tool at (l, 0.1)
    # in link 2's frame, turned by 0.3
    expected = sympy.Matrix([(l + q2) * sympy.cos(q1) - sympy.sin(q1) / 10,
                             (l + q2) * sympy.sin(q1) + sympy.cos(q1) / 10])
    assert sympy.simplify(derivation["p_tool"] - expected) == sympy.zeros(2, 1)
    assert derivation["theta_tool"] == sympy.Matrix([[q1 + sympy.Rational(3, 10)]])
    assert derivation["J_tool"].shape == (3, 2) and derivation["Jdot_tool"].shape == (3, 2)
    values = {table.parameters[p.name]: p.value for p in derivation.robot.parameters}
    for q, qd, _ in _states(2):
        point = {**dict(zip(table.q, q)), **dict(zip(table.qd, qd)), **values}

        def number(m, point=point):
            return np.array(m.xreplace(point).evalf(), dtype=float)

        np.testing.assert_allclose(number(derivation["J_tool"]), module.frame_jacobian(q, "tool"), **TOL)
        np.testing.assert_allclose(number(derivation["Jdot_tool"] * sympy.Matrix(qd)).ravel(),
                                   module.frame_jacobian_dot_qd(q, qd, "tool"), **TOL)
        np.testing.assert_allclose(number(derivation["p_tool"]).ravel(), module.frame_transform(q, "tool")[:2, 2], **TOL)


def test_symbolic_spatial_frame_matches_the_generated_functions(directory):
    text = _with_frames(random_spatial_tree(random.Random(2), 3).yaml_text, ["b3", "b1"], False, random.Random(5))
    derivation, module = text_derivation("spatial_symbolic_frames", text, directory)
    table = derivation.symbols
    for q, qd, _ in _states(3, count=2):
        point = {**dict(zip(table.q, q)), **dict(zip(table.qd, qd))}

        def number(m, point=point):
            return np.array(m.xreplace(point).evalf(), dtype=float)

        for name in ("f0", "f1"):
            transform = module.frame_transform(q, name)
            np.testing.assert_allclose(number(derivation[f"R_{name}"]), transform[:3, :3], **TOL)
            np.testing.assert_allclose(number(derivation[f"p_{name}"]).ravel(), transform[:3, 3], **TOL)
            np.testing.assert_allclose(number(derivation[f"J_{name}"]), module.frame_jacobian(q, name), **TOL)
            np.testing.assert_allclose(number(derivation[f"Jdot_{name}"] * sympy.Matrix(qd)).ravel(),
                                       module.frame_jacobian_dot_qd(q, qd, name), **TOL)


def test_frame_quantities_are_in_the_json(directory):
    import json

    derivation, _ = text_derivation("rp_tool", RP_TOOL, directory)
    quantities = json.loads(dynderive.render_json(derivation))["quantities"]
    for key in ("p_tool", "theta_tool", "J_tool", "Jdot_tool"):
        assert key in quantities and quantities[key]["description"]
    assert quantities["J_tool"]["shape"] == [3, 2]


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot, frame", [("ur5", "tool0"), ("panda", "panda_link8")])
def test_urdf_welded_links_become_frames(robot, frame, generated):
    """The reader's frames against Pinocchio's own URDF parser (the same file)."""
    pin = pytest.importorskip("pinocchio")
    module = generated(robot)
    assert frame in module.FRAMES
    model = pin.buildModelFromUrdf(str(ROOT / "robots" / f"{robot}.urdf"))
    data = model.createData()
    names = [model.names[i] for i in range(1, model.njoints)]
    perm = np.array([module.COORDINATES.index(name) for name in names])
    rng = np.random.default_rng(11)
    fid = model.getFrameId(frame)
    for _ in range(3):
        q, qd = rng.uniform(-2, 2, model.nq), rng.uniform(-2, 2, model.nq)
        pin.forwardKinematics(model, data, q[perm], qd[perm], np.zeros(model.nq))
        pin.computeJointJacobians(model, data, q[perm])
        pin.updateFramePlacements(model, data)
        transform = module.frame_transform(q, frame)
        np.testing.assert_allclose(transform[:3, :3], data.oMf[fid].rotation, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(transform[:3, 3], data.oMf[fid].translation, rtol=1e-9, atol=1e-9)
        jacobian = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(module.frame_jacobian(q, frame)[:, perm], jacobian, rtol=1e-9, atol=1e-9)


def test_unknown_frames_and_bad_wrenches_are_refused(directory):
    _, module = text_derivation("rp_tool", RP_TOOL, directory)
    with pytest.raises(ValueError, match=r"unknown frame 'flange' \(frames: tool\)"):
        module.frame_jacobian([0.1, 0.2], "flange")
    with pytest.raises(ValueError, match="must have shape"):
        module.inverse_dynamics([0.1, 0.2], [0, 0], [0, 0], {"tool": [1.0, 2.0]})
    rp = import_code(dynderive.render_code(dynderive.derive(dynderive.load_robot("rp_arm"))), Path(directory), "rp_plain")
    assert rp.FRAMES == ()
    with pytest.raises(ValueError, match="declares no 'frames'"):
        rp.forward_dynamics([0.1, 0.2], [0, 0], None, {"tool": [1.0, 2.0, 0.0]})
    np.testing.assert_allclose(rp.forward_dynamics([0.1, 0.2], [0, 0], None, None),
                               rp.forward_dynamics([0.1, 0.2], [0, 0]))


def test_frame_errors_are_positioned(tmp_path):
    text = RP_TOOL.replace("link: link2", "link: link9") + "\n"
    text = text.replace("maximal:", "  - name: tool\n    link: world\nmaximal:", 1)
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as error:
        dynderive.load_robot(path)
    messages = [str(p) for p in error.value.problems]
    assert any("frames[0]" in m and "unknown link 'link9'" in m and "did you mean 'link2'" in m for m in messages)
    assert any("frames[1]" in m and "duplicate frame name 'tool'" in m for m in messages)
    assert any("frames[1]" in m and "a frame on the world is fixed" in m for m in messages)


LIFT = """name: lift
planar: true
parameters: {m: {value: 1.7}, g: {value: 9.81}}
gravity: [0, -g]
links:
  - {name: body, mass: m, com: [0.3, 0.1], inertia: 0.2}
joints:
  - {name: z, type: prismatic, parent: world, child: body, axis: [0, 1], effort: F}
frames:
  - {name: hook, link: body, origin: [0.5, -0.25]}
"""


def test_simulate_applies_forces_at_frames(tmp_path):
    """A body on a vertical slide: held by a force m g at a frame off its centre it stays at
    rest (the moment goes into the slide); a force of 3 m g lifts it at 2 g."""
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    path = tmp_path / "lift.yaml"
    path.write_text(LIFT)
    runner = CliRunner()
    for force, acceleration in (("0,m*g,0.7*t", 0.0), ("0,3*m*g,0", 2 * 9.81), ("0,0,0", -9.81)):
        csv = tmp_path / "run.csv"
        result = runner.invoke(app, ["simulate", str(path), "--q0", "0.2", "--duration", "1", "--force",
                                     f"hook={force}", "--csv", str(csv), "-q"])
        assert result.exit_code == 0, result.output
        rows = np.loadtxt(csv, delimiter=",", skiprows=1)
        t, z = rows[:, 0], rows[:, 1]
        np.testing.assert_allclose(z, 0.2 + acceleration * t**2 / 2, rtol=1e-7, atol=1e-7)
    bad = runner.invoke(app, ["simulate", str(path), "--force", "hand=0,1,0", "-q"])
    assert bad.exit_code == 2 and "FRAME one of hook" in bad.output
