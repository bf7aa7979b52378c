"""Problem 1 of the reference problem set, reproduced by robots/rp_arm.yaml.

The expected formulas are transcribed from the reference's printed solution
(../shared/reference/hw6_lagrangian_dynamics.md, 1.1-1.3), independently of the engine.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp
from sympy import Matrix, cos, sin

import dynderive

m, l, g, q1, q2, qd1, qd2, qdd1, qdd2, tau1, F2 = sp.symbols("m l g q1 q2 qd1 qd2 qdd1 qdd2 tau1 F2")

# 1.1
T_ref = m / 2 * (qd2**2 + qd1**2 * (l / 2 + q2) ** 2) + sp.Rational(5, 24) * m * l**2 * qd1**2
V_ref = m * g * (l + q2) * sin(q1)
L_ref = T_ref - V_ref
# 1.2
Y_ref = Matrix([tau1, F2])
EOM1_ref = Matrix([
    (sp.Rational(5, 12) * l**2 + (l / 2 + q2) ** 2) * m * qdd1 + 2 * m * qd1 * qd2 * (l / 2 + q2)
    + m * g * (l + q2) * cos(q1) - tau1,
    m * qdd2 - m * qd1**2 * (l / 2 + q2) + m * g * sin(q1) - F2,
])
# 1.3
M_ref = Matrix([[sp.Rational(5, 12) * m * l**2 + m * (l / 2 + q2) ** 2, 0], [0, m]])
C_ref = Matrix([[qd2 * m * (l / 2 + q2), qd1 * m * (l / 2 + q2)], [-qd1 * m * (l / 2 + q2), 0]])
N_ref = Matrix([m * g * (l + q2) * cos(q1), m * g * sin(q1)])
J1_ref = Matrix([[0, 0], [l / 2, 0], [1, 0]])
J2_ref = Matrix([[0, 1], [l / 2 + q2, 0], [1, 0]])

REFERENCE = {"T_g": T_ref, "V_g": V_ref, "L_g": L_ref, "Y_g": Y_ref, "EOM_g1": EOM1_ref,
             "M_g": M_ref, "C_g": C_ref, "N_g": N_ref, "EOM_g2": EOM1_ref,
             "J_b1": J1_ref, "J_b2": J2_ref}
LOCALS = {str(s): s for s in (m, l, g, q1, q2, qd1, qd2, qdd1, qdd2, tau1, F2)}


@pytest.fixture(scope="module")
def dump():
    return json.loads(dynderive.render_json(dynderive.derive(dynderive.load_robot("rp_arm"))))


def _is_zero(expr) -> bool:
    expr = sp.Matrix(expr) if isinstance(expr, sp.MatrixBase) else sp.Matrix([expr])
    return all(sp.simplify(sp.expand(e)) == 0 for e in expr)


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_json_quantity_equals_reference(dump, name):
    entry = dump["quantities"][name]
    value = sp.sympify(entry["sympy"], locals=LOCALS)
    expected = REFERENCE[name]
    if isinstance(expected, sp.MatrixBase):
        assert entry["shape"] == list(expected.shape)
        assert _is_zero(sp.Matrix(value) - expected), f"{name}: {value} != {expected}"
    else:
        assert entry["shape"] == [1, 1]
        assert _is_zero(value - expected), f"{name}: {value} != {expected}"
    assert entry["latex"]


def test_compact_forms_match_the_printed_ones():
    """Not only equal: the engine prints M, C, N, V in the reference's own compact form."""
    d = dynderive.derive(dynderive.load_robot("rp_arm"))
    assert d["N_g"] == N_ref
    assert d["C_g"] == C_ref
    assert d["M_g"] == M_ref
    assert d["V_g"] == V_ref
    assert d["J_b2"] == J2_ref


