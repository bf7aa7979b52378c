"""Floating-base robots (DESIGN.md section 10): the generated NumPy module of a
robot whose root floats equals Pinocchio with a ``JointModelFreeFlyer`` root (crba, rnea,
computeGeneralizedGravity, aba, integrate, difference, neutral) to 1e-9, at random unit
quaternions and velocities: solo12, a1, go1, anymal_c, bolt, simple_humanoid and talos_reduced
from example-robot-data (``--floating-base``), and
random floating trees with full-precision numbers, generic axes and full inertia tensors.
Then the input checks: where a floating joint may stand, and what is not built yet."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import json
import random
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.input.urdf import identifier
from dynderive.mechanics.tree import offsets
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.centroidal_checks import DIFFERENCES
from dynderive.verify.checks import (
    ENERGY_RUN,
    LINEARIZE_ALONG_INTEGRATE,
    MOMENTUM,
    POWER_BALANCE,
    run_checks,
)
from dynderive.verify.pinocchio_model import pinocchio_maps

from conftest import example_robot as _example_robot
from conftest import floating_module_source, import_code
from random_robots3d import _random_inertia, random_spatial_tree

pin = pytest.importorskip("pinocchio")
runner = CliRunner()


def _module(robot, tmp_path: Path):
    """The generated NumPy module of a ``Robot`` (derived here) or of a ``Derivation`` (the
    caller's, not derived again), imported from ``tmp_path``."""
    derivation = robot if isinstance(robot, dynderive.Derivation) else dynderive.derive(robot)
    path = tmp_path / f"{derivation.robot.name}_dynamics.py"
    path.write_text(render_code(derivation))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _pinocchio(robot):
    """Pinocchio's model of a floating-base ``Robot`` (``pinocchio_maps``: a floating
    joint as a ``JointModelFreeFlyer``) and where its q and v entries are in ours."""
    return pinocchio_maps(robot, {p.name: p.value for p in robot.parameters if p.value is not None})


def _compare(robot, module, model, qp, vp, seed: int, states: int = 3) -> None:
    """Every function of the module against Pinocchio's, at random states (q from Pinocchio's
    ``randomConfiguration``: random unit quaternions)."""
    data = model.createData()
    rng = np.random.default_rng(seed)
    pin.seed(seed)
    nq, nv = model.nq, model.nv
    assert (module.NQ, module.NV) == (nq, nv)
    np.testing.assert_array_equal(module.neutral_configuration()[qp], pin.neutral(model))
    efforts = len(module.EFFORTS)
    where_v = robot.offsets()[1]   # URDF <dynamics damping friction> (go1, talos): taken from tau, as for a fixed base
    damping, friction = np.zeros(nv), np.zeros(nv)
    for joint in (j for j in robot.joints if j.owns and not j.multi):
        damping[where_v[joint.name]] = float(joint.damping or 0)
        friction[where_v[joint.name]] = float(joint.friction or 0)
    for k in range(states):
        q_pin = pin.randomConfiguration(model, -np.ones(nq), np.ones(nq))
        q1_pin = pin.randomConfiguration(model, -np.ones(nq), np.ones(nq))
        v_pin, a_pin = rng.normal(size=nv), rng.normal(size=nv)
        q, q1, v, a = np.empty(nq), np.empty(nq), np.empty(nv), np.empty(nv)
        q[qp], q1[qp], v[vp], a[vp] = q_pin, q1_pin, v_pin, a_pin
        u = rng.normal(size=efforts)
        applied = np.zeros(nv)   # the efforts at their joints' columns
        applied[list(robot.effort_columns())] = u   # a floating or spherical joint's several
        dissipation = damping * v + friction * np.sign(v)
        tau_pin = (applied - dissipation)[vp]
        M_pin = pin.crba(model, data, q_pin)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        scale = max(1.0, np.max(np.abs(M_pin)))
        np.testing.assert_allclose(module.mass_matrix(q)[np.ix_(vp, vp)], M_pin, rtol=0, atol=1e-9 * scale)
        tau = pin.rnea(model, data, q_pin, v_pin, a_pin) + dissipation[vp]
        np.testing.assert_allclose(module.inverse_dynamics(q, v, a)[vp], tau, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(tau))))
        g = pin.computeGeneralizedGravity(model, data, q_pin)
        np.testing.assert_allclose(module.gravity_vector(q)[vp], g, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(g))))
        assert module.kinetic_energy(q, v) == pytest.approx(pin.computeKineticEnergy(model, data, q_pin, v_pin),
                                                            rel=1e-9, abs=1e-9)
        assert module.potential_energy(q) == pytest.approx(pin.computePotentialEnergy(model, data, q_pin),
                                                           rel=1e-9, abs=1e-9)
        qdd = pin.aba(model, data, q_pin, v_pin, tau_pin)
        np.testing.assert_allclose(module.forward_dynamics(q, v, u)[vp], qdd, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(qdd))))
        dt = [0.37, 1e-7, 2.5][k % 3]   # a small step: the series of exp near zero
        np.testing.assert_allclose(module.integrate(q, v, dt)[qp], pin.integrate(model, q_pin, v_pin * dt),
                                   rtol=0, atol=1e-9)
        np.testing.assert_allclose(module.difference(q, q1)[vp], pin.difference(model, q_pin, q1_pin),
                                   rtol=0, atol=1e-9)
        near = pin.integrate(model, q_pin, v_pin * 1e-6)
        q_near = np.empty(nq)
        q_near[qp] = near
        np.testing.assert_allclose(module.difference(q, q_near)[vp], pin.difference(model, q_pin, near),
                                   rtol=0, atol=1e-12)
    # a batch of states gives each state's result
    Q = np.stack([q, q1])
    np.testing.assert_allclose(module.mass_matrix(Q)[1], module.mass_matrix(q1), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(module.difference(Q, module.integrate(Q, v, 0.5)), np.stack([v, v]) * 0.5,
                               rtol=0, atol=1e-9)


@pytest.mark.pinocchio
@pytest.mark.parametrize("relative", ["solo_description/robots/solo12.urdf", "a1_description/urdf/a1.urdf",
                                      "go1_description/urdf/go1.urdf", "anymal_c_simple_description/urdf/anymal.urdf",
                                      "bolt_description/robots/bolt.urdf",
                                      "simple_humanoid_description/urdf/simple_humanoid.urdf",
                                      "talos_data/robots/talos_reduced.urdf"])
def test_legged_robots_float_as_in_pinocchio(relative, tmp_path):
    """``--floating-base``: Pinocchio's ``buildModelFromUrdf(path, JointModelFreeFlyer())``, its
    Coriolis matrix and ``computeABADerivatives`` included."""
    path = _example_robot(relative)
    robot = dynderive.load_robot(path, floating_base=True)
    assert robot.joints[0].name == "root_joint" and robot.joints[0].type == "floating"
    model, qp, vp = free_flyer_model(path, robot)
    module = import_code(floating_module_source(relative), tmp_path, f"{robot.name}_dynamics")
    _compare(robot, module, model, qp, vp, seed=len(relative))
    _coriolis_and_derivatives(module, model, qp, vp, seed=len(relative))


def free_flyer_model(path: Path, robot) -> tuple:
    """Pinocchio's ``buildModelFromUrdf(path, JointModelFreeFlyer())`` and where its q and v
    entries are in ours (``robot`` loaded with ``floating_base=True``)."""
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    where = offsets(robot)
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        ours = identifier(name)
        qp.extend(range(where.q[ours], where.q[ours] + joint.nq))
        vp.extend(range(where.v[ours], where.v[ours] + joint.nv))
    return model, np.array(qp), np.array(vp)


def _coriolis_and_derivatives(module, model, qp, vp, seed: int) -> None:
    """At one random state: the Coriolis matrix against ``computeCoriolisMatrix`` and
    ``linearize`` against ``computeABADerivatives`` (tangent space, efforts at their columns)."""
    data = model.createData()
    rng = np.random.default_rng(seed)
    pin.seed(seed + 1)
    nv = model.nv
    q_pin, v_pin = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)), rng.normal(size=nv)
    q, v = np.empty(model.nq), np.empty(nv)
    q[qp], v[vp] = q_pin, v_pin
    u = rng.normal(size=len(module.EFFORTS))
    tau = np.zeros(nv)
    tau[list(module.EFFORT_COLUMNS)] = u
    C_pin = pin.computeCoriolisMatrix(model, data, q_pin, v_pin)
    np.testing.assert_allclose(module.coriolis_matrix(q, v)[np.ix_(vp, vp)], C_pin, rtol=0,
                               atol=1e-9 * max(1.0, np.max(np.abs(C_pin))))
    A, B = module.linearize(q, v, u)
    friction = module.friction_forces(v)   # the URDF's <dynamics> (go1, talos): taken out of tau for Pinocchio
    damping = np.diag([(module.friction_forces(v + 1e-6 * e) - module.friction_forces(v - 1e-6 * e))[k] / 2e-6
                       for k, e in enumerate(np.eye(nv))])
    pin.computeABADerivatives(model, data, q_pin, v_pin, (tau - friction)[vp])
    Minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
    ddq_dv = data.ddq_dv - Minv @ damping[np.ix_(vp, vp)]   # d/dv of M^-1 (tau - b v - ...)
    scale = max(1.0, np.max(np.abs(data.ddq_dq)), np.max(np.abs(ddq_dv)))
    np.testing.assert_allclose(A[nv:, :nv][np.ix_(vp, vp)], data.ddq_dq, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(A[nv:, nv:][np.ix_(vp, vp)], ddq_dv, rtol=0, atol=1e-9 * scale)
    order = list(vp)
    np.testing.assert_allclose(B[nv:][vp], Minv[:, [order.index(c) for c in module.EFFORT_COLUMNS]], rtol=0,
                               atol=1e-9 * max(1.0, np.max(np.abs(Minv))))


def _floating_tree(seed: int, joints: int | None = None) -> str:
    """A random spatial tree (``random_robots3d``, of ``joints`` joints: 2 to 5 at random when
    not given) hung from a floating base link of random mass and full inertia, reached by a
    floating joint with a random origin (actuated for even seeds: six efforts)."""
    rng = random.Random(seed)
    data = yaml.safe_load(random_spatial_tree(rng, joints or rng.randint(2, 5)).yaml_text)
    for joint in data["joints"]:
        if joint["parent"] == "world":
            joint["parent"] = "base"
    inertia = _random_inertia(rng)
    data["links"].insert(0, {"name": "base", "mass": rng.uniform(0.5, 3.0),
                             "com": [rng.uniform(-0.3, 0.3) for _ in range(3)],
                             "inertia": [inertia[0][0], inertia[1][1], inertia[2][2], inertia[0][1], inertia[0][2],
                                         inertia[1][2]]})
    origin = {"xyz": [rng.uniform(-1, 1) for _ in range(3)], "rpy": [rng.uniform(-3, 3) for _ in range(3)]}
    free = {"name": "free", "type": "floating", "parent": "world", "child": "base", "origin": origin}
    if seed % 2 == 0:   # a base pushed by a wrench from the world (a drone's thrust): thrust_fx ... thrust_tz
        free["effort"] = "thrust"
    data["joints"].insert(rng.randrange(len(data["joints"]) + 1), free)   # anywhere in the file: its offsets follow
    data["name"] = "floating_tree"
    return yaml.safe_dump(data, sort_keys=False)


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", range(6))
def test_random_floating_trees_equal_pinocchio(seed, tmp_path):
    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(seed))
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    _compare(robot, _module(robot, tmp_path), model, qp, vp, seed)


