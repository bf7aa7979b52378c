"""``inverse_dynamics_derivatives`` and ``forward_dynamics_derivatives`` of every code target.

The NumPy module against Pinocchio's ``computeRNEADerivatives`` and ``computeABADerivatives``
(to 1e-9) on a fixed-base robot (the bundled UR5 URDF) and two with quaternions (the floating
elbow URDF, a free box with an arm), in Pinocchio's order and on its tangent space;
the drives' slope against central differences of ``inverse_dynamics`` (exact and smoothed
sign); ``forward_dynamics_derivatives`` equal to ``linearize``'s lower blocks, bit for bit.
Then the C target (through ctypes: its struct and status codes) and MATLAB (Octave) against the
NumPy module (to 1e-12; Octave's solve of the forward derivatives to linearize's 1e-10) on a
fixed robot with drives, a closed loop and a floating robot with drives (the loaded targets,
the extension and JAX among them, for every robot class: ``test_targets_agree.py``).
"""

from __future__ import annotations

import shutil
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.mechanics.tree import offsets

from conftest import ROOT, import_code, on_loops

ELBOW = ROOT / "tests" / "floating_elbow.urdf"
UR5 = ROOT / "robots" / "ur5.urdf"
EPS = 0.05   # friction_smoothing of the smoothed runs
RTOL = 1e-12
#: The robots every target is compared on: drives (fixed base), a closed loop, a floating base with drives.
TARGET_ROBOTS = ("cart_pole_damped", "four_bar", "rough_tree")


@cache
def _derived(key: str):
    """(derivation, NumPy module) of a bundled robot's name, ``ur5``, ``elbow`` (a floating joint
    below a revolute one), ``box`` (a floating base with an arm) or ``rough_tree`` (a floating
    tree with damping and friction), derived once."""
    from test_drives import _text
    from test_free_flyer import BOX

    folder = Path(_folder()) / key
    folder.mkdir(parents=True, exist_ok=True)
    if key == "ur5":
        robot = dynderive.load_robot(UR5)
    elif key == "elbow":
        robot = dynderive.load_robot(ELBOW)
    elif key == "box":
        (folder / "box.yaml").write_text(BOX)
        robot = dynderive.load_robot(folder / "box.yaml")
    elif key == "rough_tree":
        (folder / "rough_tree.yaml").write_text(_text(2))
        robot = dynderive.load_robot(folder / "rough_tree.yaml")
    else:
        robot = dynderive.load_robot(key)
    derivation = dynderive.derive(robot)
    return derivation, import_code(dynderive.render_code(derivation), folder, f"derivatives_{key}")


@cache
def _folder() -> str:
    import tempfile

    return tempfile.mkdtemp(prefix="derivatives_")


def _states(module, seed: int, count: int = 3):
    """Random (q, qd, qdd, u) of shape (count, size): q on the manifold (unit quaternions) and,
    for a loop robot, on the constraints."""
    rng = np.random.default_rng(seed)
    nv, nu = len(getattr(module, "VELOCITIES", module.COORDINATES)), len(module.EFFORTS)
    if hasattr(module, "integrate"):
        q = module.integrate(module.neutral_configuration(), rng.uniform(-1.0, 1.0, (count, nv)))
        qd = rng.normal(size=(count, nv))
    else:
        q, qd = rng.uniform(-1.2, 1.2, (count, nv)), rng.normal(size=(count, nv))
        if hasattr(module, "ASSEMBLED_CONFIGURATION"):
            q, qd = on_loops(module, q, qd)
    return q, qd, rng.normal(size=(count, nv)), rng.normal(size=(count, nu))


def _close(actual, expected, what: str, rtol: float = RTOL) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= rtol * scale, \
        f"{what}: error {error:.3g} at scale {scale:.3g}"


# --- the NumPy module ------------------------------------------------------------------------


