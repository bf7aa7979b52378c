"""URDF ``<mimic>`` (and a YAML joint's ``mimic``) on moving joints: the follower has no
coordinate of its own, its variable is ``multiplier * q_leader + offset`` (DESIGN.md section 10).

Two references. Pinocchio built with mimic joints (``buildModelFromUrdf(path, mimic=True)``:
``nq`` and ``nv`` leave the followers out): crba, rnea, nonLinearEffects,
computeGeneralizedGravity, forward dynamics (its ``aba`` refuses mimic joints: ``M^-1 (tau -
h)``), frame placements and LOCAL_WORLD_ALIGNED Jacobians. And the uncoupled robot (every
follower a coordinate of its own, its drive terms kept) mapped through the coupling
``q = G q_c + offset``: ``M_c = G^T M G``, ``h_c = G^T h(G q_c + offset, G qd_c)``, which checks
the drive terms (damping, friction, armature, springs on followers) that Pinocchio does not
model. The test arm has generic axes, rotated joint origins, full inertia tensors and
full-precision numbers; a revolute follower on its leader's own path (the leader's column of M
sums both joints), a prismatic finger mirroring the other with an offset, a revolute follower
on another branch.

On the floating-base path a follower likewise has no entry of its own in q or v (NQ and NV count
the leaders' coordinates) and its column joins its leader's. Two references: Pinocchio with
mimic joints and a free flyer (``buildModelFromUrdf(path, JointModelFreeFlyer(), mimic=True)``,
its own URDF parser) on the arm loaded with ``--floating-base`` (a massive base; a revolute
follower below its leader with a joint between, a prismatic finger mirroring the other, a
revolute follower on another branch): M (from its rnea: its crba is wrong for such a follower),
rnea, nonLinearEffects, gravity, forward dynamics (``M^-1 (tau - h)``), integrate, difference,
frames. And the uncoupled robot (every follower a coordinate of its own, drive terms kept)
mapped by the coupling, ``M_c = G^T M G``, on a random tree with a floating base and a
spherical joint. Then ``dynderive check``'s rows (Pinocchio with a spherical joint and mimic
joints), the JAX target against NumPy, and what stays refused.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import random
from pathlib import Path

import numpy as np
import pytest
import sympy
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.mechanics.quasi_velocity import is_step_by_step
from dynderive.mechanics.tree import offsets
from dynderive.render.sheets.html import render_html
from dynderive.render.sheets.html_math import coordinate_math_names
from dynderive.render.sheets.latex_format import coordinate_names
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import generated_module, run_checks

from random_robots3d import _random_axis, _random_inertia

pin = pytest.importorskip("pinocchio")
runner = CliRunner()

LIMIT = '<limit lower="-3" upper="3" effort="100" velocity="5"/>'


def _link(name: str, mass: str, com: str, inertia: tuple[str, ...]) -> str:
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    return (f'  <link name="{name}"><inertial><origin xyz="{com}" '
            f'rpy="0.3141592653589793 -0.2718281828459045 0.1414213562373095"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" '
            f'iyy="{iyy}" iyz="{iyz}" izz="{izz}"/></inertial></link>\n')


ARM = (
    '<robot name="mimic_arm">\n  <link name="base"/>\n'
    + _link("l1", "1.734519283746512", "0.0123456789012345 -0.0234567890123456 0.1345678901234567",
            ("0.0312345678901234", "0.0012345678901234", "-0.0023456789012345", "0.0287654321098765",
             "0.0009876543210987", "0.0198765432109876"))
    + _link("l2", "1.2345678901234567", "0.2123456789012345 0.0112345678901234 -0.0087654321098765",
            ("0.0123456789012345", "-0.0011234567890123", "0.0007654321098765", "0.0456789012345678",
             "0.0013456789012345", "0.0398765432109876"))
    + _link("l3", "0.8765432109876543", "0.1012345678901234 -0.0156789012345678 0.0213456789012345",
            ("0.0067890123456789", "0.0004567890123456", "-0.0003456789012345", "0.0123456789012345",
             "0.0006789012345678", "0.0109876543210987"))
    + _link("fa", "0.1234567890123456", "0.0034567890123456 0.0123456789012345 0.0312345678901234",
            ("0.0002345678901234", "0.0000123456789012", "-0.0000234567890123", "0.0001987654321098",
             "0.0000345678901234", "0.0000876543210987"))
    + _link("fb", "0.1345678901234567", "-0.0023456789012345 -0.0134567890123456 0.0298765432109876",
            ("0.0002456789012345", "-0.0000134567890123", "0.0000212345678901", "0.0002087654321098",
             "-0.0000312345678901", "0.0000912345678901"))
    + _link("tip", "0.0456789012345678", "0.0012345678901234 0.0023456789012345 0.0156789012345678",
            ("0.0000345678901234", "0.0000012345678901", "0.0000023456789012", "0.0000298765432109",
             "-0.0000013456789012", "0.0000123456789012"))
    + '  <link name="tool"/>\n'
    + f'''  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0.0123456789012345 -0.0213456789012345 0.1534567890123456" rpy="0.0712345678901234 -0.0523456789012345 0.0312345678901234"/>
    <axis xyz="0.1234567890123456 -0.2345678901234567 0.9643650760992955"/>{LIMIT}</joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.0312345678901234 0.0123456789012345 0.2712345678901234" rpy="1.5707963267948966 0.1234567890123456 -0.0712345678901234"/>
    <axis xyz="0.0312345678901234 0.9987654321098765 -0.0412345678901234"/>{LIMIT}</joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.3312345678901234 -0.0212345678901234 0.0112345678901234" rpy="-0.2123456789012345 0.0345678901234567 0.4123456789012345"/>
    <axis xyz="-0.0612345678901234 0.2312345678901234 0.9712345678901234"/>{LIMIT}
    <mimic joint="j1" multiplier="0.7312345678901234" offset="0.3112345678901234"/></joint>
  <joint name="f1" type="prismatic"><parent link="l3"/><child link="fa"/>
    <origin xyz="0.1812345678901234 0.0212345678901234 -0.0112345678901234" rpy="0.0123456789012345 -0.0234567890123456 0.0345678901234567"/>
    <axis xyz="0.0412345678901234 0.9912345678901234 0.1234567890123456"/>{LIMIT}
    <dynamics damping="0.2123456789012345" friction="0.0312345678901234"/></joint>
  <joint name="f2" type="prismatic"><parent link="l3"/><child link="fb"/>
    <origin xyz="0.1812345678901234 -0.0212345678901234 -0.0112345678901234" rpy="-0.0123456789012345 0.0234567890123456 -0.0345678901234567"/>
    <axis xyz="-0.0412345678901234 -0.9912345678901234 0.1234567890123456"/>{LIMIT}
    <mimic joint="f1" multiplier="-1.1234567890123456" offset="0.0123456789012345"/>
    <dynamics damping="0.3123456789012345"/></joint>
  <joint name="k" type="revolute"><parent link="fa"/><child link="tip"/>
    <origin xyz="0.0112345678901234 0.0312345678901234 0.0612345678901234" rpy="0.2123456789012345 0.1123456789012345 -0.3123456789012345"/>
    <axis xyz="0.8123456789012345 -0.3123456789012345 0.4123456789012345"/>{LIMIT}
    <mimic joint="j2" multiplier="-1.3712345678901234" offset="-0.2012345678901234"/></joint>
  <joint name="flange" type="fixed"><parent link="fb"/><child link="tool"/>
    <origin xyz="0.0123456789012345 -0.0312345678901234 0.0712345678901234" rpy="0.1 -0.2 0.3"/></joint>
</robot>
'''
)

#: leader -> followers (name, multiplier, offset), as written above
COUPLED = {"j1": [("j3", 0.7312345678901234, 0.3112345678901234)],
           "f1": [("f2", -1.1234567890123456, 0.0123456789012345)],
           "j2": [("k", -1.3712345678901234, -0.2012345678901234)]}


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = tmp_path_factory.mktemp("mimic") / "mimic_arm.urdf"
    path.write_text(ARM)
    robot = dynderive.load_robot(path)
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "mimic_arm")
    return path, robot, module


def _pinocchio(path: Path, robot) -> tuple:
    """Pinocchio with mimic joints, and the index in its q (= v) of each of our coordinates."""
    model = pin.buildModelFromUrdf(str(path), mimic=True)
    order = np.zeros(len(robot.coordinates), dtype=int)
    for name, joint in zip(model.names, model.joints):
        if name in robot.coordinates:
            order[robot.coordinates.index(name)] = joint.idx_v
    return model, order


def test_followers_have_no_coordinate(arm):
    path, robot, module = arm
    assert robot.coordinates == ("j1", "j2", "f1")
    assert module.COORDINATES == ("j1", "j2", "f1")
    assert robot.efforts == ("tau_j1", "tau_j2", "f_f1")
    assert not any("mimic" in note for note in robot.notes)
    model, _ = _pinocchio(path, robot)
    assert (model.nq, model.nv) == (3, 3)


def _rnea_mass_matrix(model, data, q: np.ndarray) -> np.ndarray:
    """Pinocchio's M column by column from its rnea (``M e_k = rnea(q, 0, e_k) - rnea(q, 0, 0)``).
    Pinocchio 4.1's ``crba`` disagrees with its own rnea (and with ``G^T M G``) on this arm, in
    the entries between j1 and the joints below its follower j3 (a follower on its leader's path
    with a joint between them; Pinocchio fixed other such crba cases in PR #2716):
    ``test_crba_without_the_follower_on_its_leaders_path`` compares crba where it is right."""
    zero = np.zeros(model.nv)
    base = pin.rnea(model, data, q, zero, zero)
    return np.array([pin.rnea(model, data, q, zero, e) - base for e in np.eye(model.nv)]).T


def _ours(order: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Our vector or matrix in Pinocchio's order."""
    out = np.empty(values.shape)
    if values.ndim == 1:
        out[order] = values
    else:
        out[np.ix_(order, order)] = values
    return out


def test_agrees_with_pinocchio_mimic_model(arm):
    """M (from Pinocchio's rnea), rnea, nonLinearEffects, computeGeneralizedGravity and the
    forward dynamics at random states, to 1e-9 of their size."""
    path, robot, module = arm
    model, order = _pinocchio(path, robot)
    data = model.createData()
    rng = np.random.default_rng(30)
    # Pinocchio does not model damping and friction: compare without them (the module's
    # inverse_dynamics adds friction_forces; mass_matrix, gravity_vector, coriolis_matrix do not)
    for q, qd, qdd in rng.uniform(-1.5, 1.5, (4, 3, 3)):
        qp, vp, ap = _ours(order, q), _ours(order, qd), _ours(order, qdd)
        M = _rnea_mass_matrix(model, data, qp)
        np.testing.assert_allclose(_ours(order, module.mass_matrix(q)), M, rtol=0,
                                   atol=1e-9 * np.max(np.abs(M)))
        tau = pin.rnea(model, data, qp, vp, ap)
        ours = module.inverse_dynamics(q, qd, qdd) - module.friction_forces(qd)
        np.testing.assert_allclose(_ours(order, ours), tau, rtol=0, atol=1e-9 * np.max(np.abs(tau)))
        h = pin.nonLinearEffects(model, data, qp, vp)
        ours = module.coriolis_matrix(q, qd) @ qd + module.gravity_vector(q)
        np.testing.assert_allclose(_ours(order, ours), h, rtol=0, atol=1e-9 * np.max(np.abs(h)))
        g = pin.computeGeneralizedGravity(model, data, qp)
        np.testing.assert_allclose(_ours(order, module.gravity_vector(q)), g, rtol=0,
                                   atol=1e-9 * np.max(np.abs(g)))
        u = rng.uniform(-2, 2, 3)
        # Pinocchio's aba refuses mimic joints: M^-1 (Y - F - h), F the module's friction forces
        expected = np.linalg.solve(M, _ours(order, u - module.friction_forces(qd)) - h)
        np.testing.assert_allclose(_ours(order, module.forward_dynamics(q, qd, u)), expected, rtol=0,
                                   atol=1e-9 * np.max(np.abs(expected)))


def test_crba_without_the_follower_on_its_leaders_path(tmp_path):
    """Pinocchio's crba itself, on the arm without j3's coupling (j3 a coordinate of its own):
    the other two followers stay (a finger mirroring the other, a revolute follower of j2 on
    another branch)."""
    text = ARM.replace('\n    <mimic joint="j1" multiplier="0.7312345678901234" '
                       'offset="0.3112345678901234"/>', "")
    assert text != ARM
    path = tmp_path / "mimic_arm.urdf"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    assert robot.coordinates == ("j1", "j2", "j3", "f1")
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "mimic_arm")
    model, order = _pinocchio(path, robot)
    data = model.createData()
    for q in np.random.default_rng(31).uniform(-1.5, 1.5, (4, 4)):
        M = pin.crba(model, data, _ours(order, q))
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(_ours(order, module.mass_matrix(q)), M, rtol=0,
                                   atol=1e-9 * np.max(np.abs(M)))
        np.testing.assert_allclose(M, _rnea_mass_matrix(model, data, _ours(order, q)), rtol=0,
                                   atol=1e-9 * np.max(np.abs(M)))