BOX = """name: box
title: A free box with an arm
planar: false
parameters:
  m: {value: 2.0, unit: kg}
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: base, mass: m, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
  - {name: arm, mass: m, com: [0.2, 0, 0], inertia: [0.001, 0.03, 0.03, 0, 0, 0]}
joints:
  - {name: root, type: floating, parent: world, child: base}
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 1, 0], effort: tau2}
"""


def _solve(tmp_path: Path, text: str, *args: str):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    return path, runner.invoke(app, ["solve", str(path), *args, "--out", str(tmp_path / "out")])


def test_solve_writes_the_module_and_says_what_is_not_built(tmp_path):
    path, result = _solve(tmp_path, BOX, "--code")
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if line.startswith("note: box")]
    assert notes == ["note: box has a floating base (NQ = 8, NV = 7): every output is built except the MATLAB "
                     "derivation script (--matlab writes its +package only)"]
    text = (tmp_path / "out" / "box_dynamics.py").read_text()
    assert "root_qw" in text and "NQ = 8" in text and "NV = 7" in text
    docstring = text.split('"""')[1]
    assert "Not built yet" not in docstring and "\\n" not in docstring
    for present in ("def coriolis_matrix", "def linearize", "def regressor", "def parameter_vector",
                    "def friction_forces(qd, *, friction_smoothing=0.0", "def forward_dynamics(q, qd, u=None, wrenches=None"):
        assert present in text   # the box has no damping: friction_forces is zero, its signature the same
    # the same bytes each run
    _, again = _solve(tmp_path, BOX, "--code")
    assert again.exit_code == 0 and (tmp_path / "out" / "box_dynamics.py").read_text() == text


