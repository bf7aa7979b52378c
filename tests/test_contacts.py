"""Contact dynamics of 3-D robots (DESIGN.md section 11): ``constrained_forward_dynamics`` and
``impulse_dynamics`` of the generated NumPy and JAX modules, the robot file's ``contacts:`` and
``simulate --contacts``.

Against Pinocchio to 1e-9 at random states: ``pin.forwardDynamics(model, data, q, v, tau, J,
gamma, 0)`` and ``pin.impulseDynamics(model, data, q, v, J, r, 0)``, with J and gamma built from
``getFrameJacobian`` and ``getFrameClassicalAcceleration`` (point contacts, LOCAL_WORLD_ALIGNED)
or ``getFrameAcceleration`` (surface contacts, LOCAL) at zero acceleration: solo12 on its four
feet (example-robot-data, ``--floating-base``), talos_reduced on both soles (surface), and a
random floating tree and a random fixed-base tree (full-precision numbers) with a point and a
surface contact. Properties: solo12 standing at rest under gravity (the efforts that hold it:
zero accelerations, the feet's vertical forces carry its weight), the KKT residual, Baumgarte
stabilisation with anchors, impacts (the contacts' velocities after, the kinetic energy lost),
batches, JAX equal to NumPy (eager and under jax.jit; skipped without jax locally, required when
CI is set), run-time errors, positioned errors of bad ``contacts:`` entries (exit 2), and a
simulation that holds its contact.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.input.urdf import identifier
from dynderive.render.targets.numpy.code import render_code

from conftest import example_robot as _example_robot
from conftest import floating_module_source, import_code
from random_robots3d import random_spatial_tree

runner = CliRunner()


def _close(actual, expected, what: str, tolerance: float = 1e-9) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= tolerance * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _tree(seed: int, floating: bool) -> str:
    """A random spatial tree of 5 joints (full-precision numbers; below a floating base link when
    ``floating``) with two frames at random poses, a surface contact ``sole`` on its deepest link
    and a point contact ``toe`` (on the base when floating, else beside the sole)."""
    rng = random.Random(seed)
    data = yaml.safe_load(random_spatial_tree(rng, 5).yaml_text)
    parent = {j["child"]: (j["parent"], j["type"] != "fixed") for j in data["joints"]}

    def depth(link: str) -> int:
        return 0 if link == "world" else parent[link][1] + depth(parent[link][0])

    deepest = max((link["name"] for link in data["links"]), key=depth)
    if floating:
        for joint in data["joints"]:
            if joint["parent"] == "world":
                joint["parent"] = "base"
        data["links"].insert(0, {"name": "base", "mass": rng.uniform(0.5, 3.0),
                                 "com": [rng.uniform(-0.3, 0.3) for _ in range(3)],
                                 "inertia": [0.11, 0.13, 0.17, 0.01, -0.02, 0.015]})
        data["joints"].insert(0, {"name": "free", "type": "floating", "parent": "world", "child": "base",
                                  "origin": {"xyz": [rng.uniform(-1, 1) for _ in range(3)],
                                             "rpy": [rng.uniform(-3, 3) for _ in range(3)]}})

    def pose() -> dict:
        return {"xyz": [rng.uniform(-0.5, 0.5) for _ in range(3)], "rpy": [rng.uniform(-3, 3) for _ in range(3)]}

    data["frames"] = [{"name": "sole", "link": deepest, "origin": pose()},
                      {"name": "toe", "link": "base" if floating else deepest, "origin": pose()}]
    data["contacts"] = [{"frame": "sole", "kind": "surface"}, {"frame": "toe"}]
    data["name"] = f"contact_tree_{seed}"
    return yaml.safe_dump(data, sort_keys=False)


def _maps(robot, model):
    """(qp, vp): q_pin = q[qp], v_pin = v[vp] for a URDF robot and Pinocchio's model of it."""
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    return np.array(qp), np.array(vp)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("contacts")


_CACHE: dict[str, tuple] = {}