def _uncoupled(robot):
    """The same robot with every follower a coordinate of its own (its drive terms kept)."""
    import dataclasses

    joints = tuple(dataclasses.replace(j, mimic=None) for j in robot.joints)
    return dataclasses.replace(robot, name=robot.name + "_uncoupled", joints=joints)


def _coupling(robot, free):
    """``G`` and ``offset`` with ``q_free = G q + offset`` (free: the uncoupled robot)."""
    G = np.zeros((len(free.coordinates), len(robot.coordinates)))
    offset = np.zeros(len(free.coordinates))
    for i, name in enumerate(free.coordinates):
        joint = next(j for j in robot.joints if j.name == name)
        leader, multiplier, shift = robot.driver(joint)
        G[i, robot.coordinates.index(leader)] = multiplier
        offset[i] = shift
    return G, offset


def test_frames_agree_with_pinocchio(arm):
    """The welded link ``tool`` (a frame on the follower finger fb): placement, LOCAL_WORLD_ALIGNED
    Jacobian (its columns sum the joints each coordinate moves) and classical acceleration."""
    path, robot, module = arm
    assert module.FRAMES == ("tool",)
    model, order = _pinocchio(path, robot)
    data = model.createData()
    for q, qd in np.random.default_rng(32).uniform(-1.5, 1.5, (4, 2, 3)):
        frame_agrees_with_pinocchio(module, model, data, "tool", (q, qd), (_ours(order, q), _ours(order, qd)),
                                    np.argsort(order))


