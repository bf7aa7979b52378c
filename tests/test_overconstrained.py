"""Over-constrained loops (issue 26, item 1): the Bennett linkage of ``robots/bennett.yaml``.

Its 3-D revolute loop joint gives 5 loop rows of rank 2 on the constraints (mobility 1), and
which rows are implied by the others changes with the configuration. The generated module
(derived once per session) is compared with references that share no code with dynderive
(``tests/overconstrained_references.py``): Bennett's closed form (q3 = -q1 and
tan(q1/2) tan(q2/2) = sin((beta + alpha)/2) / sin((beta - alpha)/2)), a Pinocchio open tree
and a sympy.physics.mechanics model, both with ALL five loop rows and their KKT system solved
by least squares. The named state of the issue is the folded configuration q = (0, pi, 0)
(also written (0, -pi, 0)) with qd1 = 1.3, qd3 = -1.3 and u = -1.9254673312495403.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from loop_references import read_robot, reference, wrap
from overconstrained_references import (
    ALPHA,
    BENNETT,
    BETA,
    MechanicsReference,
    closed_form,
    closed_form_residual,
    kkt_least_squares,
    pinocchio_dynamics,
)

from conftest import derivation_of

TOL = {"rtol": 1e-9, "atol": 1e-9}
U_NAMED = -1.9254673312495403
N_RANDOM = 10


@pytest.fixture(scope="module")
def bennett(generated):
    return generated("bennett")


@pytest.fixture(scope="module")
def mechanics():
    return MechanicsReference(BENNETT)


def named_states() -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The folded configuration of the issue, written with q2 = pi and with q2 = -pi."""
    _, qd = closed_form(0.0, 1.3)
    assert qd[0] == 1.3 and qd[2] == -1.3
    u = np.array([U_NAMED])
    return [(np.array([0.0, np.pi, 0.0]), qd, u), (np.array([0.0, -np.pi, 0.0]), qd, u)]


