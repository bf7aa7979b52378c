"""Closed-loop robots: independent references, and dynderive's loop engine against them.

``tests/loop_references.py`` holds the references (closed forms of the bundled loop robots and
a Pinocchio KKT model built from the YAML text, no dynderive code). Tests whose names contain
``reference`` validate those references on their own; tests whose names contain ``dynderive``
compare the generated module of ``robots/four_bar.yaml``, ``robots/slider_crank.yaml`` and
``robots/spatial_four_bar.yaml`` with them (issue #15). The rows and signs of dynderive's
``a_g`` are its own choice, so only invariants are compared: ``a_g = 0`` at assembled states,
``A_g qd = 0`` for admissible velocities, the constrained ``qdd`` and the generalized
constraint force ``A_g^T lambda_g``.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from loop_references import (
    LOOP_ROBOTS,
    ROBOTS,
    closed_form,
    defaults,
    four_bar_closed_form,
    freudenstein_residual,
    reference,
    slider_crank_closed_form,
    spatial_four_bar_closed_form,
    wrap,
)

#: which coordinates are angles (compared modulo 2 pi)
ANGLES = {"four_bar": [True, True, True], "slider_crank": [True, True, False],
          "spatial_four_bar": [True, True, True, True]}
COORDINATES = {"four_bar": ("q1", "q2", "q3"), "slider_crank": ("q1", "q2", "s"),
               "spatial_four_bar": ("q1", "q2", "q3", "q4")}
N_STATES = 6
TOL = {"rtol": 1e-9, "atol": 1e-9}


def states(robot: str, seed: int = 0, n: int = N_STATES):
    """[(q, qd, u)]: random crank angle and rate on the default branch, random effort."""
    rng = np.random.default_rng(seed)
    values = defaults(robot)
    out = []
    for _ in range(n):
        q, qd = closed_form(robot, rng.uniform(-np.pi, np.pi), rng.uniform(-3.0, 3.0), values)
        out.append((q, qd, rng.uniform(-2.0, 2.0, 1)))
    return out


def angle_close(robot: str, actual: np.ndarray, expected: np.ndarray, atol: float = 1e-9) -> None:
    diff = np.asarray(actual, dtype=float) - np.asarray(expected, dtype=float)
    diff = np.where(ANGLES[robot], wrap(diff), diff)
    np.testing.assert_allclose(diff, 0.0, atol=atol)


def fd(f, x: float, h: float = 1e-6):
    return (np.asarray(f(x + h)) - np.asarray(f(x - h))) / (2 * h)


# =========================================================================================
# The references on their own
# =========================================================================================


def test_reference_four_bar_closed_form_geometry():
    v = defaults("four_bar")
    a, b, c, d = v["a"], v["b"], v["c"], v["d"]
    assert a + max(b, c, d) <= sum(sorted([b, c, d])[:2]) and a < min(b, c, d), "Grashof crank-rocker"
    for q1 in np.linspace(-np.pi, np.pi, 37):
        out = four_bar_closed_form(q1, **v)
        q = out["q"]
        A, B, O4 = out["A"], out["B"], out["O4"]
        np.testing.assert_allclose(np.linalg.norm(B - A), b, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(B - O4), c, atol=1e-12)
        # positions from the angles: coupler end and rocker end coincide
        coupler_end = A + b * np.array([np.cos(q[0] + q[1]), np.sin(q[0] + q[1])])
        rocker_end = O4 + c * np.array([np.cos(q[2]), np.sin(q[2])])
        np.testing.assert_allclose(coupler_end, rocker_end, atol=1e-12)
        assert abs(freudenstein_residual(q[0], q[2], **v)) < 1e-12
        # default branch: B to the left of A -> O4
        D = O4 - A
        assert D[0] * (B - A)[1] - D[1] * (B - A)[0] > 0
    assert four_bar_closed_form(0.0, **v)["B"][1] > 0
    mirror = four_bar_closed_form(0.3, **v, branch=-1)
    assert abs(freudenstein_residual(0.3, mirror["q"][2], **v)) < 1e-12


@pytest.mark.parametrize("q1", [-2.5, -1.0, 0.0, 0.4, 1.7, 3.0])
def test_reference_four_bar_velocity_is_derivative(q1):
    v = defaults("four_bar")
    qd = four_bar_closed_form(q1, 1.0, **v)["qd"]
    dq = fd(lambda t: np.unwrap(four_bar_closed_form(t, **v)["q"] - four_bar_closed_form(q1, **v)["q"]), q1)
    np.testing.assert_allclose(qd, wrap(dq), atol=1e-7)


@pytest.mark.parametrize("q1", [-2.5, -1.0, 0.0, 0.4, 1.7, 3.0])
def test_reference_slider_crank_closed_form(q1):
    v = defaults("slider_crank")
    r, l, e = v["r"], v["l"], v["e"]
    out = slider_crank_closed_form(q1, 1.0, **v)
    q = out["q"]
    rod_end = out["A"] + l * np.array([np.cos(q[0] + q[1]), np.sin(q[0] + q[1])])
    np.testing.assert_allclose(rod_end, [q[2], e], atol=1e-12)
    assert q[2] > r * np.cos(q1)
    dq = fd(lambda t: slider_crank_closed_form(t, **v)["q"], q1)
    np.testing.assert_allclose(out["qd"], [1.0, wrap(dq[1]), dq[2]], atol=1e-7)


def test_reference_spatial_four_bar_closed_form():
    v = defaults("spatial_four_bar")
    a, b, c = v["a"], v["b"], v["c"]
    np.testing.assert_allclose(spatial_four_bar_closed_form(0.0, **v)["q"], 0.0, atol=1e-15)
    ref = reference("spatial_four_bar")
    for q1 in np.linspace(-np.pi, np.pi, 25):
        out = spatial_four_bar_closed_form(q1, **v)
        assert -0.9 < out["gamma_over_R"] < -0.4, "far from the dead positions: the crank turns fully"
        np.testing.assert_allclose(np.linalg.norm(out["B"] - out["A"]), b, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(out["B"] - out["O4"]), c, atol=1e-12)
        # the Pinocchio model's loop points (from the YAML) are the closed form's A -> B ends
        (p_coupler, p_rocker), = ref.loop_points(out["q"])
        np.testing.assert_allclose(p_coupler, out["B"], atol=1e-12)
        np.testing.assert_allclose(p_rocker, out["B"], atol=1e-12)
        assert abs(a) > 0
    q, qd = closed_form("spatial_four_bar", 0.8, 1.0, v)
    dq = fd(lambda t: spatial_four_bar_closed_form(t, **v)["q"], 0.8)
    np.testing.assert_allclose(qd, dq, atol=1e-7)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_reference_pinocchio_loop_closes_at_closed_forms(robot):
    pytest.importorskip("pinocchio")
    ref = reference(robot)
    values = defaults(robot)
    assert ref.robot.coordinates == list(COORDINATES[robot])
    for q1 in np.linspace(-np.pi, np.pi, 13):
        q, qd = closed_form(robot, q1, 1.3, values)
        np.testing.assert_allclose(ref.constraints(q), 0.0, atol=1e-12)
        J = ref.jacobian(q)
        np.testing.assert_allclose(J @ qd, 0.0, atol=1e-12)
        # mobility 1: k independent rows, n - k = 1
        assert np.linalg.matrix_rank(J, tol=1e-8) == ref.k == ref.n - 1
    # assembling from a perturbed guess gives back the closed form (branch kept)
    rng = np.random.default_rng(1)
    q, _ = closed_form(robot, 0.9, 0.0, values)
    guess = q + np.r_[0.0, rng.uniform(-0.05, 0.05, ref.n - 1)]
    angle_close(robot, ref.assemble(guess), q, atol=1e-11)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_reference_pinocchio_jacobian_and_drift_by_finite_differences(robot):
    pytest.importorskip("pinocchio")
    ref = reference(robot)
    rng = np.random.default_rng(2)
    for _ in range(3):
        q = rng.uniform(-1.5, 1.5, ref.n)           # not assembled: the formulas hold anywhere
        qd = rng.uniform(-1.5, 1.5, ref.n)
        h = 1e-6
        numeric = np.column_stack([(ref.constraints(q + h * e) - ref.constraints(q - h * e)) / (2 * h)
                                   for e in np.eye(ref.n)])
        np.testing.assert_allclose(ref.jacobian(q), numeric, atol=1e-8)
        jdot_qd = (ref.jacobian(q + h * qd) - ref.jacobian(q - h * qd)) / (2 * h) @ qd
        np.testing.assert_allclose(ref.drift(q, qd), jdot_qd, atol=1e-7)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_reference_kkt_solution_properties(robot):
    """J qdd + Jdot qd = 0; the constraint force does no work; reduced (Lagrange) equations hold;
    the accelerations are the time derivative of the closed-form velocities."""
    pytest.importorskip("pinocchio")
    ref = reference(robot)
    values = defaults(robot)
    for q, qd, u in states(robot, seed=3):
        qdd, force = ref.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(ref.jacobian(q) @ qdd + ref.drift(q, qd), 0.0, atol=1e-10)
        assert abs(qd @ force) < 1e-10 * (1 + np.abs(force).max())
        # the constraint force lies in the row space of J
        J = ref.jacobian(q)
        lam = np.linalg.lstsq(J.T, force, rcond=None)[0]
        np.testing.assert_allclose(J.T @ lam, force, atol=1e-10)
        # along the closed-form curve q(q1): qdd = R qdd1 + dR/dq1 qd1^2 with R = dq/dq1
        q1, qd1 = q[0], qd[0]
        R = closed_form(robot, q1, 1.0, values)[1]
        dR = fd(lambda t: closed_form(robot, t, 1.0, values)[1], q1, 1e-5)
        np.testing.assert_allclose(qdd, R * qdd[0] + dR * qd1**2, rtol=1e-6, atol=1e-6)
        # Baumgarte gains do nothing on the manifold
        np.testing.assert_allclose(ref.forward_dynamics(q, qd, u, alpha=10.0, beta=10.0)[0], qdd, atol=1e-10)


@pytest.mark.pinocchio
def test_reference_matches_pinocchio_constraint_dynamics():
    pytest.importorskip("pinocchio")
    ref = reference("spatial_four_bar")
    for q, qd, u in states("spatial_four_bar", seed=4):
        qdd, _ = ref.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(ref.constraint_dynamics(q, qd, u), qdd, rtol=1e-8, atol=1e-8)


def _integrate(forward, energy, constraints, q0, qd0, t_end=1.0):
    from scipy.integrate import solve_ivp

    n = len(q0)

    def rhs(_t, x):
        return np.concatenate([x[n:], forward(x[:n], x[n:])])

    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, qd0]), method="DOP853", rtol=1e-11, atol=1e-12,
                    dense_output=False, t_eval=np.linspace(0.0, t_end, 21))
    assert sol.success
    e = np.array([energy(x[:n], x[n:]) for x in sol.y.T])
    a = max(np.abs(constraints(x[:n])).max() for x in sol.y.T)
    return e, a, sol.y[:, -1]


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_reference_energy_conservation(robot):
    pytest.importorskip("pinocchio")
    ref = reference(robot)
    q0, qd0 = closed_form(robot, 0.4, 2.0, defaults(robot))
    e, a, _ = _integrate(lambda q, qd: ref.forward_dynamics(q, qd, alpha=10.0, beta=10.0)[0],
                         ref.energy, ref.constraints, q0, qd0)
    assert np.ptp(e) < 1e-6 * max(1.0, np.abs(e).max())
    assert a < 1e-7


# =========================================================================================
# dynderive against the references (issue #15)
# =========================================================================================


@cache
def _generated(robot: str, directory: str):
    import dynderive

    from conftest import import_code

    derivation = dynderive.derive(dynderive.load_robot(ROBOTS / f"{robot}.yaml"))
    module = import_code(dynderive.render_code(derivation), Path(directory), f"loops_{robot}_dynamics")
    return derivation, module


@pytest.fixture(scope="module")
def loop_dir(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("loops"))


@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_loop_module_interface(robot, loop_dir):
    _, m = _generated(robot, loop_dir)
    assert tuple(m.COORDINATES) == COORDINATES[robot]
    assert tuple(m.INDEPENDENT_COORDINATES) == ("q1",)
    assert tuple(m.EFFORTS) == ("tau1",)
    n, k = len(COORDINATES[robot]), len(COORDINATES[robot]) - 1
    q, qd, u = states(robot, n=1)[0]
    assert m.loop_constraints(q).shape == (k,)
    assert m.loop_jacobian(q).shape == (k, n)
    assert m.loop_jacobian_dot(q, qd).shape == (k, n)
    assert m.loop_forces(q, qd, u).shape == (k,)
    assert m.forward_dynamics(q, qd, u).shape == (n,)
    # batches
    qs = np.stack([s[0] for s in states(robot)])
    qds = np.stack([s[1] for s in states(robot)])
    us = np.stack([s[2] for s in states(robot)])
    assert m.loop_jacobian(qs).shape == (N_STATES, k, n)
    batch = m.forward_dynamics(qs, qds, us)
    assert batch.shape == (N_STATES, n)
    np.testing.assert_allclose(batch, np.stack([m.forward_dynamics(*s) for s in zip(qs, qds, us, strict=True)]),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_assemble_matches_closed_form(robot, loop_dir):
    _, m = _generated(robot, loop_dir)
    values = defaults(robot)
    rng = np.random.default_rng(5)
    for q1 in np.linspace(-3.0, 3.0, 7):
        q, _ = closed_form(robot, q1, 0.0, values)
        guess = q + np.r_[0.0, rng.uniform(-0.05, 0.05, len(q) - 1)]
        assembled = m.assemble(guess)
        np.testing.assert_allclose(assembled[0], guess[0], rtol=0, atol=1e-14)  # independent kept
        angle_close(robot, assembled, q, atol=1e-9)
        np.testing.assert_allclose(m.loop_constraints(assembled), 0.0, atol=1e-10)


@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_loop_constraints_and_jacobian_at_closed_forms(robot, loop_dir):
    _, m = _generated(robot, loop_dir)
    values = defaults(robot)
    for q1 in np.linspace(-np.pi, np.pi, 13):
        q, qd = closed_form(robot, q1, 1.7, values)
        np.testing.assert_allclose(m.loop_constraints(q), 0.0, atol=1e-12)
        A = m.loop_jacobian(q)
        np.testing.assert_allclose(A @ qd, 0.0, atol=1e-11)
        assert np.linalg.matrix_rank(A, tol=1e-8) == len(q) - 1
    if robot == "spatial_four_bar":
        np.testing.assert_allclose(m.loop_constraints(np.zeros(4)), 0.0, atol=1e-15)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_loop_jacobian_matches_pinocchio(robot, loop_dir):
    """Same constraint manifold: A_g and J have the same row space, also off the manifold; the
    drift agrees on admissible accelerations (A qdd + Adot qd = 0 at the reference qdd)."""
    pytest.importorskip("pinocchio")
    _, m = _generated(robot, loop_dir)
    ref = reference(robot)
    for q, qd, u in states(robot, seed=6):
        A, J = m.loop_jacobian(q), ref.jacobian(q)
        assert np.linalg.matrix_rank(np.vstack([A, J]), tol=1e-8) == ref.k
        qdd, _ = ref.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(A @ qdd + m.loop_jacobian_dot(q, qd) @ qd, 0.0, atol=1e-9)
        # Adot is the time derivative of A
        h = 1e-6
        numeric = (m.loop_jacobian(q + h * qd) - m.loop_jacobian(q - h * qd)) / (2 * h)
        np.testing.assert_allclose(m.loop_jacobian_dot(q, qd), numeric, atol=1e-7)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_open_tree_matches_pinocchio(robot, loop_dir):
    pytest.importorskip("pinocchio")
    _, m = _generated(robot, loop_dir)
    ref = reference(robot)
    for q, qd, _ in states(robot, seed=7):
        np.testing.assert_allclose(m.mass_matrix(q), ref.mass(q), **TOL)
        np.testing.assert_allclose(m.coriolis_matrix(q, qd) @ qd + m.gravity_vector(q), ref.bias(q, qd), **TOL)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_forward_dynamics_matches_pinocchio(robot, loop_dir):
    pytest.importorskip("pinocchio")
    _, m = _generated(robot, loop_dir)
    ref = reference(robot)
    for q, qd, u in states(robot, seed=8):
        qdd, _ = ref.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(m.forward_dynamics(q, qd, u), qdd, **TOL)
        np.testing.assert_allclose(m.forward_dynamics(q, qd, u, alpha=10.0, beta=10.0), qdd, **TOL)
    q, qd, _ = states(robot, seed=8)[0]
    np.testing.assert_allclose(m.forward_dynamics(q, qd), ref.forward_dynamics(q, qd)[0], **TOL)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_loop_forces_match_pinocchio(robot, loop_dir):
    pytest.importorskip("pinocchio")
    _, m = _generated(robot, loop_dir)
    ref = reference(robot)
    for q, qd, u in states(robot, seed=9):
        _, force = ref.forward_dynamics(q, qd, u)
        lam = m.loop_forces(q, qd, u)
        np.testing.assert_allclose(m.loop_jacobian(q).T @ lam, force, **TOL)
        # and the contract's equation with dynderive's own accelerations
        qdd = m.forward_dynamics(q, qd, u)
        residual = m.inverse_dynamics(q, qd, qdd) - ref.generalized_forces(u) - m.loop_jacobian(q).T @ lam
        np.testing.assert_allclose(residual, 0.0, atol=1e-9)


@pytest.mark.pinocchio
@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_integration_conserves_energy(robot, loop_dir):
    pytest.importorskip("pinocchio")
    _, m = _generated(robot, loop_dir)
    ref = reference(robot)
    q0, qd0 = closed_form(robot, 0.4, 2.0, defaults(robot))

    def energy(q, qd):
        return float(m.kinetic_energy(q, qd) + m.potential_energy(q))

    e, a, end = _integrate(lambda q, qd: m.forward_dynamics(q, qd, alpha=10.0, beta=10.0),
                           energy, m.loop_constraints, q0, qd0)
    assert np.ptp(e) < 1e-6 * max(1.0, np.abs(e).max())
    assert a < 1e-7
    # the same trajectory as the reference
    _, _, ref_end = _integrate(lambda q, qd: ref.forward_dynamics(q, qd, alpha=10.0, beta=10.0)[0],
                               ref.energy, ref.constraints, q0, qd0)
    np.testing.assert_allclose(end, ref_end, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_dynderive_reduced_form(robot, loop_dir):
    """M_r = R^T M R and EOM_r = 0 at the reference accelerations (when the derivation has them)."""
    import sympy

    derivation, m = _generated(robot, loop_dir)
    keys = derivation.keys()
    if "M_r" not in keys:
        pytest.skip("no reduced form in the derivation")
    values = defaults(robot)
    for q, qd, u in states(robot, seed=10, n=3):
        R = closed_form(robot, q[0], 1.0, values)[1].reshape(-1, 1)
        qdd = m.forward_dynamics(q, qd, u)
        numbers = dict(values, tau1=float(u[0]))
        for i, name in enumerate(COORDINATES[robot]):
            stem, digits = name.rstrip("0123456789"), name[len(name.rstrip("0123456789")):]
            numbers.update({name: q[i], f"{stem}d{digits}": qd[i], f"{stem}dd{digits}": qdd[i]})

        def evaluate(expr, numbers=numbers):
            subs = {s: numbers[s.name] for s in expr.free_symbols if s.name in numbers}
            value = sympy.Matrix(expr).xreplace({k: sympy.Float(v) for k, v in subs.items()}).evalf()
            leftover = value.free_symbols
            if leftover:
                pytest.skip(f"symbols this test cannot fill in: {sorted(map(str, leftover))}")
            return np.array(value.tolist(), dtype=float)

        np.testing.assert_allclose(evaluate(derivation["M_r"]), R.T @ m.mass_matrix(q) @ R, rtol=1e-9, atol=1e-9)
        if "EOM_r" in keys:
            np.testing.assert_allclose(evaluate(derivation["EOM_r"]), 0.0, atol=1e-8)


#: loop types the bundled robots do not use, checked on variants of their files
VARIANTS = {
    "planar-prismatic": ("four_bar", "    type: revolute\n    parent: coupler",
                         "    type: prismatic\n    axis: [1, 1]\n    parent: coupler"),
    "spatial-revolute": ("spatial_four_bar", "type: spherical", "type: revolute\n    axis: [1, 0, 1]"),
    "spatial-prismatic": ("spatial_four_bar", "type: spherical", "type: prismatic\n    axis: [0, 1, 2]"),
}


@pytest.mark.pinocchio
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_reference_other_loop_types_by_finite_differences(variant, tmp_path):
    """The rows of prismatic and 3-D revolute loops: J = da/dq and Jdot qd = d(J)/dt qd."""
    pytest.importorskip("pinocchio")
    from loop_references import Reference

    robot, old, new = VARIANTS[variant]
    text = (ROBOTS / f"{robot}.yaml").read_text()
    assert old in text
    path = tmp_path / f"{robot}.yaml"
    path.write_text(text.replace(old, new))
    ref = Reference(path)
    assert ref.k == {"planar-prismatic": 2, "spatial-revolute": 5, "spatial-prismatic": 5}[variant]
    rng = np.random.default_rng(11)
    h = 1e-6
    for _ in range(3):
        q, qd = rng.uniform(-1.5, 1.5, ref.n), rng.uniform(-1.5, 1.5, ref.n)
        numeric = np.column_stack([(ref.constraints(q + h * e) - ref.constraints(q - h * e)) / (2 * h)
                                   for e in np.eye(ref.n)])
        np.testing.assert_allclose(ref.jacobian(q), numeric, atol=1e-8)
        jdot_qd = (ref.jacobian(q + h * qd) - ref.jacobian(q - h * qd)) / (2 * h) @ qd
        np.testing.assert_allclose(ref.drift(q, qd), jdot_qd, atol=1e-7)
