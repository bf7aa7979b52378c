"""``<mimic>`` joints on the floating-base path (issue 30): a follower has no entry of its own in
q or v (NQ and NV count the leaders' coordinates), its variable is ``multiplier * q_leader +
offset`` and its column joins its leader's.

Two references. Pinocchio with mimic joints and a free flyer
(``buildModelFromUrdf(path, JointModelFreeFlyer(), mimic=True)``, its own URDF parser) on
``test_mimic``'s arm loaded with ``--floating-base`` (a massive base; generic axes, full
inertias, full-precision numbers; a revolute follower below its leader with a joint between,
a prismatic finger mirroring the other, a revolute follower on another branch): M (from its
rnea: its crba is wrong for such a follower), rnea, nonLinearEffects, gravity, forward dynamics
(its ``aba`` refuses mimic joints: ``M^-1 (tau - h)``), integrate, difference, frames. And the
uncoupled robot (every follower a coordinate of its own, drive terms kept) mapped by the
coupling, ``M_c = G^T M G``, on a random tree with a floating base and a spherical joint. Then
``dynderive check``'s rows (Pinocchio with a spherical joint and mimic joints), the JAX target
against NumPy, and what stays refused.
"""

from __future__ import annotations

import dataclasses
import random
from pathlib import Path

import numpy as np
import pytest
import yaml

import dynderive
from dynderive.errors import InputError
from dynderive.mechanics.quasi_velocity import is_step_by_step
from dynderive.mechanics.tree import offsets
from dynderive.render.sheets.html import render_html
from dynderive.render.sheets.html_math import coordinate_math_names
from dynderive.render.sheets.latex_format import coordinate_names
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import generated_module, run_checks
from test_mimic import ARM, _link, frame_agrees_with_pinocchio

from random_robots3d import _random_axis, _random_inertia

pin = pytest.importorskip("pinocchio")

BASE = _link("base", "2.3456789012345678", "0.0212345678901234 -0.0312345678901234 0.0412345678901234",
             ("0.0412345678901234", "0.0023456789012345", "-0.0034567890123456", "0.0387654321098765",
              "0.0019876543210987", "0.0298765432109876"))
#: test_mimic's arm with a massive base (a massless one under j1 would make M singular), its
#: <dynamics> (damping and friction) kept
FLOATING_ARM = ARM.replace('  <link name="base"/>\n', BASE)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = tmp_path_factory.mktemp("floating_mimic") / "mimic_arm.urdf"
    path.write_text(FLOATING_ARM)
    robot = dynderive.load_robot(path, floating_base=True)
    derivation = dynderive.derive(robot)
    source = render_code(derivation)
    return path, robot, derivation, generated_module(source, robot.name)


def _pinocchio(path: Path, robot) -> tuple:
    """Pinocchio's free flyer with mimic joints, and where its q and v entries are in ours."""
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer(), mimic=True)
    where = offsets(robot)
    qp, vp = np.zeros(model.nq, dtype=int), np.zeros(model.nv, dtype=int)
    for index, (name, joint) in enumerate(zip(model.names, model.joints)):
        if index > 0 and index not in model.mimicking_joints:
            qp[joint.idx_q:joint.idx_q + joint.nq] = range(where.q[name], where.q[name] + joint.nq)
            vp[joint.idx_v:joint.idx_v + joint.nv] = range(where.v[name], where.v[name] + joint.nv)
    return model, qp, vp


def _rnea_mass_matrix(model, data, q: np.ndarray) -> np.ndarray:
    zero = np.zeros(model.nv)
    base = pin.rnea(model, data, q, zero, zero)
    return np.array([pin.rnea(model, data, q, zero, e) - base for e in np.eye(model.nv)]).T


def test_followers_have_no_coordinate(arm):
    path, robot, _, module = arm
    assert robot.joints[0].name == "root_joint" and robot.joints[0].type == "floating"
    assert robot.coordinates == ("root_joint", "j1", "j2", "f1")
    assert (module.NQ, module.NV) == (10, 9)
    assert module.COORDINATES[7:] == ("j1", "j2", "f1")
    assert robot.efforts == ("tau_j1", "tau_j2", "f_f1")
    model, _, _ = _pinocchio(path, robot)
    assert (model.nq, model.nv) == (10, 9) and len(model.mimicking_joints) == 3
    assert not is_step_by_step(robot)