def frame_agrees_with_pinocchio(module, model, data, frame: str, state: tuple, pinocchio_state: tuple,
                                columns) -> None:
    """``frame``'s placement, LOCAL_WORLD_ALIGNED Jacobian (``columns``: our velocity columns in
    Pinocchio's order) and classical acceleration at ``state`` (q, qd), Pinocchio's at
    ``pinocchio_state`` (the same state in its order)."""
    q, qd = state
    fid = model.getFrameId(frame)
    pin.forwardKinematics(model, data, *pinocchio_state, np.zeros(model.nv))
    pin.computeJointJacobians(model, data, pinocchio_state[0])
    pin.updateFramePlacements(model, data)
    T = module.frame_transform(q, frame)
    np.testing.assert_allclose(T[:3, :3], data.oMf[fid].rotation, rtol=0, atol=1e-12)
    np.testing.assert_allclose(T[:3, 3], data.oMf[fid].translation, rtol=0, atol=1e-12)
    J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(module.frame_jacobian(q, frame)[:, columns], J, rtol=0, atol=1e-12)
    a = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(module.frame_jacobian_dot_qd(q, qd, frame),
                               np.concatenate([a.linear, a.angular]),
                               rtol=0, atol=1e-11)


def _quantities_agree_with_module(derivation, module, seed: int, frames: tuple[str, ...] = ()) -> None:
    """The derivation's M_g, C_g, N_g, EOM_g1 (Lagrange's route), EOM_g2, T_g, V_g and the
    frames' J at random states equal the generated module's; its regressor gives tau."""
    table, robot = derivation.symbols, derivation.robot
    values = [p.value for p in robot.parameters]
    args = [table.q, table.qd, table.qdd, list(table.efforts.values()), list(table.parameters.values())]
    n = len(table.q)
    rng = np.random.default_rng(seed)
    functions: dict[str, object] = {}   # each quantity printed once (lambdify is most of the time)
    for q, qd, qdd in rng.uniform(-1.5, 1.5, (2, 3, n)):
        u = rng.uniform(-1, 1, len(table.efforts))

        def at(name, state=(q, qd, qdd, u)):
            if name not in functions:
                functions[name] = derivation.lambdify(args, derivation[name])
            return np.asarray(functions[name](*state, values), dtype=float)

        np.testing.assert_allclose(at("M_g"), module.mass_matrix(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(at("C_g"), module.coriolis_matrix(q, qd), rtol=0, atol=1e-12)
        np.testing.assert_allclose(at("N_g").ravel(), module.gravity_vector(q), rtol=0, atol=1e-12)
        residual = module.inverse_dynamics(q, qd, qdd) - module.generalized_forces(q, u)
        # friction: sign(qd)
        for name in ("EOM_g1", "EOM_g2")[0 if "EOM_g1" in derivation.quantities else 1:]:
            np.testing.assert_allclose(at(name).ravel(), residual, rtol=0, atol=1e-11)
        for frame in frames:
            np.testing.assert_allclose(at(f"J_{frame}"), module.frame_jacobian(q, frame), rtol=0, atol=1e-12)
        np.testing.assert_allclose(module.regressor(q, qd, qdd) @ module.parameter_vector(),
                                   module.inverse_dynamics(q, qd, qdd), rtol=0, atol=1e-11)
        kinetic = 0.5 * qd @ module.mass_matrix(q) @ qd
        assert module.kinetic_energy(q, qd) == pytest.approx(kinetic, rel=1e-12)
        assert float(at("T_g")) == pytest.approx(kinetic, rel=1e-12)
        assert float(at("V_g")) == pytest.approx(module.potential_energy(q), rel=1e-12, abs=1e-12)


def test_intermediate_form_regressor_and_energies_agree_with_the_module(arm):
    """Six joint variables: the arm takes the intermediate-variable form (the recursion's
    programs with the coupling), whose quantities, Lagrange's route included, match the module."""
    path, robot, module = arm
    derivation = dynderive.derive(robot)
    assert derivation.intermediate_form
    _quantities_agree_with_module(derivation, module, 33)


GRIPPER_YAML = """\
name: coupled
title: A shoulder driving an elbow, a finger driving its twin
parameters:
  g: {value: 9.81}
  m1: {value: 1.2345678901234567}
  b1: {value: 0.1234567890123456}
  fc1: {value: 0.0567890123456789}
  Ia1: {value: 0.0312345678901234}
gravity: [0, 0, -g]
links:
  - {name: arm, mass: m1, com: [0.0123456789012345, 0.1712345678901234, -0.0212345678901234],
     inertia: [0.0312345678901234, 0.0123456789012345, 0.0287654321098765, 0.0012345678901234,
               -0.0023456789012345, 0.0009876543210987]}
  - {name: forearm, mass: 0.8765432109876543, com: [0.1512345678901234, 0.0123456789012345, 0.0087654321098765],
     inertia: [0.0067890123456789, 0.0123456789012345, 0.0109876543210987, 0.0004567890123456,
               -0.0003456789012345, 0.0006789012345678]}
  - {name: left, mass: 0.1234567890123456, com: [0.0034567890123456, 0.0123456789012345, 0.0312345678901234],
     inertia: [0.0002345678901234, 0.0001987654321098, 0.0000876543210987, 0.0000123456789012,
               -0.0000234567890123, 0.0000345678901234]}
  - {name: right, mass: 0.1345678901234567, com: [-0.0023456789012345, -0.0134567890123456, 0.0298765432109876],
     inertia: [0.0002456789012345, 0.0002087654321098, 0.0000912345678901, -0.0000134567890123,
               0.0000212345678901, -0.0000312345678901]}
joints:
  - {name: shoulder, type: revolute, parent: world, child: arm,
     origin: {xyz: [0.0123456789012345, -0.0213456789012345, 0.1534567890123456], rpy: [0.0712345678901234, -0.0523456789012345, 0.0312345678901234]},
     axis: [0.1234567890123456, -0.2345678901234567, 0.9643650760992955], effort: tau1,
     damping: b1, friction: fc1, armature: Ia1}
  - {name: elbow, type: revolute, parent: arm, child: forearm,
     origin: {xyz: [0.0312345678901234, 0.3312345678901234, 0.0112345678901234], rpy: [1.2123456789012345, 0.1234567890123456, -0.0712345678901234]},
     axis: [0.0312345678901234, 0.9987654321098765, -0.0412345678901234],
     mimic: {joint: shoulder, multiplier: 0.5123456789012345, offset: 0.2512345678901234},
     damping: 0.0712345678901234, friction: 0.0212345678901234, armature: 0.0112345678901234,
     stiffness: 2.5123456789012345, rest: 0.1012345678901234}
  - {name: grip, type: prismatic, parent: forearm, child: left,
     origin: {xyz: [0.2812345678901234, 0.0212345678901234, -0.0112345678901234], rpy: [0.0123456789012345, -0.0234567890123456, 0.0345678901234567]},
     axis: [0.0412345678901234, 0.9912345678901234, 0.1234567890123456], effort: f_grip,
     friction: 0.2123456789012345}
  - {name: twin, type: prismatic, parent: forearm, child: right,
     origin: {xyz: [0.2812345678901234, -0.0212345678901234, -0.0112345678901234], rpy: [-0.0123456789012345, 0.0234567890123456, -0.0345678901234567]},
     axis: [-0.0412345678901234, -0.9912345678901234, 0.1234567890123456],
     mimic: {joint: grip, multiplier: -1}, damping: 0.3123456789012345, friction: 0.1012345678901234}
"""


@pytest.fixture(scope="module")
def coupled(tmp_path_factory):
    path = tmp_path_factory.mktemp("mimic") / "coupled.yaml"
    path.write_text(GRIPPER_YAML)
    robot = dynderive.load_robot(path)
    derivation = dynderive.derive(robot)
    module = generated_module(dynderive.render_code(derivation), "coupled")
    free = _uncoupled(robot)
    free_module = generated_module(dynderive.render_code(dynderive.derive(free)), "coupled_uncoupled")
    return robot, derivation, module, free, free_module


def test_yaml_mimic_takes_the_symbolic_route(coupled):
    """Two coordinates, four joint variables: the closed-form route (body Jacobians of the
    coupled kinematics, C from M's derivatives) agrees with the module's programs (Lagrange's
    route is skipped here, its Lagrangian being too large with these numbers; the arm's
    intermediate form checks it)."""
    robot, derivation, module, _, _ = coupled
    assert robot.coordinates == ("shoulder", "grip") and robot.efforts == ("tau1", "f_grip")
    assert not derivation.intermediate_form
    _quantities_agree_with_module(derivation, module, 34)


def test_drive_terms_of_followers_map_through_the_coupling(coupled):
    """Against the uncoupled robot (followers with coordinates of their own, same drive terms):
    M = G^T M_f G, tau = G^T tau_f(G q + o, G qd, G qdd) (damping, Coulomb friction, armature
    and the follower's spring included), the same energies, and forward dynamics solving it."""
    robot, _, module, free, free_module = coupled
    G, offset = _coupling(robot, free)
    assert free.coordinates == ("shoulder", "elbow", "grip", "twin")
    rng = np.random.default_rng(35)
    for q, qd, qdd in rng.uniform(-1.5, 1.5, (4, 3, 2)):
        qf, vf, af = G @ q + offset, G @ qd, G @ qdd
        M = G.T @ free_module.mass_matrix(qf) @ G
        np.testing.assert_allclose(module.mass_matrix(q), M, rtol=0, atol=1e-12)
        tau = G.T @ free_module.inverse_dynamics(qf, vf, af)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd), tau, rtol=0, atol=1e-11)
        np.testing.assert_allclose(module.friction_forces(qd), G.T @ free_module.friction_forces(vf), rtol=0,
                                   atol=1e-12)
        np.testing.assert_allclose(module.gravity_vector(q), G.T @ free_module.gravity_vector(qf), rtol=0,
                                   atol=1e-11)
        assert module.potential_energy(q) == pytest.approx(free_module.potential_energy(qf), rel=1e-12)
        assert module.kinetic_energy(q, qd) == pytest.approx(free_module.kinetic_energy(qf, vf), rel=1e-12)
        u = rng.uniform(-1, 1, 2)
        expected = np.linalg.solve(M, module.generalized_forces(q, u)
                                   - G.T @ free_module.inverse_dynamics(qf, vf, 0 * vf))
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u), expected, rtol=0, atol=1e-10)


