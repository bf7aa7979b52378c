"""The C target's closed loops and external wrenches (``render/targets/c/c_loops.py``): every bundled
loop robot and the over-constrained loops of ``tests/loops`` compile with strict warnings as
C99 and C++, and their loop functions, constrained forward dynamics (Baumgarte gains from the
struct), loop forces and linearize agree with the NumPy module at random assembled states
(velocities in the loops' null space) to 1e-12 relative; the wrench variants agree with the
NumPy module's ``wrenches=`` for a planar and a 3-D robot with frames, and a loop robot with
a frame; one loop robot under -fsanitize=address,undefined.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render.targets.c.c import render_c
from test_c_target import CC, STRICT, Library, _close, _compile, _write

from conftest import ROBOTS, ROOT, acceleration_scale, derivation_of, import_code, module_of, stable_seed

HERE = Path(__file__).parent / "loops"
LOOP_ROBOTS = ["four_bar", "slider_crank", "bennett", "spatial_four_bar",
               *(str(p) for p in sorted(HERE.glob("*.yaml")))]
P = ctypes.POINTER(ctypes.c_double)


def _derive(robot: str):
    return derivation_of(robot) if "/" not in robot else dynderive.derive(dynderive.load_robot(robot))


def _module(robot: str, derivation, directory: Path):
    if "/" not in robot:
        return module_of(robot, str(directory))
    return import_code(dynderive.render_code(derivation), directory, f"{derivation.robot.name}_loops_dynamics")


def _call(library: Library, function: str, inputs: list, sizes: tuple[int, ...], p) -> tuple[int, np.ndarray]:
    """``function(*inputs, p, *outputs)``; an input None is NULL; outputs pre-filled with NaN."""
    arrays = [None if a is None else np.ascontiguousarray(a, dtype=float) for a in inputs]
    outs = [np.full(size, np.nan) for size in sizes]
    params = None if p is None else np.ascontiguousarray(p, dtype=float)
    result = getattr(library.lib, f"{library.name}_{function}")(
        *(None if a is None else a.ctypes.data_as(P) for a in arrays),
        None if params is None else params.ctypes.data_as(P), *(o.ctypes.data_as(P) for o in outs))
    return result, np.concatenate(outs)


def _dependent_mask(module) -> np.ndarray:
    return np.array([0.0 if c in module.INDEPENDENT_COORDINATES else 1.0 for c in module.COORDINATES])


def _states(module, rng, count: int):
    """Assembled configurations near the module's own, velocities R_g qd_i (A_g qd = 0)."""
    n = len(module.COORDINATES)
    base = np.array(module.ASSEMBLED_CONFIGURATION)
    states = []
    while len(states) < count:
        guess = base + rng.normal(scale=0.15, size=n)
        try:
            q = module.assemble(guess)
        except ValueError:
            continue
        qd = module.reduced_basis(q) @ rng.normal(size=len(module.INDEPENDENT_COORDINATES))
        states.append((q, qd, rng.normal(size=len(module.EFFORTS))))
    return states