def test_lagrange_steps_match_reference():
    d = dynderive.derive(dynderive.load_robot("rp_arm"))
    steps = d.generalized_steps["lagrange"]
    expected_dL_dqd = Matrix([sp.Rational(5, 12) * m * l**2 * qd1 + m * qd1 * (l / 2 + q2) ** 2, m * qd2])
    expected_ddt = Matrix([
        sp.Rational(5, 12) * m * l**2 * qdd1 + m * qdd1 * (l / 2 + q2) ** 2 + 2 * m * qd1 * qd2 * (l / 2 + q2),
        m * qdd2,
    ])
    expected_dL_dq = Matrix([-m * g * (l + q2) * cos(q1), m * qd1**2 * (l / 2 + q2) - m * g * sin(q1)])
    assert _is_zero(steps["dL_dqd"] - expected_dL_dqd)
    assert _is_zero(steps["ddt_dL_dqd"] - expected_ddt)
    assert _is_zero(steps["dL_dq"] - expected_dL_dq)


def test_engine_reports_eom_check():
    d = dynderive.derive(dynderive.load_robot("rp_arm"))
    check = next(c for c in d.checks if c.name == "EOM_g1 == EOM_g2")
    assert check.passed and check.method == "symbolic"


# -- the generated module against the closed forms, numerically -------------------------

PARAMS = {"m": 1.3, "l": 0.7, "g": 9.81}


def _closed_forms(q, qd, params):
    a = params["l"] / 2 + q[1]
    mm, gg, ll = params["m"], params["g"], params["l"]
    M = np.array([[5 / 12 * mm * ll**2 + mm * a**2, 0], [0, mm]])
    C = np.array([[qd[1] * mm * a, qd[0] * mm * a], [-qd[0] * mm * a, 0]])
    N = np.array([mm * gg * (ll + q[1]) * np.cos(q[0]), mm * gg * np.sin(q[0])])
    T = mm / 2 * (qd[1] ** 2 + qd[0] ** 2 * a**2) + 5 / 24 * mm * ll**2 * qd[0] ** 2
    V = mm * gg * (ll + q[1]) * np.sin(q[0])
    return M, C, N, T, V


def test_generated_module_equals_reference_single_and_batch(generated):
    module = generated("rp_arm")
    assert module.COORDINATES == ("q1", "q2") and module.EFFORTS == ("tau1", "F2")
    assert module.PARAMETERS == {"m": 1.0, "l": 1.0, "g": 9.81}
    rng = np.random.default_rng(1)
    qs, qds, us = rng.uniform(-1.5, 1.5, (3, 8, 2))
    for q, qd, u in zip(qs, qds, us):
        M, C, N, T, V = _closed_forms(q, qd, PARAMS)
        np.testing.assert_allclose(module.mass_matrix(q, **PARAMS), M, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.coriolis_matrix(q, qd, **PARAMS), C, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.gravity_vector(q, **PARAMS), N, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.kinetic_energy(q, qd, **PARAMS), T, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.potential_energy(q, **PARAMS), V, rtol=1e-12, atol=1e-12)
        qdd = np.linalg.solve(M, u - C @ qd - N)
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u, **PARAMS), qdd, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd, **PARAMS), u, rtol=1e-12, atol=1e-12)
    # a batch (k, n) gives the per-state results stacked
    batch_M = module.mass_matrix(qs, **PARAMS)
    assert batch_M.shape == (8, 2, 2)
    batch_qdd = module.forward_dynamics(qs, qds, us, **PARAMS)
    assert batch_qdd.shape == (8, 2)
    for k in range(8):
        M, C, N, T, V = _closed_forms(qs[k], qds[k], PARAMS)
        np.testing.assert_allclose(batch_M[k], M, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(batch_qdd[k], np.linalg.solve(M, us[k] - C @ qds[k] - N),
                                   rtol=1e-12, atol=1e-12)
    assert module.kinetic_energy(qs, qds, **PARAMS).shape == (8,)
    assert module.inverse_dynamics(qs, qds, batch_qdd, **PARAMS).shape == (8, 2)


def test_generated_module_defaults_are_the_yaml_defaults(generated):
    module = generated("rp_arm")
    q = np.array([0.4, 0.1])
    M, *_ = _closed_forms(q, np.zeros(2), {"m": 1.0, "l": 1.0, "g": 9.81})
    np.testing.assert_allclose(module.mass_matrix(q), M, rtol=1e-12)


def test_generated_module_rejects_wrong_shapes(generated):
    module = generated("rp_arm")
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 2\)"):
        module.mass_matrix(np.zeros(3))
