"""Closed loops on robots with quaternions in q (a floating base, spherical joints): the loops as
rows on the tree's twists (``mechanics/loop_programs.py``), written by ``solve --code``.

Every loop joint type on a floating base with a spherical joint below it: the rows' Jacobian
and drift against central differences along ``integrate``, the constrained accelerations keep
the loops closed (``A qdd = -Adot qd``, Baumgarte's gains as documented), the loop forces close
the equations of motion and do no work on the motions the loops allow, ``assemble`` closes them.
Then what is refused: an ``independent`` list on such a robot, and the targets that do not print
these loops (one positioned line, exit 2, nothing written). MuJoCo's hard limit on an MJCF
connect: ``test_mjcf_mujoco.py``."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

runner = CliRunner()

ROBOT = """\
name: floating_loop_types
planar: false
parameters:
  m: {value: 1.3}
  g: {value: 9.81}
gravity: [0, 0, -g]
links:
  - {name: base, mass: 4*m, com: [0.02, -0.01, 0.03], inertia: [0.05, 0.04, 0.03, 0.001, 0.002, -0.001]}
  - {name: arm, mass: m, com: [0.1, 0.01, 0], inertia: [0.002, 0.01, 0.011, 0, 0.0001, 0]}
  - {name: ball, mass: m/2, com: [0.05, 0, 0.02], inertia: [0.001, 0.002, 0.0025, 0.0001, 0, 0]}
  - {name: slider, mass: m/3, com: [0, 0.04, 0], inertia: [0.003, 0.001, 0.003, 0, 0, 0.0002]}
joints:
  - {name: root, type: floating, parent: world, child: base}
  - {name: j1, type: revolute, parent: base, child: arm, origin: {xyz: [0.1, 0.05, -0.02], rpy: [0.3, -0.2, 0.1]},
     axis: [0, 0.6, 0.8], effort: tau1}
  - {name: j2, type: spherical, parent: arm, child: ball, origin: {xyz: [0.2, 0, 0.01], rpy: [0, 0.4, 0]}}
  - {name: j3, type: prismatic, parent: base, child: slider, origin: {xyz: [-0.1, 0.02, 0.05], rpy: [0.1, 0.2, 0.3]},
     axis: [1, 0, 0], effort: f3}
loops:
  - {name: r1, type: revolute, parent: ball, child: slider, origin: {xyz: [0.1, 0.02, 0], rpy: [0.2, 0, 0.1]},
     child_origin: {xyz: [0, 0.1, 0.03], rpy: [0, 0.3, 0]}, axis: [0, 0, 1]}
  - {name: p1, type: prismatic, parent: arm, child: slider, origin: {xyz: [0.05, 0, 0.1], rpy: [0, 0, 0.5]},
     child_origin: {xyz: [0.02, 0, 0], rpy: [0.1, 0, 0]}, axis: [0.6, 0, 0.8]}
  - {name: s1, type: spherical, parent: world, child: ball, origin: {xyz: [0.3, 0.1, 1.0], rpy: [0, 0, 0]},
     child_origin: {xyz: [0.1, 0, 0], rpy: [0, 0, 0]}}
"""

#: A floating base whose arm's tip is tied to the base by a ball joint: three rows, assembles.
TIED = """\
name: tied
planar: false
parameters:
  m: {value: 1.0}
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: 3*m, com: [0, 0, 0], inertia: [0.03, 0.04, 0.05, 0, 0, 0]}
  - {name: upper, mass: m, com: [0.15, 0, 0], inertia: [0.001, 0.008, 0.008, 0, 0, 0]}
  - {name: lower, mass: m/2, com: [0.15, 0, 0], inertia: [0.001, 0.004, 0.004, 0, 0, 0]}
joints:
  - {name: root, type: floating, parent: world, child: base}
  - {name: shoulder, type: spherical, parent: base, child: upper, origin: {xyz: [0.1, 0, 0], rpy: [0, 0, 0]}}
  - {name: elbow, type: revolute, parent: upper, child: lower, origin: {xyz: [0.3, 0, 0], rpy: [0, 0, 0]},
     axis: [0, 0, 1], effort: tau_elbow}
loops:
  - {name: tie, type: spherical, parent: lower, child: base, origin: {xyz: [0.3, 0, 0], rpy: [0, 0, 0]},
     child_origin: {xyz: [0.1, 0.3, 0], rpy: [0, 0, 0]}}