def _robot(name: str, folder: Path):
    """(robot, derivation, NumPy module, Pinocchio (model, qp, vp) or None), derived once."""
    if name not in _CACHE:
        if name in ("solo12", "talos"):
            relative = {"solo12": "solo_description/robots/solo12.urdf",
                        "talos": "talos_data/robots/talos_reduced.urdf"}[name]
            robot = dynderive.load_robot(_example_robot(relative), floating_base=True)
            # derived once per test run (shared with test_free_flyer, test_centroidal); no test
            # here reads the derivation of a URDF robot
            derivation, source = None, floating_module_source(relative)
        else:
            path = folder / f"{name}.yaml"
            path.write_text(_tree(int(name.split("_")[1]), name.startswith("floating")))
            robot = dynderive.load_robot(path)
            derivation = dynderive.derive(robot)
            source = render_code(derivation)
        module = import_code(source, folder, f"{name}_contacts_dynamics")
        _CACHE[name] = (robot, derivation, module)
    return _CACHE[name]


def _pinocchio(name: str, robot):
    pin = pytest.importorskip("pinocchio")
    if name in ("solo12", "talos"):
        relative = {"solo12": "solo_description/robots/solo12.urdf", "talos": "talos_data/robots/talos_reduced.urdf"}
        model = pin.buildModelFromUrdf(str(_example_robot(relative[name])), pin.JointModelFreeFlyer())
        return (model, *_maps(robot, model))
    from dynderive.verify.pinocchio_model import pinocchio_maps

    return pinocchio_maps(robot, {p.name: p.value for p in robot.parameters if p.value is not None})


def _random_state(module, rng, batch=()):
    nv = len(module.VELOCITIES) if hasattr(module, "VELOCITIES") else len(module.COORDINATES)
    if hasattr(module, "integrate"):
        q = module.integrate(module.neutral_configuration(), rng.uniform(-1.5, 1.5, batch + (nv,)))
    else:
        q = rng.uniform(-1.5, 1.5, batch + (nv,))
    return q, rng.normal(size=batch + (nv,)), rng.normal(size=batch + (len(module.EFFORTS),))


CASES = [("solo12", ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]),
         ("talos", [("left_sole_link", "surface"), ("right_sole_link", "surface")]),
         ("floating_10", None),
         ("fixed_6", [("toe", "point")])]


@pytest.mark.pinocchio
@pytest.mark.parametrize("name, contacts", CASES, ids=[c[0] for c in CASES])
def test_constrained_and_impulse_dynamics_equal_pinocchio(name, contacts, folder):
    """qdd and the forces of pin.forwardDynamics, qd_plus and the impulses of pin.impulseDynamics,
    at random states and efforts (the robot file's CONTACTS where ``contacts`` is None)."""
    pin = pytest.importorskip("pinocchio")
    robot, _, module = _robot(name, folder)
    model, qp, vp = _pinocchio(name, robot)
    data = model.createData()
    contacts = module.CONTACTS if contacts is None else contacts
    held = [(c, module.CONTACT_KINDS.get(c, "point")) if isinstance(c, str) else c for c in contacts]
    rng = np.random.default_rng(len(name))
    nv = model.nv
    for _ in range(2):
        q, qd, u = _random_state(module, rng)
        q_pin, v_pin = q[qp], qd[vp]
        applied = np.zeros(nv)
        applied[list(robot.effort_columns())] = u
        where_v = robot.offsets()[1]
        dissipation = np.zeros(nv)   # URDF <dynamics damping friction> (talos): the module's F, as inverse_dynamics'
        for joint in (j for j in robot.joints if j.owns and not j.multi):
            dissipation[where_v[joint.name]] = (float(joint.damping or 0) * qd[where_v[joint.name]]
                                                + float(joint.friction or 0) * np.sign(qd[where_v[joint.name]]))
        pin.computeJointJacobians(model, data, q_pin)
        pin.forwardKinematics(model, data, q_pin, v_pin, np.zeros(nv))
        pin.updateFramePlacements(model, data)
        rows, drifts = [], []
        for frame, kind in held:
            fid = model.getFrameId(frame)
            if kind == "point":
                rows.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3])
                drifts.append(pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear)
            else:
                rows.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL))
                drifts.append(pin.getFrameAcceleration(model, data, fid, pin.LOCAL).vector)
        J, gamma = np.vstack(rows), np.concatenate(drifts)
        ddq = pin.forwardDynamics(model, data, q_pin, v_pin, (applied - dissipation)[vp], J, gamma, 0.0).copy()
        qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts)
        _close(qdd[vp], ddq, f"{name} qdd")
        _close(forces, data.lambda_c, f"{name} forces")
        for restitution in (0.0, 0.6):
            after = pin.impulseDynamics(model, data, q_pin, v_pin, J, restitution, 0.0).copy()
            qd_plus, impulses = module.impulse_dynamics(q, qd, contacts, restitution)
            _close(qd_plus[vp], after, f"{name} qd_plus")
            _close(impulses, data.impulse_c, f"{name} impulses")