def _mutated(tmp_path, change, tag: str) -> Path:
    data = yaml.safe_load(GRIPPER_YAML)
    change(data)
    path = tmp_path / f"{tag}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _joint(index: int, **keys):
    return lambda data: data["joints"][index].update(keys)


def _mimic(index: int, **keys):
    return lambda data: data["joints"][index]["mimic"].update(keys)


REFUSED = [
    ("unknown", _mimic(1, joint="shouldr"),
     "joints[1].mimic.joint: unknown joint 'shouldr' (did you mean 'shoulder'?)"),
    ("self", _mimic(1, joint="elbow"), "joints[1].mimic.joint: a joint cannot mimic itself"),
    ("chain", _mimic(3, joint="elbow"),
     "joints[3].mimic.joint: joint 'elbow' mimics joint 'shoulder' itself: a joint "
     "can only mimic a joint with a coordinate of its own (mimic the first one, multipliers and offsets "
     "composed)"),
    ("cycle", lambda d: (_mimic(1, joint="twin")(d), _mimic(3, joint="elbow")(d)),
     "joints[1].mimic.joint: joint 'twin' mimics joint 'elbow' itself"),
    ("infinite", _mimic(1, multiplier=float("inf")),
     "joints[1].mimic.multiplier: expected a finite number, got inf"),
    ("huge", _mimic(1, multiplier=10**400), "joints[1].mimic.multiplier: expected a finite number, got 1000"),
    ("text", _mimic(1, offset="x"), "joints[1].mimic.offset: expected a finite number, got 'x'"),
    ("zero", _mimic(1, multiplier=0),
     "joints[1].mimic.multiplier: multiplier 0 does not move the joint (make it "
     "type: fixed)"),
    ("key", _mimic(1, factor=2),
     "joints[1].mimic.factor: unknown key 'factor' (allowed: joint, multiplier, offset)"),
    ("effort", _joint(1, effort="tau2"),
     "joints[1].effort: a mimic joint has no effort of its own (its drive acts on "
     "its leader's coordinate, through the multiplier): put the effort on joint 'shoulder'"),
    ("springs", _joint(0, stiffness=1.0),
     "joints[1].stiffness: coordinate 'shoulder' already has a spring (on joint "
     "'shoulder'): one spring per coordinate, on a leader or on one of its mimic joints"),
    ("fixed", _joint(1, type="fixed"),
     "joints[1].mimic: a fixed joint cannot mimic another (only revolute and "
     "prismatic joints can)"),
    ("leader", _joint(0, type="fixed"),
     "joints[1].mimic.joint: joint 'shoulder' is fixed: only revolute and prismatic "
     "joints can be mimicked"),
]


