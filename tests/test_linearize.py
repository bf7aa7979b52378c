"""Linearization: ``dynderive linearize`` and the generated ``linearize``.

The closed form of the cart-pole about upright against the textbook's (a uniform pole of
length L on a cart: theta'' = 6 g (M + m) theta / (L (4 M + m)) + ...), the generated function
against central differences of ``forward_dynamics`` on random planar and 3-D robots and a
robot with drives, and against Pinocchio's ``computeABADerivatives``.

Floating base: the module's Coriolis matrix, linearization and regressor against Pinocchio with
a ``JointModelFreeFlyer`` root (computeCoriolisMatrix, computeABADerivatives,
computeJointTorqueRegressor) to 1e-9, and against their own properties: C qd is the bias,
dM/dt - 2 C is skew-symmetric, A and B equal central differences through ``integrate``,
regressor @ parameter_vector equals inverse dynamics. ``test_free_flyer``'s helpers need
Pinocchio, so its tests import them.

Floating-base robots: A and B on the tangent space equal Pinocchio's ``computeABADerivatives``
through the command line, a configuration off the unit sphere is normalized with a note (a zero
quaternion refused), and the LaTeX document says so and compiles.
"""

from __future__ import annotations

import json
import random
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.input.urdf import identifier

from conftest import ROOT, floating_module_source, import_code, text_derivation
from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

runner = CliRunner()


def _finite_differences(module, q, qd, u, **keywords):
    n, h = len(q), 1e-6
    x = np.concatenate([q, qd])

    def f(state, effort):
        return np.concatenate([state[n:], module.forward_dynamics(state[:n], state[n:], effort, **keywords)])

    A = np.array([(f(x + h * e, u) - f(x - h * e, u)) / (2 * h) for e in np.eye(2 * n)]).T
    B = np.array([(f(x, u + h * e) - f(x, u - h * e)) / (2 * h)
                  for e in np.eye(len(u))]).T.reshape(2 * n, len(u))
    return A, B


def test_cart_pole_about_upright_is_the_textbook_one():
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", "q=0,0", "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document["method"] == "symbolic" and document["agreement"] < 1e-12
    mc, mp, lp, g = sympy.symbols("mc mp lp g")
    names = {"mc": mc, "mp": mp, "lp": lp, "g": g}
    A = sympy.sympify(document["A"]["sympy"], locals=names)
    B = sympy.sympify(document["B"]["sympy"], locals=names)
    # theta turns counterclockwise from the upward vertical (the pole tips towards -x), so the
    # couplings have the opposite signs of the textbook's theta measured towards +x
    expected_A = sympy.Matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                               [0, 3 * g * mp / (4 * mc + mp), 0, 0],
                               [0, 6 * g * (mc + mp) / (lp * (4 * mc + mp)), 0, 0]])
    expected_B = sympy.Matrix([0, 0, 4 / (4 * mc + mp), 6 / (lp * (4 * mc + mp))])
    assert sympy.simplify(A - expected_A) == sympy.zeros(4, 4)
    assert sympy.simplify(B - expected_B) == sympy.zeros(4, 1)
    numbers = np.array(document["A_numeric"])
    assert numbers[3, 1] == pytest.approx(6 * 9.81 * 1.1 / 4.1)   # upright is unstable
    hanging = json.loads(runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=pi", "--json",
                                             "-q"]).stdout)
    assert np.array(hanging["A_numeric"])[3, 1] == pytest.approx(-6 * 9.81 * 1.1 / 4.1)   # hanging is stable


HOSTILE = '\x1b[2J\x1b]0;owned\x07 """\\ $x$ \\end{document} %{}#&_^~ \u2603\u202e'