@pytest.mark.parametrize("robot", LOOP_ROBOTS, ids=lambda r: Path(r).stem)
def test_loop_robot_agrees_with_numpy(robot, tmp_path, code_dir):
    derivation = _derive(robot)
    module = _module(robot, derivation, Path(code_dir))
    library = Library(derivation, tmp_path)
    n, k = library.n, len(module.loop_constraints(module.ASSEMBLED_CONFIGURATION))
    header = (tmp_path / f"{library.name}_dynamics.h").read_text()
    assert f"#define {library.name.upper()}_NC {k}" in header
    defaults = [*map(float, module.PARAMETERS.values()), 0.0]
    rng = np.random.default_rng(stable_seed(robot))
    for q, qd, u in _states(module, rng, 3):
        terms = acceleration_scale(module, q, qd, u)
        assert np.max(np.abs(module.loop_jacobian(q) @ qd)) < 1e-9 * max(1.0, np.max(np.abs(qd)))
        _, a = _call(library, "loop_constraints", [q], (k,), None)
        assert np.max(np.abs(a)) < 1e-11   # assembled: zero, up to rounding (no relative test)
        off = q + rng.normal(scale=2e-2, size=n)
        _, a = _call(library, "loop_constraints", [off], (k,), None)
        _close(a, module.loop_constraints(off), "loop_constraints")
        _, A = _call(library, "loop_jacobian", [q], (k * n,), None)
        _close(A.reshape(k, n), module.loop_jacobian(q), "loop_jacobian")
        _, Y = _call(library, "generalized_forces", [q, u], (n,), None)
        _close(Y, module.generalized_forces(q, u), "generalized_forces")
        _, Adot = _call(library, "loop_jacobian_dot", [q, qd], (k * n,), None)
        _close(Adot.reshape(k, n), module.loop_jacobian_dot(q, qd), "loop_jacobian_dot")
        for alpha, beta in ((0.0, 0.0), (3.7, 5.3)):
            p = [*defaults, alpha, beta]
            status, qdd = _call(library, "forward_dynamics", [q, qd, u], (n,), p)
            assert status == 0
            expected = module.forward_dynamics(q, qd, u, alpha=alpha, beta=beta)
            _close(qdd, expected, f"forward_dynamics alpha={alpha}", terms)
            status, qdd = _call(library, "forward_dynamics_wrenches", [q, qd, u, None], (n,), p)
            assert status == 0
            _close(qdd, expected, "forward_dynamics_wrenches NULL", terms)
        # off the constraints the Baumgarte terms matter: the C struct's gains are read
        status, qdd = _call(library, "forward_dynamics", [off, qd, u], (n,), [*defaults, 2.0, 7.0])
        assert status == 0
        _close(qdd, module.forward_dynamics(off, qd, u, alpha=2.0, beta=7.0), "forward_dynamics off the constraints",
               acceleration_scale(module, off, qd, u))
        assert np.max(np.abs(qdd - module.forward_dynamics(off, qd, u))) > 1e-6
        status, lam = _call(library, "loop_forces", [q, qd, u], (k,), None)
        assert status == 0
        _close(lam, module.loop_forces(q, qd, u), "loop_forces")
        m = len(module.INDEPENDENT_COORDINATES)
        status, R = _call(library, "reduced_basis", [q], (n * m,), None)
        assert status == 0
        _close(R.reshape(n, m), module.reduced_basis(q), "reduced_basis")
        status, qdd = _call(library, "reduced_forward_dynamics", [q, qd, u], (n,), None)
        assert status == 0
        _close(qdd, module.reduced_forward_dynamics(q, qd, u), "reduced_forward_dynamics", terms)
        guess = q + 0.05 * _dependent_mask(module)   # the dependent coordinates moved
        status, assembled = _call(library, "assemble", [guess], (n,), None)
        assert status == 0
        _close(assembled, module.assemble(guess), "assemble")
        status, AB = _call(library, "linearize", [q, qd, u], (4 * n * n, 2 * n * library.nu), None)
        assert status == 0
        A_lin, B_lin = module.linearize(q, qd, u)
        _close(AB[:4 * n * n].reshape(2 * n, 2 * n), A_lin, "linearize A")
        _close(AB[4 * n * n:].reshape(2 * n, library.nu), B_lin, "linearize B")


