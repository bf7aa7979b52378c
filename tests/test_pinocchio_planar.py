"""Random planar trees: dynderive's generated code against an independent Pinocchio model.

Each case draws a branching tree (revolute and prismatic joints, arbitrary origins and
non-unit prismatic axes, sometimes a fixed weld) with ``tests/random_robots.py``, derives it
with dynderive, imports the generated NumPy module and compares it with a Pinocchio model
built from the same numbers (not from the YAML) at random states.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import dynderive  # noqa: E402

from conftest import random_tree_derivation  # noqa: E402
from random_robots import PlanarTree, depth_first, random_planar_tree  # noqa: E402

pytestmark = pytest.mark.pinocchio

#: (seed, moving joints): three trees of each size from 2 to 5 joints.
CASES = [(seed, 2 + seed % 4) for seed in range(12)]
N_STATES = 5
TOL = {"rtol": 1e-9, "atol": 1e-9}


def tree_of(seed: int, n_joints: int) -> PlanarTree:
    return random_planar_tree(random.Random(seed), n_joints)


# --- the independent model -------------------------------------------------------------


def _placement(x: float, y: float, theta: float):
    c, s = np.cos(theta), np.sin(theta)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return pin.SE3(rotation, np.array([x, y, 0.0]))


def pinocchio_model(tree: PlanarTree):
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
    model.gravity.linear = np.array([tree.gravity[0], tree.gravity[1], 0.0])
    coordinate = {j.name: i for i, j in enumerate(tree.moving_joints)}
    # link index -> (Pinocchio joint id, placement of the link frame in that joint's frame)
    frame_of: dict[int, tuple[int, Any]] = {-1: (0, pin.SE3.Identity())}
    perm: list[int] = []
    world_energy = 0.0
    for k in depth_first(tree):
        joint = tree.joints[k]
        link = tree.links[joint.child]
        com = np.array([link.com[0], link.com[1], 0.0])
        inertia = pin.Inertia(link.mass, com, np.diag([link.inertia] * 3))  # Ixx = Iyy = Izz: physical
        parent_id, parent_placement = frame_of[joint.parent]
        placement = parent_placement * _placement(*joint.origin)
        if joint.type == "fixed":
            model.appendBodyToJoint(parent_id, inertia, placement)
            frame_of[joint.child] = (parent_id, placement)
            if parent_id == 0:
                world_energy -= link.mass * float(model.gravity.linear @ placement.act(com))
            continue
        if joint.type == "revolute":
            jmodel = pin.JointModelRZ()
        else:
            ax, ay = joint.axis
            norm = np.hypot(ax, ay)
            jmodel = pin.JointModelPrismaticUnaligned(np.array([ax / norm, ay / norm, 0.0]))
        jid = model.addJoint(parent_id, jmodel, placement, joint.name)
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        frame_of[joint.child] = (jid, pin.SE3.Identity())
        perm.append(coordinate[joint.name])
    assert model.nq == model.nv == tree.n_dof == len(perm)
    assert [model.names[i] for i in range(1, model.njoints)] == [tree.moving_joints[i].name for i in perm]
    return model, np.array(perm, dtype=int), world_energy


# --- the case under test ---------------------------------------------------------------


@dataclass
class Case:
    tree: PlanarTree
    module: Any
    model: Any
    data: Any
    perm: np.ndarray          # q_pin = q[perm]
    world_energy: float
    q: np.ndarray
    qd: np.ndarray
    u: np.ndarray

    # Pinocchio, called and answered in dynderive's coordinate order
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


@pytest.fixture(scope="module", params=CASES, ids=[f"seed{s}-{n}dof" for s, n in CASES])
def case(request, tmp_path_factory) -> Case:
    seed, n_joints = request.param
    tree = tree_of(seed, n_joints)
    _, module = random_tree_derivation(seed, n_joints, str(tmp_path_factory.getbasetemp()))
    assert tuple(module.COORDINATES) == tuple(j.name for j in tree.moving_joints)
    assert tuple(module.EFFORTS) == tuple(j.effort for j in tree.moving_joints)
    model, perm, world_energy = pinocchio_model(tree)
    rng = np.random.default_rng(1000 + seed)
    shape = (N_STATES, tree.n_dof)
    return Case(tree, module, model, model.createData(), perm, world_energy,
                rng.uniform(-1.5, 1.5, shape), rng.uniform(-1.5, 1.5, shape), rng.uniform(-5.0, 5.0, shape))


def test_mass_matrix(case):
    for q in case.q:
        np.testing.assert_allclose(case.module.mass_matrix(q), case.mass(q), **TOL)


def test_gravity_vector(case):
    for q in case.q:
        np.testing.assert_allclose(case.module.gravity_vector(q), case.gravity(q), **TOL)


def test_coriolis_times_velocity(case):
    zero = np.zeros(case.tree.n_dof)
    for q, qd in zip(case.q, case.qd, strict=True):
        expected = case.rnea(q, qd, zero) - case.gravity(q)
        np.testing.assert_allclose(case.module.coriolis_matrix(q, qd) @ qd, expected, **TOL)


def test_inverse_dynamics(case):
    for q, qd, qdd in zip(case.q, case.qd, case.u, strict=True):
        np.testing.assert_allclose(case.module.inverse_dynamics(q, qd, qdd), case.rnea(q, qd, qdd), **TOL)


def test_forward_dynamics(case):
    # every moving joint is actuated, efforts in coordinate order: tau = u
    for q, qd, u in zip(case.q, case.qd, case.u, strict=True):
        np.testing.assert_allclose(case.module.forward_dynamics(q, qd, u), case.aba(q, qd, u), **TOL)


def test_energies(case):
    for q, qd in zip(case.q, case.qd, strict=True):
        np.testing.assert_allclose(case.module.kinetic_energy(q, qd), case.kinetic(q, qd), **TOL)
        # same convention, V = -sum m g . c (no offset), once the world-welded bodies are added
        np.testing.assert_allclose(case.module.potential_energy(q), case.potential(q), **TOL)


def test_batch_matches_single_states(case):
    m = case.module
    n = case.tree.n_dof
    masses = m.mass_matrix(case.q)
    assert masses.shape == (N_STATES, n, n)
    np.testing.assert_allclose(masses, np.stack([m.mass_matrix(q) for q in case.q]), rtol=1e-12, atol=1e-12)
    accelerations = m.forward_dynamics(case.q, case.qd, case.u)
    assert accelerations.shape == (N_STATES, n)
    single = np.stack([m.forward_dynamics(q, qd, u) for q, qd, u in zip(case.q, case.qd, case.u, strict=True)])
    np.testing.assert_allclose(accelerations, single, rtol=1e-12, atol=1e-12)
    assert m.kinetic_energy(case.q, case.qd).shape == (N_STATES,)
    assert m.potential_energy(case.q).shape == (N_STATES,)
    # a (2, 5, n) batch too
    grid = np.stack([case.q, case.q[::-1]])
    assert m.gravity_vector(grid).shape == (2, N_STATES, n)
    np.testing.assert_allclose(m.gravity_vector(grid)[1], m.gravity_vector(case.q[::-1]), rtol=1e-12, atol=1e-12)


def test_module_without_parameters_compiles(tmp_path):
    """A robot with ``parameters: {}`` must render to valid Python (no bare ``*``)."""
    path = tmp_path / "random_tree.yaml"
    path.write_text(tree_of(0, 2).yaml_text)
    source = dynderive.render_code(dynderive.derive(dynderive.load_robot(path)))
    compile(source, "random_tree_dynamics.py", "exec")


def test_the_cases_cover_the_features():
    """The fixed seeds give what the comparison is meant to exercise."""
    trees = [tree_of(seed, n) for seed, n in CASES]
    assert sum(t.branches for t in trees) >= 4
    assert sum(t.has_fixed for t in trees) >= 3
    assert any(t.has_fixed and any(j.parent == f.child for f in t.joints if not f.moves for j in t.joints)
               for t in trees), "no joint hangs from a welded link"
    assert all({j.type for j in t.moving_joints} == {"revolute", "prismatic"} for t in trees)
    # a revolute joint downstream of a prismatic one, and the reverse
    def after(t: PlanarTree, first: str, second: str) -> bool:
        return any(j.type == second and t.joints[j.parent].type == first for j in t.joints if j.parent >= 0)
    assert any(after(t, "prismatic", "revolute") for t in trees)
    assert any(after(t, "revolute", "prismatic") for t in trees)
    assert all(t.joints[k].child == k for t in trees for k in range(len(t.joints)))
    # Pinocchio's depth-first order differs from the file order in some cases
    assert any(list(pinocchio_model(t)[1]) != list(range(t.n_dof)) for t in trees)