@pytest.fixture(scope="module")
def solo12(folder):
    return _robot("solo12", folder)


def test_solo12_standing_at_rest_carries_its_weight(solo12):
    """At rest in its neutral configuration (legs straight down) with the efforts that hold it
    (forces f balancing gravity on the base, u = (g - J^T f) at the joints): zero accelerations,
    the feet held, the vertical forces summing to the weight m g."""
    robot, _, module = solo12
    feet = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]
    q, qd = module.neutral_configuration(), np.zeros(module.NV)
    J = np.concatenate([module.frame_jacobian(q, f)[:3] for f in feet])
    g = module.gravity_vector(q)
    f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]   # the base's six rows balanced by the feet
    u = (g - J.T @ f)[list(module.EFFORT_COLUMNS)]
    qdd, forces = module.constrained_forward_dynamics(q, qd, u, feet)
    _close(qdd, np.zeros(module.NV), "qdd at rest", 1e-10)
    _close(J @ qdd, np.zeros(12), "the feet's accelerations", 1e-10)
    weight = sum(float(link.mass) for link in robot.links) * 9.81
    assert float(np.sum(forces.reshape(4, 3)[:, 2])) == pytest.approx(weight, rel=1e-10)
    _close(forces, f, "forces")
    # with no effort it sags, but the feet stay held and the forces still are J^T's share of the motion
    qdd, forces = module.constrained_forward_dynamics(q, qd, None, feet)
    _close(J @ qdd, np.zeros(12), "the feet's accelerations without effort", 1e-10)


def _kkt(module, q, qd, u, held, qdd, forces, parameters=None):
    """[M qdd - J^T forces - (tau - h); J qdd + gamma] from the module's own functions."""
    parameters = parameters or {}
    tau = np.zeros(module.NV)
    tau[list(module.EFFORT_COLUMNS)] = u
    h = module.inverse_dynamics(q, qd, np.zeros(module.NV), **parameters)
    rows, drifts = [], []
    for frame, kind in held:
        J, a = module.frame_jacobian(q, frame, **parameters), module.frame_jacobian_dot_qd(q, qd, frame, **parameters)
        if kind == "point":
            rows.append(J[:3])
            drifts.append(a[:3])
        else:
            R = module.frame_transform(q, frame, **parameters)[:3, :3]
            v = J @ qd
            rows.append(np.vstack([R.T @ J[:3], R.T @ J[3:]]))
            drifts.append(np.concatenate([R.T @ (a[:3] - np.cross(v[3:], v[:3])), R.T @ a[3:]]))
    J, gamma = np.vstack(rows), np.concatenate(drifts)
    return module.mass_matrix(q, **parameters) @ qdd - J.T @ forces - (tau - h), J @ qdd + gamma, J, gamma