def test_printing_and_other_commands(tmp_path):
    """``solve`` with no output flag prints a small robot's equations (the floating sheet's
    M, C, N and Y, tested against the module in test_sheets_compile.py); nothing is written."""
    from test_sheets_compile import _chain  # full-precision numbers, generic axes, full inertias

    text = _chain(13, 1, title="'A floating arm <b>&amp;'").replace("rest: 0.3}", "rest: 0.3, damping: 0.27123}")
    path, result = _solve(tmp_path, text)
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("A floating arm <b>&amp; (chain13): NQ = 8 coordinates (root_x, root_y, "
                                    "root_z, root_qx, root_qy, root_qz, root_qw, q1), NV = 7 velocities")
    assert "M(q) v' + C(q, v) v + N(q) + F(v) = Y" in result.stdout
    for block in ("M(q) =", "C(q, v) =", "N(q) =", "F(v) = (damping and friction)", "Y ="):
        assert f"\n{block}\n" in result.stdout
    assert "0.27123⋅qd₁" in result.stdout and "u₁" in result.stdout
    assert not (tmp_path / "out").exists()
    # a larger robot: where its programs are written instead

    path, result = _solve(tmp_path, _chain(8, 3))
    assert result.exit_code == 0, result.output
    assert "M, C and N are computed by recursive algorithms" in result.stdout and "\nM(q) =" not in result.stdout
    assert not (tmp_path / "out").exists()
    for command in (["linearize", "-q"], ["identify", "-q"]):   # built: tests/test_linearize.py, tests/test_regressor.py
        result = runner.invoke(app, [*command, str(path)])
        assert result.exit_code == 0, (command, result.output)


