"""Maximal coordinates (Problem 2 of the reference, 2.1-2.7) and the change of basis."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp
from sympy import Matrix, cos, sin

import dynderive

from conftest import BUNDLED, import_code, on_loops, random_tree_derivation

m, l, g, tau1, F2 = sp.symbols("m l g tau1 F2")
q1, q2, qd1, qd2 = sp.symbols("q1 q2 qd1 qd2")
x1, y1, phi1, x2, y2, phi2 = qm = sp.symbols("x1 y1 phi1 x2 y2 phi2")
qmd = sp.symbols("xd1 yd1 phid1 xd2 yd2 phid2")
qmdd = sp.symbols("xdd1 ydd1 phidd1 xdd2 ydd2 phidd2")
lam = sp.symbols("lambda1:5")
LOCALS = {str(s): s for s in (m, l, g, tau1, F2, q1, q2, qd1, qd2, *qm, *qmd, *qmdd, *lam)}

# Transcribed from the reference's printed solution (2.1-2.7).
a_ref = Matrix([x1 - l * cos(phi1) / 2, y1 - l * sin(phi1) / 2, y2 * cos(phi2) - x2 * sin(phi2), phi2 - phi1])
A_ref = Matrix([
    [1, 0, l * sin(phi1) / 2, 0, 0, 0],
    [0, 1, -l * cos(phi1) / 2, 0, 0, 0],
    [0, 0, 0, -sin(phi2), cos(phi2), -x2 * cos(phi2) - y2 * sin(phi2)],
    [0, 0, -1, 0, 0, 1],
])
# 2.6: Adot by the chain rule, computed here from the printed A (the printed Adot matrix is
# typeset with a column missing in row 3).
Adot_ref = sum((A_ref.diff(c) * v for c, v in zip(qm, qmd)), sp.zeros(4, 6))
xd1, yd1, phid1, xd2, yd2, phid2 = qmd
T_m_ref = m * (xd1**2 + xd2**2 + yd1**2 + yd2**2) / 2 + m * l**2 * (phid1**2 + phid2**2) / 24
V_m_ref = m * g * (y1 + y2)
L_m_ref = T_m_ref - V_m_ref
Y_m_ref = Matrix([-F2 * cos(phi1), -F2 * sin(phi1), tau1, F2 * cos(phi1), F2 * sin(phi1), 0])
M_m_ref = sp.diag(m, m, m * l**2 / 12, m, m, m * l**2 / 12)
C_m_ref = sp.zeros(6, 6)
N_m_ref = Matrix([0, m * g, 0, 0, m * g, 0])
xdd1, ydd1, phidd1, xdd2, ydd2, phidd2 = qmdd
EOM_m1_ref = Matrix([  # equations (3)-(8), left side minus right side
    m * xdd1 + lam[0] + F2 * cos(phi1),
    m * ydd1 + m * g + lam[1] + F2 * sin(phi1),
    m * l**2 * phidd1 / 12 + l / 2 * sin(phi1) * lam[0] - l / 2 * cos(phi1) * lam[1] - lam[3] - tau1,
    m * xdd2 - sin(phi1) * lam[2] - F2 * cos(phi1),
    m * ydd2 + m * g + cos(phi1) * lam[2] - F2 * sin(phi1),
    m * l**2 * phidd2 / 12 - x2 * cos(phi2) * lam[2] - y2 * sin(phi2) * lam[2] + lam[3],
])
h_ref = Matrix([l * cos(q1) / 2, l * sin(q1) / 2, q1, (l / 2 + q2) * cos(q1), (l / 2 + q2) * sin(q1), q1])
H_ref = Matrix([
    [-l * sin(q1) / 2, 0], [l * cos(q1) / 2, 0], [1, 0],
    [-(l / 2 + q2) * sin(q1), cos(q1)], [(l / 2 + q2) * cos(q1), sin(q1)], [1, 0],
])
EXACT = {"a_m": a_ref, "A_m": A_ref, "Adot_m": Adot_ref, "T_m": T_m_ref, "V_m": V_m_ref, "L_m": L_m_ref,
         "M_m": M_m_ref, "C_m": C_m_ref, "N_m": N_m_ref, "h": h_ref, "H": H_ref, "Y_m": Y_m_ref}


@pytest.fixture(scope="module")
def dump():
    return json.loads(dynderive.render_json(dynderive.derive(dynderive.load_robot("rp_arm"))))


def _value(dump, name):
    return sp.sympify(dump["quantities"][name]["sympy"], locals=LOCALS)


def _zero(expr) -> bool:
    return all(sp.simplify(sp.expand(e)) == 0 for e in sp.Matrix(expr))


@pytest.mark.parametrize("name", sorted(EXACT))
def test_json_equals_reference(dump, name):
    assert _zero(sp.Matrix([_value(dump, name)]) - sp.Matrix([EXACT[name]]) if not isinstance(EXACT[name], sp.MatrixBase)
                 else _value(dump, name) - EXACT[name]), name


def test_eom_m1_equals_printed_equations_on_the_manifold(dump):
    """The printed (6), (7) use phi1 for link 2's angle, equal to phi2 on the manifold."""
    difference = (_value(dump, "EOM_m1") - EOM_m1_ref).subs(phi2, phi1)
    assert _zero(difference)
    assert _zero(_value(dump, "EOM_m2") - _value(dump, "EOM_m1"))