@pytest.mark.pinocchio
@pytest.mark.parametrize("key", ["ur5", "elbow", "box"])
def test_numpy_module_is_pinocchios(key):
    pin = pytest.importorskip("pinocchio")
    derivation, module = _derived(key)
    robot = derivation.robot
    if key == "box":   # Pinocchio's model built from the robot's numbers: a free-flyer root
        from dynderive.verify.pinocchio_model import pinocchio_maps

        values = {p.name: p.value for p in robot.parameters if p.value is not None}
        model, qp, vp = pinocchio_maps(robot, values)
    else:   # Pinocchio's own URDF parser
        model = pin.buildModelFromUrdf(str(UR5 if key == "ur5" else ELBOW))
        where = offsets(robot)
        qp, vp = [], []
        for name, joint in zip(model.names[1:], model.joints[1:]):
            qp.extend(range(where.q[name], where.q[name] + joint.nq))
            vp.extend(range(where.v[name], where.v[name] + joint.nv))
        kinds = [j.shortname() for j in model.joints[1:]]
        assert key == "ur5" or kinds == ["JointModelRY", "JointModelFreeFlyer"]
    ix = np.ix_(vp, vp)
    data = model.createData()
    nv, nu = model.nv, len(robot.efforts)
    rng = np.random.default_rng(11)
    pin.seed(11)
    for _ in range(3):
        q, v, a = np.empty(model.nq), np.empty(nv), np.empty(nv)
        q[qp] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v[vp], a[vp], u = rng.normal(size=nv), rng.normal(size=nv), rng.normal(size=nu)
        dtau_dq, dtau_dqd = module.inverse_dynamics_derivatives(q, v, a)
        pin.computeRNEADerivatives(model, data, q[qp], v[vp], a[vp])
        scale = max(1.0, np.max(np.abs(data.dtau_dq)), np.max(np.abs(data.dtau_dv)))
        np.testing.assert_allclose(dtau_dq[ix], data.dtau_dq, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(dtau_dqd[ix], data.dtau_dv, rtol=0, atol=1e-9 * scale)
        M = np.triu(data.M) + np.triu(data.M, 1).T   # dtau/dqdd
        np.testing.assert_allclose(module.mass_matrix(q)[ix], M, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(M))))
        inputs = np.zeros((nv, nu))
        if hasattr(module, "EFFORT_COLUMNS"):
            inputs[list(module.EFFORT_COLUMNS), range(nu)] = 1.0
        else:
            inputs = module.generalized_forces(q, np.eye(nu)).T
        dqdd_dq, dqdd_dqd, dqdd_du = module.forward_dynamics_derivatives(q, v, u)
        pin.computeABADerivatives(model, data, q[qp], v[vp], (inputs @ u)[vp])
        scale = max(1.0, np.max(np.abs(data.ddq_dq)), np.max(np.abs(data.ddq_dv)))
        np.testing.assert_allclose(dqdd_dq[ix], data.ddq_dq, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(dqdd_dqd[ix], data.ddq_dv, rtol=0, atol=1e-9 * scale)
        inverse = np.empty((nv, nv))
        inverse[ix] = np.triu(data.Minv) + np.triu(data.Minv, 1).T
        expected = inverse @ inputs
        np.testing.assert_allclose(dqdd_du, expected, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(expected))))
        assert np.max(np.abs(dtau_dq)) > 1e-3 and np.max(np.abs(dqdd_dqd)) > 1e-3   # not trivially zero