"""

#: A planar four-bar on a floating base, closed by a revolute loop joint: five rows of rank two at
#: every configuration (the gap across the plane and the axes' alignment hold by construction).
FOUR_BAR = """\
name: floating_four_bar
planar: false
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: 2.7123456789012345, com: [0.2012345678901234, 0.0123456789012345, -0.0212345678901234], inertia: [0.0312345678901234, 0.0523456789012345, 0.0612345678901234, 0.0012345678901234, -0.0009876543210987, 0.0007654321098765]}
  - {name: crank, mass: 0.4123456789012345, com: [0.1012345678901234, 0.0012345678901234, 0.0], inertia: [0.0002123456789012, 0.0014123456789012, 0.0015123456789012, 0.0, 0.0, 0.0000123456789012]}
  - {name: coupler, mass: 0.6123456789012345, com: [0.2212345678901234, -0.0012345678901234, 0.0], inertia: [0.0003123456789012, 0.0104123456789012, 0.0106123456789012, 0.0000212345678901, 0.0, 0.0]}
  - {name: rocker, mass: 0.5123456789012345, com: [0.1512345678901234, 0.0, 0.0012345678901234], inertia: [0.0002523456789012, 0.0040123456789012, 0.0041123456789012, 0.0, 0.0000112345678901, 0.0]}
joints:
  - {name: root, type: floating, parent: world, child: base}
  - {name: j1, type: revolute, parent: base, child: crank, origin: {xyz: [0, 0, 0], rpy: [0, 0, 1.2]}, axis: [0, 0, 1], effort: tau1}
  - {name: j2, type: revolute, parent: crank, child: coupler, origin: {xyz: [0.2, 0, 0], rpy: [0, 0, -1.0]}, axis: [0, 0, 1]}
  - {name: j3, type: revolute, parent: base, child: rocker, origin: {xyz: [0.4, 0, 0], rpy: [0, 0, 1.9]}, axis: [0, 0, 1]}
loops:
  - {name: pin, type: revolute, parent: coupler, child: rocker, origin: {xyz: [0.45, 0, 0], rpy: [0, 0, 0]},
     child_origin: {xyz: [0.3, 0, 0], rpy: [0, 0, 0]}, axis: [0, 0, 1]}