def test_kkt_residual_baumgarte_and_impacts(folder):
    """A random floating tree with a surface and a point contact (the robot file's CONTACTS):
    the KKT residual is zero; with baumgarte = (kp, kd) and anchors the contacts accelerate by
    -kd (velocity) - kp (position error); an impact leaves J qd_plus = -e J qd_minus and, plastic,
    loses kinetic energy; a contact given by index equals it given by name."""
    _, _, module = _robot("floating_10", folder)
    assert module.CONTACTS == ("sole", "toe") and module.CONTACT_KINDS == {"sole": "surface", "toe": "point"}
    held = [("sole", "surface"), ("toe", "point")]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, qd, u = _random_state(module, rng)
        qdd, forces = module.constrained_forward_dynamics(q, qd, u)
        assert forces.shape == (9,)
        top, bottom, J, gamma = _kkt(module, q, qd, u, held, qdd, forces)
        _close(top, np.zeros(module.NV), "KKT dynamics rows", 1e-9)
        _close(bottom, np.zeros(9), "KKT contact rows", 1e-9)
        # Baumgarte: anchors off the frames' current poses
        pose = module.frame_transform(q, "sole")
        turn = np.array([[np.cos(0.01), -np.sin(0.01), 0], [np.sin(0.01), np.cos(0.01), 0], [0, 0, 1]])
        anchor_sole = pose.copy()
        anchor_sole[:3, :3] = pose[:3, :3] @ turn
        anchor_sole[:3, 3] += [0.01, -0.02, 0.005]
        anchor_toe = module.frame_transform(q, "toe")[:3, 3] + [0.003, 0.0, -0.01]
        kp, kd = 25.0, 10.0
        qdd, forces = module.constrained_forward_dynamics(q, qd, u, baumgarte=(kp, kd), anchors=[anchor_sole, anchor_toe])
        R = pose[:3, :3]
        skew = (turn.T - turn) / 2   # R_ref^T R = turn^T
        error = np.concatenate([R.T @ (pose[:3, 3] - anchor_sole[:3, 3]), [skew[2, 1], skew[0, 2], skew[1, 0]],
                                module.frame_transform(q, "toe")[:3, 3] - anchor_toe])
        _close(J @ qdd + gamma, -kd * (J @ qd) - kp * error, "Baumgarte", 1e-9)
        top, _, _, _ = _kkt(module, q, qd, u, held, qdd, forces)
        _close(top, np.zeros(module.NV), "KKT dynamics rows with Baumgarte", 1e-9)
        for restitution in (0.0, 0.5):
            qd_plus, impulses = module.impulse_dynamics(q, qd, restitution=restitution)
            _close(J @ qd_plus, -restitution * (J @ qd), "contact velocities after the impact", 1e-9)
            _close(module.mass_matrix(q) @ (qd_plus - qd), J.T @ impulses, "momentum jump", 1e-9)
        assert module.kinetic_energy(q, module.impulse_dynamics(q, qd)[0]) < module.kinetic_energy(q, qd)
        by_index = module.constrained_forward_dynamics(q, qd, u, [(module.FRAMES.index("sole"), "surface"), 1])
        _close(by_index[0], module.constrained_forward_dynamics(q, qd, u)[0], "contacts by index")


def test_batches_give_each_states_result(folder):
    _, _, module = _robot("floating_10", folder)
    rng = np.random.default_rng(5)
    q, qd, u = _random_state(module, rng, (2, 3))
    qdd, forces = module.constrained_forward_dynamics(q, qd, u, baumgarte=(0, 4.0))
    qd_plus, impulses = module.impulse_dynamics(q, qd, restitution=0.3)
    assert qdd.shape == (2, 3, module.NV) and forces.shape == (2, 3, 9) and impulses.shape == (2, 3, 9)
    for i in range(2):
        for j in range(3):
            one = module.constrained_forward_dynamics(q[i, j], qd[i, j], u[i, j], baumgarte=(0, 4.0))
            _close(qdd[i, j], one[0], "batched qdd", 1e-12)
            _close(forces[i, j], one[1], "batched forces", 1e-12)
            _close(qd_plus[i, j], module.impulse_dynamics(q[i, j], qd[i, j], restitution=0.3)[0], "batched qd_plus", 1e-12)
    # one configuration, many velocities; no contact is forward_dynamics
    qdd, _ = module.constrained_forward_dynamics(q[0, 0], qd[0], u[0, 0])
    _close(qdd[1], module.constrained_forward_dynamics(q[0, 0], qd[0, 1], u[0, 0])[0], "broadcast q", 1e-12)
    qdd, forces = module.constrained_forward_dynamics(q, qd, u, ())
    assert forces.shape == (2, 3, 0)
    _close(qdd, module.forward_dynamics(q, qd, u), "no contact", 1e-10)