def test_hostile_titles_are_encoded_in_every_output(tmp_path):
    """A title with terminal escapes, quotes, LaTeX commands and bidi controls reaches the
    terminal with its control characters escaped and the LaTeX document escaped."""
    text = (ROOT / "robots" / "cart_pole.yaml").read_text().replace("title: Cart-pole",
                                                                    f"title: {json.dumps(HOSTILE)}")
    path = tmp_path / "hostile.yaml"
    path.write_text(text)
    terminal = runner.invoke(app, ["linearize", str(path), "-q"])
    assert terminal.exit_code == 0, terminal.output
    assert "\x1b" not in terminal.stdout and "\x07" not in terminal.stdout and "\u202e" not in terminal.stdout
    latex = runner.invoke(app, ["linearize", str(path), "--latex", "-q"])
    assert latex.exit_code == 0, latex.output
    assert r"\end{document}" in latex.stdout and latex.stdout.count(r"\end{document}") == 1
    assert "\x1b" not in latex.stdout and "$x$" not in latex.stdout
    document = json.loads(runner.invoke(app, ["linearize", str(path), "--json", "-q"]).stdout)
    assert document["robot"] == "cart_pole"


def test_terminal_and_latex_outputs(tmp_path):
    text = runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=pi/2,F=1", "-q"])
    assert text.exit_code == 0, text.output
    assert "A =" in text.stdout and "agree to" in text.stdout
    latex = runner.invoke(app, ["linearize", "rp_arm", "--at", "q=0.3,0.2", "--latex", "-q"])
    assert latex.exit_code == 0, latex.output
    assert r"\begin{document}" in latex.stdout and "A = " in latex.stdout
    if shutil.which("pdflatex"):
        (tmp_path / "lin.tex").write_text(latex.stdout)
        run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-no-shell-escape", "lin.tex"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stdout[-2000:]


@pytest.mark.parametrize("at, message", [
    ("q=0", "--at:1:1: q: expected 2 values, got 1"),
    ("speed=1", "--at:1:1: unknown name 'speed'"),
    ("1,2", "--at:1:1: expected KEY=VALUE"),
    ("theta=sqrt(-1)", "--at:1:1: theta:"),
])
def test_bad_operating_points_are_refused(at, message):
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", at, "-q"])
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output


def test_closed_loops_are_linearized_on_their_constraints(generated):
    """The command puts the state on the loops (independent coordinates kept); the generated
    function is the tangent of the constrained accelerations (central differences of
    ``forward_dynamics`` with alpha = beta = 0)."""
    result = runner.invoke(app, ["linearize", "four_bar", "--at", "q1=0.5,q2=1", "--json"])
    assert result.exit_code == 0, result.output
    assert "note: q2 = " in result.stderr and "follows from the loops" in result.stderr
    document = json.loads(result.stdout)
    assert document["method"] == "numeric" and document["state"]["q"][0] == 0.5
    module = generated("four_bar")
    np.testing.assert_allclose(module.loop_constraints(document["state"]["q"]), 0, atol=1e-10)
    for name in ("four_bar", "slider_crank", "spatial_four_bar"):
        module = generated(name)
        n = len(module.COORDINATES)
        rng = np.random.default_rng(4)
        guess = np.array(module.ASSEMBLED_CONFIGURATION) + rng.uniform(-0.2, 0.2, n)
        q = module.assemble(guess)
        qd = module.reduced_basis(q) @ rng.uniform(-1, 1, len(module.INDEPENDENT_COORDINATES))
        u = rng.uniform(-1, 1, len(module.EFFORTS))
        A, B = module.linearize(q, qd, u)
        A_fd, B_fd = _finite_differences(module, q, qd, u)
        scale = max(1.0, float(np.max(np.abs(A))))
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * scale)
        np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6 * scale)


CASES = [("planar", 1, 3), ("planar", 2, 5), ("spatial", 3, 4), ("spatial", 5, 6)]


def _module(kind, seed, n, directory):
    rng = random.Random(seed)
    tree = random_planar_tree(rng, n) if kind == "planar" else random_spatial_tree(rng, n)
    return text_derivation(f"lin_{kind}_{seed}_{n}", tree.yaml_text, directory)