def test_agrees_with_pinocchio_free_flyer_with_mimic_joints(arm):
    path, robot, _, module = arm
    model, qp, vp = _pinocchio(path, robot)
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
        friction = module.friction_forces(v)   # damping and friction, which Pinocchio's rnea and aba leave out
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
        np.testing.assert_allclose(module.integrate(q, v, 0.37)[qp], pin.integrate(model, qq, 0.37 * vv), atol=1e-12)
        np.testing.assert_allclose(module.difference(q, q1)[vp], pin.difference(model, qq, q1[qp]), atol=1e-9)
        frame_agrees_with_pinocchio(module, model, data, "tool", (q, v), (qq, vv), vp)
        Y = module.regressor(q, v, a)
        np.testing.assert_allclose(Y @ module.parameter_vector(), module.inverse_dynamics(q, v, a), rtol=0, atol=1e-12)
    assert crba_wrong > 1e-3   # why M is read from rnea: Pinocchio 4.1's crba with j3 below j1, j2 between


def test_sheets_name_only_the_leaders_coordinates(arm):
    """The LaTeX sheet and the HTML page of a floating robot with followers: a name for each
    entry of q, v and vdot (the followers have none), the same symbols on both; the page renders."""
    _, robot, derivation, _ = arm
    table = derivation.symbols
    latex, math = coordinate_names(derivation), coordinate_math_names(derivation)
    assert set(latex) == set(math) == {*table.q, *table.qd, *table.qdd}
    assert "j3" not in " ".join(latex.values()) and "\\dot{v}_{x}" in latex.values()
    page = render_html(derivation)
    assert page.startswith("<!DOCTYPE html>") and page.count("<math") > 10