def test_eom_g3_equals_eom_g1(dump):
    assert _zero(_value(dump, "EOM_g3") - _value(dump, "EOM_g1"))
    names = {c["name"]: c for c in dump["checks"]}
    for check in ("a_m(h(q)) == 0", "A_m(h(q)) H(q) == 0", "EOM_m1 == EOM_m2", "EOM_g3 == EOM_g1"):
        assert names[check]["passed"] and names[check]["method"] == "symbolic", check


def test_lambda_closed_form_in_json_matches_the_formula(dump):
    """lambdaVec from the JSON, against the formula evaluated with the reference matrices."""
    lam_json = _value(dump, "lambdaVec")
    rng = np.random.default_rng(5)
    for _ in range(3):
        point = dict(zip((m, l, g, tau1, F2), rng.uniform(0.5, 2.0, 5)))
        point |= dict(zip(qm, rng.uniform(-1, 1, 6))) | dict(zip(qmd, rng.uniform(-1, 1, 6)))
        A = np.array(A_ref.subs(point), dtype=float)
        M = np.array(M_m_ref.subs(point), dtype=float)
        rhs = np.array((Y_m_ref - N_m_ref).subs(point), dtype=float)[:, 0]
        Adot = np.array(Adot_ref.subs(point), dtype=float)
        v = np.array([point[s] for s in qmd])
        W = A @ np.linalg.solve(M, A.T)
        expected = np.linalg.solve(W, A @ np.linalg.solve(M, rhs) + Adot @ v)
        np.testing.assert_allclose(np.array(lam_json.subs(point), dtype=float)[:, 0], expected, rtol=1e-10)


