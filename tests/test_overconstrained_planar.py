"""An over-constrained planar mechanism (a double parallelogram: 4 loop rows of rank 3) against
its textbook closed form, in generalized and maximal coordinates.

On the parallelogram branch the coupler translates, so with theta the crank angle

    (J1 + J3 + J4 + m2 L^2) theta'' + g L cos(theta) (m1/2 + m3/2 + m4/2 + m2) = tau1,

J_i = m_i L^2 / 3 (a rod about its pivot), and q = (theta, -theta, theta, theta)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dynderive

from conftest import import_code

HERE = Path(__file__).parent / "loops"


@pytest.fixture(scope="module")
def mechanism(tmp_path_factory):
    derivation = dynderive.derive(dynderive.load_robot(HERE / "double_parallelogram.yaml"))
    module = import_code(dynderive.render_code(derivation), tmp_path_factory.mktemp("parallelogram"))
    return derivation, module


def _closed_form(theta: float, thetad: float, tau: float, p: dict[str, float]) -> float:
    L, g = p["L"], p["g"]
    inertia = (p["m1"] + p["m3"] + p["m4"]) * L**2 / 3 + p["m2"] * L**2
    return (tau - g * L * np.cos(theta) * ((p["m1"] + p["m3"] + p["m4"]) / 2 + p["m2"])) / inertia


def test_rank_and_mobility(mechanism):
    derivation, module = mechanism
    model = derivation.loop_model
    assert derivation["a_g"].shape == (4, 1) and model.rank == 3 and derivation.mobility == 1
    assert any("over-constrained" in note for note in derivation.notes)
    assert module.INDEPENDENT_COORDINATES == ("q1",)
    # the default assembly is a regular point of the parallelogram branch, not the flat fold at 0
    q = np.array(module.ASSEMBLED_CONFIGURATION)
    assert np.max(np.abs(module.loop_constraints(q))) < 1e-14
    assert np.allclose(q, [q[0], -q[0], q[0], q[0]], atol=1e-12) and abs(np.sin(q[0])) > 0.1


@pytest.mark.parametrize("theta", [0.83190311417040341, -2.2719734092154213, 1.5707963267948966, 2.9])
def test_forward_dynamics_matches_the_closed_form(mechanism, theta):
    derivation, module = mechanism
    p = dict(module.PARAMETERS)
    q = module.assemble(np.array([theta, -theta + 0.2, theta - 0.15, theta + 0.1]))   # a guess near the branch
    assert np.allclose(q, [theta, -theta, theta, theta], atol=1e-10)
    assert np.max(np.abs(module.loop_constraints(q))) < 1e-12   # every row closed
    thetad, tau = 1.3172047412658903, -0.71965810393771285
    qd = np.array([thetad, -thetad, thetad, thetad])
    qdd = module.forward_dynamics(q, qd, np.array([tau]))
    expected = _closed_form(theta, thetad, tau, p)
    np.testing.assert_allclose(qdd, [expected, -expected, expected, expected], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(module.reduced_forward_dynamics(q, qd, np.array([tau])), qdd, atol=1e-10)
    # the loop force: A^T lambda = M qdd + C qd + N - Y, lambda of least norm (in the row space of A)
    lam = module.loop_forces(q, qd, np.array([tau]))
    A = module.loop_jacobian(q)
    force = module.mass_matrix(q) @ qdd + module.inverse_dynamics(q, qd, np.zeros(4)) - module.generalized_forces(q, [tau])
    np.testing.assert_allclose(A.T @ lam, force, atol=1e-9)
    left_null = np.linalg.svd(A)[0][:, 3:]
    assert np.max(np.abs(left_null.T @ lam)) < 1e-9


def test_maximal_model_agrees(mechanism):
    derivation, module = mechanism
    theta, thetad, tau = 0.61572316734212197, -0.93108218453094613, 0.38417402917634588
    q = module.assemble(np.array([theta, *module.ASSEMBLED_CONFIGURATION[1:]]))
    qd = np.array([thetad, -thetad, thetad, thetad])
    qdd = module.forward_dynamics(q, qd, np.array([tau]))
    qm, H = module.to_maximal(q), module.to_maximal_jacobian(q)
    h = 1e-6
    Hdot = (module.to_maximal_jacobian(q + h * qd) - module.to_maximal_jacobian(q - h * qd)) / (2 * h)
    qmdd = module.maximal_forward_dynamics(qm, H @ qd, np.array([tau]))
    np.testing.assert_allclose(qmdd, H @ qdd + Hdot @ qd, atol=1e-7)
    # and the batch path gives the same accelerations
    batch = module.forward_dynamics(np.array([q, q]), np.array([qd, qd]), np.array([[tau], [tau]]))
    np.testing.assert_allclose(batch[1], qdd, atol=1e-12)