"""


def _solve(tmp_path: Path, text: str, *options: str):
    """``dynderive solve ROBOT --code OPTIONS --out OUT``: the result, the robot file's bytes
    unchanged, and every file written inside OUT."""
    robot = tmp_path / "robot.yaml"
    robot.write_text(text)
    before = robot.read_bytes()
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(robot), "--code", *options, "--out", str(out), "-q"])
    assert robot.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["robot.yaml"] + (["out"] if out.exists() else []))
    return result, robot, out


def _module(tmp_path: Path, text: str):
    result, robot, out = _solve(tmp_path, text)
    assert result.exit_code == 0, result.output
    name = text.split("\n", 1)[0].split(": ")[1]
    path = out / f"{name}_dynamics.py"
    spec = importlib.util.spec_from_file_location(f"{name}_{tmp_path.name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def types(tmp_path_factory):
    return _module(tmp_path_factory.mktemp("types"), ROBOT)


@pytest.fixture(scope="module")
def tied(tmp_path_factory):
    return _module(tmp_path_factory.mktemp("tied"), TIED)


@pytest.fixture(scope="module")
def four_bar(tmp_path_factory):
    return _module(tmp_path_factory.mktemp("four_bar"), FOUR_BAR)


def _states(module, seed: int, count: int = 3):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = module.integrate(module.neutral_configuration(), rng.uniform(-1, 1, module.NV))
        yield q, rng.uniform(-1, 1, module.NV), rng.uniform(-1, 1, len(module.EFFORTS))


def test_every_loop_type_has_its_rows(types):
    assert types.LOOPS == ("r1", "p1", "s1")
    q = types.neutral_configuration()
    assert types.loop_constraints(q).shape == (13,)   # revolute 5, prismatic 5, spherical 3
    assert types.loop_jacobian(q).shape == (13, types.NV) and types.NV == 11


@pytest.mark.parametrize("seed", [1, 2])
def test_jacobian_and_drift_are_the_rows_derivatives_along_integrate(types, seed):
    """A v = d a(integrate(q, v t))/dt and Adot qd = d(A(q(t))) qd/dt at t = 0, by central
    differences, for the revolute, prismatic and spherical rows alike."""
    h = 1e-6
    for q, v, _ in _states(types, seed):
        ahead, behind = types.integrate(q, v * h), types.integrate(q, -v * h)
        rate = (types.loop_constraints(ahead) - types.loop_constraints(behind)) / (2 * h)
        np.testing.assert_allclose(types.loop_jacobian(q) @ v, rate, atol=1e-8 * max(1.0, np.max(np.abs(rate))))
        drift = (types.loop_jacobian(ahead) - types.loop_jacobian(behind)) @ v / (2 * h)
        np.testing.assert_allclose(types.loop_jacobian_dot_qd(q, v), drift, atol=1e-8 * max(1.0, np.max(np.abs(drift))))


@pytest.mark.parametrize("robot", ["types", "tied"])
def test_the_loop_forces_close_the_equations_of_motion(robot, request):
    """M qdd + h = tau + A^T lambda (inverse_dynamics at forward_dynamics' qdd), also where the
    rows outnumber the velocities (13 rows on 11: the multipliers of least norm)."""
    module = request.getfixturevalue(robot)
    for q, qd, u in _states(module, 3):
        qdd = module.forward_dynamics(q, qd, u)
        tau = np.zeros(module.NV)
        tau[list(module.EFFORT_COLUMNS)] = u
        forces = module.inverse_dynamics(q, qd, qdd)
        closed = tau + module.loop_jacobian(q).T @ module.loop_forces(q, qd, u)
        np.testing.assert_allclose(forces, closed, atol=1e-9 * max(1.0, np.max(np.abs(forces))))


def test_accelerations_keep_the_loops_closed_and_baumgarte_pulls_back(tied):
    """A qdd = -Adot qd (alpha = beta = 0), and with Baumgarte's gains -Adot qd - 2 alpha A qd -
    beta^2 a, off the constraints too."""
    for q, qd, u in _states(tied, 3):
        A, qdd = tied.loop_jacobian(q), tied.forward_dynamics(q, qd, u)
        np.testing.assert_allclose(A @ qdd, -tied.loop_jacobian_dot_qd(q, qd), atol=1e-9 * max(1.0, np.max(np.abs(qdd))))
        gained = tied.forward_dynamics(q, qd, u, alpha=2.0, beta=3.0)
        expected = -tied.loop_jacobian_dot_qd(q, qd) - 4.0 * A @ qd - 9.0 * tied.loop_constraints(q)
        np.testing.assert_allclose(A @ gained, expected, atol=1e-9 * max(1.0, np.max(np.abs(expected))))


def test_batches_broadcast(tied):
    states = list(_states(tied, 4))
    qs, qds, us = (np.array(column) for column in zip(*states))
    np.testing.assert_allclose(tied.forward_dynamics(qs, qds, us),
                               [tied.forward_dynamics(q, qd, u) for q, qd, u in states], rtol=1e-12, atol=1e-12)


def test_assemble_closes_the_loop_and_the_loop_forces_do_no_work(tied):
    """From a configuration near the neutral one, assemble closes the tie (every coordinate may
    move); on the velocities the loop allows, the loop force A^T lambda does no work and the
    accelerations keep A qd = 0 to first order."""
    rng = np.random.default_rng(5)
    q0 = tied.assemble(tied.neutral_configuration())
    assert np.max(np.abs(tied.loop_constraints(q0))) < 1e-12
    for _ in range(3):
        q = tied.assemble(tied.integrate(q0, rng.uniform(-0.2, 0.2, tied.NV)))
        assert np.max(np.abs(tied.loop_constraints(q))) < 1e-12
        assert np.linalg.norm(q[3:7]) == pytest.approx(1.0, abs=1e-12)   # the base's quaternion stays unit
        A = tied.loop_jacobian(q)
        null = np.linalg.svd(A)[2][3:]
        qd = null.T @ rng.uniform(-1, 1, len(null))
        force = A.T @ tied.loop_forces(q, qd, [0.3])
        assert abs(qd @ force) < 1e-12 * max(1.0, np.max(np.abs(force)))
        qdd = tied.forward_dynamics(q, qd, [0.3])
        h = 1e-6
        ahead = tied.loop_jacobian(tied.integrate(q, qd, h)) @ (qd + h * qdd)
        behind = tied.loop_jacobian(tied.integrate(q, qd, -h)) @ (qd - h * qdd)
        assert np.max(np.abs(ahead - behind)) / (2 * h) < 1e-6


def test_assemble_refuses_what_it_cannot_close(tied):
    """A tie the arm cannot reach (the base's own origin far from it cannot be, but a guess
    that diverges is said, not returned)."""
    far = tied.neutral_configuration()
    far[7:] = [np.nan] * (len(far) - 7)
    with pytest.raises(ValueError, match="assemble: the loop constraints could not be solved"):
        tied.assemble(far)


@pytest.mark.parametrize("robot", ["tied", "four_bar"])
def test_linearize_is_the_constrained_accelerations_derivative_along_integrate(robot, request):
    """linearize on the tangent space (the loops' rows differentiated line by line, the solve in
    their row space at the state) equals central differences of forward_dynamics through
    integrate, of qd and of u, at a state on the loops (dq along the motions they allow: across
    them a redundant row's rank changes, the four-bar's five rows of rank two becoming three) and
    off them (every dq); forward_dynamics_derivatives are its blocks. No reduced form is kept."""
    module = request.getfixturevalue(robot)
    nv, step = module.NV, 1e-6
    assert not hasattr(module, "INDEPENDENT_COORDINATES") and not hasattr(module, "reduced_basis")
    for index, (q, qd, u) in enumerate(_states(module, 31, 2)):
        directions = np.eye(nv)
        if index == 0:   # on the loops: assembled, qd and dq in the motions they allow
            q = module.assemble(q)
            _, sigma, vt = np.linalg.svd(module.loop_jacobian(q))
            directions = vt[int(np.sum(sigma > 1e-9 * sigma[0])):].T
            qd = directions @ (directions.T @ qd)
        A, B = module.linearize(q, qd, u)
        assert A.shape == (2 * nv, 2 * nv) and B.shape == (2 * nv, len(module.EFFORTS))
        np.testing.assert_array_equal(A[:nv], np.hstack([np.zeros((nv, nv)), np.eye(nv)]))
        columns = []
        for e in directions.T * step:
            columns.append((module.forward_dynamics(module.integrate(q, e), qd, u)
                            - module.forward_dynamics(module.integrate(q, -e), qd, u)) / (2 * step))
        for e in np.eye(nv) * step:
            columns.append((module.forward_dynamics(q, qd + e, u) - module.forward_dynamics(q, qd - e, u)) / (2 * step))
        for e in np.eye(len(module.EFFORTS)) * step:
            columns.append((module.forward_dynamics(q, qd, u + e) - module.forward_dynamics(q, qd, u - e)) / (2 * step))
        expected = np.array(columns).T
        got = np.hstack([A[nv:, :nv] @ directions, A[nv:, nv:], B[nv:]])
        scale = max(1.0, float(np.max(np.abs(expected))))
        assert np.max(np.abs(got - expected)) < 1e-6 * scale, (index, np.max(np.abs(got - expected)))
        by_q, by_qd, by_u = module.forward_dynamics_derivatives(q, qd, u)
        np.testing.assert_allclose(np.hstack([by_q, by_qd, by_u]), np.hstack([A[nv:], B[nv:]]), rtol=0,
                                   atol=1e-14 * scale)


@pytest.mark.parametrize(("option", "target"), [("--casadi", "the CasADi target (--casadi)")])
def test_targets_without_these_loops_refuse_at_the_first_loop_joint(tmp_path, option, target):
    result, robot, out = _solve(tmp_path, TIED, option)
    assert result.exit_code == 2, result.output
    line = next(n for n, text in enumerate(TIED.splitlines(), 1) if "{name: tie," in text)
    assert result.stderr.splitlines() == [
        f"{robot}:{line}:5: loop joint 'tie': closed loops on a robot with a floating or spherical joint are not "
        f"built for {target} yet (--code, --jax, --torch, --c, --c-extension and --matlab close them)"]
    assert not out.exists()
    assert "internal error" not in result.output


def test_check_with_the_casadi_backend_refuses_such_loops_in_one_line(tmp_path):
    """``check --backend casadi`` renders the module as ``--casadi`` does: the same refusal, not
    an internal error."""
    robot = tmp_path / "robot.yaml"
    robot.write_text(TIED)
    result = runner.invoke(app, ["check", str(robot), "--backend", "casadi", "-q"])
    assert result.exit_code == 2, result.output
    line = next(n for n, text in enumerate(TIED.splitlines(), 1) if "{name: tie," in text)
    assert result.stderr.splitlines()[-1].startswith(f"{robot}:{line}:5: loop joint 'tie': closed loops on a robot")
    assert "internal error" not in result.output and "Traceback" not in result.output


@pytest.mark.parametrize("text", [TIED, ROBOT], ids=["tied", "types"])
def test_the_matlab_package_agrees_with_the_numpy_module_in_octave(tmp_path, text):
    """``--matlab`` prints the loops' rows from their programs and forward_dynamics and loop_forces
    from the engine's loop solve (the rank found at each state): equal to the NumPy module's, with
    Baumgarte gains too, linearize on the tangent space and assemble (the tied robot's)."""
    from test_matlab_numeric import OCTAVE, _Calls, _octave, _vector

    if OCTAVE is None:
        pytest.skip("GNU Octave is not installed")
    result, robot, out = _solve(tmp_path, text, "--matlab")
    assert result.exit_code == 0, result.output
    (tmp_path / "numpy").mkdir()
    module = _module(tmp_path / "numpy", text)
    name = text.split("\n", 1)[0].split(": ")[1]
    package = out / f"+{name}"
    assert (package / "assemble.m").exists() and (package / "linearize.m").exists()
    calls = _Calls(name, 1e-11)
    calls.lines.append(f"p = {name}.parameters(); p.alpha = 0.7; p.beta = 1.9;")
    for index, (q, qd, u) in enumerate(_states(module, 8, 2)):
        state = f"{_vector(q)}, {_vector(qd)}"
        calls.add(f"a{index}", f"loop_constraints({_vector(q)})", module.loop_constraints(q))
        calls.add(f"A{index}", f"loop_jacobian({_vector(q)})", module.loop_jacobian(q))
        calls.add(f"drift{index}", f"loop_jacobian_dot_qd({state})", module.loop_jacobian_dot_qd(q, qd))
        # the solves go through each LAPACK's SVD of the rows (the rank found at the state): two
        # libraries agree to the system's conditioning, not to the rows' 1e-11 (a CI run: 1.4e-11)
        solve = 1e-9
        calls.add(f"qdd{index}", f"forward_dynamics({state}, {_vector(u)})", module.forward_dynamics(q, qd, u),
                  tolerance=solve)
        calls.add(f"gains{index}", f"forward_dynamics({state}, {_vector(u)}, p)",
                  module.forward_dynamics(q, qd, u, alpha=0.7, beta=1.9), tolerance=solve)
        calls.add(f"lambda{index}", f"loop_forces({state}, {_vector(u)})", module.loop_forces(q, qd, u),
                  tolerance=solve)
        A, B = module.linearize(q, qd, u)
        calls.add(f"lin{index}", f"linearize({state}, {_vector(u)})", A, tolerance=solve)
        if text is TIED:   # the types robot's three loops do not close together
            guess = module.integrate(module.neutral_configuration(), np.full(module.NV, 0.1 * (index + 1)))
            calls.add(f"assembled{index}", f"assemble({_vector(guess)})", module.assemble(guess), tolerance=solve)
        calls.add(f"dqdd{index}", f"forward_dynamics_derivatives({state}, {_vector(u)})", A[module.NV:, :module.NV],
                  tolerance=solve)
    calls.check(_octave(out, "\n".join(calls.lines), warnings=False))


@pytest.mark.parametrize("independent", ["[elbow]", "[shoulder, elbow]"])
def test_independent_coordinates_are_refused_on_such_a_robot(tmp_path, independent):
    text = TIED + f"independent: {independent}\n"
    result, robot, out = _solve(tmp_path, text)
    assert result.exit_code == 2, result.output
    line = len(text.splitlines())
    assert result.stderr.splitlines() == [
        f"{robot}:{line}:1: independent: a floating-base robot keeps no reduced form of its loops, so it takes no "
        "independent coordinates (forward_dynamics solves the loops with their multipliers)"]
    assert not out.exists()


def test_the_linearize_command_closes_the_loops_at_the_point(tmp_path):
    """``dynderive linearize`` of such a robot: the point's configuration assembled and its
    velocity projected onto the motions the loops allow (notes name the entries that moved), A and
    B the module's linearize there."""
    import json

    robot = tmp_path / "robot.yaml"
    robot.write_text(TIED)
    result = runner.invoke(app, ["linearize", str(robot), "--json", "--at", "qd=0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1.0"])
    assert result.exit_code == 0, result.output
    assert "elbowd = " in result.stderr and "follows from the loops (given 1)" in result.stderr
    document = json.loads(result.stdout)
    (tmp_path / "numpy").mkdir()
    module = _module(tmp_path / "numpy", TIED)
    q, qd, u = (np.array(document["state"][key]) for key in ("q", "qd", "u"))
    assert np.max(np.abs(module.loop_constraints(q))) < 1e-9 and np.max(np.abs(module.loop_jacobian(q) @ qd)) < 1e-9
    A, B = module.linearize(q, qd, u)
    scale = float(np.max(np.abs(A)))   # the point as printed (its digits) against the command's own
    np.testing.assert_allclose(np.array(document["A_numeric"]), A, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(np.array(document["B_numeric"]), B, rtol=0, atol=1e-10 * scale)


def test_the_json_counts_the_rows_and_leaves_the_mobility_to_the_module(tmp_path):
    import json

    result, robot, out = _solve(tmp_path, TIED, "--json")
    assert result.exit_code == 0, result.output
    document = json.loads((out / "tied.json").read_text())
    assert document["degrees_of_freedom"] is None
    assert document["loops"] == {"constraint_rows": 3, "rows": [["tie", f"{axis} of the gap between the loop frames"]
                                                                for axis in "xyz"]}


def test_the_jax_module_agrees_under_jit_and_vmap(tmp_path):
    """``--jax`` prints the same loops from the same template: forward_dynamics, loop_forces and
    assemble equal the NumPy module's, under ``jax.jit(jax.vmap(...))`` too."""
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    result, robot, out = _solve(tmp_path, TIED, "--jax")
    assert result.exit_code == 0, result.output
    modules = []
    for name in ("tied_dynamics", "tied_dynamics_jax"):
        spec = importlib.util.spec_from_file_location(f"{name}_{tmp_path.name}", out / f"{name}.py")
        modules.append(importlib.util.module_from_spec(spec))
        spec.loader.exec_module(modules[-1])
    numpy_module, jax_module = modules
    states = list(_states(numpy_module, 6, 4))
    qs, qds, us = (np.array(column) for column in zip(*states))
    expected = numpy_module.forward_dynamics(qs, qds, us)
    np.testing.assert_allclose(np.asarray(jax_module.forward_dynamics(qs, qds, us)), expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))
    batched = jax.jit(jax.vmap(jax_module.forward_dynamics))(qs, qds, us)
    np.testing.assert_allclose(np.asarray(batched), expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))
    forces = numpy_module.loop_forces(qs, qds, us)
    np.testing.assert_allclose(np.asarray(jax_module.loop_forces(qs, qds, us)), forces, rtol=0, atol=1e-12 * np.max(np.abs(forces)))
    closed = np.asarray(jax_module.assemble(qs))
    assert np.max(np.abs(numpy_module.loop_constraints(closed))) < 1e-12


def test_checks_linearize_row_holds_and_catches_a_wrong_block(tied, four_bar):
    """``check``'s row for a robot on a manifold (linearize against central differences through
    integrate; with loops, dq along the motions they allow) passes on both robots' states on the
    loops, and fails for a linearize whose velocity block is off by 1e-2."""
    from dynderive.verify.checks import _linearize_along_integrate

    for module in (tied, four_bar):
        states = list(_states(module, 5, 2))
        qs, us = np.array([module.assemble(q) for q, _, _ in states]), np.array([u for _, _, u in states])
        vs = []
        for q, (_, qd, _) in zip(qs, states):
            _, sigma, vt = np.linalg.svd(module.loop_jacobian(q))
            rows = vt[:int(np.sum(sigma > 1e-9 * sigma[0]))]
            vs.append(qd - rows.T @ (rows @ qd))
        row = _linearize_along_integrate(module, {}, qs, np.array(vs), us, True)
        assert row.status == "pass" and row.residual < 1e-6, row

        assert _linearize_along_integrate(_Off(module), {}, qs, np.array(vs), us, True).status == "FAIL"


class _Off:
    """A module whose linearize's velocity block is off by 1e-2."""

    def __init__(self, module):
        self.module = module

    def __getattr__(self, name):
        return getattr(self.module, name)

    def linearize(self, q, qd, u):
        A, B = self.module.linearize(q, qd, u)
        A[self.module.NV:, self.module.NV:] += 1e-2
        return A, B