def test_accelerations_that_nearly_cancel_are_compared_to_their_terms(tmp_path, code_dir):
    """At the double parallelogram's first state drawn from seed 61 the constrained
    accelerations (8.8e-4) are 2e4 times smaller than the unconstrained ones they are made of
    (16.8), so C and NumPy differ by 5e-15 there, rounding of the terms: compared to the
    terms, not to the result (where it once failed when the seed came from the path's length)."""
    robot = str(HERE / "double_parallelogram.yaml")
    derivation = _derive(robot)
    module = _module(robot, derivation, Path(code_dir))
    library = Library(derivation, tmp_path)
    q, qd, u = _states(module, np.random.default_rng(61), 1)[0]
    terms = acceleration_scale(module, q, qd, u)
    expected = module.forward_dynamics(q, qd, u)
    assert np.max(np.abs(expected)) < 1e-3 * terms   # the cancellation is real
    status, qdd = _call(library, "forward_dynamics", [q, qd, u], (library.n,),
                        [*map(float, module.PARAMETERS.values()), 0.0, 0.0, 0.0])
    assert status == 0
    _close(qdd, expected, "forward_dynamics", terms)


def test_singular_loop_configuration_is_reported(tmp_path, code_dir):
    """With crank, coupler and rocker all along the x axis (q = 0) the loop Jacobian's rows
    lose rank (the first is zero): the NumPy module's solve raises, forward dynamics and the
    loop forces return 2 and leave their outputs untouched."""
    library = Library(derivation_of("four_bar"), tmp_path)
    module = module_of("four_bar", str(code_dir))
    q, qd, u = np.zeros(3), np.array([0.2, -0.1, 0.3]), np.ones(1)
    assert np.linalg.matrix_rank(module.loop_jacobian(q)) == 1
    with pytest.raises(np.linalg.LinAlgError):
        module.forward_dynamics(q, qd, u)
    status, qdd = _call(library, "forward_dynamics", [q, qd, u], (3,), None)
    assert status == 2 and np.all(np.isnan(qdd))
    status, lam = _call(library, "loop_forces", [q, qd, u], (2,), None)
    assert status == 2 and np.all(np.isnan(lam))


def test_assemble_reports_no_assembly(tmp_path, code_dir):
    """A four-bar whose ground link is longer than the other three together cannot close:
    the NumPy module raises, the C function returns 1 and leaves q untouched."""
    library = Library(derivation_of("four_bar"), tmp_path)
    module = module_of("four_bar", str(code_dir))
    values = {**module.PARAMETERS, "d": 5.0}
    guess = np.array(module.ASSEMBLED_CONFIGURATION)
    with pytest.raises(ValueError):
        module.assemble(guess, **values)
    status, q = _call(library, "assemble", [guess], (3,), [*values.values(), 0.0, 0.0, 0.0])
    assert status == 1 and np.all(np.isnan(q))
    status, q = _call(library, "assemble", [guess], (3,), None)
    assert status == 0
    _close(q, module.assemble(guess), "assemble")


def _framed_loop(tmp_path: Path) -> Path:
    """The four-bar with a frame at the coupler's far end (a loop robot with a frame)."""
    text = (ROBOTS / "four_bar.yaml").read_text()
    assert "\nframes:" not in text
    text = text.replace("    effort: tau1\n", "    effort: tau1\n    damping: 0.3\n    friction: 0.2\n")
    path = tmp_path / "four_bar.yaml"
    path.write_text(text.rstrip("\n") + "\nframes:\n  - {name: tip, link: coupler, origin: [b/2, 0.1]}\n")
    return path


