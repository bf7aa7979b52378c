"""The Python extension of the C target (``solve --c-extension``): every function agrees with
the NumPy module to 1e-12 relative, one state and a broadcast batch, with keyword parameters,
``friction_smoothing`` and wrenches; the same signatures, constants and errors; the CLI flag,
no compiler (exit 2), a failing compiler (exit 1, the log kept); hostile text.

Floating-base robots too: every function agrees with the floating NumPy module (which agrees
with Pinocchio's free flyer: ``test_free_flyer.py``) to 1e-12 relative at random unit
quaternions, one state and a broadcast batch: solo12 from example-robot-data, random trees with
spherical joints on a fixed and a floating base, a free box with parameters; the same constants,
signatures and errors; NaN where M is not positive definite; ``solve``/``build --c-extension``,
``check --backend c`` and ``simulate --backend c``; a failing compiler; hostile text.

Needs a C compiler and Python's headers: skipped locally without them, required in CI (CI=true).
Each robot is compiled once per session, at -O0 (the values, not the speed, are tested; the CLI uses -O2;
solo12's 0.9 MB of C: 8 s).
"""

from __future__ import annotations

import importlib.util
import inspect
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.c_extension.c_extension import bindings, c_string, render_extension
from dynderive.render.targets.c_extension.compile import build_extension
from dynderive.render.targets.c_extension.contacts import contact_names
from dynderive.verify.checks import random_configurations

from conftest import (
    ROBOTS,
    acceleration_scale,
    derivation_of,
    import_code,
    module_of,
    stable_seed,
)