def random_states(module, seed: int, n: int = N_RANDOM) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """[(q, qd, u)]: q assembled by the generated ``assemble`` from a guess near the closed form
    at a random crank angle, qd a random vector projected onto the null space of all five rows
    (from the closed form: dq/dq1, checked against both references), a random effort."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q1 = rng.uniform(-np.pi, np.pi)
        exact, tangent = closed_form(q1, 1.0)
        guess = exact + np.r_[0.0, rng.uniform(-0.05, 0.05, 2)]
        q = module.assemble(guess)
        np.testing.assert_allclose(wrap(q - exact), 0.0, atol=1e-9)
        out.append((q, rng.uniform(-3.0, 3.0) * tangent, rng.uniform(-2.0, 2.0, 1)))
    return out


def all_states(module, seed: int):
    return named_states() + random_states(module, seed)


def least_norm(A: np.ndarray, force: np.ndarray, rank: int = 2) -> np.ndarray:
    """The multipliers of least norm with A^T lambda = force (A of rank ``rank``)."""
    U, s, Vt = np.linalg.svd(A)
    return U[:, :rank] @ ((Vt[:rank] @ force) / s[:rank])


# =========================================================================================
# The references on their own
# =========================================================================================


def test_reference_file_is_a_bennett_linkage():
    """The twists the closed form uses are the file's, and Bennett's condition holds."""
    robot = read_robot(BENNETT)
    a = robot.values["a"]
    joints = {j["name"]: j for j in robot.joints}
    loop = robot.loops[0]
    twist = {name: np.arctan2(rotation[2, 1], rotation[1, 1])
             for name, (rotation, _) in [("q2", joints["q2"]["origin"]), ("q3", joints["q3"]["origin"]),
                                         ("ground", loop["origin"]), ("link3", loop["child_origin"])]}
    np.testing.assert_allclose([twist["q2"], twist["link3"], twist["q3"], -twist["ground"]],
                               [ALPHA, ALPHA, BETA, BETA], atol=1e-15)
    b = joints["q3"]["origin"][1][0]
    np.testing.assert_allclose([joints["q2"]["origin"][1][0], loop["child_origin"][1][0], -loop["origin"][1][0]],
                               [a, a, b], rtol=1e-15)
    np.testing.assert_allclose(a / np.sin(ALPHA), b / np.sin(BETA), rtol=1e-15)   # Bennett's condition
    assert closed_form_residual(1.0, 2.0) != 0.0


def test_reference_closed_form_closes_every_mechanics_row(mechanics):
    for q1 in np.r_[np.linspace(-np.pi, np.pi, 13)[1:-1], 1e-9, -1e-9]:
        q, qd = closed_form(q1, 1.3)
        assert abs(closed_form_residual(q[0], q[1])) < 1e-15
        np.testing.assert_allclose(mechanics.constraints(q), 0.0, atol=1e-14)
        J = mechanics.jacobian(q)
        np.testing.assert_allclose(J @ qd, 0.0, atol=1e-14)
        assert np.linalg.matrix_rank(J, tol=1e-8) == 2
        h = 1e-6      # qd is the derivative of the curve
        numeric = wrap(closed_form(q1 + h)[0] - closed_form(q1 - h)[0]) / (2 * h)
        np.testing.assert_allclose(1.3 * numeric, qd, atol=1e-7)
    q, _ = closed_form(0.0)
    np.testing.assert_allclose(q, [0.0, np.pi, 0.0], atol=1e-15)    # the folded configuration


@pytest.mark.pinocchio
def test_reference_mechanics_agrees_with_pinocchio(mechanics):
    pytest.importorskip("pinocchio")
    ref = reference("bennett")
    assert ref.k == mechanics.k == 5
    rng = np.random.default_rng(20)
    for _ in range(4):       # the open tree and the rows' span, anywhere
        q, qd = rng.uniform(-3.0, 3.0, 3), rng.uniform(-2.0, 2.0, 3)
        M, f, J, _ = mechanics.system(q, qd, np.zeros(1))
        np.testing.assert_allclose(M, ref.mass(q), **TOL)
        np.testing.assert_allclose(-f, ref.bias(q, qd), **TOL)
        np.testing.assert_allclose(np.linalg.svd(J)[1], np.linalg.svd(ref.jacobian(q))[1], **TOL)
    for q1 in (0.0, 0.7, -2.3, 3.0):
        q, qd = closed_form(q1, 1.3)
        np.testing.assert_allclose(ref.constraints(q), 0.0, atol=1e-14)
        qdd, force = mechanics.forward_dynamics(q, qd, [U_NAMED])
        ref_qdd, ref_force = pinocchio_dynamics(ref, q, qd, [U_NAMED])
        np.testing.assert_allclose(qdd, ref_qdd, **TOL)
        np.testing.assert_allclose(force, ref_force, **TOL)
        # along the curve: qdd = (dq/dq1) qdd1 + d(dq/dq1)/dq1 qd1^2
        h = 1e-5
        bend = (closed_form(q1 + h, 1.3)[1] - closed_form(q1 - h, 1.3)[1]) / (2 * h)
        np.testing.assert_allclose(qdd, qd / 1.3 * qdd[0] + bend * 1.3, rtol=1e-6, atol=1e-6)


def test_reference_least_squares_kkt_refuses_an_inconsistent_system():
    M, J = np.eye(2), np.array([[1.0, 0.0], [2.0, 0.0]])
    np.testing.assert_allclose(kkt_least_squares(M, np.array([1.0, 2.0]), J, np.array([3.0, 6.0])), [3.0, 2.0])
    with pytest.raises(AssertionError, match="inconsistent"):
        kkt_least_squares(M, np.array([1.0, 2.0]), J, np.array([3.0, 5.0]))


# =========================================================================================
# dynderive against the references
# =========================================================================================


def test_assemble_from_random_guesses(bennett):
    """From 30 random guesses (q1 anywhere, q2 and q3 random), ``assemble`` closes every row,
    keeps q1 and lands on Bennett's curve, or raises ValueError. An assembly exists for every
    q1 here, so each ValueError is Newton's iteration stalling at a local minimum of the
    residual; with a guess near the curve every one of these q1 assembles."""
    rng = np.random.default_rng(26)
    converged = 0
    for _ in range(30):
        guess = rng.uniform(-np.pi, np.pi, 3)
        try:
            q = bennett.assemble(guess)
        except ValueError:
            near = closed_form(guess[0])[0] + np.r_[0.0, rng.uniform(-0.1, 0.1, 2)]
            q = bennett.assemble(near)
        else:
            converged += 1
        assert q[0] == guess[0]
        np.testing.assert_allclose(bennett.loop_constraints(q), 0.0, atol=1e-9)
        np.testing.assert_allclose(wrap(q[2] + q[0]), 0.0, atol=1e-9)
        assert abs(closed_form_residual(q[0], q[1])) < 1e-9
        np.testing.assert_allclose(wrap(q - closed_form(q[0])[0]), 0.0, atol=1e-9)
    assert converged >= 15, f"only {converged} of 30 random guesses assembled"


def test_rows_have_rank_2_and_the_references_row_space(bennett, mechanics):
    for q, qd, _ in all_states(bennett, seed=21):
        A = bennett.loop_jacobian(q)
        assert A.shape == (5, 3)
        singular = np.linalg.svd(A)[1]
        assert singular[1] > 1e-2 and singular[2] < 1e-12, singular
        J = mechanics.jacobian(q)
        assert np.linalg.matrix_rank(np.vstack([A, J]), tol=1e-8) == 2
        np.testing.assert_allclose(bennett.loop_constraints(q), 0.0, atol=1e-12)
        np.testing.assert_allclose(A @ qd, 0.0, atol=1e-12)
        basis = bennett.reduced_basis(q)
        np.testing.assert_allclose(A @ basis, 0.0, atol=1e-12)
        np.testing.assert_allclose(basis[:, 0], closed_form(q[0], 1.0)[1], **TOL)


def _compare(bennett, states, dynamics):
    for q, qd, u in states:
        qdd_ref, force_ref = dynamics(q, qd, u)
        qdd = bennett.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(qdd, qdd_ref, **TOL)
        np.testing.assert_allclose(qdd[0] + qdd[2], 0.0, atol=1e-9)     # q3 = -q1 on this branch
        np.testing.assert_allclose(bennett.reduced_forward_dynamics(q, qd, u), qdd_ref, **TOL)
        np.testing.assert_allclose(bennett.forward_dynamics(q, qd, u, alpha=7.0, beta=7.0), qdd_ref, **TOL)
        A = bennett.loop_jacobian(q)
        lam = bennett.loop_forces(q, qd, u)
        np.testing.assert_allclose(A.T @ lam, force_ref, **TOL)
        # least norm: orthogonal to the null space of A^T (the last 3 left singular vectors)
        left = np.linalg.svd(A)[0][:, 2:]
        np.testing.assert_allclose(left.T @ lam, 0.0, atol=1e-9)
        np.testing.assert_allclose(lam, least_norm(A, force_ref), **TOL)


@pytest.mark.pinocchio
def test_forward_dynamics_and_loop_forces_match_pinocchio(bennett):
    pytest.importorskip("pinocchio")
    ref = reference("bennett")
    for q, qd, _ in all_states(bennett, seed=22):
        np.testing.assert_allclose(bennett.mass_matrix(q), ref.mass(q), **TOL)
        np.testing.assert_allclose(ref.jacobian(q) @ qd, 0.0, atol=1e-12)
    _compare(bennett, all_states(bennett, seed=22), lambda q, qd, u: pinocchio_dynamics(ref, q, qd, u))


def test_forward_dynamics_and_loop_forces_match_mechanics(bennett, mechanics):
    for q, qd, u in named_states():
        qdd, _ = mechanics.forward_dynamics(q, qd, u)
        # the folded state of the issue: qdd1 + qdd3 = 0 in the reference too
        np.testing.assert_allclose(qdd[0] + qdd[2], 0.0, atol=1e-9)
    _compare(bennett, all_states(bennett, seed=23), mechanics.forward_dynamics)


# =========================================================================================
# Properties
# =========================================================================================


def test_dynderive_check_passes():
    from dynderive import render_code
    from dynderive.verify.checks import run_checks

    derivation = derivation_of("bennett")
    rows = run_checks(derivation, render_code(derivation))
    statuses = {row.name: row.status for row in rows}
    assert "FAIL" not in statuses.values(), [r for r in rows if r.status == "FAIL"]
    assert [s for name, s in statuses.items() if name.startswith("loop constraints a_g = 0 at")] == ["pass"]
    assert statuses["A_g qd = 0 for the velocities the loops allow"] == "pass"
    assert [s for name, s in statuses.items() if name.startswith("power balance")] == ["pass"]


def _energy(module, q, qd):
    return float(module.kinetic_energy(q, qd) + module.potential_energy(q))


def test_energy_conserved_without_effort(bennett):
    """Through the folded configuration (q1 = 0): 10 steps of 0.05 s, after each q put back
    on the constraints by ``assemble`` and qd onto the null space of all five rows."""
    from scipy.integrate import solve_ivp

    q, qd = closed_form(-0.3, 2.0)
    energy = [_energy(bennett, q, qd)]
    drift, angles = 0.0, [q[0]]

    def rhs(_t, x):
        return np.r_[x[3:], bennett.forward_dynamics(x[:3], x[3:])]

    for _ in range(10):
        sol = solve_ivp(rhs, (0.0, 0.05), np.r_[q, qd], method="DOP853", rtol=1e-12, atol=1e-12)
        assert sol.success
        end = sol.y[:, -1]
        drift = max(drift, float(np.max(np.abs(bennett.loop_constraints(end[:3])))))
        angles += list(sol.y[0])
        q = bennett.assemble(end[:3])
        null = np.linalg.svd(bennett.loop_jacobian(q))[2][2]
        qd = null * (null @ end[3:])
        energy.append(_energy(bennett, q, qd))
    assert min(angles) < 0.0 < max(angles)
    assert drift < 1e-8
    assert np.ptp(energy) < 1e-8 * max(1.0, np.max(np.abs(energy)))
    np.testing.assert_allclose(wrap(q - closed_form(q[0])[0]), 0.0, atol=1e-12)


@pytest.mark.parametrize("which", ["folded", "random"])
def test_linearize_matches_central_differences(bennett, which):
    q, qd, u = named_states()[0] if which == "folded" else random_states(bennett, seed=24, n=1)[0]
    A, B = bennett.linearize(q, qd, u)
    x, h = np.r_[q, qd], 1e-6

    def accel(x, u=u):
        return bennett.forward_dynamics(x[:3], x[3:], u)

    numeric = np.column_stack([(accel(x + h * e) - accel(x - h * e)) / (2 * h) for e in np.eye(6)])
    scale = max(1.0, np.max(np.abs(numeric)))
    np.testing.assert_allclose(A[3:], numeric, atol=1e-6 * scale)
    np.testing.assert_allclose(A[:3], np.c_[np.zeros((3, 3)), np.eye(3)])
    by_effort = (accel(x, u + h) - accel(x, u - h)) / (2 * h)
    np.testing.assert_allclose(B[3:, 0], by_effort, atol=1e-6 * scale)


# =========================================================================================
# Mobility in the outputs
# =========================================================================================


def test_outputs_report_mobility():
    from dynderive import render_json, render_latex
    from dynderive.render.sheets.terminal import render_terminal

    derivation = derivation_of("bennett")
    first = render_terminal(derivation).splitlines()[0]
    assert "1 DOF" in first and "5 loop constraints of rank 2" in first, first
    document = json.loads(render_json(derivation))
    assert document["degrees_of_freedom"] == 1
    assert document["loops"]["constraint_rows"] == 5 and document["loops"]["independent_constraints"] == 2
    assert document["loops"]["independent_coordinates"] == ["q1"]
    sheet = " ".join(render_latex(derivation).split())
    assert "add 5 constraints, of which 2 are independent (the mechanism is over-constrained)" in sheet
    assert "so it has 1 degree of freedom" in sheet


def test_four_bar_reports_two_independent_constraints():
    """The command line's terminal summary, and the JSON (of the cached derivation)."""
    from typer.testing import CliRunner

    from dynderive import render_json
    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["solve", "four_bar", "-q"])
    assert result.exit_code == 0, result.output
    first = result.stdout.splitlines()[0]
    assert "1 DOF" in first and "2 independent loop constraints" in first, first
    document = json.loads(render_json(derivation_of("four_bar")))
    assert document["degrees_of_freedom"] == 1
    assert document["loops"]["constraint_rows"] == 2 and document["loops"]["independent_constraints"] == 2