def test_dissipative_loop_robot(tmp_path):
    """Damping and Coulomb friction (friction_smoothing from the struct) in the constrained
    forward dynamics, the loop forces and linearize of a loop robot."""
    derivation = dynderive.derive(dynderive.load_robot(_framed_loop(tmp_path)))
    assert derivation.robot.dissipative
    module = import_code(dynderive.render_code(derivation), tmp_path, "damped_four_bar_dynamics")
    library = Library(derivation, tmp_path / "c")
    n, k = 3, 2
    for q, qd, u in _states(module, np.random.default_rng(8), 2):
        for eps in (0.0, 0.05):
            p = [*map(float, module.PARAMETERS.values()), eps, 0.0, 0.0]
            status, qdd = _call(library, "forward_dynamics", [q, qd, u], (n,), p)
            assert status == 0
            _close(qdd, module.forward_dynamics(q, qd, u, friction_smoothing=eps), "forward_dynamics")
            status, lam = _call(library, "loop_forces", [q, qd, u], (k,), p)
            _close(lam, module.loop_forces(q, qd, u, friction_smoothing=eps), "loop_forces")
            status, qdd = _call(library, "reduced_forward_dynamics", [q, qd, u], (n,), p)
            _close(qdd, module.reduced_forward_dynamics(q, qd, u, friction_smoothing=eps), "reduced_forward_dynamics")
            status, AB = _call(library, "linearize", [q, qd, u], (4 * n * n, 2 * n), p)
            assert status == 0
            A, B = module.linearize(q, qd, u, friction_smoothing=eps)
            _close(AB[:4 * n * n].reshape(2 * n, 2 * n), A, "linearize A")
            _close(AB[4 * n * n:].reshape(2 * n, 1), B, "linearize B")


@pytest.mark.parametrize("robot", ["planar_3r", "elbow_arm", "framed_four_bar"])
def test_wrenches_agree_with_numpy(robot, tmp_path, code_dir):
    if robot == "framed_four_bar":
        derivation = dynderive.derive(dynderive.load_robot(_framed_loop(tmp_path)))
        module = import_code(dynderive.render_code(derivation), tmp_path, "framed_four_bar_dynamics")
    else:
        derivation, module = derivation_of(robot), module_of(robot, str(code_dir))
    library = Library(derivation, tmp_path / "c")
    n, frames = library.n, len(module.FRAMES)
    twist = 3 if library.planar else 6
    assert frames > 0
    rng = np.random.default_rng(41)
    loops = hasattr(module, "loop_constraints")
    states = _states(module, rng, 3) if loops else [
        (rng.uniform(-1.5, 1.5, n), rng.normal(size=n), rng.normal(size=library.nu)) for _ in range(3)]
    for q, qd, u in states:
        qdd = rng.normal(size=n)
        w = rng.normal(size=(frames, twist))
        given = {frame: w[i] for i, frame in enumerate(module.FRAMES)}
        _, tau = _call(library, "inverse_dynamics_wrenches", [q, qd, qdd, w], (n,), None)
        _close(tau, module.inverse_dynamics(q, qd, qdd, given), "inverse_dynamics_wrenches")
        _, tau0 = _call(library, "inverse_dynamics_wrenches", [q, qd, qdd, None], (n,), None)
        _close(tau0, module.inverse_dynamics(q, qd, qdd), "inverse_dynamics_wrenches NULL")
        assert np.max(np.abs(tau - tau0)) > 1e-3
        status, acc = _call(library, "forward_dynamics_wrenches", [q, qd, u, w], (n,), None)
        assert status == 0
        _close(acc, module.forward_dynamics(q, qd, u, given), "forward_dynamics_wrenches")
        status, acc0 = _call(library, "forward_dynamics_wrenches", [q, qd, u, None], (n,), None)
        assert status == 0
        _close(acc0, module.forward_dynamics(q, qd, u), "forward_dynamics_wrenches NULL")
        assert np.max(np.abs(acc - acc0)) > 1e-3


def test_robot_without_frames_ignores_wrenches(tmp_path, code_dir):
    """No frames: the wrenches argument is never read (NULL or anything)."""
    library = Library(derivation_of("double_pendulum"), tmp_path)
    module = module_of("double_pendulum", str(code_dir))
    q, qd, u = np.array([0.3, -0.4]), np.array([0.5, 0.1]), np.array([0.7, -0.2])
    status, acc = _call(library, "forward_dynamics_wrenches", [q, qd, u, None], (2,), None)
    assert status == 0
    _close(acc, module.forward_dynamics(q, qd, u), "forward_dynamics_wrenches")
    _, tau = _call(library, "inverse_dynamics_wrenches", [q, qd, acc, None], (2,), None)
    _close(tau, module.inverse_dynamics(q, qd, acc), "inverse_dynamics_wrenches")