def test_linearize_along_integrate(arm):
    """``linearize``'s lower rows against central differences of forward_dynamics along
    integrate (the derivatives' tangent seeds skip the followers, moved by their leaders)."""
    _, robot, _, module = arm
    rng = np.random.default_rng(31)
    q, v, u = rng.uniform(-1.2, 1.2, 10), rng.normal(size=9), rng.normal(size=3)
    q[3:7] /= np.linalg.norm(q[3:7])
    A, B = module.linearize(q, v, u)
    h = 1e-6
    dq = np.array([module.forward_dynamics(module.integrate(q, e, h), v, u)
                   - module.forward_dynamics(module.integrate(q, e, -h), v, u) for e in np.eye(9)]).T / (2 * h)
    dv = np.array([module.forward_dynamics(q, v + h * e, u) - module.forward_dynamics(q, v - h * e, u)
                   for e in np.eye(9)]).T / (2 * h)
    scale = max(1.0, np.max(np.abs(dq)))
    np.testing.assert_allclose(A[9:, :9], dq, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(A[9:, 9:], dv, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(B[9:], np.linalg.inv(module.mass_matrix(q))[:, list(robot.effort_columns())],
                               rtol=0, atol=1e-9)


def test_the_jax_module_agrees_with_numpy(arm):
    """The JAX target's mass matrix, inverse and forward dynamics and frame Jacobian equal the
    NumPy module's (float64, a batch of states; the followers' columns summed alike). Eager JAX
    runs a straight-line program op by op: four functions, not all of ``check --backend jax``."""
    jax = pytest.importorskip("jax")
    from dynderive.render.targets.jax.jax import render_jax

    jax.config.update("jax_enable_x64", True)
    _, robot, derivation, module = arm
    traced = generated_module(render_jax(derivation), f"{robot.name}_jax")
    rng = np.random.default_rng(33)
    q = rng.uniform(-1.2, 1.2, (2, 10))
    q[:, 3:7] /= np.linalg.norm(q[:, 3:7], axis=1, keepdims=True)
    v, a, u = rng.normal(size=(2, 9)), rng.normal(size=(2, 9)), rng.normal(size=(2, 3))
    for name, args in (("mass_matrix", (q,)), ("inverse_dynamics", (q, v, a)), ("forward_dynamics", (q, v, u)),
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
        links.append({"name": name, "mass": _r(rng.uniform(0.3, 2.0)), "com": [_r(rng.uniform(-0.2, 0.2)) for _ in range(3)],
                      "inertia": [inertia[0][0], inertia[1][1], inertia[2][2], inertia[0][1], inertia[0][2],
                                  inertia[1][2]]})

    def origin() -> dict:
        return {"xyz": [_r(rng.uniform(-0.4, 0.4)) for _ in range(3)], "rpy": [_r(rng.uniform(-2, 2)) for _ in range(3)]}

    joints = [{"name": "root", "type": "floating", "parent": "world", "child": "base", "origin": origin()},
              {"name": "ball", "type": "spherical", "parent": "base", "child": "l1", "origin": origin(), "effort": "m"},
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
                           "planar": False, "parameters": {"g": 9.81}, "gravity": [0, 0, "-g"], "links": links,
                           "joints": joints, "frames": [{"name": "tip", "link": "l3", "origin": origin()}]},
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
        np.testing.assert_allclose(coupled.inverse_dynamics(q, v, a), tau, rtol=0, atol=1e-11 * np.max(np.abs(tau)))
        np.testing.assert_allclose(coupled.gravity_vector(q), G.T @ uncoupled.gravity_vector(qf), rtol=0, atol=1e-11)
        np.testing.assert_allclose(coupled.coriolis_matrix(q, v) @ v, G.T @ uncoupled.coriolis_matrix(qf, vf) @ vf,
                                   rtol=0, atol=1e-11)
        assert coupled.potential_energy(q) == pytest.approx(uncoupled.potential_energy(qf), rel=1e-12)
        assert coupled.kinetic_energy(q, v) == pytest.approx(uncoupled.kinetic_energy(qf, vf), rel=1e-12)
        applied = np.zeros(10)
        applied[list(robot.effort_columns())] = u
        bias = G.T @ uncoupled.inverse_dynamics(qf, vf, np.zeros(12))
        np.testing.assert_allclose(coupled.forward_dynamics(q, v, u), np.linalg.solve(M, applied - bias), rtol=0,
                                   atol=1e-9)
        np.testing.assert_allclose(coupled.regressor(q, v, a) @ coupled.parameter_vector(), tau, rtol=0, atol=1e-11)
        T = uncoupled.frame_transform(qf, "tip")
        np.testing.assert_allclose(coupled.frame_transform(q, "tip"), T, rtol=0, atol=1e-13)
        np.testing.assert_allclose(coupled.frame_jacobian(q, "tip"), uncoupled.frame_jacobian(qf, "tip") @ G,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(coupled.friction_forces(v), G.T @ uncoupled.friction_forces(vf), rtol=0, atol=1e-12)
    drives = [p for p in coupled.PARAMETER_VECTOR if p.startswith(("damping", "friction", "armature", "stiffness"))]
    # one parameter per coordinate (Pinocchio's per-velocity damping, friction, armature): the
    # followers' terms folded into their leader's, b + m^2 b_f, fc + |m| fc_f, Ia + m^2 Ia_f
    assert drives == ["damping_j1", "friction_j1", "armature_j1", "stiffness_j1"]
    m3, m2 = -0.7312345678901234, 0.1234567890123456
    values = dict(zip(coupled.PARAMETER_VECTOR, coupled.parameter_vector()))
    assert values["damping_j1"] == pytest.approx(0.1712345678901234 + m3**2 * 0.0912345678901234, rel=1e-14)
    assert values["friction_j1"] == pytest.approx(abs(m3) * 0.0412345678901234 + abs(m2) * 0.2312345678901234, rel=1e-14)
    assert values["armature_j1"] == pytest.approx(0.0412345678901234 + m3**2 * 0.0312345678901234
                                                  + m2**2 * 0.0212345678901234, rel=1e-14)


def test_check_passes(arm, driven):
    """``dynderive check``'s rows: the arm's with Pinocchio's mimic joints and free flyer; the
    spherical tree's with its drive terms (Pinocchio's row skipped: it models no springs)."""
    _, _, derivation, _ = arm
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
                         {"name": "q2", "type": "revolute", "parent": "b", "child": "c", "mimic": {"joint": "q1"}}]}
    assert "joints[2].mimic: mimic joints are built for 3-D robots only" in _bad(tmp_path, planar)