def test_run_time_errors(folder):
    _, _, module = _robot("fixed_6", folder)
    q, qd, u = _random_state(module, np.random.default_rng(1))
    assert module.CONTACTS == ("sole", "toe")
    with pytest.raises(ValueError, match="redundant"):   # 5 joints, 9 constraints
        module.constrained_forward_dynamics(q, qd, u)
    with pytest.raises(ValueError, match="redundant"):
        module.impulse_dynamics(q, qd)
    with pytest.raises(ValueError, match="unknown frame 'heel'"):
        module.constrained_forward_dynamics(q, qd, u, ["heel"])
    with pytest.raises(ValueError, match="out of range"):
        module.constrained_forward_dynamics(q, qd, u, [7])
    with pytest.raises(ValueError, match="'point' or 'surface'"):
        module.constrained_forward_dynamics(q, qd, u, [("toe", "line")])
    with pytest.raises(ValueError, match="held twice"):
        module.constrained_forward_dynamics(q, qd, u, ["toe", 1])
    with pytest.raises(ValueError, match="a pair"):
        module.constrained_forward_dynamics(q, qd, u, ["toe"], baumgarte=1.0)
    with pytest.raises(ValueError, match="kp needs anchors"):
        module.constrained_forward_dynamics(q, qd, u, ["toe"], baumgarte=(1.0, 0.0))
    qdd, forces = module.constrained_forward_dynamics(q, qd, u, "toe")   # one name: one contact
    assert forces.shape == (3,)


@pytest.mark.parametrize("name", ["floating_10", "fixed_6"])
def test_jax_equals_numpy(name, folder):
    """Both functions, with and without Baumgarte anchors, equal the NumPy module's to 1e-12:
    the floating tree's eagerly and under jax.vmap, the fixed tree's under jax.jit (contacts static)."""
    if os.environ.get("CI"):   # required in CI (jax is in the test extra)
        import jax
    else:
        jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from dynderive.render.targets.jax.jax import render_jax

    _, derivation, module = _robot(name, folder)
    jax_module = import_code(render_jax(derivation), folder, f"{name}_contacts_dynamics_jax")
    assert jax_module.CONTACTS == module.CONTACTS and jax_module.CONTACT_KINDS == module.CONTACT_KINDS
    floating = name == "floating_10"
    extra = {} if floating else {"contacts": ["toe"]}   # the fixed tree holds one point contact
    q, qd, u = _random_state(module, np.random.default_rng(9), (3,))
    anchors = [module.frame_transform(q, "sole") + 0.01, module.frame_transform(q, "toe")[..., :3, 3] - 0.02]
    stabilised = {"baumgarte": (9.0, 6.0), "anchors": anchors if floating else anchors[1:]}
    traced = not floating   # compiling the floating tree's bodies under jax.jit takes 10 s more
    for options in (extra, extra | stabilised):
        expected = module.constrained_forward_dynamics(q, qd, u, **options)
        actual = (jax.jit(lambda a, b, c, o=options: jax_module.constrained_forward_dynamics(a, b, c, **o))(q, qd, u)
                  if traced and options is not extra else jax_module.constrained_forward_dynamics(q, qd, u, **options))
        for e, a in zip(expected, actual, strict=True):
            _close(a, e, f"{name} JAX constrained_forward_dynamics {sorted(options)}", 1e-12)
    expected = module.impulse_dynamics(q, qd, restitution=0.4, **extra)
    actual = (jax.jit(lambda a, b: jax_module.impulse_dynamics(a, b, restitution=0.4, **extra))(q, qd) if traced
              else jax_module.impulse_dynamics(q, qd, restitution=0.4, **extra))
    for e, a in zip(expected, actual, strict=True):
        _close(a, e, f"{name} JAX impulse_dynamics", 1e-12)
    if floating:
        vmapped = jax.vmap(lambda a, b, c: jax_module.constrained_forward_dynamics(a, b, c)[0])(q, qd, u)
        _close(vmapped, module.constrained_forward_dynamics(q, qd, u)[0], f"{name} vmap", 1e-12)