def test_loop_robot_under_sanitizers(tmp_path, code_dir):
    """Bennett (over-constrained: the Jacobi row space) under -fsanitize=address,undefined; its
    printed results agree with the NumPy module."""
    derivation = derivation_of("bennett")
    path = _write(derivation, tmp_path)
    module = module_of("bennett", str(code_dir))
    n, k = 3, len(module.loop_constraints(module.ASSEMBLED_CONFIGURATION))
    q, qd, u = _states(module, np.random.default_rng(3), 1)[0]
    literal = lambda v: "{" + ", ".join(repr(float(x)) for x in v) + "}"   # noqa: E731
    driver = tmp_path / "driver.c"
    driver.write_text(f"""#include <stdio.h>
#include "bennett_dynamics.h"
int main(void)
{{
    const double q[] = {literal(q)}, qd[] = {literal(qd)}, u[] = {literal(u)};
    double acc[{n}], lambda[{k}], A[{4 * n * n}], B[{2 * n * len(module.EFFORTS)}];
    int i;
    if (bennett_forward_dynamics(q, qd, u, 0, acc) != 0) return 2;
    if (bennett_loop_forces(q, qd, u, 0, lambda) != 0) return 3;
    if (bennett_linearize(q, qd, u, 0, A, B) != 0) return 4;
    for (i = 0; i < {n}; i++) printf("%.17g\\n", acc[i]);
    for (i = 0; i < {k}; i++) printf("%.17g\\n", lambda[i]);
    for (i = 0; i < {4 * n * n}; i++) printf("%.17g\\n", A[i]);
    return 0;
}}
""")
    binary = tmp_path / "driver"
    run = subprocess.run([CC, *STRICT, "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
                          str(driver), str(path), "-I", str(tmp_path), "-o", str(binary), "-lm"],
                         capture_output=True, text=True)
    if run.returncode != 0 and "asan" in run.stderr.lower() and not os.environ.get("CI"):
        pytest.skip(f"no sanitizer runtime: {run.stderr.strip()[:200]}")
    assert run.returncode == 0, run.stderr
    result = subprocess.run([str(binary)], capture_output=True, text=True, env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert result.returncode == 0 and not result.stderr, result.stderr
    numbers = np.array([float(x) for x in result.stdout.split()])
    _close(numbers[:n], module.forward_dynamics(q, qd, u), "forward_dynamics")
    _close(numbers[n:n + k], module.loop_forces(q, qd, u), "loop_forces")
    _close(numbers[n + k:].reshape(2 * n, 2 * n), module.linearize(q, qd, u)[0], "linearize A")


def test_loop_code_has_no_mutable_globals(tmp_path):
    """The Jacobi row space, the eliminations and Newton's iteration keep their arrays on the
    stack: the object file holds code and read-only data only (thread-safe)."""
    if shutil.which("nm") is None:
        pytest.skip("no nm")
    path = _write(derivation_of("bennett"), tmp_path)
    _compile(path)
    symbols = subprocess.run(["nm", str(path.with_suffix(".o"))], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-2] for line in symbols.splitlines() if len(line.split()) >= 2}
    assert "R" in kinds and not kinds & set("BbDdCGgSs"), symbols


def test_header_declares_the_loop_functions(tmp_path):
    header, source = render_c(derivation_of("spatial_four_bar"))
    for function in ("loop_constraints", "loop_jacobian", "loop_jacobian_dot", "loop_forces", "loop_forces_wrenches",
                     "forward_dynamics", "forward_dynamics_wrenches", "inverse_dynamics_wrenches", "linearize"):
        assert f" spatial_four_bar_{function}(" in header
    assert "double alpha;" in header and "double beta;" in header
    assert "malloc" not in source and "static double" not in source