def test_generated_constraint_forces_equal_reference_lambda_on_manifold(generated):
    module = generated("rp_arm")
    assert module.MAXIMAL_COORDINATES == ("x1", "y1", "phi1", "x2", "y2", "phi2")
    p = {"m": 1.3, "l": 0.8, "g": 9.81}
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, u = rng.uniform(-1.2, 1.2, (3, 2))
        state = {q1: q[0], q2: q[1], m: p["m"], l: p["l"], g: p["g"]}
        h = np.array(h_ref.subs(state), dtype=float)[:, 0]
        H = np.array(H_ref.subs(state), dtype=float)
        v = H @ qd
        point = dict(zip(qm, h)) | dict(zip(qmd, v)) | {m: p["m"], l: p["l"], g: p["g"], tau1: u[0], F2: u[1]}
        A = np.array(A_ref.subs(point), dtype=float)
        M = np.array(M_m_ref.subs(point), dtype=float)
        Adot = np.array(Adot_ref.subs(point), dtype=float)
        rhs = np.array((Y_m_ref - N_m_ref).subs(point), dtype=float)[:, 0]
        W = A @ np.linalg.solve(M, A.T)
        expected = np.linalg.solve(W, A @ np.linalg.solve(M, rhs) + Adot @ v)
        np.testing.assert_allclose(module.constraint_forces(h, v, u, **p), expected, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(module.to_maximal(q, **p), h, atol=1e-12)
        np.testing.assert_allclose(module.to_maximal_jacobian(q, **p), H, atol=1e-12)


# -- change-of-basis identities, numerically, for every planar robot --------------------

def _identities(module, n_states=4, seed=0, params=None):
    params = params or {}
    rng = np.random.default_rng(seed)
    n = len(module.COORDINATES)
    for _ in range(n_states):
        q, qd, qdd = rng.uniform(-1.3, 1.3, (3, n))
        (q,), (qd,) = on_loops(module, q[None], qd[None])   # closed loops: a state they allow
        u = rng.uniform(-2, 2, len(module.EFFORTS))
        h = module.to_maximal(q, **params)
        H = module.to_maximal_jacobian(q, **params)
        eps = 1e-6
        Hdot = (module.to_maximal_jacobian(q + eps * qd, **params) - module.to_maximal_jacobian(q - eps * qd, **params)) / (2 * eps)
        v = H @ qd
        np.testing.assert_allclose(module.constraints(h, **params), 0, atol=1e-10)
        AH = module.constraint_jacobian(h, **params) @ H
        # closed loops: the loop rows of A_m H are A_g, which the allowed velocities annul
        np.testing.assert_allclose(AH @ qd if hasattr(module, "LOOPS") else AH, 0, atol=1e-10)
        Mm = module.maximal_mass_matrix(h, **params)
        np.testing.assert_allclose(H.T @ Mm @ H, module.mass_matrix(q, **params), atol=1e-10)
        Cm = module.maximal_coriolis_matrix(h, v, **params)
        np.testing.assert_allclose(H.T @ (Mm @ Hdot + Cm @ H) @ qd, module.coriolis_matrix(q, qd, **params) @ qd, atol=1e-6)
        np.testing.assert_allclose(H.T @ module.maximal_gravity_vector(h, **params), module.gravity_vector(q, **params), atol=1e-10)
        np.testing.assert_allclose(H.T @ module.maximal_efforts(h, u, **params), module.generalized_forces(q, u, **params), atol=1e-10)
        # constrained dynamics: qmdd = H qdd + Hdot qd, for the generalized qdd
        qdd_g = module.forward_dynamics(q, qd, u, **params)
        qmdd = module.maximal_forward_dynamics(h, v, u, **params)
        np.testing.assert_allclose(qmdd, H @ qdd_g + Hdot @ qd, atol=1e-5)


PLANAR = [r for r in BUNDLED if dynderive.load_robot(r).planar]


@pytest.mark.parametrize("robot", PLANAR)
def test_change_of_basis_identities_bundled(generated, robot):
    _identities(generated(robot))


RANDOM_CASES = [(0, 2), (1, 3), (2, 4), (5, 3), (8, 4)]


@pytest.mark.parametrize("seed,n", RANDOM_CASES, ids=[f"seed{s}-{n}dof" for s, n in RANDOM_CASES])
def test_change_of_basis_identities_random_trees(tmp_path_factory, seed, n):
    derivation, module = random_tree_derivation(seed, n, str(tmp_path_factory.getbasetemp()))
    assert all(c.passed for c in derivation.checks), [c.summary() for c in derivation.checks]
    _identities(module, seed=seed)


def test_rp_arm_with_automatic_constraints(tmp_path):
    """Without the override, the joints give equivalent constraints and every check holds."""
    source = dynderive.load_robot("rp_arm").source
    text = open(source).read()
    text = text[: text.index("maximal:")]
    path = tmp_path / "rp_arm.yaml"
    path.write_text(text)
    d = dynderive.derive(dynderive.load_robot(path))
    assert d.maximal_steps["constraint_origin"] == "joints"
    assert all(c.passed for c in d.checks), [c.summary() for c in d.checks]
    assert d["a_m"].shape == (4, 1)
    # the automatic constraints vanish exactly where the reference's do (on h(q))
    assert _zero(d["a_m"].xreplace(dict(zip(qm, h_ref))))
    assert _zero((d["Y_m"] - Y_m_ref).xreplace(dict(zip(qm, h_ref))))
    module = import_code(dynderive.render_code(d), tmp_path, "rp_auto_dynamics")
    _identities(module)


def test_wrong_constraint_override_fails_the_checks(tmp_path):
    source = open(dynderive.load_robot("rp_arm").source).read()
    path = tmp_path / "wrong.yaml"
    path.write_text(source.replace("- phi2 - phi1", "- phi2 - 2*phi1"))
    d = dynderive.derive(dynderive.load_robot(path))
    failed = {c.name for c in d.checks if not c.passed}
    assert "a_m(h(q)) == 0" in failed


def test_constrained_simulation_tracks_generalized(generated):
    """Maximal (with Baumgarte) and generalized simulations of the RP arm agree over 3 s."""
    from scipy.integrate import solve_ivp

    module = generated("rp_arm")
    u = np.array([0.5, 0.3])
    q0, qd0 = np.array([0.3, 0.2]), np.array([0.0, 0.1])

    def generalized(t, y):
        return np.concatenate([y[2:], module.forward_dynamics(y[:2], y[2:], u)])

    def maximal(t, y):
        return np.concatenate([y[6:], module.maximal_forward_dynamics(y[:6], y[6:], u, alpha=5.0, beta=5.0)])

    times = np.linspace(0, 3, 31)
    sol_g = solve_ivp(generalized, (0, 3), np.concatenate([q0, qd0]), t_eval=times, rtol=1e-10, atol=1e-10)
    h0 = module.to_maximal(q0)
    v0 = module.to_maximal_jacobian(q0) @ qd0
    sol_m = solve_ivp(maximal, (0, 3), np.concatenate([h0, v0]), t_eval=times, rtol=1e-10, atol=1e-10)
    assert sol_g.success and sol_m.success
    mapped = module.to_maximal(sol_g.y[:2].T)
    np.testing.assert_allclose(sol_m.y[:6].T, mapped, atol=1e-5)
    assert np.max(np.abs(module.constraints(sol_m.y[:6].T))) < 1e-6
