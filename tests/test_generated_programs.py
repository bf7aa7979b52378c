"""The fast generated code (straight-line programs, ``recursive.py``: M, C, N of 3-D robots,
inverse and forward dynamics of every robot) is exact.

Independent reference: the derivation's own symbolic M_g, C_g, N_g (explicit expressions from
body Jacobians and Lie brackets, a different route from CRBA / Newton-Euler), evaluated with
``lambdify``. Required: agreement to 1e-12 relative on every path of the generated module:
one state (floats and ``math``), a batch in several chunks (NumPy), array parameters.
"""

from __future__ import annotations

import random
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.mechanics import structured
from dynderive.mechanics.recursive import mass_matrix_program
from dynderive.mechanics.tidy import fold_constants, operation_count

from conftest import import_code
from random_robots3d import random_spatial_tree

REL = 1e-12
ROOT = Path(__file__).resolve().parents[1]


def _rel(actual, expected) -> float:
    return float(np.max(np.abs(np.asarray(actual) - expected)) / max(1.0, float(np.max(np.abs(expected)))))


@pytest.fixture(scope="module", params=["double_pendulum", "cart_pole", "elbow_arm", "ur5", "panda", "tree-6", "tree-7"])
def case(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp(request.param)
    if request.param.startswith("tree"):
        n = int(request.param.split("-")[1])
        tree = random_spatial_tree(random.Random(40 + n), n)
        path = folder / "tree.yaml"
        path.write_text(tree.yaml_text)
        robot = dynderive.load_robot(path)
    else:
        urdf = ROOT / "robots" / f"{request.param}.urdf"
        robot = dynderive.load_robot(urdf if urdf.is_file() else request.param)
    # the reference: expanded M, C, N from body Jacobians and Christoffel symbols, also for
    # arms whose sheet uses the intermediate-variable form (built from the same programs)
    with mock.patch.object(structured, "LAGRANGE_DOF_LIMIT", 99):
        derivation = dynderive.derive(robot)
        assert not derivation.intermediate_form
        module = import_code(dynderive.render_code(derivation), folder, f"{robot.name}_programs")
        table = derivation.symbols
        values = table.defaults(robot)
        params = sorted(values, key=str)
        args = [*table.q, *table.qd, *params]
        # constants folded to doubles: NumPy has no sqrt of a 30-digit integer (full-precision inputs)
        reference = {name: sympy.lambdify(args, fold_constants(derivation[name].xreplace(values)), "numpy", cse=True)
                     for name in ("M_g", "C_g", "N_g")}
    return robot, derivation, module, reference, [values[p] for p in params]


def _reference(case, name, q, qd):
    _, _, _, reference, params = case
    return np.array(reference[name](*q, *qd, *params), dtype=float).reshape(-1) if name == "N_g" \
        else np.array(reference[name](*q, *qd, *params), dtype=float)


def _states(n, count=4, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, (count, n)), rng.uniform(-2, 2, (count, n))


def test_one_state_matches_the_symbolic_quantities(case):
    robot, derivation, module, _, _ = case
    n = len(robot.coordinates)
    qs, qds = _states(n)
    for q, qd in zip(qs, qds):
        M, C, N = (_reference(case, name, q, qd) for name in ("M_g", "C_g", "N_g"))
        assert _rel(module.mass_matrix(q), M) < REL
        assert _rel(module.coriolis_matrix(q, qd), C) < REL
        assert _rel(module.gravity_vector(q), N) < REL
        qdd = np.linspace(-1, 1, n)
        assert _rel(module.inverse_dynamics(q, qd, qdd), M @ qdd + C @ qd + N) < REL
        u = np.linspace(0.5, -0.5, len(module.EFFORTS))
        Y = np.array(sympy.lambdify(list(derivation.symbols.efforts.values()), derivation["Y_g"])(*u),
                     dtype=float).reshape(-1) if len(u) else np.zeros(n)
        expected = np.linalg.solve(M, Y - C @ qd - N)
        assert _rel(module.forward_dynamics(q, qd, u), expected) < 1e-10  # a solve: conditioning of M
        assert module.kinetic_energy(q, qd) == pytest.approx(0.5 * qd @ M @ qd, rel=REL)


def test_batches_in_chunks_match_single_states(case):
    """Several chunks with a remainder (chunk of 3 states, 8 states), batch shape kept."""
    robot, _, module, _, _ = case
    n = len(robot.coordinates)
    qs, qds = _states(n, count=8, seed=1)
    u = np.random.default_rng(2).uniform(-1, 1, (8, len(module.EFFORTS)))
    module._CHUNK = 3
    try:
        M = module.mass_matrix(qs.reshape(2, 4, n))
        assert M.shape == (2, 4, n, n)
        C = module.coriolis_matrix(qs, qds)
        FD = module.forward_dynamics(qs, qds, u)
        ID = module.inverse_dynamics(qs, qds, FD)
    finally:
        module._CHUNK = 4096
    for k in range(8):
        assert _rel(M.reshape(8, n, n)[k], module.mass_matrix(qs[k])) < REL
        assert _rel(C[k], module.coriolis_matrix(qs[k], qds[k])) < REL
        assert _rel(FD[k], module.forward_dynamics(qs[k], qds[k], u[k])) < REL
    tau = np.zeros((8, n))
    actuated = [k for k, j in enumerate(j for j in robot.joints if j.moves) if j.effort]
    tau[:, actuated] = u
    assert _rel(ID, tau) < 1e-10   # inverse of forward dynamics


def test_broadcasting_a_single_state_against_a_batch(case):
    robot, _, module, _, _ = case
    n = len(robot.coordinates)
    qs, qds = _states(n, count=5, seed=3)
    batch = module.coriolis_matrix(qs[0], qds)
    assert batch.shape == (5, n, n)
    assert _rel(batch[4], module.coriolis_matrix(qs[0], qds[4])) < REL


def test_array_parameters_broadcast():
    """Parameters may be arrays (a sweep over a mass): one pass, no chunking."""
    derivation = dynderive.derive(dynderive.load_robot("elbow_arm"))
    module = import_code(dynderive.render_code(derivation), Path(tempfile.mkdtemp()), "elbow_arm_sweep")
    q = np.array([0.3, -0.4, 0.9])
    masses = np.array([1.0, 2.0, 3.0])
    swept = module.mass_matrix(q, m3=masses)
    assert swept.shape == (3, 3, 3)
    for k, m in enumerate(masses):
        assert _rel(swept[k], module.mass_matrix(q, m3=m)) < REL


def test_programs_are_short_and_skip_structural_zeros():
    """The Panda's axes along z and pi/2 rotations leave CRBA under 1000 operations (the
    explicit symbolic M has over 100 000)."""
    robot = dynderive.load_robot(ROOT / "robots" / "panda.urdf")
    table = dynderive.model.symbols.SymbolTable.for_robot(robot)
    program = mass_matrix_program(robot, table)
    assert program.operations < 1000
    assert operation_count(sympy.sympify("a*b + c*d + sin(x)")) == 5


def test_robot_without_efforts_in_a_batch(tmp_path):
    """No effort symbols: u has shape (..., 0) and the chunks must still be cut (regression)."""
    path = tmp_path / "one.yaml"
    path.write_text("name: one\ngravity: [0, 0, -9.81]\nlinks:\n"
                    "  - {name: b1, mass: 1.0, com: [0.3, 0, 0], inertia: [0.1, 0.1, 0.1, 0, 0, 0]}\n"
                    "joints:\n  - {name: q1, type: revolute, parent: world, child: b1, axis: [0, 1, 0]}\n")
    module = import_code(dynderive.render_code(dynderive.derive(dynderive.load_robot(path))), tmp_path, "one_dof")
    q = np.linspace(-1, 1, 7)[:, None]
    qdd = module.forward_dynamics(q, np.zeros_like(q))
    # a pendulum about y: M = I_yy + m c^2 = 0.19, N = dV/dq = -m g c cos(q)
    np.testing.assert_allclose(qdd[:, 0], 9.81 * 0.3 * np.cos(q[:, 0]) / 0.19, rtol=1e-13)
    assert module.mass_matrix(np.zeros((0, 1))).shape == (0, 1, 1)


@pytest.mark.parametrize("robot", ["panda", "ur5", "cart_pole_damped", "spatial_four_bar"])
def test_program_printer_matches_sympys_printer(robot):
    """The fast printer of program lines (``code._ProgramPrinter``) writes what the SymPy-based
    ``_LinePrinter`` writes, character for character, on every line of a robot's programs."""
    from dynderive.render.codegen.printer import _LinePrinter, _ProgramPrinter

    path = ROOT / "robots" / (f"{robot}.urdf" if robot in ("panda", "ur5") else f"{robot}.yaml")
    derivation = dynderive.derive(dynderive.load_robot(path))
    fast, general = _ProgramPrinter({}), _LinePrinter({})
    lines = [e for program in derivation.programs.values() for _, e in program.lines] + [
        e for program in derivation.programs.values() for e in program.outputs]
    assert len(lines) > 50
    for expr in lines:
        expr = fold_constants(sympy.sympify(expr), rationals=False)
        assert fast(expr) == general.doprint(expr)


def test_program_printer_keeps_the_meaning_of_every_form():
    """Signs, fractions, powers, negative exponents and functions: the printed Python evaluates
    to the expression's value (random points), and the names map to their slots."""
    from dynderive.render.codegen.printer import _ProgramPrinter

    x, y, z = sympy.symbols("x y z")
    forms = [-x, x - y, -x - y, x / y, -x / y, 1 / (x * y), 2 / x, -sympy.Rational(3, 7) * x / y,
             sympy.Rational(3, 7) * x * y, -sympy.Rational(3, 7) * x * y, x**2 * y**-3, (x + y)**2,
             -(x + y) * z, sympy.Float(-0.25) + x, sympy.Float(-0.25) * x * y, sympy.sin(x)**2 * sympy.cos(y),
             x * (y - z) / (x + y), sympy.Rational(-1, 3) + x, 1 / (x + y)**2, (2 * x)**3, -x**2,
             sympy.Integer(-4), sympy.Rational(5, 8), x**-1, sympy.sqrt(x + y), abs(x - y) * y]
    printer = _ProgramPrinter({x: "a", y: "b"})
    rng = random.Random(1)
    env = {"sin": np.sin, "cos": np.cos, "sqrt": np.sqrt, "abs": abs}
    for form in forms:
        text = printer(form)
        for _ in range(3):
            values = {"a": rng.uniform(0.5, 2), "b": rng.uniform(0.5, 2), "z": rng.uniform(0.5, 2)}
            expected = float(form.subs({x: values["a"], y: values["b"], z: values["z"]}))
            assert eval(text, env, dict(values)) == pytest.approx(expected, rel=1e-12), (form, text)