ARM = """name: arm
planar: false
parameters:
  m: 1.0
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: l1, mass: m, com: [0.1, 0, 0], inertia: [0.01, 0.01, 0.01, 0, 0, 0]}
  - {name: l2, mass: m, com: [0.1, 0, 0], inertia: [0.01, 0.01, 0.01, 0, 0, 0]}
joints:
  - {name: q1, type: revolute, parent: world, child: l1, axis: [0, 1, 0]}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [0.2, 0, 0]}, axis: [0, 1, 0]}
frames:
  - {name: foot, link: l2, origin: {xyz: [0.2, 0, 0]}}
  - {name: knee, link: l1, origin: {xyz: [0.2, 0, 0]}}
"""


def _errors(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    return [line for line in result.output.splitlines() if line.startswith(str(path))]


def test_bad_contacts_entries_are_positioned_errors(tmp_path):
    text = ARM + """contacts:
  - {frame: fot, kind: point}
  - {frame: foot, kind: line}
  - {frame: knee}
  - {frame: knee, kind: surface}
  - {kind: point}
  - {frame: foot, size: 1}
  - [foot]
  - {frame: 3, kind: surfac}
"""
    lines = _errors(tmp_path, text)
    path = tmp_path / "robot.yaml"
    start = ARM.count("\n") + 2
    assert lines == [
        f"{path}:{start}:13: contacts[0].frame: unknown frame 'fot' (did you mean 'foot'?)",
        f"{path}:{start + 1}:25: contacts[1].kind: unknown contact kind 'line'; expected point or surface",
        f"{path}:{start + 3}:13: contacts[3].frame: frame 'knee' is already a contact (first at {start + 2}:13)",
        f"{path}:{start + 4}:5: contacts[4]: missing required key 'frame'",
        f"{path}:{start + 5}:19: contacts[5].size: unknown key 'size' (allowed: frame, kind)",
        f"{path}:{start + 5}:13: contacts[5].frame: frame 'foot' is already a contact (first at {start + 1}:13)",
        f"{path}:{start + 6}:5: contacts[6]: expected a mapping, got a list",
        f"{path}:{start + 7}:13: contacts[7].frame: expected a frame's name, got a number",
        f"{path}:{start + 7}:22: contacts[7].kind: unknown contact kind 'surfac' (did you mean 'surface'?); "
        "expected point or surface"]
    lines = _errors(tmp_path, ARM + "contacts: []\n")
    assert lines == [f"{path}:{start - 1}:11: contacts: expected a non-empty list of {{frame: NAME, kind: point|surface}}, "
                     "got an empty list"]


def test_planar_robots_refuse_contacts_and_loop_robots_take_them(tmp_path):
    planar = (Path(__file__).parents[1] / "robots" / "rp_arm.yaml").read_text()
    lines = _errors(tmp_path, planar.rstrip("\n") + "\ncontacts:\n  - {frame: tip}\n")
    assert len(lines) == 1 and lines[0].endswith("contacts: contact dynamics are 3-D only (this robot is planar)")
    path = tmp_path / "bennett.yaml"   # an over-constrained loop holds a contact too (its rows solved with the loops')
    path.write_text((Path(__file__).parents[1] / "robots" / "bennett.yaml").read_text().rstrip("\n")
                    + "\nframes:\n  - {name: tip, link: link2, origin: {xyz: [0.1, 0.0, 0.0]}}\ncontacts:\n  - {frame: tip}\n")
    robot = dynderive.load_robot(path)
    assert [(c.frame, c.kind) for c in robot.contacts] == [("tip", "point")]


def test_contacts_load_onto_the_robot_and_the_module(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text(ARM + "contacts:\n  - {frame: foot, kind: surface}\n  - {frame: knee}\n")
    robot = dynderive.load_robot(path)
    assert [(c.frame, c.kind) for c in robot.contacts] == [("foot", "surface"), ("knee", "point")]
    source = render_code(dynderive.derive(robot))
    assert "CONTACTS = (\"foot\", \"knee\")" in source and "CONTACT_KINDS = {\"foot\": \"surface\", \"knee\": \"point\"}" in source


def test_simulate_holds_the_contacts(tmp_path):
    """``simulate --contacts``: a free box with an arm held at a surface contact on its base stays
    put (Baumgarte-stabilised, anchored where it starts); the summary names the contacts; a
    contact on an unknown frame is exit 2 at the option."""
    path = tmp_path / "held.yaml"
    path.write_text(HELD)
    csv = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.5", "--frames", "6", "--quiet",
                                 "--contacts", "pad:surface", "--csv", str(csv), "--effort", "tau2=0.5*sin(3*t)"])
    assert result.exit_code == 0, result.output
    assert "holding pad (surface)" in result.output
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    module = import_code(render_code(dynderive.derive(dynderive.load_robot(path))), tmp_path, "held_dynamics")
    poses = module.frame_transform(rows[:, 1:1 + module.NQ], "pad")
    assert np.max(np.abs(poses - poses[0])) < 1e-6
    assert np.ptp(rows[:, module.COORDINATES.index("q2") + 1]) > 1e-3   # the arm moves
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.1", "--quiet", "--contacts", "pda"])
    assert result.exit_code == 2 and result.output.startswith("--contacts:1:1: unknown frame 'pda' (did you mean 'pad'?)")
    # the robot file's contacts are held by default, and 'none' holds none
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.1", "--frames", "3", "--quiet"])
    assert result.exit_code == 0 and "holding pad (surface)" in result.output, result.output
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.1", "--frames", "3", "--quiet",
                                 "--contacts", "none"])
    assert result.exit_code == 0 and "holding" not in result.output, result.output