@pytest.mark.parametrize("key", ["cart_pole_damped", "rough_tree"])
@pytest.mark.parametrize("smoothing", [0.0, EPS])
def test_drives_slope_is_the_derivative_of_inverse_dynamics(key, smoothing):
    """Central differences of inverse_dynamics (through integrate for q) with damping and
    Coulomb friction, the exact sign (zero slope off qd = 0) and the smoothed one."""
    derivation, module = _derived(key)
    assert derivation.robot.dissipative
    friction = {"friction_smoothing": smoothing}
    step = module.integrate if hasattr(module, "integrate") else (lambda q, dq: q + dq)
    for q, qd, qdd, _ in zip(*_states(module, 5)):
        dtau_dq, dtau_dqd = module.inverse_dynamics_derivatives(q, qd, qdd, **friction)
        h, n = 1e-6, len(qd)
        for k in range(n):
            e = np.zeros(n)
            e[k] = h
            by_q = (module.inverse_dynamics(step(q, e), qd, qdd, **friction)
                    - module.inverse_dynamics(step(q, -e), qd, qdd, **friction)) / (2 * h)
            by_qd = (module.inverse_dynamics(q, qd + e, qdd, **friction)
                     - module.inverse_dynamics(q, qd - e, qdd, **friction)) / (2 * h)
            scale = max(1.0, np.max(np.abs(dtau_dq)), np.max(np.abs(dtau_dqd)))
            np.testing.assert_allclose(dtau_dq[:, k], by_q, rtol=0, atol=1e-6 * scale)
            np.testing.assert_allclose(dtau_dqd[:, k], by_qd, rtol=0, atol=1e-6 * scale)
    with pytest.raises(ValueError, match="friction_smoothing must not be negative"):
        module.inverse_dynamics_derivatives(q, qd, qdd, friction_smoothing=-1.0)


@pytest.mark.parametrize("key", [*TARGET_ROBOTS, "elbow", "box"])
def test_forward_derivatives_are_linearizes_blocks(key):
    _, module = _derived(key)
    q, qd, qdd, u = _states(module, 3)
    for smoothing in (0.0, EPS):
        for index in (slice(None), 0):   # a batch, and one state
            A, B = module.linearize(q[index], qd[index], u[index], friction_smoothing=smoothing)
            n = A.shape[-1] // 2
            blocks = module.forward_dynamics_derivatives(q[index], qd[index], u[index],
                                                         friction_smoothing=smoothing)
            assert isinstance(blocks, tuple) and len(blocks) == 3
            np.testing.assert_array_equal(blocks[0], A[..., n:, :n])
            np.testing.assert_array_equal(blocks[1], A[..., n:, n:])
            np.testing.assert_array_equal(blocks[2], B[..., n:, :])
    # linearize's dtau terms are inverse_dynamics_derivatives at the state's own qdd
    if not hasattr(module, "ASSEMBLED_CONFIGURATION"):
        dq, dqd = module.inverse_dynamics_derivatives(q[0], qd[0], module.forward_dynamics(q[0], qd[0], u[0]))
        M = module.mass_matrix(q[0])
        dqdd_dq, dqdd_dqd, _ = module.forward_dynamics_derivatives(q[0], qd[0], u[0])
        _close(M @ dqdd_dq, -dq, "M dqdd/dq = -dtau/dq", 1e-10)
        _close(M @ dqdd_dqd, -dqd, "M dqdd/dqd = -dtau/dqd", 1e-10)
    # a batch gives each state's result
    batch = module.inverse_dynamics_derivatives(q, qd, qdd)
    for k in range(len(q)):
        one = module.inverse_dynamics_derivatives(q[k], qd[k], qdd[k])
        for got, want in zip(batch, one):
            _close(got[k], want, "batch")


# --- the other targets -------------------------------------------------------------------------


def _calls(module):
    """(name, arguments, keywords) of the two functions at batches of states, exact and smoothed sign."""
    q, qd, qdd, u = _states(module, 17)
    for smoothing in (0.0, EPS):
        yield "inverse_dynamics_derivatives", (q, qd, qdd), {"friction_smoothing": smoothing}
        yield "forward_dynamics_derivatives", (q, qd, u), {"friction_smoothing": smoothing}


