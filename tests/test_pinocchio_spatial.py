"""Random spatial (3-D) trees: dynderive's generated code against an independent Pinocchio model.

Each case draws a branching tree (revolute and prismatic joints about arbitrary non-unit
axes, general ``xyz``/``rpy`` joint origins, full inertia tensors, sometimes a fixed weld)
with ``tests/random_robots3d.py``, derives it with dynderive, imports the generated NumPy
module and compares it with a Pinocchio model built from the same numbers (not from the
YAML) at random states.

The Pinocchio model is itself checked without dynderive: against Pinocchio's own URDF
parser fed the same robot (URDF semantics are the contract of the 3-D format), against
dynderive's *planar* derivation of planar trees rewritten in 3-D, and for the usual
structural properties (M symmetric positive definite, ``aba`` inverts ``rnea``).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")


from conftest import random_tree_derivation, text_derivation  # noqa: E402
from random_robots import depth_first, random_planar_tree  # noqa: E402
from random_robots3d import SpatialTree, random_spatial_tree, spatial_from_planar  # noqa: E402

pytestmark = pytest.mark.pinocchio

#: (seed, moving joints): two trees of each size from 2 to 7 joints. The seeds are picked so
#: that the set covers the features (see ``test_the_cases_cover_the_features``) and derives
#: quickly (the derivation time grows steeply with the number of revolute joints in series).
CASES = [(0, 2), (6, 2), (1, 3), (7, 3), (2, 4), (18, 4), (3, 5), (16, 5), (4, 6), (15, 6), (5, 7), (11, 7)]
#: cases whose Mdot - 2C is checked for skew-symmetry
SKEW_CASES = [(3, 5), (4, 6)]
#: planar trees (``random_robots.py``) rewritten in 3-D
PLANAR_CASES = [(0, 2), (5, 3), (2, 4)]
N_STATES = 5
TOL = {"rtol": 1e-9, "atol": 1e-9}


def tree_of(seed: int, n_joints: int) -> SpatialTree:
    return random_spatial_tree(random.Random(seed), n_joints)


# --- deriving (cached for the session) -------------------------------------------------


_derivation = text_derivation


@pytest.fixture(scope="session")
def derive3d(tmp_path_factory):
    """``derive3d(name, tree)`` -> (derivation, generated module), cached per session."""
    directory = str(tmp_path_factory.mktemp("spatial"))
    return lambda name, tree: _derivation(name, tree.yaml_text, directory)


# --- the independent model -------------------------------------------------------------


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _placement(xyz, rpy):
    roll, pitch, yaw = rpy
    return pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.array(xyz, dtype=float))


def _joint_model(joint):
    axis = np.array(joint.unit_axis)
    aligned = {(1.0, 0.0, 0.0): "X", (0.0, 1.0, 0.0): "Y", (0.0, 0.0, 1.0): "Z"}.get(tuple(axis))
    if joint.type == "revolute":
        return getattr(pin, f"JointModelR{aligned}")() if aligned else pin.JointModelRevoluteUnaligned(axis)
    return getattr(pin, f"JointModelP{aligned}")() if aligned else pin.JointModelPrismaticUnaligned(axis)


def pinocchio_model(tree: SpatialTree):
    """Pinocchio model of ``tree``, built from the numbers (not from the YAML).

    Moving joints are added depth-first, so Pinocchio's configuration order may differ from
    dynderive's coordinate order (moving joints in file order): ``perm`` maps one to the
    other, ``q_pin = q[perm]``. A link welded by a fixed joint becomes a body appended to the
    Pinocchio joint that carries its parent, at the composed placement; joints hanging from
    it are placed relative to that same Pinocchio joint. Pinocchio's potential energy skips
    bodies on the universe while dynderive counts them (a constant): ``world_energy`` is that
    constant. Returns ``(model, perm, world_energy)``.
    """
    model = pin.Model()
    model.gravity.linear = np.array(tree.gravity, dtype=float)
    coordinate = {j.name: i for i, j in enumerate(tree.moving_joints)}
    # link index -> (Pinocchio joint id, placement of the link frame in that joint's frame)
    frame_of: dict[int, tuple[int, Any]] = {-1: (0, pin.SE3.Identity())}
    perm: list[int] = []
    world_energy = 0.0
    for k in depth_first(tree):
        joint = tree.joints[k]
        link = tree.links[joint.child]
        com = np.array(link.com, dtype=float)
        inertia = pin.Inertia(link.mass, com, np.array(link.inertia, dtype=float))
        parent_id, parent_placement = frame_of[joint.parent]
        placement = parent_placement * _placement(joint.xyz, joint.rpy)
        if joint.type == "fixed":
            model.appendBodyToJoint(parent_id, inertia, placement)
            frame_of[joint.child] = (parent_id, placement)
            if parent_id == 0:
                world_energy -= link.mass * float(model.gravity.linear @ placement.act(com))
            continue
        jid = model.addJoint(parent_id, _joint_model(joint), placement, joint.name)
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        frame_of[joint.child] = (jid, pin.SE3.Identity())
        perm.append(coordinate[joint.name])
    assert model.nq == model.nv == tree.n_dof == len(perm)
    assert [model.names[i] for i in range(1, model.njoints)] == [tree.moving_joints[i].name for i in perm]
    return model, np.array(perm, dtype=int), world_energy


def urdf_of(tree: SpatialTree) -> str:
    """The robot as URDF (unit axes), for Pinocchio's own parser."""
    def vec(values) -> str:
        return " ".join(repr(float(v)) for v in values)

    parts = ['<?xml version="1.0"?>', '<robot name="random_tree3d">', '  <link name="world"/>']
    for link in tree.links:
        i = link.inertia
        parts += [
            f'  <link name="{link.name}">',
            "    <inertial>",
            f'      <origin xyz="{vec(link.com)}" rpy="0 0 0"/>',
            f'      <mass value="{link.mass!r}"/>',
            f'      <inertia ixx="{i[0][0]!r}" ixy="{i[0][1]!r}" ixz="{i[0][2]!r}" '
            f'iyy="{i[1][1]!r}" iyz="{i[1][2]!r}" izz="{i[2][2]!r}"/>',
            "    </inertial>",
            "  </link>",
        ]
    for joint in tree.joints:
        parent = "world" if joint.parent < 0 else tree.links[joint.parent].name
        parts += [
            f'  <joint name="{joint.name}" type="{joint.type}">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{tree.links[joint.child].name}"/>',
            f'    <origin xyz="{vec(joint.xyz)}" rpy="{vec(joint.rpy)}"/>',
        ]
        if joint.moves:
            parts += [
                f'    <axis xyz="{vec(joint.unit_axis)}"/>',
                '    <limit lower="-100" upper="100" effort="100" velocity="100"/>',
            ]
        parts.append("  </joint>")
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