@pytest.mark.parametrize("arguments, message", [
    (["rp_arm", "--contacts", "tip"], "--contacts:1:1: contact dynamics are 3-D only (this robot is planar)"),
    (["bennett", "--contacts", "tip"], "--contacts:1:1: unknown frame 'tip' (this robot declares no frames)"),
    (["HELD", "--contacts", "pad:edge"], "--contacts:1:1: unknown contact kind 'edge' of pad; expected point or surface"),
    (["HELD", "--contacts", "pad,pad"], "--contacts:1:5: frame 'pad' is listed twice"),
])
def test_simulate_refuses_contacts_it_cannot_hold(arguments, message, tmp_path):
    if arguments[0] == "HELD":
        path = tmp_path / "held.yaml"
        path.write_text(HELD)
        arguments = [str(path), *arguments[1:]]
    result = runner.invoke(app, ["simulate", *arguments, "--duration", "0.1", "--quiet"])
    assert result.exit_code == 2 and result.output.startswith(message), result.output


HELD = """name: held
title: A free box with an arm, held at a pad
planar: false
parameters:
  m: {value: 2.0, unit: kg}
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: base, mass: m, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
  - {name: arm, mass: m, com: [0.2, 0, 0], inertia: [0.001, 0.03, 0.03, 0, 0, 0]}
joints:
  - {name: root, type: floating, parent: world, child: base, origin: {xyz: [0, 0, 0.3]}}
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 1, 0], effort: tau2}
frames:
  - {name: pad, link: base, origin: {xyz: [0, 0, -0.1]}}
contacts:
  - {frame: pad, kind: surface}
"""


