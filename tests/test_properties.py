"""Physical properties of every bundled robot's generated dynamics, at random states."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from conftest import BUNDLED, derivation_of, on_loops

STATES = 6


def _states(module, seed):
    """Random states; for closed loops, assembled ones with velocities the loops allow."""
    rng = np.random.default_rng(seed)
    n = len(module.COORDINATES)
    qs, qds = on_loops(module, rng.uniform(-1.5, 1.5, (STATES, n)), rng.uniform(-2, 2, (STATES, n)))
    return qs, qds, rng.uniform(-3, 3, (STATES, len(module.EFFORTS)))


@pytest.mark.parametrize("robot", BUNDLED)
def test_mass_matrix_symmetric_positive_definite(generated, robot):
    module = generated(robot)
    q, _, _ = _states(module, 0)
    M = module.mass_matrix(q)
    np.testing.assert_allclose(M, np.swapaxes(M, -1, -2), atol=1e-12)
    assert np.all(np.linalg.eigvalsh(M) > 0)


@pytest.mark.parametrize("robot", BUNDLED)
def test_mdot_minus_2c_is_skew_symmetric(generated, robot):
    """Mdot from the symbolic dM/dq (independent of C's code path), then Mdot - 2C skew."""
    module = generated(robot)
    d = derivation_of(robot)
    table = d.symbols
    M = d["M_g"]
    Mdot = sum((M.diff(qk) * qdk for qk, qdk in zip(table.q, table.qd)), sp.zeros(*M.shape))
    defaults = {table.parameters[p]: v for p, v in module.PARAMETERS.items()}
    mdot = sp.lambdify([table.q, table.qd], Mdot.xreplace(defaults), "numpy")
    qs, qds, _ = _states(module, 1)
    for q, qd in zip(qs, qds):
        S = np.asarray(mdot(q, qd), dtype=float) - 2 * module.coriolis_matrix(q, qd)
        np.testing.assert_allclose(S, -S.T, atol=1e-10)


@pytest.mark.parametrize("robot", BUNDLED)
def test_inverse_of_forward_dynamics_round_trip(generated, robot):
    module = generated(robot)
    qs, qds, us = _states(module, 2)
    qdd = module.forward_dynamics(qs, qds, us)
    expected = module.generalized_forces(qs, us)
    if hasattr(module, "LOOPS"):   # the open tree's inverse dynamics also carries the loop forces
        expected = expected + np.einsum("...ji,...j->...i", module.loop_jacobian(qs), module.loop_forces(qs, qds, us))
    np.testing.assert_allclose(module.inverse_dynamics(qs, qds, qdd), expected, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("robot", BUNDLED)
def test_power_balance(generated, robot):
    """dE/dt = qd . Y - qd . F along the dynamics (E = T + V; F the damping and friction
    forces, zero for robots without), via a central difference in time."""
    module = generated(robot)
    qs, qds, us = _states(module, 3)
    h = 1e-6
    for q, qd, u in zip(qs, qds, us):
        qdd = module.forward_dynamics(q, qd, u)

        def energy(t, q=q, qd=qd, qdd=qdd):
            qt, qdt = q + qd * t + qdd * t**2 / 2, qd + qdd * t
            return module.kinetic_energy(qt, qdt) + module.potential_energy(qt)

        rate = (energy(h) - energy(-h)) / (2 * h)
        power = qd @ module.generalized_forces(q, u) - qd @ module.friction_forces(qd)
        assert rate == pytest.approx(power, rel=1e-5, abs=1e-6)


@pytest.mark.parametrize("robot", BUNDLED)
def test_every_bundled_robot_passes_its_checks(robot):
    d = derivation_of(robot)
    assert d.checks and all(c.passed for c in d.checks), [c.summary() for c in d.checks if not c.passed]