# --- Pinocchio, called and answered in dynderive's coordinate order --------------------


@dataclass
class PinRobot:
    model: Any
    data: Any
    perm: np.ndarray          # q_pin = q[perm]
    world_energy: float

    @classmethod
    def of(cls, tree: SpatialTree) -> PinRobot:
        model, perm, world_energy = pinocchio_model(tree)
        return cls(model, model.createData(), perm, world_energy)

    def _in(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=float)[self.perm]

    def _out(self, v: np.ndarray) -> np.ndarray:
        out = np.empty(len(self.perm))
        out[self.perm] = v
        return out

    def mass(self, q: np.ndarray) -> np.ndarray:
        pin.crba(self.model, self.data, self._in(q))
        upper = np.triu(self.data.M)  # crba fills the upper triangle only
        full = upper + np.triu(upper, 1).T
        out = np.empty_like(full)
        out[np.ix_(self.perm, self.perm)] = full
        return out

    def gravity(self, q: np.ndarray) -> np.ndarray:
        return self._out(pin.computeGeneralizedGravity(self.model, self.data, self._in(q)))

    def rnea(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return self._out(pin.rnea(self.model, self.data, self._in(q), self._in(qd), self._in(qdd)))

    def aba(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self._out(pin.aba(self.model, self.data, self._in(q), self._in(qd), self._in(tau)))

    def kinetic(self, q: np.ndarray, qd: np.ndarray) -> float:
        return pin.computeKineticEnergy(self.model, self.data, self._in(q), self._in(qd))

    def potential(self, q: np.ndarray) -> float:
        return pin.computePotentialEnergy(self.model, self.data, self._in(q)) + self.world_energy


def states(seed: int, n: int, k: int = N_STATES):
    """(q, qd, u) arrays of shape (k, n)."""
    rng = np.random.default_rng(1000 + seed)
    return rng.uniform(-1.5, 1.5, (k, n)), rng.uniform(-1.5, 1.5, (k, n)), rng.uniform(-5.0, 5.0, (k, n))


# --- the independent model, checked on its own -----------------------------------------


def test_rpy_convention():
    """``pin.rpy.rpyToMatrix(r, p, y)`` is URDF's Rz(y) Ry(p) Rx(r)."""
    rng = np.random.default_rng(7)
    for roll, pitch, yaw in rng.uniform(-np.pi, np.pi, (10, 3)):
        np.testing.assert_allclose(pin.rpy.rpyToMatrix(roll, pitch, yaw),
                                   rot_z(yaw) @ rot_y(pitch) @ rot_x(roll), rtol=0, atol=1e-14)


def test_the_generated_numbers_are_physical():
    for seed in range(60):
        tree = random_spatial_tree(random.Random(seed), 2 + seed % 6)
        for link in tree.links:
            inertia = np.array(link.inertia)
            np.testing.assert_array_equal(inertia, inertia.T)
            a, b, c = np.linalg.eigvalsh(inertia)
            assert a > 0.02 and a + b > c + 0.01, (seed, link)
            assert 0.5 <= link.mass <= 3.0
        for joint in tree.moving_joints:
            assert np.linalg.norm(joint.axis) > 0.3


@pytest.mark.parametrize(("seed", "n_joints"), CASES, ids=[f"seed{s}-{n}dof" for s, n in CASES])
def test_pinocchio_model_is_consistent(seed, n_joints):
    """M symmetric positive definite, aba inverts rnea, C(q, qd) qd from rnea is quadratic."""
    tree = tree_of(seed, n_joints)
    robot = PinRobot.of(tree)
    for q, qd, qdd in zip(*states(seed, tree.n_dof), strict=True):
        mass = robot.mass(q)
        np.testing.assert_allclose(mass, mass.T, rtol=0, atol=1e-14)
        assert np.linalg.eigvalsh(mass)[0] > 1e-6
        tau = robot.rnea(q, qd, qdd)
        np.testing.assert_allclose(robot.aba(q, qd, tau), qdd, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(tau, mass @ qdd + robot.rnea(q, qd, 0 * qd), rtol=1e-9, atol=1e-9)
        bias = robot.rnea(q, qd, 0 * qd) - robot.gravity(q)
        np.testing.assert_allclose(robot.rnea(q, 2 * qd, 0 * qd) - robot.gravity(q), 4 * bias,
                                   rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(robot.kinetic(q, qd), 0.5 * qd @ mass @ qd, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize(("seed", "n_joints"), CASES, ids=[f"seed{s}-{n}dof" for s, n in CASES])
def test_pinocchio_model_matches_urdf_parser(seed, n_joints):
    """The hand-built model is the robot Pinocchio's URDF parser builds from the same numbers."""
    tree = tree_of(seed, n_joints)
    robot = PinRobot.of(tree)
    urdf = pin.buildModelFromXML(urdf_of(tree))
    urdf.gravity.linear = np.array(tree.gravity, dtype=float)
    names = [tree.moving_joints[i].name for i in robot.perm]  # hand-built order
    # the URDF parser's order, in dynderive's coordinates
    coordinate = {j.name: i for i, j in enumerate(tree.moving_joints)}
    assert urdf.nq == urdf.nv == tree.n_dof
    other = PinRobot(urdf, urdf.createData(),
                     np.array([coordinate[urdf.names[i]] for i in range(1, urdf.njoints)]), 0.0)
    assert sorted(names) == sorted(urdf.names[1:])
    for q, qd, qdd in zip(*states(seed, tree.n_dof), strict=True):
        np.testing.assert_allclose(robot.mass(q), other.mass(q), **TOL)
        np.testing.assert_allclose(robot.gravity(q), other.gravity(q), **TOL)
        np.testing.assert_allclose(robot.rnea(q, qd, qdd), other.rnea(q, qd, qdd), **TOL)
        np.testing.assert_allclose(robot.aba(q, qd, qdd), other.aba(q, qd, qdd), **TOL)
        np.testing.assert_allclose(robot.kinetic(q, qd), other.kinetic(q, qd), **TOL)
        # potential energies differ by the bodies welded to the world (a constant)
        np.testing.assert_allclose(robot.potential(q) - robot.potential(0 * q),
                                   other.potential(q) - other.potential(0 * q), **TOL)


@pytest.mark.parametrize(("seed", "n_joints"), PLANAR_CASES, ids=[f"planar{s}-{n}dof" for s, n in PLANAR_CASES])
def test_pinocchio_model_matches_planar_derivation(seed, n_joints, tmp_path_factory):
    """A planar tree rewritten in 3-D: the spatial Pinocchio model gives dynderive's planar results."""
    tree = spatial_from_planar(random_planar_tree(random.Random(seed), n_joints))
    _, module = random_tree_derivation(seed, n_joints, str(tmp_path_factory.getbasetemp()))
    robot = PinRobot.of(tree)
    for q, qd, u in zip(*states(seed, tree.n_dof), strict=True):
        np.testing.assert_allclose(module.mass_matrix(q), robot.mass(q), **TOL)
        np.testing.assert_allclose(module.gravity_vector(q), robot.gravity(q), **TOL)
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u), robot.aba(q, qd, u), **TOL)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, u), robot.rnea(q, qd, u), **TOL)
        np.testing.assert_allclose(module.kinetic_energy(q, qd), robot.kinetic(q, qd), **TOL)
        np.testing.assert_allclose(module.potential_energy(q), robot.potential(q), **TOL)


# --- the case under test ---------------------------------------------------------------


@dataclass
class Case:
    tree: SpatialTree
    module: Any
    robot: PinRobot
    q: np.ndarray
    qd: np.ndarray
    u: np.ndarray


@pytest.fixture(scope="module", params=CASES, ids=[f"seed{s}-{n}dof" for s, n in CASES])
def case(request, derive3d) -> Case:
    seed, n_joints = request.param
    tree = tree_of(seed, n_joints)
    _, module = derive3d(f"random_tree3d_{seed}_{n_joints}", tree)
    assert tuple(module.COORDINATES) == tuple(j.name for j in tree.moving_joints)
    assert tuple(module.EFFORTS) == tuple(j.effort for j in tree.moving_joints)
    return Case(tree, module, PinRobot.of(tree), *states(seed, tree.n_dof))


def test_mass_matrix(case):
    for q in case.q:
        np.testing.assert_allclose(case.module.mass_matrix(q), case.robot.mass(q), **TOL)


def test_gravity_vector(case):
    for q in case.q:
        np.testing.assert_allclose(case.module.gravity_vector(q), case.robot.gravity(q), **TOL)


def test_coriolis_times_velocity(case):
    zero = np.zeros(case.tree.n_dof)
    for q, qd in zip(case.q, case.qd, strict=True):
        expected = case.robot.rnea(q, qd, zero) - case.robot.gravity(q)
        np.testing.assert_allclose(case.module.coriolis_matrix(q, qd) @ qd, expected, **TOL)


def test_inverse_dynamics(case):
    for q, qd, qdd in zip(case.q, case.qd, case.u, strict=True):
        np.testing.assert_allclose(case.module.inverse_dynamics(q, qd, qdd), case.robot.rnea(q, qd, qdd), **TOL)


def test_forward_dynamics(case):
    # every moving joint is actuated, efforts in coordinate order: tau = u
    for q, qd, u in zip(case.q, case.qd, case.u, strict=True):
        np.testing.assert_allclose(case.module.generalized_forces(q, u), u, **TOL)
        np.testing.assert_allclose(case.module.forward_dynamics(q, qd, u), case.robot.aba(q, qd, u), **TOL)


def test_energies(case):
    for q, qd in zip(case.q, case.qd, strict=True):
        np.testing.assert_allclose(case.module.kinetic_energy(q, qd), case.robot.kinetic(q, qd), **TOL)
        # same convention, V = -sum m g . c (no offset), once the world-welded bodies are added
        np.testing.assert_allclose(case.module.potential_energy(q), case.robot.potential(q), **TOL)


def test_batch_matches_single_states(case):
    m = case.module
    n = case.tree.n_dof
    masses = m.mass_matrix(case.q)
    assert masses.shape == (N_STATES, n, n)
    np.testing.assert_allclose(masses, np.stack([case.robot.mass(q) for q in case.q]), **TOL)
    accelerations = m.forward_dynamics(case.q, case.qd, case.u)
    assert accelerations.shape == (N_STATES, n)
    expected = np.stack([case.robot.aba(q, qd, u) for q, qd, u in zip(case.q, case.qd, case.u, strict=True)])
    np.testing.assert_allclose(accelerations, expected, **TOL)
    assert m.coriolis_matrix(case.q, case.qd).shape == (N_STATES, n, n)
    assert m.inverse_dynamics(case.q, case.qd, case.u).shape == (N_STATES, n)
    assert m.kinetic_energy(case.q, case.qd).shape == (N_STATES,)
    assert m.potential_energy(case.q).shape == (N_STATES,)
    # a (2, 5, n) batch too
    grid = np.stack([case.q, case.q[::-1]])
    assert m.gravity_vector(grid).shape == (2, N_STATES, n)
    np.testing.assert_allclose(m.gravity_vector(grid)[1], m.gravity_vector(case.q[::-1]), rtol=1e-12, atol=1e-12)


def test_no_maximal_functions(case):
    assert not [name for name in dir(case.module) if "maximal" in name.lower()]


@pytest.mark.parametrize(("seed", "n_joints"), SKEW_CASES, ids=[f"seed{s}-{n}dof" for s, n in SKEW_CASES])
def test_mdot_minus_2c_is_skew_symmetric(seed, n_joints, derive3d):
    tree = tree_of(seed, n_joints)
    _, module = derive3d(f"random_tree3d_{seed}_{n_joints}", tree)
    h = 1e-5
    for q, qd, _ in zip(*states(seed, tree.n_dof), strict=True):
        mdot = (module.mass_matrix(q + h * qd) - module.mass_matrix(q - h * qd)) / (2 * h)
        skew = mdot - 2 * module.coriolis_matrix(q, qd)
        np.testing.assert_allclose(skew + skew.T, 0.0, rtol=0, atol=1e-6)
        assert np.max(np.abs(skew)) > 1e-3  # not trivially zero


@pytest.mark.parametrize(("seed", "n_joints"), PLANAR_CASES[:2], ids=[f"planar{s}-{n}dof" for s, n in PLANAR_CASES[:2]])
def test_planar_tree_in_3d_matches_planar_derivation(seed, n_joints, derive3d, tmp_path_factory):
    """dynderive's 3-D path on a planar tree written in 3-D agrees with its planar path."""
    tree = spatial_from_planar(random_planar_tree(random.Random(seed), n_joints))
    _, planar = random_tree_derivation(seed, n_joints, str(tmp_path_factory.getbasetemp()))
    _, spatial = derive3d(f"planar_as_spatial_{seed}_{n_joints}", tree)
    assert tuple(spatial.COORDINATES) == tuple(planar.COORDINATES)
    for q, qd, u in zip(*states(seed, tree.n_dof), strict=True):
        np.testing.assert_allclose(spatial.mass_matrix(q), planar.mass_matrix(q), **TOL)
        np.testing.assert_allclose(spatial.coriolis_matrix(q, qd) @ qd, planar.coriolis_matrix(q, qd) @ qd, **TOL)
        np.testing.assert_allclose(spatial.gravity_vector(q), planar.gravity_vector(q), **TOL)
        np.testing.assert_allclose(spatial.forward_dynamics(q, qd, u), planar.forward_dynamics(q, qd, u), **TOL)
        np.testing.assert_allclose(spatial.potential_energy(q), planar.potential_energy(q), **TOL)


def revolutes_in_series(tree: SpatialTree) -> int:
    """The most revolute joints on one path from the world to a link."""
    def count(k: int) -> int:
        joint = tree.joints[k]
        return (joint.type == "revolute") + (count(joint.parent) if joint.parent >= 0 else 0)
    return max(count(k) for k in range(len(tree.joints)))


def test_the_cases_cover_the_features():
    """The fixed seeds give what the comparison is meant to exercise."""
    trees = [tree_of(seed, n) for seed, n in CASES]
    assert {t.n_dof for t in trees} == {2, 3, 4, 5, 6, 7}
    assert sum(t.branches for t in trees) >= 4
    assert sum(t.has_fixed for t in trees) >= 3
    assert any(t.has_fixed and any(j.parent == f.child for f in t.joints if not f.moves for j in t.joints)
               for t in trees), "no joint hangs from a welded link"
    assert any(t.joints[0].type == "fixed" or any(j.parent == -1 and not j.moves for j in t.joints)
               for t in trees), "no link welded to the world"
    assert all({j.type for j in t.moving_joints} == {"revolute", "prismatic"} for t in trees)
    assert any(link.nested for t in trees for link in t.links), "no 3x3 nested-list inertia"
    assert any(not j.write_axis for t in trees for j in t.joints), "no default axis"
    assert any(sum(1 for a in j.axis if a != 0) == 1 and j.write_axis for t in trees for j in t.moving_joints)

    assert sum(revolutes_in_series(t) >= 3 for t in trees) >= 2

    # a revolute joint downstream of a prismatic one, and the reverse
    def after(t: SpatialTree, first: str, second: str) -> bool:
        return any(j.type == second and t.joints[j.parent].type == first for j in t.joints if j.parent >= 0)
    assert any(after(t, "prismatic", "revolute") for t in trees)
    assert any(after(t, "revolute", "prismatic") for t in trees)
    assert all(t.joints[k].child == k for t in trees for k in range(len(t.joints)))
    # Pinocchio's depth-first order differs from the file order in some cases
    assert any(list(pinocchio_model(t)[1]) != list(range(t.n_dof)) for t in trees)