@pytest.mark.parametrize(("tag", "change", "message"), REFUSED, ids=[r[0] for r in REFUSED])
def test_refused_with_a_positioned_error(tmp_path, tag, change, message):
    path = _mutated(tmp_path, change, tag)
    with pytest.raises(InputError) as refused:
        dynderive.load_robot(path)
    problems = refused.value.problems
    assert any(message in p.message for p in problems), str(refused.value)
    assert all(p.file == str(path) and p.line > 1 and p.column >= 1 for p in problems)
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output


def test_urdf_mimic_of_a_missing_or_fixed_joint_is_ignored_with_a_note(tmp_path):
    """A <mimic> naming a joint the file does not have (alex_psyonic_hands.urdf), or a fixed
    one: the joint is an independent coordinate, as in Pinocchio's default, with a note there."""
    line = 1 + ARM[:ARM.index('<mimic joint="f1"')].count("\n")
    for leader, why in (("nowhere", "which the file does not have"),
                        ("flange", "a fixed joint, which has no coordinate")):
        path = tmp_path / f"{leader}.urdf"
        path.write_text(ARM.replace('<mimic joint="f1"', f'<mimic joint="{leader}"'))
        robot = dynderive.load_robot(path)
        assert robot.coordinates == ("j1", "j2", "f1", "f2")
        assert robot.notes == (f"{path}:{line}:5: note: joint 'f2': its <mimic> names joint '{leader}', "
                               f"{why}: 'f2' is an independent coordinate (as in Pinocchio's default, "
                               "buildModelFromUrdf without mimic)",)


def test_import_writes_the_mimic_and_reloads_the_same_robot(arm, tmp_path):
    path, robot, _ = arm
    out = tmp_path / "mimic_arm.yaml"
    result = runner.invoke(app, ["import", str(path), "--output", str(out)])
    assert result.exit_code == 0, result.output
    joints = {j["name"]: j for j in yaml.safe_load(out.read_text())["joints"]}
    assert joints["f2"]["mimic"] == {"joint": "f1", "multiplier": -1.1234567890123456,
                                     "offset": 0.0123456789012345}
    assert "effort" not in joints["f2"] and joints["f2"]["damping"] == 0.3123456789012345
    reloaded = dynderive.load_robot(out)
    assert reloaded.joints == robot.joints and reloaded.coordinates == robot.coordinates


def _panda() -> Path:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    return next(Path(str(dist.locate_file(f))) for f in dist.files or ()
                if str(f).endswith("panda_description/urdf/panda.urdf"))


def test_the_pandas_second_finger_mimics_the_first():
    """example-robot-data's Panda: panda_finger_joint2 follows panda_finger_joint1 (multiplier 1,
    offset 0), so 8 coordinates (Pinocchio's nv with mimic=True); its damping 0.3 joins the
    leader's (0.6 in all); M (crba) and rnea by the programs equal Pinocchio's mimic model."""
    from dynderive.mechanics.drives import joint_drives
    from dynderive.mechanics.recursive import inverse_dynamics_program, mass_matrix_program
    from dynderive.model.symbols import SymbolTable

    path = _panda()
    robot = dynderive.load_robot(path)
    follower = next(j for j in robot.joints if j.name == "panda_finger_joint2")
    assert follower.mimic == dynderive.model.robot.Mimic("panda_finger_joint1", 1, 0) \
        and follower.effort is None
    assert len(robot.coordinates) == 8 and "panda_finger_joint2" not in robot.coordinates
    assert not any("mimic" in note for note in robot.notes)
    table = SymbolTable.for_robot(robot)
    assert [float(d.damping) for d in joint_drives(robot, table)][7] == pytest.approx(0.6, rel=1e-15)
    model, order = _pinocchio(path, robot)
    assert model.nv == 8
    data = model.createData()
    arguments = [*table.parameters.values(), *table.q, *table.qd, *table.qdd]
    programs = [sympy.lambdify(arguments, p.outputs, modules="math", cse=lambda out, p=p: (p.lines, out))
                for p in (mass_matrix_program(robot, table), inverse_dynamics_program(robot, table))]
    values = [p.value for p in robot.parameters]
    for q, qd, qdd in np.random.default_rng(36).uniform(-1.5, 1.5, (2, 3, 8)):
        M = np.reshape(programs[0](*values, *q, *qd, *qdd), (8, 8))
        tau = np.array(programs[1](*values, *q, *qd, *qdd))
        M_pin = pin.crba(model, data, _ours(order, q))
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        np.testing.assert_allclose(_ours(order, M), M_pin, rtol=0, atol=1e-9 * np.max(np.abs(M_pin)))
        tau_pin = pin.rnea(model, data, _ours(order, q), _ours(order, qd), _ours(order, qdd))
        np.testing.assert_allclose(_ours(order, tau), tau_pin, rtol=0, atol=1e-9 * np.max(np.abs(tau_pin)))