@pytest.mark.parametrize("key", TARGET_ROBOTS)
def test_c_is_the_numpy_modules(key, tmp_path):
    if not (shutil.which("gcc") or shutil.which("cc")):
        pytest.skip("no C compiler")
    from test_c_target import Library

    derivation, module = _derived(key)
    library = Library(derivation, tmp_path)
    nv, nu = len(derivation.symbols.qd), len(derivation.symbols.efforts)
    loops = 2 if derivation.robot.loops else 0   # the struct's Baumgarte gains after friction_smoothing
    for name, args, keywords in _calls(module):
        p = [*module.PARAMETERS.values(), keywords["friction_smoothing"], *([0.0] * loops)]
        want = getattr(module, name)(*args, **keywords)
        sizes = (nv * nv, nv * nv) if name.startswith("inverse") else (nv * nv, nv * nv, nv * nu)
        for state in range(len(args[0])):
            status, out = library.call(name, [a[state] for a in args], sizes, p)
            if name.startswith("forward"):
                assert status == 0
            parts = np.split(out, np.cumsum(sizes)[:-1])
            for k, (part, w) in enumerate(zip(parts, want)):
                _close(part.reshape(w[state].shape), w[state], f"{key} C {name}[{k}] {keywords}")


def test_c_extension_propagates_nan_and_refuses_a_negative_smoothing(tmp_path):
    """The extension's derivative functions (their values for every robot class:
    ``test_targets_agree.py``): NaN in, NaN out; a negative ``friction_smoothing`` refused."""
    from test_c_extension import _load

    derivation, module = _derived("rough_tree")
    try:
        ext = _load(derivation, tmp_path)
    except Exception as exc:   # no compiler or no Python headers: the extension's own tests say which
        pytest.skip(f"the extension cannot be built here: {exc}")
    q, qd, _, _ = _states(module, 17)
    assert np.all(np.isnan(ext.forward_dynamics_derivatives(np.full(len(q[0]), np.nan), qd[0])[0]))
    assert derivation.robot.dissipative
    with pytest.raises(ValueError, match="friction_smoothing"):
        ext.inverse_dynamics_derivatives(q[0], qd[0], qd[0], friction_smoothing=-1.0)


@pytest.mark.parametrize("key", TARGET_ROBOTS)
def test_matlab_is_the_numpy_modules(key, tmp_path):
    from test_matlab_numeric import OCTAVE, _octave, _vector

    if OCTAVE is None:
        pytest.skip("GNU Octave is not installed")
    from dynderive.render.targets.matlab.matlab import render_matlab

    derivation, module = _derived(key)
    for path, text in render_matlab(derivation).items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    name = derivation.robot.name
    lines, expected = [f"p0 = {name}.parameters();"], {}
    for index, (function, args, keywords) in enumerate(_calls(module)):
        outputs = ["a", "b"] if function.startswith("inverse") else ["a", "b", "c"]
        want = getattr(module, function)(*args, **keywords)
        for state in range(len(args[0])):
            label = f"c{index}s{state}"
            vectors = "".join(f"x{k} = {_vector(a[state])}; " for k, a in enumerate(args))
            lines.append(f"p = p0; p.friction_smoothing = {keywords['friction_smoothing']}; {vectors}"
                         f"[{', '.join(outputs)}] = {name}.{function}(x0, x1, x2, p);")
            for k, out in enumerate(outputs):
                lines.append(f"fprintf('{label}_{k} %d %d', size({out}, 1), size({out}, 2)); "
                             f"fprintf(' %.17g', {out}.'); fprintf('\\n');")
                expected[f"{label}_{k}"] = (want[k][state], 1e-10 if function.startswith("forward") else RTOL)
    seen = set()
    for line in _octave(tmp_path, "\n".join(lines) + "\n").splitlines():
        parts = line.split()
        if parts and parts[0] in expected:
            want, tolerance = expected[parts[0]]
            got = np.array([float(v) for v in parts[3:]]).reshape(int(parts[1]), int(parts[2]))
            _close(got, want, f"{key} MATLAB {parts[0]}", tolerance)
            seen.add(parts[0])
    assert seen == set(expected)