def test_the_library_never_takes_lagranges_path(tmp_path):
    (tmp_path / "box.yaml").write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(tmp_path / "box.yaml"))
    assert sorted(derivation.programs) == ["coriolis", "forward_dynamics", "gravity", "inverse_dynamics",
                                           "inverse_dynamics_derivatives", "mass_matrix", "potential", "regressor"]
    with pytest.raises(InputError, match=r"box\.yaml:\d+:\d+: .*not built yet for floating-base robots"):
        derivation["M_g"]


def _bad(tmp_path: Path, text: str) -> list[str]:
    path, result = _solve(tmp_path, text, "--code")
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
    return [line.removeprefix(f"{path}:") for line in result.stderr.splitlines()]


BELOW = BOX.replace("  - {name: root, type: floating, parent: world, child: base}\n",
                    "  - {name: root, type: revolute, parent: world, child: base, axis: [0.3, 0.2, 0.9], effort: tau1}\n") \
    .replace("{name: q2, type: revolute", "{name: q2, type: floating").replace(", axis: [0, 1, 0], effort: tau2", "")
TWO_BODIES = BOX.replace("parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 1, 0], effort: tau2}",
                         "parent: world, child: arm, origin: {xyz: [0, 0, 0.4]}}").replace("{name: q2, type: revolute",
                                                                                          "{name: q2, type: floating")