HEADERS = (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()
if not (shutil.which("gcc") or shutil.which("cc")) or not HEADERS:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C extension tests, but no C compiler or no Python.h was found")
    pytest.skip("no C compiler or no Python.h", allow_module_level=True)

RTOL = 1e-12
FUNCTIONS = ["mass_matrix", "coriolis_matrix", "gravity_vector", "generalized_forces", "inverse_dynamics", "forward_dynamics",
             "kinetic_energy", "potential_energy", "friction_forces", "linearize", "inverse_dynamics_derivatives",
             "forward_dynamics_derivatives", "regressor", "parameter_vector", "frame_transform", "frame_jacobian",
             "frame_jacobian_dot_qd"]


def _load(derivation, folder: Path, optimization: str = "-O0"):
    """Compile ``derivation``'s extension into ``folder`` and import it (not into sys.modules:
    several robots of one name can be loaded side by side)."""
    folder.mkdir(parents=True, exist_ok=True)
    filename, data = build_extension(derivation, optimization=optimization)
    path = folder / filename
    path.write_bytes(data)
    spec = importlib.util.spec_from_file_location(f"{derivation.robot.name}_dynamics_c", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def compiled(tmp_path_factory):
    """``compiled(robot)`` -> (extension, NumPy module) of a bundled robot, built once."""
    cache = {}

    def get(robot):
        """``robot``: a bundled robot's name, or a robot file's path (``tests/loops``)."""
        if robot not in cache:
            folder = tmp_path_factory.mktemp(f"ext_{Path(robot).stem}")
            derivation = derivation_of(robot)
            module = module_of(robot, str(folder)) if "/" not in robot else import_code(
                dynderive.render_code(derivation), folder, f"{Path(robot).stem}_file_dynamics")
            cache[robot] = (_load(derivation, folder), module)
        return cache[robot]

    return get


def _close(actual, expected, what: str, rtol: float = RTOL, terms: float = 0.0) -> None:
    """Equal to ``rtol`` of the expected value's size, or of ``terms``, the size of the terms
    that cancel in it, if larger."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), terms, 1e-300)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= rtol * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _broadcast_agree(ext, module, seed: int, parameters: dict | None = None, smoothing: float | None = None) -> None:
    """Every function of the extension against the NumPy module, one state and a batch whose
    arguments broadcast ((4, 3, n) with (3, n) and (n,)), each result of the NumPy module's type
    (the binding's broadcasting; the values of every robot class: ``test_targets_agree.py``)."""
    rng = np.random.default_rng(seed)
    n, nu = len(module.COORDINATES), len(module.EFFORTS)
    kwargs = dict(parameters or {})
    friction = {} if smoothing is None else {"friction_smoothing": smoothing}
    for batch in ((), (4, 3)):
        q = rng.uniform(-1.5, 1.5, batch + (n,))
        qd, qdd, u = rng.normal(size=batch[1:] + (n,)), rng.normal(size=(n,)), rng.normal(size=batch + (nu,))
        calls = [
            ("mass_matrix", (q,), {}), ("coriolis_matrix", (q, qd), {}), ("gravity_vector", (q,), {}),
            ("generalized_forces", (q, u), {}),
            ("inverse_dynamics", (q, qd, qdd), friction), ("forward_dynamics", (q, qd, u), friction),
            ("forward_dynamics", (q, qd), friction), ("kinetic_energy", (q, qd), {}), ("potential_energy", (q,), {}),
            ("friction_forces", (qd,), friction), ("regressor", (q, qd, qdd), friction), ("parameter_vector", (), {}),
            ("linearize", (q, qd, u), friction),
        ]
        calls += [(f, (q, frame), {}) for frame in module.FRAMES for f in ("frame_transform", "frame_jacobian")]
        calls += [("frame_jacobian_dot_qd", (q, qd, frame), {}) for frame in module.FRAMES]
        for name, args, extra in calls:
            got = getattr(ext, name)(*args, **extra, **kwargs)
            want = getattr(module, name)(*args, **extra, **kwargs)
            if name == "linearize":
                _close(got[0], want[0], f"{name} A {batch}")
                _close(got[1], want[1], f"{name} B {batch}")
                assert isinstance(got, tuple) and len(got) == 2
            else:
                _close(got, want, f"{name} {batch}")
                assert type(got) is type(want), f"{name}: {type(got)} != {type(want)}"
        if module.FRAMES:   # wrenches at every frame, one per batch row shape
            twist = ext.frame_jacobian(q, module.FRAMES[0]).shape[-2]
            wrenches = {f: rng.normal(size=batch[1:] + (twist,)) for f in module.FRAMES}
            _close(ext.inverse_dynamics(q, qd, qdd, wrenches, **friction, **kwargs),
                   module.inverse_dynamics(q, qd, qdd, wrenches, **friction, **kwargs), f"inverse_dynamics wrenches {batch}")
            _close(ext.forward_dynamics(q, qd, u, wrenches=wrenches, **friction, **kwargs),
                   module.forward_dynamics(q, qd, u, wrenches=wrenches, **friction, **kwargs),
                   f"forward_dynamics wrenches {batch}")


def test_constants_and_signatures_are_the_numpy_modules(compiled):
    for robot in ("planar_3r", "cart_pole_damped"):
        ext, module = compiled(robot)
        for constant in ("PARAMETERS", "COORDINATES", "EFFORTS", "FRAMES", "PARAMETER_VECTOR"):
            assert getattr(ext, constant) == getattr(module, constant), constant
        assert list(ext.PARAMETERS.values()) == list(module.PARAMETERS.values())   # same doubles, same order
        for name in FUNCTIONS:
            assert str(inspect.signature(getattr(ext, name))) == str(inspect.signature(getattr(module, name))), name


def test_large_batch_split_among_threads(compiled):
    """A batch large enough for the threaded loop (each part starts mid-way through a
    broadcast batch index), with wrenches, against the NumPy module."""
    ext, module = compiled("planar_3r")
    rng = np.random.default_rng(8)
    q, qd = rng.uniform(-1.5, 1.5, (101, 1, 3)), rng.normal(size=(97, 3))
    _close(ext.coriolis_matrix(q, qd), module.coriolis_matrix(q, qd), "coriolis_matrix (101, 97)")
    wrenches = {"tool": rng.normal(size=(97, 3))}
    _close(ext.forward_dynamics(q, qd, wrenches=wrenches), module.forward_dynamics(q, qd, wrenches=wrenches),
           "forward_dynamics (101, 97) with wrenches")


def test_keyword_parameters_and_smoothing(compiled):
    ext, module = compiled("cart_pole_damped")
    rng = np.random.default_rng(4)
    values = {k: v * (1 + rng.uniform(0.1, 0.5)) for k, v in module.PARAMETERS.items()}
    _broadcast_agree(ext, module, seed=5, parameters=values, smoothing=0.05)
    _broadcast_agree(ext, module, seed=6, parameters={"mp": 0.3, "fc": 0.4}, smoothing=0.0)
    qd = np.array([0.02, -0.04])
    assert not np.allclose(ext.friction_forces(qd, friction_smoothing=0.05), ext.friction_forces(qd))


def test_errors_are_the_numpy_modules(compiled):
    ext, module = compiled("planar_3r")
    q = np.zeros(3)
    cases = [
        lambda m: m.mass_matrix(np.zeros(4)), lambda m: m.mass_matrix(1.0), lambda m: m.coriolis_matrix(q, [[1.0, 2.0]]),
        lambda m: m.forward_dynamics(q, q, np.zeros(2)), lambda m: m.frame_jacobian(q, "nowhere"),
        lambda m: m.frame_transform(q, 3), lambda m: m.inverse_dynamics(q, q, q, {"nowhere": np.zeros(3)}),
        lambda m: m.inverse_dynamics(q, q, q, {"tool": np.zeros(6)}), lambda m: m.inverse_dynamics(q, q, q, [1]),
    ]
    for case in cases:
        with pytest.raises(ValueError) as theirs:
            case(module)
        with pytest.raises(ValueError) as ours:
            case(ext)
        assert str(ours.value) == str(theirs.value)
    for case in (lambda m: m.mass_matrix(q, nothing=1.0), lambda m: m.mass_matrix(q, friction_smoothing=0.1),
                 lambda m: m.mass_matrix(), lambda m: m.mass_matrix(q, q=q), lambda m: m.gravity_vector(q, g="x")):
        with pytest.raises(TypeError):
            case(module)
        with pytest.raises(TypeError):
            case(ext)
    with pytest.raises(ValueError, match="no arrays of parameter values"):
        ext.mass_matrix(q, m1=np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="broadcast"):
        ext.coriolis_matrix(np.zeros((2, 3)), np.zeros((4, 3)))
    _close(ext.mass_matrix(q=q, m1=np.float64(3.0)), module.mass_matrix(q, m1=3.0), "keywords")
    assert ext.inverse_dynamics(q, q, q, {}).shape == (3,) and ext.mass_matrix(np.zeros((0, 3))).shape == (0, 3, 3)


def test_negative_smoothing_and_a_mass_matrix_that_is_not_positive_definite(compiled):
    ext, module = compiled("cart_pole_damped")
    q = np.array([0.3, 0.2])
    for name, args in (("friction_forces", (q,)), ("inverse_dynamics", (q, q, q)), ("forward_dynamics", (q, q))):
        with pytest.raises(ValueError, match="friction_smoothing must not be negative, got -0.5"):
            getattr(module, name)(*args, friction_smoothing=-0.5)
        with pytest.raises(ValueError, match="friction_smoothing must not be negative, got -0.5"):
            getattr(ext, name)(*args, friction_smoothing=-0.5)
    rp, _ = compiled("rp_arm")   # a negative mass: NaN for that state, the others computed
    qs = np.array([[0.3, 0.2], [0.1, 0.4]])
    qdd = rp.forward_dynamics(qs, np.zeros(2), np.ones(2), m=-1.0)
    assert np.all(np.isnan(qdd))
    A, B = rp.linearize(qs[0], np.zeros(2), m=-1.0)
    assert np.all(np.isnan(A)) and np.all(np.isnan(B))
    assert np.all(np.isfinite(rp.forward_dynamics(qs, np.zeros(2), np.ones(2))))


def test_table_has_one_row_per_function():
    names = [b.name for b in bindings(derivation_of("rp_arm"))]
    assert sorted(names) == sorted(FUNCTIONS)


def _decode_c_string(literal: str) -> bytes:
    assert literal.startswith('"') and literal.endswith('"')
    body = literal[1:-1]
    assert all(" " <= c <= "~" for c in body) and "??" not in body
    out, i = bytearray(), 0
    while i < len(body):
        if body[i] == "\\":
            if body[i + 1] in '\\"?':
                out.append(ord(body[i + 1]))
                i += 2
            else:
                assert re.fullmatch(r"[0-7]{3}", body[i + 1:i + 4])
                out.append(int(body[i + 1:i + 4], 8))
                i += 4
        else:
            assert body[i] != '"'
            out.append(ord(body[i]))
            i += 1
    return bytes(out)


HOSTILE = 'a */ int x; /* b\n#include <stdlib.h>\r\\ ??/ ??= // c \u202e\x00 \U0001f600 "q\' */ 7'


def test_c_string_cannot_break_out():
    assert _decode_c_string(c_string(HOSTILE)) == HOSTILE.encode("utf-8")


def test_hostile_text_stays_out_of_the_binding(tmp_path, compiled):
    text = (ROBOTS / "rp_arm.yaml").read_text()
    encoded = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    text = "\n".join(f'title: "{encoded}"' if ln.startswith("title:") else ln for ln in text.splitlines()) + "\n"
    text = text.replace("description: mass of each link", f'description: "{encoded}"')
    path = tmp_path / "rp_arm.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.title == HOSTILE
    source = render_extension(derivation)
    assert "stdlib" not in source and "\U0001f600" not in source and all(ord(c) < 128 for c in source)
    ext = _load(derivation, tmp_path / "ext")
    _, module = compiled("rp_arm")
    _close(ext.mass_matrix([0.3, 0.2]), module.mass_matrix([0.3, 0.2]), "hostile rp_arm")


def test_solve_writes_an_importable_extension(tmp_path):
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--c", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    name = "rp_arm_dynamics_c" + sysconfig.get_config_var("EXT_SUFFIX")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["rp_arm_dynamics.h", "rp_arm_dynamics.c", name])
    run = subprocess.run([sys.executable, "-c", "import rp_arm_dynamics_c as m; print(m.mass_matrix([0.0, 0.5])[0, 0])"],
                         cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert abs(float(run.stdout) - (2 / 3 + 0.25 + 0.5)) < 1e-12   # 2 m l^2/3 + m q2^2 + m l q2 at m = l = 1


def test_no_compiler_is_exit_2(tmp_path, monkeypatch):
    empty = tmp_path / "bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    monkeypatch.delenv("CC", raising=False)
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.output.startswith("--c-extension:1:1: no C compiler found")
    assert not (tmp_path / "out").exists()
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc") + " -O3")
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "--c-extension:1:1: the C compiler CC=" in result.output


def test_failing_compiler_keeps_the_other_outputs_and_the_log(tmp_path, monkeypatch):
    fake = tmp_path / "fakecc"
    fake.write_text("#!/bin/sh\necho 'x.c:1:1: error: something broke' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--code", "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 1
    assert "the C compiler failed: x.c:1:1: error: something broke" in result.output
    log = tmp_path / "out" / "rp_arm_dynamics_c.log"
    assert (tmp_path / "out" / "rp_arm_dynamics.py").is_file() and "something broke" in log.read_text()
    assert str(log) in result.output


def test_robot_without_efforts_and_parameter_without_default(tmp_path):
    """NU = 0 (u omitted, B of shape (2n, 0)); a parameter without a default is a required
    keyword (TypeError without it, as in the NumPy module) and not in PARAMETERS."""
    path = tmp_path / "double_pendulum.yaml"
    path.write_text("\n".join(ln for ln in (ROBOTS / "double_pendulum.yaml").read_text().splitlines()
                              if "effort:" not in ln) + "\n")
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert not derivation.robot.efforts
    module = import_code(dynderive.render_code(derivation), tmp_path, "passive_pendulum_dynamics")
    _broadcast_agree(_load(derivation, tmp_path / "passive"), module, seed=9)
    path = tmp_path / "rp_arm.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("m: {value: 1.0, unit: kg,", "m: {unit: kg,"))
    derivation = dynderive.derive(dynderive.load_robot(path))
    ext = _load(derivation, tmp_path / "no_default")
    module = import_code(dynderive.render_code(derivation), tmp_path, "no_default_dynamics")
    assert ext.PARAMETERS == module.PARAMETERS and "m" not in ext.PARAMETERS
    for m in (module, ext):
        with pytest.raises(TypeError, match="missing 1 required keyword-only argument: 'm'"):
            m.mass_matrix(np.zeros(2))
    _broadcast_agree(ext, module, seed=10, parameters={"m": 2.5})


def test_no_python_headers_is_exit_2(tmp_path, monkeypatch):
    import dynderive.render.targets.c_extension.compile as compile_module

    monkeypatch.setattr(compile_module.sysconfig, "get_paths", lambda: {"include": str(tmp_path)})
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.output.startswith("--c-extension:1:1: Python's C headers (Python.h)")
    assert not (tmp_path / "out").exists()


def test_wrench_kernels_call_the_c_targets_wrench_functions():
    """The C target declares ``<name>_inverse_dynamics_wrenches`` (and the forward one) for every
    robot: the binding calls them, with no helpers of its own."""
    derivation = derivation_of("planar_3r")
    native = render_extension(derivation)
    assert "planar_3r_inverse_dynamics_wrenches(in[0], in[1], in[2], w, p, out[0]);" in native
    assert "return planar_3r_forward_dynamics_wrenches(in[0], in[1], in[2], w, p, out[0]);" in native
    assert "ext_inverse_dynamics_wrenches" not in native and "ext_solve" not in native


LOOP_FUNCTIONS = ["loop_constraints", "loop_jacobian", "loop_jacobian_dot", "loop_forces", "reduced_basis",
                  "reduced_forward_dynamics", "assemble"]
LOOP_ROBOTS = ["four_bar", "slider_crank", "bennett", "spatial_four_bar",
               *(str(p) for p in sorted((Path(__file__).parent / "loops").glob("*.yaml")))]


def _loop_states(module, seed: int, count: int):
    """``count`` assembled states (q, qd with A_g qd = 0, u) stacked, and q moved off the loops."""
    from test_c_loops import _states

    rng = np.random.default_rng(seed)
    q, qd, u = (np.array(a) for a in zip(*_states(module, rng, count), strict=True))
    return q, qd, u, q + rng.normal(scale=2e-2, size=q.shape)


def _agree_on_loops(ext, module, seed: int, parameters: dict | None = None, smoothing: float | None = None) -> None:
    """Every function of a loop robot's extension against the NumPy module at assembled
    states: one state, a batch of three, and a batch whose arguments broadcast."""
    kwargs = dict(parameters or {})
    friction = {} if smoothing is None else {"friction_smoothing": smoothing}
    q, qd, u, off = _loop_states(module, seed, 3)
    dependent = np.array([c not in module.INDEPENDENT_COORDINATES for c in module.COORDINATES], dtype=float)
    qdd = np.random.default_rng(seed).normal(size=q.shape[-1])
    for pick in (0, slice(None)):
        s, sd, su, so = q[pick], qd[pick], u[pick], off[pick]
        calls = [
            ("mass_matrix", (s,), {}), ("coriolis_matrix", (s, sd), {}), ("gravity_vector", (s,), {}),
            ("inverse_dynamics", (s, sd, qdd), friction), ("kinetic_energy", (s, sd), {}),
            ("potential_energy", (s,), {}), ("friction_forces", (sd,), friction), ("regressor", (s, sd, qdd), friction),
            ("loop_constraints", (so,), {}), ("loop_jacobian", (s,), {}), ("loop_jacobian_dot", (s, sd), {}),
            ("forward_dynamics", (s, sd, su), friction), ("forward_dynamics", (s, sd), friction),
            ("forward_dynamics", (s, sd, u[0]), friction),   # u broadcast over the batch
            ("forward_dynamics", (so, sd, su), dict(friction, alpha=2.0, beta=7.0)),   # off the loops: the gains act
            ("forward_dynamics", (s, sd, su), dict(friction, alpha=3.7)),
            ("loop_forces", (s, sd, su), friction), ("loop_forces", (s, sd), friction),
            ("reduced_basis", (s,), {}), ("reduced_forward_dynamics", (s, sd, su), friction),
            ("assemble", (s + 0.05 * dependent,), {}), ("linearize", (s, sd, su), friction),
        ]
        calls += [(f, (s, frame), {}) for frame in module.FRAMES for f in ("frame_transform", "frame_jacobian")]
        for name, args, extra in calls:
            got = getattr(ext, name)(*args, **extra, **kwargs)
            want = getattr(module, name)(*args, **extra, **kwargs)
            if name == "assemble":   # Newton's method stops at |a_g| < 1e-12: both roots are that close, and
                # the NumPy module's batch takes further steps on states that have converged (until all have)
                _close(got, want, f"assemble {np.shape(args[0])}", rtol=1e-10)
                assert np.max(np.abs(module.loop_constraints(got, **kwargs))) < 1e-12
                continue
            terms = 0.0
            if name in ("forward_dynamics", "reduced_forward_dynamics"):
                terms = acceleration_scale(module, *args[:2], args[2] if len(args) > 2 else np.zeros(len(module.EFFORTS)))
            for k, (g, w) in enumerate(zip(got, want, strict=True) if name == "linearize" else [(got, want)]):
                _close(g, w, f"{name}[{k}] {extra} {np.shape(args[0])}", terms=terms)
    gains = ext.forward_dynamics(off, qd, u, alpha=2.0, beta=7.0, **friction, **kwargs)
    assert np.max(np.abs(gains - ext.forward_dynamics(off, qd, u, **friction, **kwargs))) > 1e-6


@pytest.mark.parametrize("robot", LOOP_ROBOTS, ids=lambda r: Path(r).stem)
def test_loop_robot_agrees_with_numpy(robot, compiled):
    ext, module = compiled(robot)
    _agree_on_loops(ext, module, seed=stable_seed(robot))
    for constant in ("LOOPS", "INDEPENDENT_COORDINATES", "ASSEMBLED_CONFIGURATION", "PARAMETERS", "COORDINATES",
                     "EFFORTS", "FRAMES", "PARAMETER_VECTOR"):
        assert getattr(ext, constant) == getattr(module, constant), constant
        assert type(getattr(ext, constant)) is type(getattr(module, constant)), constant
    assert [type(x) for x in ext.ASSEMBLED_CONFIGURATION] == [type(x) for x in module.ASSEMBLED_CONFIGURATION]
    for name in FUNCTIONS + LOOP_FUNCTIONS:
        assert str(inspect.signature(getattr(ext, name))) == str(inspect.signature(getattr(module, name))), name


def test_loop_robot_with_keyword_parameters(compiled):
    ext, module = compiled("four_bar")
    _agree_on_loops(ext, module, seed=3, parameters={"m2": 2.5, "g": 3.0})


def test_dissipative_loop_robot_with_a_frame(tmp_path):
    """Damping, Coulomb friction (friction_smoothing, a negative one refused) and wrenches
    at a frame in forward_dynamics and loop_forces of a loop robot."""
    from test_c_loops import _framed_loop

    derivation = dynderive.derive(dynderive.load_robot(_framed_loop(tmp_path)))
    module = import_code(dynderive.render_code(derivation), tmp_path, "framed_damped_four_bar_dynamics")
    ext = _load(derivation, tmp_path / "ext")
    _agree_on_loops(ext, module, seed=12, smoothing=0.05)
    q, qd, u, _ = _loop_states(module, 13, 3)
    for w in (np.array([0.7, -1.1, 0.4]), np.random.default_rng(14).normal(size=(3, 3))):
        for name in ("forward_dynamics", "loop_forces"):
            with_wrench = getattr(ext, name)(q, qd, u, {"tip": w}, friction_smoothing=0.05)
            _close(with_wrench, getattr(module, name)(q, qd, u, {"tip": w}, friction_smoothing=0.05), f"{name} w")
            one = {"tip": w if w.ndim == 1 else w[0]}
            _close(getattr(ext, name)(q[0], qd[0], u[0], wrenches=one),
                   getattr(module, name)(q[0], qd[0], u[0], wrenches=one), f"{name} one state w")
            assert np.max(np.abs(with_wrench - getattr(ext, name)(q, qd, u, friction_smoothing=0.05))) > 1e-3
    for name in ("forward_dynamics", "loop_forces", "reduced_forward_dynamics"):
        for m in (module, ext):
            with pytest.raises(ValueError, match="friction_smoothing must not be negative, got -0.5"):
                getattr(m, name)(q, qd, friction_smoothing=-0.5)


def test_loop_keywords_and_failures(compiled):
    """alpha and beta only where the NumPy module takes them; assemble's failure is the NumPy
    module's ValueError (one state, or any state of a batch); a singular loop system is NaN for
    that state (the NumPy module raises LinAlgError for the whole call)."""
    ext, module = compiled("four_bar")
    tree, _ = compiled("rp_arm")
    q = np.array(module.ASSEMBLED_CONFIGURATION)
    for case in (lambda m: m.loop_forces(q, q, alpha=1.0), lambda m: m.reduced_forward_dynamics(q, q, beta=1.0),
                 lambda m: m.assemble(q, alpha=1.0), lambda m: m.linearize(q, q, alpha=1.0)):
        for m in (module, ext):
            with pytest.raises(TypeError, match="unexpected keyword argument"):
                case(m)
    with pytest.raises(TypeError, match="unexpected keyword argument 'alpha'"):
        tree.forward_dynamics(np.zeros(2), np.zeros(2), alpha=1.0)
    message = "assemble: the loop constraints could not be solved for these independent coordinates from this guess"
    guesses = np.array([q, q + 0.1, [0.3, np.nan, 1.0]])
    for m in (module, ext):
        with pytest.raises(ValueError, match=message):
            m.assemble(q, d=5.0)   # the ground link longer than the other three together
        with pytest.raises(ValueError, match=message):
            m.assemble(guesses)
    _close(ext.assemble(guesses[:2]), module.assemble(guesses[:2]), "assemble batch", rtol=1e-10)
    singular, qd, u = np.zeros(3), np.array([0.2, -0.1, 0.3]), np.ones(1)   # all links along x: rank 1
    with pytest.raises(np.linalg.LinAlgError):
        module.forward_dynamics(singular, qd, u)
    states = np.array([singular, q])
    for name, size in (("forward_dynamics", 3), ("loop_forces", 2), ("reduced_forward_dynamics", 3)):
        got = getattr(ext, name)(states, qd, u)
        assert got.shape == (2, size) and np.all(np.isnan(got[0])), name
        _close(got[1], getattr(module, name)(q, qd, u), name)
    assert np.all(np.isnan(ext.reduced_basis(singular))) and np.all(np.isnan(ext.linearize(singular, qd)[0]))


def test_loop_table_rows_and_the_cli(tmp_path):
    derivation = derivation_of("four_bar")
    table = {b.name: b for b in bindings(derivation)}
    assert sorted(table) == sorted(FUNCTIONS + LOOP_FUNCTIONS)
    assert table["forward_dynamics"].members == ("alpha", "beta") and table["assemble"].error
    assert all(not b.members for b in bindings(derivation_of("rp_arm")))
    result = CliRunner().invoke(app, ["solve", "four_bar", "--c-extension", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    run = subprocess.run([sys.executable, "-c", "import four_bar_dynamics_c as m; print(m.LOOPS, "
                          "m.loop_constraints(m.assemble(m.ASSEMBLED_CONFIGURATION)).tolist())"],
                         cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    loops, residual = run.stdout.split(" [")
    assert loops == "('c1',)" and max(abs(float(x)) for x in residual.strip("]\n").split(",")) < 1e-11


# -- floating base and spherical joints ------------------------------------------------------------
# test_free_flyer and test_spherical skip themselves without Pinocchio: the tests below import
# them, so that the rest of this file runs without it.

runner = CliRunner()


def _framed() -> str:
    """``test_free_flyer``'s box with a frame at the arm's tip."""
    from test_free_flyer import BOX

    return BOX + "frames:\n  - {name: tip, link: arm, origin: {xyz: [0.4, 0, 0]}}\n"


@pytest.fixture(scope="session")
def compiled_floating(tmp_path_factory):
    """``compiled_floating(key, text_or_path)`` -> (extension, NumPy module, robot), built once per key."""
    from test_free_flyer import _module

    cache = {}

    def get(key: str, source):
        if key not in cache:
            folder = tmp_path_factory.mktemp(f"fext_{key}")
            if isinstance(source, str):
                (folder / "robot.yaml").write_text(source)
                robot = dynderive.load_robot(folder / "robot.yaml")
            else:
                robot = dynderive.load_robot(source, floating_base=True)
            derivation = dynderive.derive(robot)
            cache[key] = (_load(derivation, folder / "ext"), _module(derivation, folder), derivation.robot)
        return cache[key]

    return get


def _close_floating(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _broadcast_agree_floating(ext, module, robot, seed: int, values: dict | None = None) -> None:
    """Every function of the extension against the NumPy module, one state and a batch whose
    arguments broadcast ((4, 3, size) with (3, size) and (size,)), at random unit quaternions."""
    rng = np.random.default_rng(seed)
    nq, nv, nu = module.NQ, module.NV, len(module.EFFORTS)
    kw = dict(values or {})
    for batch in ((), (4, 3)):
        q = random_configurations(robot, rng, int(np.prod(batch))).reshape(batch + (nq,))
        q1 = random_configurations(robot, rng, 3 if batch else 1).reshape(batch[1:] + (nq,))
        qd, qdd, u = rng.normal(size=batch[1:] + (nv,)), rng.normal(size=(nv,)), rng.normal(size=batch + (nu,))
        dt = rng.uniform(-1.0, 1.0, batch)
        calls = [
            ("mass_matrix", (q,), kw), ("coriolis_matrix", (q, qd), kw), ("gravity_vector", (q,), kw),
            ("inverse_dynamics", (q, qd, qdd), kw), ("forward_dynamics", (q, qd, u), kw),
            ("forward_dynamics", (q, qd), kw), ("kinetic_energy", (q, qd), kw), ("potential_energy", (q,), kw),
            ("linearize", (q, qd, u), kw), ("linearize", (q, qd), kw), ("regressor", (q, qd, qdd), kw),
            ("parameter_vector", (), kw), ("neutral_configuration", (), {}), ("integrate", (q, qd, 0.3), {}),
            ("integrate", (q, qd, dt), {}), ("integrate", (q, qd), {}), ("configuration_rate", (q, qd), {}),
            ("difference", (q, q1), {}), ("difference", (q1, q), {}),
        ]
        calls += [(f, (q, frame), kw) for frame in module.FRAMES for f in ("frame_transform", "frame_jacobian")]
        calls += [("frame_jacobian_dot_qd", (q, qd, frame), kw) for frame in module.FRAMES]
        for name, args, extra in calls:
            got, want = getattr(ext, name)(*args, **extra), getattr(module, name)(*args, **extra)
            if name == "linearize":
                assert isinstance(got, tuple) and len(got) == 2
                _close_floating(got[0], want[0], f"{name} A {batch}")
                _close_floating(got[1], want[1], f"{name} B {batch}")
            else:
                _close_floating(got, want, f"{name} {batch}")
                assert type(got) is type(want), f"{name}: {type(got)} != {type(want)}"


def test_keyword_parameters_constants_and_signatures(compiled_floating):
    ext, module, robot = compiled_floating("box", _framed())
    _broadcast_agree_floating(ext, module, robot, seed=5, values={"m": 2.5, "g": 9.7})
    for constant in ("NQ", "NV", "COORDINATES", "VELOCITIES", "EFFORTS", "FRAMES", "PARAMETERS", "PARAMETER_VECTOR"):
        assert getattr(ext, constant) == getattr(module, constant), constant
    functions = sorted(n for n, v in vars(module).items() if inspect.isfunction(v) and not n.startswith("_"))
    derivation = dynderive.derive(robot)
    assert sorted({b.name for b in bindings(derivation)} | contact_names(derivation)) == functions
    for name in functions:
        assert inspect.signature(getattr(ext, name)) == inspect.signature(getattr(module, name)), name
    big = random_configurations(robot, np.random.default_rng(2), 300)   # the batch loop without the GIL
    ones = np.ones(module.NV)
    _close_floating(ext.integrate(big, ones, 0.1), module.integrate(big, ones, 0.1), "300 states")
    _close_floating(ext.forward_dynamics(q=big, qd=ones, m=3.0), module.forward_dynamics(big, ones, m=3.0),
                    "keywords")


def test_errors_of_a_floating_robot_are_the_numpy_modules(compiled_floating):
    ext, module, _ = compiled_floating("box", _framed())
    q, v = module.neutral_configuration(), np.zeros(module.NV)
    for case, error in [(lambda m: m.mass_matrix(q[:7]), "q must have shape \\(..., 8\\), got \\(7,\\)"),
                        (lambda m: m.integrate(q, q), "v must have shape \\(..., 7\\), got \\(8,\\)"),
                        (lambda m: m.difference(q, v), "q_to must have shape \\(..., 8\\), got \\(7,\\)"),
                        (lambda m: m.frame_jacobian(q, "nowhere"), "unknown frame 'nowhere' \\(frames: tip\\)")]:
        for target in (module, ext):
            with pytest.raises(ValueError, match=error):
                case(target)
    for case in (lambda m: m.integrate(q, v, 0.1, m=2.0), lambda m: m.neutral_configuration(g=1.0),
                 lambda m: m.difference(q), lambda m: m.mass_matrix(q, mass=1.0)):
        for target in (module, ext):
            with pytest.raises(TypeError):
                case(target)
    with pytest.raises(ValueError, match="no arrays of parameter values"):
        ext.mass_matrix(q, m=np.array([1.0, 2.0]))


def test_a_mass_matrix_that_is_not_positive_definite_is_nan(compiled_floating):
    """A negative mass: the C target refuses to factor M; forward_dynamics and linearize give
    NaN (every state of the batch: the parameters are one), the other functions numbers."""
    ext, module, robot = compiled_floating("box", _framed())
    qs = random_configurations(robot, np.random.default_rng(3), 2)
    v, u = np.zeros(module.NV), np.ones(1)
    assert np.all(np.isnan(ext.forward_dynamics(qs, v, u, m=-1.0)))
    assert np.all(np.isnan(ext.forward_dynamics(qs[0], v, m=-1.0)))   # one state: the fast path's keywords
    for A, B in (ext.linearize(qs, v, u, m=-1.0), ext.linearize(qs[0], v, m=-1.0)):
        assert np.all(np.isnan(A)) and np.all(np.isnan(B))
    _close_floating(ext.mass_matrix(qs, m=-1.0), module.mass_matrix(qs, m=-1.0), "M at m = -1")
    assert np.all(np.isfinite(ext.forward_dynamics(qs, v, u)))


def test_hostile_text_stays_out_of_the_binding_and_the_c(tmp_path, compiled_floating):
    encoded = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    text = _framed().replace("title: A free box with an arm", f'title: "{encoded}"')
    text = text.replace("m: {value: 2.0, unit: kg}", f'm: {{value: 2.0, unit: kg, description: "{encoded}"}}')
    (tmp_path / "box.yaml").write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(tmp_path / "box.yaml"))
    assert derivation.robot.title == HOSTILE
    source = render_extension(derivation)
    assert "stdlib" not in source and all(ord(c) < 128 for c in source)
    plain = render_extension(dynderive.derive(dynderive.load_robot(_write(tmp_path / "plain", _framed()))))
    assert source == plain   # the title and the descriptions never reach the binding
    from dynderive.render.targets.c.c import render_c

    for c_text in render_c(derivation):   # in the C target: comments, printable ASCII
        assert all(ord(c) < 128 for c in c_text) and not any(line.lstrip().startswith("#include <stdlib")
                                                             for line in c_text.splitlines())
    ext = _load(derivation, tmp_path / "ext")
    _, module, robot = compiled_floating("box", _framed())
    _broadcast_agree_floating(ext, module, robot, seed=9)


def _write(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "box.yaml").write_text(text)
    return folder / "box.yaml"


def _unoptimized_commands(monkeypatch) -> None:
    """The commands build the extension at -O0, as ``_load`` does: the values are compared, not
    the speed (their -O2 build: ``test_solve_writes_an_importable_extension``, ``test_backend_c.py``)."""
    import functools

    from dynderive.render.targets.c_extension import compile as extension

    monkeypatch.setattr(extension, "build_extension", functools.partial(extension.build_extension, optimization="-O0"))


def test_solve_build_and_check_on_the_command_line(tmp_path, monkeypatch):
    _unoptimized_commands(monkeypatch)   # five builds of the box
    path = _write(tmp_path, _framed())
    name = "box_dynamics_c" + sysconfig.get_config_var("EXT_SUFFIX")
    result = runner.invoke(app, ["solve", str(path), "--c-extension", "--code", "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, result.output
    assert "every output is built except the MATLAB derivation script" in result.stderr
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == sorted(["box_dynamics.py", name])
    run = subprocess.run([sys.executable, "-c", "import numpy as np, box_dynamics as m, box_dynamics_c as c; "
                          "q = m.integrate(m.neutral_configuration(), np.arange(7.0) / 7, 1.0); "
                          "print(abs(c.mass_matrix(q) - m.mass_matrix(q)).max(), c.NQ, c.NV)"],
                         cwd=tmp_path / "a", capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    worst, nq, nv = run.stdout.split()
    assert float(worst) <= 1e-12 and (nq, nv) == ("8", "7")
    result = runner.invoke(app, ["solve", str(path), "--c", "--c-extension", "--out", str(tmp_path / "b"), "-q"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == sorted(["box_dynamics.h", "box_dynamics.c", name])
    result = runner.invoke(app, ["build", str(path), "--c-extension", "--out", str(tmp_path / "c"), "-j", "1"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "c" / name).is_file() and not (tmp_path / "c" / "box_dynamics.py").exists()
    result = runner.invoke(app, ["check", str(path), "--backend", "c", "--states", "3"])
    assert result.exit_code == 0, result.output
    for function in ("mass_matrix", "linearize", "integrate", "difference", "frame_jacobian_dot_qd (frame tip)"):
        assert f"compiled {function} == NumPy module" in result.stdout, function
    result = runner.invoke(app, ["check", str(path), "--backend", "c", "--states", "3", "--json", "-q"])
    rows = {r["name"]: r["status"] for r in json.loads(result.stdout)["checks"]}
    compiled_rows = [n for n in rows if n.startswith("compiled ")]
    # 21 functions, 9 centroidal, the two contact functions (the box declares no contacts: forward dynamics)
    # and inverse and forward dynamics with a wrench at every frame
    assert len(compiled_rows) == 33 and all(rows[n] == "pass" for n in compiled_rows)
    assert rows["compiled forward_dynamics with wrenches at every frame == NumPy module"] == "pass"


def test_failing_compiler_on_a_floating_robot_keeps_the_other_outputs_and_the_log(tmp_path, monkeypatch):
    from test_free_flyer import BOX

    fake = tmp_path / "fakecc"
    fake.write_text("#!/bin/sh\necho 'x.c:1:1: error: something broke' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    path = _write(tmp_path, BOX)
    result = runner.invoke(app, ["solve", str(path), "--c-extension", "--code", "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 1
    assert "the C compiler failed: x.c:1:1: error: something broke" in result.output
    log = tmp_path / "out" / "box_dynamics_c.log"
    assert (tmp_path / "out" / "box_dynamics.py").is_file() and "something broke" in log.read_text()


def test_simulate_with_the_c_backend_follows_the_numpy_run(tmp_path, monkeypatch):
    """``simulate --backend c`` of a floating robot (damping, smoothed Coulomb friction, a
    wrench at a frame, an effort): the compiled forward dynamics, configuration rate and
    friction give the NumPy run's trajectory and dissipated work."""
    from dynderive.render.targets.c_extension import compile as compile_command

    _unoptimized_commands(monkeypatch)
    called: dict[str, int] = {}
    build = compile_command.compiled_module

    class Counted:   # the extension, counting the integrator's calls
        def __init__(self, module):
            self.module = module

        def __getattr__(self, name):
            def call(*args, **kwargs):
                called[name] = called.get(name, 0) + 1
                return getattr(self.module, name)(*args, **kwargs)
            return call

    monkeypatch.setattr(compile_command, "compiled_module", lambda *a, **k: Counted(build(*a, **k)))
    from test_sheets_compile import _chain  # full-precision numbers, generic axes, full inertias

    text = _chain(12, 2).replace("effort: u2}", "effort: u2, damping: 0.0712345678901234, friction: 0.0312345678901234}") \
        + "frames:\n  - {name: tip, link: l2, origin: {xyz: [0.3123456789012345, 0.0123456789012345, -0.0234567890123456]}}\n"
    assert "damping: 0.0712345678901234" in text
    path = tmp_path / "chain.yaml"
    path.write_text(text)
    runs = {}
    for backend in ("numpy", "c"):
        csv = tmp_path / f"{backend}.csv"
        result = runner.invoke(app, ["simulate", str(path), "--backend", backend, "--duration", "0.4", "--frames", "5",
                                     "--effort", "u2=0.3*sin(3*t)", "--force", "tip=0.5,0,1.5*t,0,0.1,0",
                                     "--friction-smoothing", "0.01", "--qd0", "0.1,0,0.2,0.3,-0.2,0.1,1.0,-0.4",
                                     "--csv", str(csv), "-q"])
        assert result.exit_code == 0, result.output + result.stderr
        lines = csv.read_text().splitlines()
        assert lines[0].endswith(",energy,dissipated")
        runs[backend] = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    assert np.max(np.abs(runs["numpy"][-1] - runs["numpy"][0])) > 0.05   # it moved
    np.testing.assert_allclose(runs["c"], runs["numpy"], rtol=0, atol=1e-8)
    assert min(called.get(name, 0) for name in ("forward_dynamics", "configuration_rate", "friction_forces")) > 10
