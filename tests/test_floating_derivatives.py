"""The floating-base module's Coriolis matrix, linearization and regressor (issue 30) against
Pinocchio with a ``JointModelFreeFlyer`` root (computeCoriolisMatrix, computeABADerivatives,
computeJointTorqueRegressor) to 1e-9, and against their own properties: C qd is the bias,
dM/dt - 2 C is skew-symmetric, A and B equal central differences through ``integrate``,
regressor @ parameter_vector equals inverse dynamics."""

from __future__ import annotations

import numpy as np
import pytest

import dynderive
from dynderive.input.urdf import identifier
from test_free_flyer import BOX, _example_robot, _floating_tree, _module, _pinocchio

pin = pytest.importorskip("pinocchio")


def _states(robot, model, qp, vp, seed: int, count: int = 3):
    """Random states in our order (q from Pinocchio's randomConfiguration: unit quaternions)."""
    rng = np.random.default_rng(seed)
    pin.seed(seed)
    for _ in range(count):
        q, v, a = np.empty(model.nq), np.empty(model.nv), np.empty(model.nv)
        q[qp] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v[vp], a[vp] = rng.normal(size=model.nv), rng.normal(size=model.nv)
        yield q, v, a, rng.normal(size=len(robot.efforts))


def _check(robot, module, model, qp, vp, seed: int) -> None:
    data = model.createData()
    nv = model.nv
    for q, v, a, u in _states(robot, model, qp, vp, seed):
        # Coriolis: Pinocchio's, C v = bias, dM/dt - 2 C skew (dM/dt along integrate)
        C = module.coriolis_matrix(q, v)
        C_pin = pin.computeCoriolisMatrix(model, data, q[qp], v[vp])
        scale = max(1.0, np.max(np.abs(C_pin)))
        np.testing.assert_allclose(C[np.ix_(vp, vp)], C_pin, rtol=0, atol=1e-9 * scale)
        bias = module.inverse_dynamics(q, v, np.zeros(nv)) - module.gravity_vector(q)
        np.testing.assert_allclose(C @ v, bias, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(bias))))
        h = 1e-6
        Mdot = (module.mass_matrix(module.integrate(q, v, h)) - module.mass_matrix(module.integrate(q, v, -h))) / (2 * h)
        skew = Mdot - 2 * C
        np.testing.assert_allclose(skew, -skew.T, rtol=0, atol=1e-6 * scale)
        assert np.max(np.abs(skew)) > 1e-3 * scale   # not trivially zero: the property is tested
        # linearize: computeABADerivatives, and central differences through integrate
        A, B = module.linearize(q, v, u)
        assert A.shape == (2 * nv, 2 * nv) and B.shape == (2 * nv, len(robot.efforts))
        tau = np.zeros(nv)
        tau[list(module.EFFORT_COLUMNS)] = u
        pin.computeABADerivatives(model, data, q[qp], v[vp], tau[vp])
        qdd = module.forward_dynamics(q, v, u)
        scale = max(1.0, np.max(np.abs(qdd)), np.max(np.abs(data.ddq_dq)), np.max(np.abs(data.ddq_dv)))
        np.testing.assert_allclose(A[nv:, :nv][np.ix_(vp, vp)], data.ddq_dq, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(A[nv:, nv:][np.ix_(vp, vp)], data.ddq_dv, rtol=0, atol=1e-9 * scale)
        np.testing.assert_array_equal(A[:nv], np.hstack([np.zeros((nv, nv)), np.eye(nv)]))
        Minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
        order = list(vp)
        np.testing.assert_allclose(B[nv:][vp], Minv[:, [order.index(c) for c in module.EFFORT_COLUMNS]], rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(Minv))))
        h = 1e-6
        for k in range(nv):
            step = np.zeros(nv)
            step[k] = h
            by_q = (module.forward_dynamics(module.integrate(q, step), v, u)
                    - module.forward_dynamics(module.integrate(q, -step), v, u)) / (2 * h)
            by_v = (module.forward_dynamics(q, v + step, u) - module.forward_dynamics(q, v - step, u)) / (2 * h)
            np.testing.assert_allclose(A[nv:, k], by_q, rtol=0, atol=1e-5 * scale)
            np.testing.assert_allclose(A[nv:, nv + k], by_v, rtol=0, atol=1e-5 * scale)
        # regressor
        Y = module.regressor(q, v, a)
        tau = module.inverse_dynamics(q, v, a)
        np.testing.assert_allclose(Y @ module.parameter_vector(), tau, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(tau))))
    # a batch gives each state's result
    Q, V = np.stack([q, module.neutral_configuration()]), np.stack([v, -v])
    np.testing.assert_allclose(module.coriolis_matrix(Q, V)[0], module.coriolis_matrix(q, v), rtol=1e-12, atol=1e-12)
    A2, B2 = module.linearize(Q, V, np.stack([u, u]))
    np.testing.assert_allclose(A2[0], A, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(B2[0], B, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(module.regressor(Q, V, np.stack([a, a]))[0], Y, rtol=1e-12, atol=1e-12)


def _joint_regressor(robot, module, model, qp, vp, seed: int) -> None:
    """Where every link hangs from its own moving joint at the joint's frame, the regressor's
    columns are Pinocchio's computeJointTorqueRegressor's (ten per joint, its order)."""
    data = model.createData()
    for q, v, a, _ in _states(robot, model, qp, vp, seed, count=2):
        Y_pin = pin.computeJointTorqueRegressor(model, data, q[qp], v[vp], a[vp])
        Y = module.regressor(q, v, a)
        for index, name in enumerate(model.names[1:]):
            link = next(j.child for j in robot.joints if j.name == name)
            start = module.PARAMETER_VECTOR.index(f"m_{link}")
            block = Y[np.ix_(vp, range(start, start + 10))]
            np.testing.assert_allclose(block, Y_pin[:, 10 * index:10 * index + 10], rtol=0,
                                       atol=1e-9 * max(1.0, np.max(np.abs(Y_pin))))
            np.testing.assert_allclose(module.parameter_vector()[start:start + 10],
                                       model.inertias[index + 1].toDynamicParameters(), rtol=0, atol=1e-12)


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", range(4))
def test_random_floating_trees(seed, tmp_path):
    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(seed))
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    module = _module(robot, tmp_path)
    _check(robot, module, model, qp, vp, seed)
    if all(j.moves for j in robot.joints):
        _joint_regressor(robot, module, model, qp, vp, seed)


@pytest.mark.pinocchio
def test_box_regressor_columns_are_pinocchios(tmp_path):
    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    module = _module(robot, tmp_path)
    assert module.PARAMETER_VECTOR[:3] == ("m_base", "mcx_base", "mcy_base") and len(module.PARAMETER_VECTOR) == 20
    assert tuple(p.name for p in dynderive.derive(robot).parameter_vector) == module.PARAMETER_VECTOR
    driven = BOX.replace("effort: tau2}", "effort: tau2, armature: 0.01, stiffness: 2, damping: 0.3}")
    path.write_text(driven)
    assert [p.name for p in dynderive.derive(dynderive.load_robot(path)).parameter_vector][-2:] == [
        "armature_q2", "stiffness_q2"]   # no damping column: damping is not in the floating dynamics
    (tmp_path / "driven").mkdir()
    springy = _module(dynderive.load_robot(path), tmp_path / "driven")
    q = springy.integrate(springy.neutral_configuration(), np.linspace(-1.0, 1.0, 7))
    v, a = np.linspace(0.5, -0.7, 7), np.linspace(-0.3, 0.9, 7)
    np.testing.assert_allclose(springy.regressor(q, v, a) @ springy.parameter_vector(), springy.inverse_dynamics(q, v, a),
                               rtol=0, atol=1e-12)
    path.write_text(BOX)
    _check(robot, module, model, qp, vp, 3)
    _joint_regressor(robot, module, model, qp, vp, 3)


@pytest.mark.pinocchio
def test_solo12(tmp_path):
    path = _example_robot("solo_description/robots/solo12.urdf")
    robot = dynderive.load_robot(path, floating_base=True)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    _check(robot, _module(robot, tmp_path), model, np.array(qp), np.array(vp), 12)


@pytest.mark.pinocchio
def test_frame_jacobian_dot_qd_of_solo12_feet(tmp_path):
    """Pinocchio's classical acceleration of each foot frame at zero acceleration
    (LOCAL_WORLD_ALIGNED), and the frame's acceleration J qdd + Jdot qd against central
    differences of J qd along the motion."""
    path = _example_robot("solo_description/robots/solo12.urdf")
    robot = dynderive.load_robot(path, floating_base=True)
    module = _module(robot, tmp_path)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    for q, v, a, _ in _states(robot, model, np.array(qp), np.array(vp), 5, count=2):
        pin.forwardKinematics(model, data, q[qp], v[vp], np.zeros(model.nv))
        pin.updateFramePlacements(model, data)
        h = 1e-6
        for frame in module.FRAMES:
            expected = pin.getFrameClassicalAcceleration(model, data, model.getFrameId(frame),
                                                         pin.LOCAL_WORLD_ALIGNED).vector
            bias = module.frame_jacobian_dot_qd(q, v, frame)
            np.testing.assert_allclose(bias, expected, rtol=0, atol=1e-10 * max(1.0, np.max(np.abs(expected))))
            ahead, behind = (module.frame_jacobian(module.integrate(q, v, s * h), frame) @ (v + s * h * a) for s in (1, -1))
            np.testing.assert_allclose(module.frame_jacobian(q, frame) @ a + bias, (ahead - behind) / (2 * h), rtol=0,
                                       atol=1e-5 * max(1.0, np.max(np.abs(bias))))