@pytest.mark.pinocchio
@pytest.mark.parametrize("text", [BELOW, TWO_BODIES], ids=["below_a_link", "two_free_bodies"])
def test_floating_joints_anywhere_as_in_pinocchio(text, tmp_path):
    """A floating joint below a revolute joint (a body free relative to a turning link), and
    two free bodies hanging from the world: as Pinocchio's free flyers there; neither floats as
    a whole (no momentum row), and solve's note says so."""
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    assert not robot.floating_base and robot.floating
    model, qp, vp = _pinocchio(robot)
    derivation = dynderive.derive(robot)
    _compare(robot, _module(derivation, tmp_path), model, qp, vp, seed=3)
    _, result = _solve(tmp_path, text, "--code")
    assert result.exit_code == 0 and "note: box has floating joints (NQ = " in result.stderr, result.output
    rows = [row.name for row in run_checks(derivation, render_code(derivation), states=6)]
    assert MOMENTUM not in rows and POWER_BALANCE in rows


@pytest.mark.pinocchio
def urdf_in_pinocchio(path: Path):
    """The robot of a URDF, Pinocchio's model of it (its own URDF parser) and where Pinocchio's
    q and v entries are in ours."""
    robot = dynderive.load_robot(path)
    model = pin.buildModelFromUrdf(str(path))
    where = offsets(robot)
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where.q[name], where.q[name] + joint.nq))
        vp.extend(range(where.v[name], where.v[name] + joint.nv))
    return robot, model, np.array(qp), np.array(vp)


def test_a_urdf_floating_joint_below_a_link_as_in_pinocchio(tmp_path):
    """``<joint type="floating">`` between two links: Pinocchio's URDF parser makes it a free flyer too."""
    robot, model, qp, vp = urdf_in_pinocchio(Path(__file__).parent / "floating_elbow.urdf")
    assert [j.shortname() for j in model.joints[1:]] == ["JointModelRY", "JointModelFreeFlyer"]
    _compare(robot, _module(robot, tmp_path), model, qp, vp, seed=8)


def test_floating_joint_fields_that_are_not_built(tmp_path):
    lines = _bad(tmp_path, BOX.replace("child: base}", "child: base, axis: [0, 0, 1], effort: f, damping: 0.1}"))
    assert any("joints[0].axis: a floating joint takes no axis" in line for line in lines)
    assert any("joints[0].damping: drive terms on a floating joint are not built yet" in line
               for line in lines)


def test_floating_names_clash_with_the_modules_and_each_other(tmp_path):
    lines = _bad(tmp_path, BOX.replace("  g: 9.81", "  g: 9.81\n  dt: 0.1\n  root_qw: 1"))
    assert any("parameters.dt: name 'dt' is reserved by the generated module of a floating-base robot" in line
               for line in lines)
    assert any("name 'root_qw' clashes with parameters.root_qw" in line for line in lines)


URDF = """<?xml version="1.0"?>
<robot name="legs">
  <link name="trunk"><inertial><mass value="2"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <joint name="ja" type="revolute"><parent link="trunk"/><child link="a"/><axis xyz="0 1 0"/></joint>
  <joint name="jb" type="revolute"><parent link="trunk"/><child link="b"/><axis xyz="0 1 0"/></joint>
</robot>
"""