def test_sheet_html_and_json_show_the_coupling(arm, tmp_path):
    """The recursion names a revolute follower's sine and cosine and gives its variable; the
    HTML's joint table shows it; the JSON has three coordinates and efforts."""
    path, _, _ = arm
    result = runner.invoke(app,
                           ["solve", str(path), "--latex", "--html", "--json", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    tex = (tmp_path / "mimic_arm.tex").read_text()
    assert "the mimic joint of link 3" in tex and "c_{1,3}" in tex
    # the multiplier 0.7312345678901234 at the sheet's 6 digits (the JSON keeps every one)
    assert "0.731235" in tex and "mimic joint of link 5" not in tex   # prismatic: no sine
    html = (tmp_path / "mimic_arm.html").read_text()
    assert "0.731235" in html and "0.7312345678901234" not in html
    import json

    data = json.loads((tmp_path / "mimic_arm.json").read_text())
    assert data["coordinates"] == ["j1", "j2", "f1"] and data["efforts"] == ["tau_j1", "tau_j2", "f_f1"]


# -- floating base: mimic joints under a free flyer ----------------------------------------

BASE = _link("base", "2.3456789012345678", "0.0212345678901234 -0.0312345678901234 0.0412345678901234",
             ("0.0412345678901234", "0.0023456789012345", "-0.0034567890123456", "0.0387654321098765",
              "0.0019876543210987", "0.0298765432109876"))
#: ARM with a massive base (a massless one under j1 would make M singular), its
#: <dynamics> (damping and friction) kept
FLOATING_ARM = ARM.replace('  <link name="base"/>\n', BASE)


@pytest.fixture(scope="module")
def floating_arm(tmp_path_factory):
    path = tmp_path_factory.mktemp("floating_mimic") / "mimic_arm.urdf"
    path.write_text(FLOATING_ARM)
    robot = dynderive.load_robot(path, floating_base=True)
    derivation = dynderive.derive(robot)
    source = render_code(derivation)
    return path, robot, derivation, generated_module(source, robot.name)


def _pinocchio_free_flyer(path: Path, robot) -> tuple:
    """Pinocchio's free flyer with mimic joints, and where its q and v entries are in ours."""
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer(), mimic=True)
    where = offsets(robot)
    qp, vp = np.zeros(model.nq, dtype=int), np.zeros(model.nv, dtype=int)
    for index, (name, joint) in enumerate(zip(model.names, model.joints)):
        if index > 0 and index not in model.mimicking_joints:
            qp[joint.idx_q:joint.idx_q + joint.nq] = range(where.q[name], where.q[name] + joint.nq)
            vp[joint.idx_v:joint.idx_v + joint.nv] = range(where.v[name], where.v[name] + joint.nv)
    return model, qp, vp


def test_floating_followers_have_no_coordinate(floating_arm):
    path, robot, _, module = floating_arm
    assert robot.joints[0].name == "root_joint" and robot.joints[0].type == "floating"
    assert robot.coordinates == ("root_joint", "j1", "j2", "f1")
    assert (module.NQ, module.NV) == (10, 9)
    assert module.COORDINATES[7:] == ("j1", "j2", "f1")
    assert robot.efforts == ("tau_j1", "tau_j2", "f_f1")
    model, _, _ = _pinocchio_free_flyer(path, robot)
    assert (model.nq, model.nv) == (10, 9) and len(model.mimicking_joints) == 3
    assert not is_step_by_step(robot)


def test_agrees_with_pinocchio_free_flyer_with_mimic_joints(floating_arm):
    path, robot, _, module = floating_arm
    model, qp, vp = _pinocchio_free_flyer(path, robot)
    data = model.createData()
    rng = np.random.default_rng(30)
    pin.seed(30)
    crba_wrong = 0.0
    for _ in range(3):
        q, q1 = (np.empty(10) for _ in range(2))
        q[qp] = pin.randomConfiguration(model, -np.ones(10), np.ones(10))
        q1[qp] = pin.randomConfiguration(model, -np.ones(10), np.ones(10))
        v, a = rng.normal(size=9), rng.normal(size=9)
        u = rng.normal(size=3)
        qq, vv = q[qp], v[vp]
        M = _rnea_mass_matrix(model, data, qq)
        scale = np.max(np.abs(M))
        np.testing.assert_allclose(module.mass_matrix(q)[np.ix_(vp, vp)], M, rtol=0, atol=1e-9 * scale)
        crba = pin.crba(model, data, qq)
        crba_wrong = max(crba_wrong, np.max(np.abs(np.triu(crba) + np.triu(crba, 1).T - M)))
        # damping and friction, which Pinocchio's rnea and aba leave out
        friction = module.friction_forces(v)
        f1 = offsets(robot).v["f1"]   # f1's <dynamics>, and its follower f2's damping through m = -1.123...
        expected_f1 = (0.2123456789012345 + 1.1234567890123456**2 * 0.3123456789012345) * v[f1] \
            + 0.0312345678901234 * np.sign(v[f1])
        assert friction[f1] == pytest.approx(expected_f1, rel=1e-13) and np.count_nonzero(friction) == 1
        tau = pin.rnea(model, data, qq, vv, a[vp])
        np.testing.assert_allclose((module.inverse_dynamics(q, v, a) - friction)[vp], tau, rtol=0,
                                   atol=1e-9 * np.max(np.abs(tau)))
        h = pin.nonLinearEffects(model, data, qq, vv)
        ours = module.coriolis_matrix(q, v) @ v + module.gravity_vector(q)
        np.testing.assert_allclose(ours[vp], h, rtol=0, atol=1e-9 * np.max(np.abs(h)))
        g = pin.computeGeneralizedGravity(model, data, qq)
        np.testing.assert_allclose(module.gravity_vector(q)[vp], g, rtol=0, atol=1e-9 * np.max(np.abs(g)))
        applied = np.zeros(9)
        applied[list(robot.effort_columns())] = u
        expected = np.linalg.solve(M, (applied - friction)[vp] - h)   # Pinocchio's aba refuses mimic joints
        np.testing.assert_allclose(module.forward_dynamics(q, v, u)[vp], expected, rtol=0,
                                   atol=1e-9 * np.max(np.abs(expected)))
        assert module.kinetic_energy(q, v) == pytest.approx(0.5 * vv @ M @ vv, rel=1e-12)
        np.testing.assert_allclose(module.integrate(q, v, 0.37)[qp], pin.integrate(model, qq, 0.37 * vv),
                                   atol=1e-12)
        np.testing.assert_allclose(module.difference(q, q1)[vp], pin.difference(model, qq, q1[qp]), atol=1e-9)
        frame_agrees_with_pinocchio(module, model, data, "tool", (q, v), (qq, vv), vp)
        Y = module.regressor(q, v, a)
        np.testing.assert_allclose(Y @ module.parameter_vector(), module.inverse_dynamics(q, v, a), rtol=0,
                                   atol=1e-12)
    assert crba_wrong > 1e-3   # why M is read from rnea: Pinocchio 4.1's crba with j3 below j1, j2 between


def test_sheets_name_only_the_leaders_coordinates(floating_arm):
    """The LaTeX sheet and the HTML page of a floating robot with followers: a name for each
    entry of q, v and vdot (the followers have none), the same symbols on both; the page renders."""
    _, robot, derivation, _ = floating_arm
    table = derivation.symbols
    latex, math = coordinate_names(derivation), coordinate_math_names(derivation)
    assert set(latex) == set(math) == {*table.q, *table.qd, *table.qdd}
    assert "j3" not in " ".join(latex.values()) and "\\dot{v}_{x}" in latex.values()
    page = render_html(derivation)
    assert page.startswith("<!DOCTYPE html>") and page.count("<math") > 10


def test_linearize_along_integrate(floating_arm):
    """``linearize``'s lower rows against central differences of forward_dynamics along
    integrate (the derivatives' tangent seeds skip the followers, moved by their leaders)."""
    _, robot, _, module = floating_arm
    rng = np.random.default_rng(31)
    q, v, u = rng.uniform(-1.2, 1.2, 10), rng.normal(size=9), rng.normal(size=3)
    q[3:7] /= np.linalg.norm(q[3:7])
    A, B = module.linearize(q, v, u)
    h = 1e-6
    dq = np.array([module.forward_dynamics(module.integrate(q, e, h), v, u)
                   - module.forward_dynamics(module.integrate(q, e, -h), v, u)
                   for e in np.eye(9)]).T / (2 * h)
    dv = np.array([module.forward_dynamics(q, v + h * e, u) - module.forward_dynamics(q, v - h * e, u)
                   for e in np.eye(9)]).T / (2 * h)
    scale = max(1.0, np.max(np.abs(dq)))
    np.testing.assert_allclose(A[9:, :9], dq, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(A[9:, 9:], dv, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(B[9:], np.linalg.inv(module.mass_matrix(q))[:, list(robot.effort_columns())],
                               rtol=0, atol=1e-9)


def test_the_jax_module_agrees_with_numpy(floating_arm):
    """The JAX target's mass matrix, inverse and forward dynamics and frame Jacobian equal the
    NumPy module's (float64, a batch of states; the followers' columns summed alike). Eager JAX
    runs a straight-line program op by op: four functions, not all of ``check --backend jax``."""
    jax = pytest.importorskip("jax")
    from dynderive.render.targets.jax.jax import render_jax

    jax.config.update("jax_enable_x64", True)
    _, robot, derivation, module = floating_arm
    traced = generated_module(render_jax(derivation), f"{robot.name}_jax")
    rng = np.random.default_rng(33)
    q = rng.uniform(-1.2, 1.2, (2, 10))
    q[:, 3:7] /= np.linalg.norm(q[:, 3:7], axis=1, keepdims=True)
    v, a, u = rng.normal(size=(2, 9)), rng.normal(size=(2, 9)), rng.normal(size=(2, 3))
    for name, args in (("mass_matrix", (q,)), ("inverse_dynamics", (q, v, a)),
                       ("forward_dynamics", (q, v, u)),
                       ("frame_jacobian", (q, "tool"))):
        expected = getattr(module, name)(*args)
        np.testing.assert_allclose(np.asarray(getattr(traced, name)(*args)), expected, rtol=0,
                                   atol=1e-12 * np.max(np.abs(expected)))


def _r(value: float) -> float:
    return float(f"{value:.16g}")


def _spherical_tree(drives: bool) -> str:
    """A floating base; a spherical joint below it; revolute j1, and j3 following j1 below it;
    a prismatic finger f2 on the base following j1 too; a frame on j3's link. Random
    full-precision numbers, generic axes, full inertias. ``drives``: armature and damping on j1,
    armature, springs, damping and friction on the followers."""
    rng = random.Random(30)
    links = []
    for name in ("base", "l1", "l2", "l3", "fa"):
        inertia = _random_inertia(rng)
        links.append({"name": name, "mass": _r(rng.uniform(0.3, 2.0)),
                      "com": [_r(rng.uniform(-0.2, 0.2)) for _ in range(3)],
                      "inertia": [inertia[0][0], inertia[1][1], inertia[2][2], inertia[0][1], inertia[0][2],
                                  inertia[1][2]]})

    def origin() -> dict:
        return {"xyz": [_r(rng.uniform(-0.4, 0.4)) for _ in range(3)],
                "rpy": [_r(rng.uniform(-2, 2)) for _ in range(3)]}

    joints = [{"name": "root", "type": "floating", "parent": "world", "child": "base", "origin": origin()},
              {"name": "ball", "type": "spherical", "parent": "base", "child": "l1", "origin": origin(),
               "effort": "m"},
              {"name": "j1", "type": "revolute", "parent": "l1", "child": "l2", "origin": origin(),
               "axis": list(_random_axis(rng)), "effort": "tau1"},
              {"name": "j3", "type": "revolute", "parent": "l2", "child": "l3", "origin": origin(),
               "axis": list(_random_axis(rng)), "mimic": {"joint": "j1", "multiplier": -0.7312345678901234,
                                                          "offset": 0.3112345678901234}},
              {"name": "f2", "type": "prismatic", "parent": "base", "child": "fa", "origin": origin(),
               "axis": list(_random_axis(rng)), "mimic": {"joint": "j1", "multiplier": 0.1234567890123456,
                                                          "offset": -0.0123456789012345}}]
    if drives:
        joints[2].update(armature=0.0412345678901234, damping=0.1712345678901234)
        joints[3].update(armature=0.0312345678901234, stiffness=1.2345678901234567, rest=0.2123456789012345,
                         damping=0.0912345678901234, friction=0.0412345678901234)
        joints[4].update(armature=0.0212345678901234, friction=0.2312345678901234)
    return yaml.safe_dump({"name": "spherical_mimic", "title": "floating base, spherical joint, mimic joints",
                           "planar": False, "parameters": {"g": 9.81}, "gravity": [0, 0, "-g"],
                           "links": links, "joints": joints,
                           "frames": [{"name": "tip", "link": "l3", "origin": origin()}]},
                          sort_keys=False)


@pytest.fixture(scope="module")
def driven(tmp_path_factory):
    """The spherical tree with drive terms, coupled and uncoupled (each follower a coordinate)."""
    path = tmp_path_factory.mktemp("floating_mimic") / "spherical_mimic.yaml"
    path.write_text(_spherical_tree(drives=True))
    robot = dynderive.load_robot(path)
    free = dataclasses.replace(robot, name="spherical_free", joints=tuple(dataclasses.replace(j, mimic=None)
                                                                          for j in robot.joints))
    derivation = dynderive.derive(robot)
    source = render_code(derivation)
    uncoupled = generated_module(render_code(dynderive.derive(free)), free.name)
    return robot, free, derivation, source, generated_module(source, robot.name), uncoupled


def test_the_uncoupled_robot_mapped_by_the_coupling(driven):
    """``q_free = (q, G q + offset)``, ``v_free = G v``: ``M = G^T M_free G``, ``inverse_dynamics =
    G^T inverse_dynamics_free``, gravity, energies, forward dynamics, ``friction_forces = G^T
    friction_forces_free(G v)``; the followers' armature, springs, damping and friction act on
    their leaders through the multiplier."""
    robot, free, _, _, coupled, uncoupled = driven
    assert (coupled.NQ, coupled.NV, uncoupled.NQ, uncoupled.NV) == (12, 10, 14, 12)
    where, where_free = offsets(robot), offsets(free)
    G, shift, Q = np.zeros((12, 10)), np.zeros(14), np.zeros((14, 12))
    for joint in (j for j in robot.joints if j.moves):
        leader, multiplier, offset = robot.driver(joint)
        size_q, size_v = joint.sizes if joint.owns else (1, 1)
        for k in range(size_v):
            G[where_free.v[joint.name] + k, where.v[leader] + k] = multiplier
        for k in range(size_q):
            Q[where_free.q[joint.name] + k, where.q[leader] + k] = multiplier
        shift[where_free.q[joint.name]] = offset
    rng = np.random.default_rng(32)
    for _ in range(3):
        q = rng.uniform(-1.2, 1.2, 12)
        for start in robot.quaternion_starts:
            q[start:start + 4] /= np.linalg.norm(q[start:start + 4])
        v, a, u = rng.normal(size=10), rng.normal(size=10), rng.normal(size=len(robot.efforts))
        qf, vf, af = Q @ q + shift, G @ v, G @ a
        M = G.T @ uncoupled.mass_matrix(qf) @ G
        np.testing.assert_allclose(coupled.mass_matrix(q), M, rtol=0, atol=1e-12 * np.max(np.abs(M)))
        tau = G.T @ uncoupled.inverse_dynamics(qf, vf, af)
        np.testing.assert_allclose(coupled.inverse_dynamics(q, v, a), tau, rtol=0,
                                   atol=1e-11 * np.max(np.abs(tau)))
        np.testing.assert_allclose(coupled.gravity_vector(q), G.T @ uncoupled.gravity_vector(qf), rtol=0,
                                   atol=1e-11)
        np.testing.assert_allclose(coupled.coriolis_matrix(q, v) @ v,
                                   G.T @ uncoupled.coriolis_matrix(qf, vf) @ vf,
                                   rtol=0, atol=1e-11)
        assert coupled.potential_energy(q) == pytest.approx(uncoupled.potential_energy(qf), rel=1e-12)
        assert coupled.kinetic_energy(q, v) == pytest.approx(uncoupled.kinetic_energy(qf, vf), rel=1e-12)
        applied = np.zeros(10)
        applied[list(robot.effort_columns())] = u
        bias = G.T @ uncoupled.inverse_dynamics(qf, vf, np.zeros(12))
        np.testing.assert_allclose(coupled.forward_dynamics(q, v, u), np.linalg.solve(M, applied - bias),
                                   rtol=0,
                                   atol=1e-9)
        np.testing.assert_allclose(coupled.regressor(q, v, a) @ coupled.parameter_vector(), tau, rtol=0,
                                   atol=1e-11)
        T = uncoupled.frame_transform(qf, "tip")
        np.testing.assert_allclose(coupled.frame_transform(q, "tip"), T, rtol=0, atol=1e-13)
        np.testing.assert_allclose(coupled.frame_jacobian(q, "tip"), uncoupled.frame_jacobian(qf, "tip") @ G,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(coupled.friction_forces(v), G.T @ uncoupled.friction_forces(vf), rtol=0,
                                   atol=1e-12)
    drives = [p for p in coupled.PARAMETER_VECTOR
              if p.startswith(("damping", "friction", "armature", "stiffness"))]
    # one parameter per coordinate (Pinocchio's per-velocity damping, friction, armature): the
    # followers' terms folded into their leader's, b + m^2 b_f, fc + |m| fc_f, Ia + m^2 Ia_f
    assert drives == ["damping_j1", "friction_j1", "armature_j1", "stiffness_j1"]
    m3, m2 = -0.7312345678901234, 0.1234567890123456
    values = dict(zip(coupled.PARAMETER_VECTOR, coupled.parameter_vector()))
    assert values["damping_j1"] == pytest.approx(0.1712345678901234 + m3**2 * 0.0912345678901234, rel=1e-14)
    assert values["friction_j1"] == pytest.approx(abs(m3) * 0.0412345678901234 + abs(m2) * 0.2312345678901234,
                                                  rel=1e-14)
    assert values["armature_j1"] == pytest.approx(0.0412345678901234 + m3**2 * 0.0312345678901234
                                                  + m2**2 * 0.0212345678901234, rel=1e-14)


def test_check_passes(floating_arm, driven):
    """``dynderive check``'s rows: the arm's with Pinocchio's mimic joints and free flyer; the
    spherical tree's with its drive terms (Pinocchio's row skipped: it models no springs)."""
    _, _, derivation, _ = floating_arm
    rows = run_checks(derivation, render_code(derivation), states=4)
    assert all(row.status == "pass" for row in rows), [r for r in rows if r.status != "pass"]
    [pinocchio] = [r for r in rows if r.name.startswith("agrees with Pinocchio")]
    assert "mimic joints" in pinocchio.method
    _, _, derivation, source, _, _ = driven
    rows = run_checks(derivation, source, states=3)
    assert all(row.status in ("pass", "skip") for row in rows), [r for r in rows if r.status == "FAIL"]
    assert sum(row.status == "pass" for row in rows) >= 10


def _bad(tmp_path: Path, data: dict) -> str:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(InputError) as refused:
        dynderive.load_robot(path)
    return str(refused.value)


def test_loops_and_planar_robots_with_mimic_joints_stay_refused(tmp_path):
    data = yaml.safe_load(_spherical_tree(drives=False))
    data["loops"] = [{"name": "c1", "type": "spherical", "parent": "l3", "child": "fa"}]
    message = _bad(tmp_path, data)
    assert "joints[3].mimic: mimic joints in a robot with loops are not built yet" in message
    planar = {"name": "p", "planar": True, "gravity": [0, -9.81],
              "links": [{"name": "a", "mass": 1, "inertia": 0.1}, {"name": "b", "mass": 1, "inertia": 0.1},
                        {"name": "c", "mass": 1, "inertia": 0.1}],
              "joints": [{"name": "base", "type": "floating", "parent": "world", "child": "a"},
                         {"name": "q1", "type": "revolute", "parent": "a", "child": "b"},
                         {"name": "q2", "type": "revolute", "parent": "b", "child": "c",
                          "mimic": {"joint": "q1"}}]}
    assert "joints[2].mimic: mimic joints are built for 3-D robots only" in _bad(tmp_path, planar)