def test_loops_on_a_floating_base_agree_with_numpy(tmp_path, code_dir):
    """An MJCF connect on a floating base with a ball joint in the loop (tests/mjcf/floating_loop.xml),
    and two connects whose six rows have rank five (tests/mjcf/two_connects.xml): the C loop rows, forward_dynamics (with and
    without Baumgarte's gains, off the constraints), loop_forces (least norm), linearize (the rows'
    derivatives on the tangent space, their rank found at the state) and assemble equal the NumPy
    module's."""
    for path in (ROOT / "tests" / "mjcf" / "floating_loop.xml", ROOT / "tests" / "mjcf" / "two_connects.xml"):
        derivation = dynderive.derive(dynderive.load_robot(path))
        module = import_code(dynderive.render_code(derivation), Path(code_dir), f"{derivation.robot.name}_floating_loops")
        # the ball joint's model: 0.9 MB of C, 15 s at STRICT's -O1 and 2 s at -O0; -O1's flow
        # warnings are checked on the two connects (the same kinds of code, a quarter the size)
        big = path.name == "floating_loop.xml"
        library = Library(derivation, tmp_path / derivation.robot.name, *(["-O0"] if big else []))
        header = (tmp_path / derivation.robot.name / f"{library.name}_dynamics.h").read_text()
        assert f"{library.name}_linearize" in header and f"{library.name}_loop_jacobian_dot_qd" in header
        nv, nq = module.NV, module.NQ
        k = len(module.loop_constraints(module.neutral_configuration()))
        defaults = [*map(float, module.PARAMETERS.values()), 0.0]
        rng = np.random.default_rng(61)
        for _ in range(3):
            q = module.assemble(module.integrate(module.neutral_configuration(), rng.uniform(-1, 1, nv)))
            qd, u = rng.uniform(-1, 1, nv), rng.uniform(-1, 1, len(module.EFFORTS))
            off = module.integrate(q, rng.uniform(-0.05, 0.05, nv))
            _, a = _call(library, "loop_constraints", [off], (k,), None)
            _close(a, module.loop_constraints(off), "loop_constraints")
            _, A = _call(library, "loop_jacobian", [q], (k * nv,), None)
            _close(A.reshape(k, nv), module.loop_jacobian(q), "loop_jacobian")
            _, drift = _call(library, "loop_jacobian_dot_qd", [q, qd], (k,), None)
            _close(drift, module.loop_jacobian_dot_qd(q, qd), "loop_jacobian_dot_qd")
            for state, (alpha, beta) in ((q, (0.0, 0.0)), (off, (2.0, 7.0))):
                status, qdd = _call(library, "forward_dynamics", [state, qd, u], (nv,), [*defaults, alpha, beta])
                assert status == 0
                _close(qdd, module.forward_dynamics(state, qd, u, alpha=alpha, beta=beta), f"forward_dynamics {alpha}")
            status, lam = _call(library, "loop_forces", [q, qd, u], (k,), None)
            assert status == 0
            _close(lam, module.loop_forces(q, qd, u), "loop_forces")
            nu = len(module.EFFORTS)
            for state in (q, off):
                status, AB = _call(library, "linearize", [state, qd, u], (4 * nv * nv, 2 * nv * nu), None)
                assert status == 0
                A_lin, B_lin = module.linearize(state, qd, u)
                _close(AB[:4 * nv * nv].reshape(2 * nv, 2 * nv), A_lin, "linearize A")
                _close(AB[4 * nv * nv:].reshape(2 * nv, nu), B_lin, "linearize B")
            guess = module.integrate(q, rng.uniform(-0.1, 0.1, nv))
            status, closed = _call(library, "assemble", [guess], (nq,), None)
            assert status == 0 and np.max(np.abs(module.loop_constraints(closed))) < 1e-12
            # redundant rows make the least-norm steps' last digits differ; on one row set they agree
            assert np.max(np.abs(closed - module.assemble(guess))) < (1e-12 if k == 3 else 1e-5)