@pytest.mark.parametrize("name", ["floating_10", "fixed_6"])
def test_casadi_equals_numpy(name, folder):
    """The CasADi module's Functions (one per set of contacts), with and without Baumgarte
    anchors, equal the NumPy module's to 1e-12; a Function of SX symbols differentiates."""
    if os.environ.get("CI"):   # required in CI (casadi is in the test extra)
        import casadi
    else:
        casadi = pytest.importorskip("casadi")
    from dynderive.render.targets.casadi.casadi import render_casadi

    _, derivation, module = _robot(name, folder)
    casadi_module = import_code(render_casadi(derivation), folder, f"{name}_contacts_dynamics_casadi")
    assert casadi_module.CONTACTS == module.CONTACTS and casadi_module.CONTACT_KINDS == module.CONTACT_KINDS
    floating = name == "floating_10"
    contacts = module.CONTACTS if floating else ("toe",)
    function = casadi_module.constrained_forward_dynamics(contacts)
    assert function is casadi_module.constrained_forward_dynamics(list(contacts))   # built once per set
    p = casadi_module.default_parameters()
    for q, qd, u in zip(*_random_state(module, np.random.default_rng(11), (2,))):
        poses = {frame: module.frame_transform(q, frame) for frame in module.CONTACTS + ("toe",)}
        anchors = [poses[frame] + 0.01 if module.CONTACT_KINDS.get(frame) == "surface" else poses[frame][:3, 3] - 0.02
                   for frame in contacts]
        flat = np.concatenate([np.ravel(a) for a in anchors])   # a surface's pose row by row
        for baumgarte, held in (((0.0, 0.0), None), ((9.0, 6.0), anchors)):
            expected = module.constrained_forward_dynamics(q, qd, u, contacts, baumgarte, anchors=held)
            actual = function(q, qd, u, p, 0.0, np.array(baumgarte), flat if held else 0.0)
            for e, a in zip(expected, actual, strict=True):
                _close(np.ravel(np.array(a)), e, f"{name} CasADi constrained_forward_dynamics {baumgarte}", 1e-12)
        expected = module.impulse_dynamics(q, qd, contacts, restitution=0.4)
        actual = casadi_module.impulse_dynamics(contacts)(q, qd, p, 0.4)
        for e, a in zip(expected, actual, strict=True):
            _close(np.ravel(np.array(a)), e, f"{name} CasADi impulse_dynamics", 1e-12)
    q = casadi.SX.sym("q", len(module.COORDINATES))
    qd, u = (casadi.SX.sym(s, n) for s, n in (("qd", function.size1_in(1)), ("u", function.size1_in(2))))
    qdd = function(q, qd, u)[0]
    assert casadi.jacobian(qdd, u).shape == (function.size1_in(1), function.size1_in(2))
    with pytest.raises(ValueError, match="held twice"):
        casadi_module.constrained_forward_dynamics(["toe", "toe"])


def test_check_rows_hold_and_catch_a_wrong_module():
    """``check`` holds the robot's first frame (elbow_arm declares no contacts): both rows pass;
    forces off by 1 % fail the system's row."""
    import importlib.util
    import json
    import types

    from dynderive.verify.checks import generated_module
    from dynderive.verify.contact_checks import KKT, PINOCCHIO, contact_rows

    from conftest import derivation_of

    result = CliRunner().invoke(app, ["check", "elbow_arm", "--json", "-q"])
    assert result.exit_code == 0, result.output
    rows = {row["name"]: row for row in json.loads(result.stdout)["checks"]}
    assert rows[KKT]["status"] == "pass" and "holding wrist (point)" in rows[KKT]["method"]
    if importlib.util.find_spec("pinocchio"):
        assert rows[PINOCCHIO]["status"] == "pass"
    derivation = derivation_of("elbow_arm")
    module = generated_module(dynderive.render_code(derivation), "elbow_arm_contact_rows")
    values = dict(module.PARAMETERS)
    rng = np.random.default_rng(3)
    states = (rng.uniform(-1, 1, (3, 3)), rng.normal(size=(3, 3)), rng.normal(size=(3, 3)))
    assert contact_rows(derivation, module, values, *states)[0].status == "pass"
    wrong = types.SimpleNamespace(**vars(module))
    wrong.constrained_forward_dynamics = lambda *a, **k: (lambda r: (r[0], 1.01 * r[1]))(
        module.constrained_forward_dynamics(*a, **k))
    assert contact_rows(derivation, wrong, values, *states)[0].status == "FAIL"