@pytest.fixture(scope="module")
def directory(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("linearize"))


@pytest.mark.parametrize("kind, seed, n", CASES)
def test_generated_linearize_matches_finite_differences(kind, seed, n, directory):
    _, module = _module(kind, seed, n, directory)
    rng = np.random.default_rng(seed)
    q, qd, u = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, len(module.EFFORTS))
    A, B = module.linearize(q, qd, u)
    A_fd, B_fd = _finite_differences(module, q, qd, u)
    scale = max(1.0, float(np.max(np.abs(A))))
    np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * scale)
    np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6)
    batch_A, batch_B = module.linearize(np.array([q, -q]), np.array([qd, qd]), u)
    assert batch_A.shape == (2, 2 * n, 2 * n) and batch_B.shape == (2, 2 * n, len(module.EFFORTS))
    np.testing.assert_allclose(batch_A[0], A, rtol=1e-12, atol=1e-12)


def test_linearize_with_drives_and_smoothed_friction(generated):
    module = generated("cart_pole_damped")
    q, qd, u = np.array([0.2, 0.4]), np.array([0.3, -0.7]), np.array([0.5])
    for smoothing in (0.0, 0.05):
        A, B = module.linearize(q, qd, u, friction_smoothing=smoothing)
        A_fd, B_fd = _finite_differences(module, q, qd, u, friction_smoothing=smoothing)
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-6)


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, seed, n", CASES)
def test_generated_linearize_matches_pinocchio(kind, seed, n, directory):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    derivation, module = _module(kind, seed, n, directory)
    model, perm = pinocchio_model(derivation.robot, {})
    data = model.createData()
    rng = np.random.default_rng(seed + 100)
    for _ in range(3):
        q, qd, u = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, len(module.EFFORTS))
        A, B = module.linearize(q, qd, u)
        tau = module.generalized_forces(q, u)
        pin.computeABADerivatives(model, data, q[perm], qd[perm], tau[perm])
        np.testing.assert_allclose(A[n:, :n][np.ix_(perm, perm)], data.ddq_dq, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(A[n:, n:][np.ix_(perm, perm)], data.ddq_dv, rtol=1e-8, atol=1e-8)
        inverse = np.asarray(data.Minv)
        inverse = np.triu(inverse) + np.triu(inverse, 1).T
        effort_map = module.generalized_forces(np.zeros(n), np.eye(len(module.EFFORTS))).T
        np.testing.assert_allclose(B[n:][perm], inverse @ effort_map[perm], rtol=1e-8, atol=1e-8)


# -- floating base: Coriolis matrix, linearization and regressor against Pinocchio's free flyer ----

def _states(robot, model, qp, vp, seed: int, count: int = 3):
    """Random states in our order (q from Pinocchio's randomConfiguration: unit quaternions)."""
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    pin.seed(seed)
    for _ in range(count):
        q, v, a = np.empty(model.nq), np.empty(model.nv), np.empty(model.nv)
        q[qp] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v[vp], a[vp] = rng.normal(size=model.nv), rng.normal(size=model.nv)
        yield q, v, a, rng.normal(size=len(robot.efforts))


def _check(robot, module, model, qp, vp, seed: int) -> None:
    import pinocchio as pin

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
        Mdot = (module.mass_matrix(module.integrate(q, v, h))
                - module.mass_matrix(module.integrate(q, v, -h))) / (2 * h)
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
        np.testing.assert_allclose(B[nv:][vp], Minv[:, [order.index(c) for c in module.EFFORT_COLUMNS]],
                                   rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(Minv))))
        h = 1e-6
        for k in range(nv):
            step = np.zeros(nv)
            step[k] = h
            by_q = (module.forward_dynamics(module.integrate(q, step), v, u)
                    - module.forward_dynamics(module.integrate(q, -step), v, u)) / (2 * h)
            by_v = (module.forward_dynamics(q, v + step, u)
                    - module.forward_dynamics(q, v - step, u)) / (2 * h)
            np.testing.assert_allclose(A[nv:, k], by_q, rtol=0, atol=1e-5 * scale)
            np.testing.assert_allclose(A[nv:, nv + k], by_v, rtol=0, atol=1e-5 * scale)
        # regressor
        Y = module.regressor(q, v, a)
        tau = module.inverse_dynamics(q, v, a)
        np.testing.assert_allclose(Y @ module.parameter_vector(), tau, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(tau))))
    # a batch gives each state's result
    Q, V = np.stack([q, module.neutral_configuration()]), np.stack([v, -v])
    np.testing.assert_allclose(module.coriolis_matrix(Q, V)[0], module.coriolis_matrix(q, v),
                               rtol=1e-12, atol=1e-12)
    A2, B2 = module.linearize(Q, V, np.stack([u, u]))
    np.testing.assert_allclose(A2[0], A, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(B2[0], B, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(module.regressor(Q, V, np.stack([a, a]))[0], Y, rtol=1e-12, atol=1e-12)


def _joint_regressor(robot, module, model, qp, vp, seed: int) -> None:
    """Where every link hangs from its own moving joint at the joint's frame, the regressor's
    columns are Pinocchio's computeJointTorqueRegressor's (ten per joint, its order)."""
    import pinocchio as pin

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
    pytest.importorskip("pinocchio")
    from test_free_flyer import _floating_tree, _pinocchio
    from test_free_flyer import _module as _numpy_module

    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(seed))
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    module = _numpy_module(robot, tmp_path)
    _check(robot, module, model, qp, vp, seed)
    if all(j.moves for j in robot.joints):
        _joint_regressor(robot, module, model, qp, vp, seed)


@pytest.mark.pinocchio
def test_box_regressor_columns_are_pinocchios(tmp_path):
    pytest.importorskip("pinocchio")
    from test_free_flyer import BOX, _pinocchio
    from test_free_flyer import _module as _numpy_module

    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    module = _numpy_module(robot, tmp_path)
    assert module.PARAMETER_VECTOR[:3] == ("m_base", "mcx_base", "mcy_base")
    assert len(module.PARAMETER_VECTOR) == 20
    assert tuple(p.name for p in dynderive.derive(robot).parameter_vector) == module.PARAMETER_VECTOR
    driven = BOX.replace("effort: tau2}", "effort: tau2, armature: 0.01, stiffness: 2, damping: 0.3}")
    path.write_text(driven)
    assert [p.name for p in dynderive.derive(dynderive.load_robot(path)).parameter_vector][-2:] == [
        "armature_q2", "stiffness_q2"]   # no damping column: damping is not in the floating dynamics
    (tmp_path / "driven").mkdir()
    springy = _numpy_module(dynderive.load_robot(path), tmp_path / "driven")
    q = springy.integrate(springy.neutral_configuration(), np.linspace(-1.0, 1.0, 7))
    v, a = np.linspace(0.5, -0.7, 7), np.linspace(-0.3, 0.9, 7)
    np.testing.assert_allclose(springy.regressor(q, v, a) @ springy.parameter_vector(),
                               springy.inverse_dynamics(q, v, a),
                               rtol=0, atol=1e-12)
    path.write_text(BOX)
    _check(robot, module, model, qp, vp, 3)
    _joint_regressor(robot, module, model, qp, vp, 3)


@pytest.mark.pinocchio
def test_solo12(tmp_path):
    pin = pytest.importorskip("pinocchio")
    from test_free_flyer import _example_robot

    path = _example_robot("solo_description/robots/solo12.urdf")
    robot = dynderive.load_robot(path, floating_base=True)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    module = import_code(floating_module_source("solo_description/robots/solo12.urdf"), tmp_path, "solo12_dynamics")
    _check(robot, module, model, np.array(qp), np.array(vp), 12)


@pytest.mark.pinocchio
def test_frame_jacobian_dot_qd_of_solo12_feet(tmp_path):
    """Pinocchio's classical acceleration of each foot frame at zero acceleration
    (LOCAL_WORLD_ALIGNED), and the frame's acceleration J qdd + Jdot qd against central
    differences of J qd along the motion."""
    pin = pytest.importorskip("pinocchio")
    from test_free_flyer import _example_robot

    path = _example_robot("solo_description/robots/solo12.urdf")
    robot = dynderive.load_robot(path, floating_base=True)
    module = import_code(floating_module_source("solo_description/robots/solo12.urdf"), tmp_path, "solo12_dynamics")
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
            np.testing.assert_allclose(bias, expected, rtol=0,
                                       atol=1e-10 * max(1.0, np.max(np.abs(expected))))
            ahead, behind = (module.frame_jacobian(module.integrate(q, v, s * h), frame) @ (v + s * h * a)
                             for s in (1, -1))
            np.testing.assert_allclose(module.frame_jacobian(q, frame) @ a + bias, (ahead - behind) / (2 * h),
                                       rtol=0,
                                       atol=1e-5 * max(1.0, np.max(np.abs(bias))))


# -- floating base --------------------------------------------------------------------------------
# test_free_flyer skips itself without Pinocchio: imported where its model of the floating
# elbow is needed, so that the rest of this file runs without it.

ELBOW = Path(__file__).parent / "floating_elbow.urdf"


def _pinocchio_order():
    """The floating elbow (a revolute shoulder, a free body below it) and Pinocchio's model of it."""
    from test_free_flyer import urdf_in_pinocchio

    return urdf_in_pinocchio(ELBOW)


def _at(names, values):
    return ",".join(f"{n}={float(v)!r}" for n, v in zip(names, values))


@pytest.mark.pinocchio
def test_linearize_equals_pinocchio_on_the_tangent_space():
    pin = pytest.importorskip("pinocchio")
    robot, model, qp, vp = _pinocchio_order()
    rng = np.random.default_rng(30)
    quaternion = rng.normal(size=4)
    quaternion /= np.linalg.norm(quaternion)
    q = np.concatenate([[rng.uniform(-np.pi, np.pi)], rng.uniform(-1, 1, 3), quaternion])
    v, u = rng.normal(size=7), rng.normal(size=1)
    derivation = dynderive.derive(robot)
    coordinates = [str(s) for s in derivation.symbols.q]
    velocities = [str(s) for s in derivation.symbols.qd]
    at = ",".join([_at(coordinates, q), _at(velocities, v), f"u={float(u[0])!r}"])
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", at, "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document["method"] == "numeric" and document["state"]["velocities"] == velocities
    A, B = np.array(document["A_numeric"]), np.array(document["B_numeric"])
    assert A.shape == (14, 14) and B.shape == (14, 1)

    data = model.createData()
    tau = np.zeros(7)
    tau[0] = u[0]   # the shoulder's effort
    q_pin, v_pin = np.empty(8), np.empty(7)
    q_pin[:], v_pin[:] = q[qp], v[vp]
    pin.computeABADerivatives(model, data, q_pin, v_pin, tau[vp])
    inverse = np.argsort(vp)
    ddq_dq = np.asarray(data.ddq_dq)[np.ix_(inverse, inverse)]
    ddq_dv = np.asarray(data.ddq_dv)[np.ix_(inverse, inverse)]
    Minv = np.asarray(data.Minv)
    Minv = np.triu(Minv) + np.triu(Minv, 1).T
    Minv = Minv[np.ix_(inverse, inverse)]
    expected_A = np.block([[np.zeros((7, 7)), np.eye(7)], [ddq_dq, ddq_dv]])
    expected_B = np.vstack([np.zeros((7, 1)), Minv[:, [0]]])
    scale = max(1.0, np.abs(expected_A).max())
    assert np.max(np.abs(A - expected_A)) <= 1e-9 * scale
    assert np.max(np.abs(B - expected_B)) <= 1e-9 * max(1.0, np.abs(expected_B).max())


def test_linearize_fills_the_neutral_configuration_and_normalizes_quaternions():
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", "elbow_qx=1,elbow_qw=1,elbow_vx=0.3", "--json"])
    assert result.exit_code == 0, result.output
    assert "note: joint 'elbow': its quaternion (norm 1.41421) normalized to [0.707107, 0, 0, 0.707107]" in result.stderr
    assert "qd is not 0" in result.stderr
    state = json.loads(result.stdout)["state"]
    assert state["q"][4:] == pytest.approx([2 ** -0.5, 0, 0, 2 ** -0.5], abs=1e-15)
    assert state["q"][:4] == [0.0, 0.0, 0.0, 0.0]
    text = runner.invoke(app, ["linearize", str(ELBOW), "-q"])
    assert text.exit_code == 0, text.output
    assert "x = (dq, qd) on the tangent space" in text.stdout and "not built for floating-base robots" in text.stdout
    assert "q = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]" in text.stdout   # neutral: identity quaternion


def test_linearize_refuses_a_zero_quaternion():
    at = "elbow_qx=0,elbow_qy=0,elbow_qz=0,elbow_qw=0"
    result = runner.invoke(app, ["linearize", str(ELBOW), "--at", at])
    assert result.exit_code == 2
    assert result.stderr.strip() == ("--at:1:1: joint 'elbow': its quaternion (qx, qy, qz, qw) is zero; "
                                     "give a unit quaternion")
    assert result.stdout == ""


def test_linearize_latex_of_a_floating_robot_compiles(tmp_path):
    """The LaTeX document says what the state is (tangent space) and compiles: required in CI."""
    import os
    import shutil
    import subprocess

    result = runner.invoke(app, ["linearize", str(ELBOW), "--latex", "-q"])
    assert result.exit_code == 0, result.output
    assert "linearized on the tangent space" in result.stdout and "8 coordinates" in result.stdout
    assert result.stdout.count(r"\\") >= 13 * 2   # two 14 x 14 matrices of numbers
    if shutil.which("latexmk") is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must compile the LaTeX document, but latexmk is missing")
        pytest.skip("latexmk not installed")
    (tmp_path / "lin.tex").write_text(result.stdout)
    run = subprocess.run(["latexmk", "-pdf", "-interaction=nonstopmode", "-halt-on-error", "lin.tex"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:]
    assert (tmp_path / "lin.pdf").stat().st_size > 1000


def test_a_full_precision_3d_arm_gets_its_numbers_and_says_why_no_closed_form(tmp_path):
    """A three-joint 3-D arm with CAD-like numbers: its M and forces at the point run to
    hundreds of thousands of operations, so the closed form is skipped with the reason (not
    tried for minutes) and A, B come from the generated module, equal to central differences."""
    rng = random.Random(43)   # revolute, revolute, prismatic
    path = tmp_path / "cad_arm.yaml"
    path.write_text(random_spatial_tree(rng, 3, fixed=False).yaml_text)
    result = runner.invoke(app, ["linearize", str(path), "--json", "--quiet"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document["method"] == "numeric"
    from dynderive.render.targets.numpy.code import render_code

    module = import_code(render_code(dynderive.derive(dynderive.load_robot(path))), tmp_path)
    n = len(module.COORDINATES)
    A = np.array(document["A_numeric"])
    x0, h = np.zeros(2 * n), 1e-6
    u = np.zeros(len(module.EFFORTS))

    def xdot(x):
        return np.concatenate([x[n:], module.forward_dynamics(x[:n], x[n:], u)])

    central = np.column_stack([(xdot(x0 + h * e) - xdot(x0 - h * e)) / (2 * h) for e in np.eye(2 * n)])
    np.testing.assert_allclose(A, central, rtol=0, atol=1e-6 * max(1.0, np.abs(central).max()))