def test_urdf_floating_base_option_and_note(tmp_path):
    path = tmp_path / "legs.urdf"
    path.write_text(URDF)
    fixed = dynderive.load_robot(path)
    assert not fixed.floating
    assert f"{path}:3:3: note: the root link 'trunk' carries 2 moving subtrees and is welded to the world (a fixed " \
           "base); for a floating base (legged robots, humanoids) pass --floating-base" in fixed.notes
    floating = dynderive.load_robot(path, floating_base=True)
    assert [(j.name, j.type, j.parent, j.child) for j in floating.joints][0] == ("root_joint", "floating", "world",
                                                                                 "trunk")
    assert not any("--floating-base" in note for note in floating.notes)
    out = tmp_path / "legs.yaml"
    result = runner.invoke(app, ["import", str(path), "--floating-base", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert dynderive.load_robot(out).joints == floating.joints
    result = runner.invoke(app, ["solve", str(out), "--floating-base", "--code", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "--floating-base:1:1: --floating-base floats a URDF's root link" in result.stderr
    # a URDF floating joint is imported as floating; --floating-base on it is refused
    own = URDF.replace("<robot name=\"legs\">", "<robot name=\"legs\">\n  <link name=\"world\"/>\n  <joint "
                       "name=\"free\" type=\"floating\"><parent link=\"world\"/><child link=\"trunk\"/></joint>")
    path.write_text(own)
    robot = dynderive.load_robot(path)
    assert robot.joints[0].type == "floating" and robot.floating
    result = runner.invoke(app, ["solve", str(path), "--floating-base", "--code", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert f"{path}:4:3: joint 'free' is floating already: leave out --floating-base" in result.stderr


def test_build_writes_the_module_of_a_floating_robot(tmp_path):   # its sheets: test_sheets_compile, test_html
    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "box.yaml").write_text(BOX)
    (folder / "legs.urdf").write_text(URDF)
    result = runner.invoke(app, ["build", str(folder), "--out", str(tmp_path / "a"), "--code", "--floating-base",
                                 "-j", "1"])
    assert result.exit_code == 0, result.output
    assert "root_joint_qw" in (tmp_path / "a" / "legs_dynamics.py").read_text()
    assert "root_qw" in (tmp_path / "a" / "box_dynamics.py").read_text()


def test_a_singular_mass_matrix_is_refused(tmp_path):
    """A massless base under a one-link arm: the arm's joint motion is the base's (M singular)."""
    massless = BOX.replace("{name: base, mass: m, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, "
                           "0.003]}", "{name: base, mass: 0}")
    [line] = [line for line in _bad(tmp_path, massless) if not line.startswith("note:")]
    assert line.startswith("12:5: joints[0] 'root': the mass matrix is singular at the default parameters: the motion ")
    assert "'root_wy'" in line and "'qd2'" in line


def test_check_runs_the_floating_rows(tmp_path):
    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    result = runner.invoke(app, ["check", str(path), "--json", "-q"])
    assert result.exit_code == 0, result.output
    rows = {row["name"]: row["status"] for row in json.loads(result.stdout)["checks"]}
    assert rows[POWER_BALANCE] == "pass"
    assert rows["agrees with Pinocchio's free flyer (crba, rnea, computeGeneralizedGravity, aba, energies, integrate, "
                "difference)"] == "pass"
    assert rows[MOMENTUM] == "pass" and rows[ENERGY_RUN] == "pass" and rows[LINEARIZE_ALONG_INTEGRATE] == "pass"
    assert all(status == "pass" for status in rows.values()) and len(rows) == 14   # 3 on the centre of mass


#: integrate redefined at the end of a module, with the base's (first joint's) velocity taken in
#: world axes: its linear velocity (moved along v, not R v), or its angular one (exp(w) q, not q exp(w)).
WRONG_FRAME = {
    "linear": "out[..., :3] = q[..., :3] + v[..., :3]",
    "angular": """turn = _right(np.broadcast_to(neutral_configuration(), q.shape), np.concatenate(
        [np.zeros_like(v[..., :3]), v[..., 3:6], np.zeros_like(v[..., 6:])], axis=-1))[..., 3:7]
    a, b = turn, q[..., 3:7]
    product = np.concatenate([a[..., 3:] * b[..., :3] + b[..., 3:] * a[..., :3] + np.cross(a[..., :3], b[..., :3]),
                              a[..., 3:] * b[..., 3:] - np.sum(a[..., :3] * b[..., :3], axis=-1, keepdims=True)], axis=-1)
    out[..., 3:7] = product / np.linalg.norm(product, axis=-1, keepdims=True)""",
}


def _wrong_frame(source: str, which: str) -> str:
    """The module's text with ``integrate`` taking the base's velocity in world axes (``WRONG_FRAME``)."""
    return source + f"""

_right = integrate


def integrate(q, v, dt=1.0):
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float) * np.asarray(dt, dtype=float)[..., np.newaxis]
    out = np.array(_right(q, v))
    {WRONG_FRAME[which]}
    return out
"""


@pytest.mark.parametrize("which", WRONG_FRAME)
def test_the_energy_balance_catches_a_velocity_in_the_wrong_frame(tmp_path, which):
    """A module whose integrate moves the base along v in world axes (not its own) fails the
    energy balance and Pinocchio: the row ties integrate to the dynamics without Pinocchio."""
    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(path))
    broken = _wrong_frame(render_code(derivation), which)
    failed = {row.name for row in run_checks(derivation, broken) if row.status == "FAIL"}
    # the CoM Jacobian's differences along integrate see it too (and linearize's, for the angular one)
    assert failed - {MOMENTUM, LINEARIZE_ALONG_INTEGRATE} == {POWER_BALANCE, DIFFERENCES.format(along="integrate"),
                      "agrees with Pinocchio's free flyer (crba, rnea, computeGeneralizedGravity, aba, energies, integrate, "
                      "difference)", "difference(q, integrate(q, v, dt)) = v dt"}


def test_the_size_limit_of_a_floating_robot_is_its_own(tmp_path):
    """No Coriolis stage: a floating-base robot may have 60 coordinates (n^2 work), a fixed 3-D one 30."""
    links = "".join(f"  - {{name: l{k}, mass: 1, inertia: [0.1, 0.1, 0.1, 0, 0, 0]}}\n" for k in range(36))
    chain = "".join(f"  - {{name: j{k}, type: revolute, parent: l{k - 1}, child: l{k}, axis: [0, 1, 0]}}\n"
                    for k in range(1, 36))
    text = f"name: chain\nplanar: false\ngravity: [0, 0, -9.81]\nlinks:\n{links}joints:\n"
    path = tmp_path / "chain.yaml"
    path.write_text(text + "  - {name: root, type: floating, parent: world, child: l0}\n" + chain)
    assert dynderive.load_robot(path, size_limits=True).velocity_count == 41
    path.write_text(text + "  - {name: root, type: revolute, parent: world, child: l0}\n" + chain)
    with pytest.raises(InputError, match="36 coordinates exceed the limit of 30 for a 3-D robot"):
        dynderive.load_robot(path, size_limits=True)


def test_generated_property_checks_pass_and_catch_a_wrong_module(tmp_path):
    """``--code --tests``: the module's own checks pass; with the base's velocity taken in world
    axes by integrate, the energy balance and the integrate/difference checks fail."""
    import subprocess
    import sys

    _, result = _solve(tmp_path, BOX, "--code", "--tests")
    assert result.exit_code == 0, result.output
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_box_dynamics.py"],
                         cwd=out, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and "43 passed" in run.stdout, run.stdout + run.stderr
    module = out / "box_dynamics.py"
    module.write_text(_wrong_frame(module.read_text(), "angular"))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_box_dynamics.py"],
                         cwd=out, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1 and "test_energy_balance_along_integrate" in run.stdout, run.stdout


@pytest.mark.pinocchio
def test_frames_of_a_legged_robot_equal_pinocchio(tmp_path):
    """solo12's feet (links welded to the shanks, frames of the same names): pose and
    LOCAL_WORLD_ALIGNED Jacobian, against Pinocchio's free flyer."""
    path = _example_robot("solo_description/robots/solo12.urdf")
    robot = dynderive.load_robot(path, floating_base=True)
    module = import_code(floating_module_source("solo_description/robots/solo12.urdf"), tmp_path, "solo12_dynamics")
    assert "FL_FOOT" in module.FRAMES
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    pin.seed(7)
    for _ in range(3):
        q_pin = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        q = np.empty(model.nq)
        q[qp] = q_pin
        pin.computeJointJacobians(model, data, q_pin)
        pin.updateFramePlacements(model, data)
        for frame in module.FRAMES:
            fid = model.getFrameId(frame)
            T = module.frame_transform(q, frame)
            np.testing.assert_allclose(T[:3, :3], data.oMf[fid].rotation, rtol=0, atol=1e-12)
            np.testing.assert_allclose(T[:3, 3], data.oMf[fid].translation, rtol=0, atol=1e-12)
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(module.frame_jacobian(q, frame)[:, vp], J, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="unknown frame 'hand'"):
        module.frame_jacobian(q, "hand")
