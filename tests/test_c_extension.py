"""The Python extension of the C target (``solve --c-extension``): every function agrees with
the NumPy module to 1e-12 relative, one state and a broadcast batch, with keyword parameters,
``friction_smoothing`` and wrenches; the same signatures, constants and errors; the CLI flag,
no compiler (exit 2), a failing compiler (exit 1, the log kept); hostile text.

Needs a C compiler and Python's headers: skipped locally without them, required in CI (CI=true).
Each robot is compiled once per session, at -O1 (faster to compile; the CLI uses -O2).
"""

from __future__ import annotations

import importlib.util
import inspect
import os
import random
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
from dynderive.commands.compile import build_extension
from dynderive.render.c_extension import bindings, c_string, render_extension

from conftest import ROBOTS, derivation_of, import_code, module_of, random_tree_derivation

HEADERS = (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()
if not (shutil.which("gcc") or shutil.which("cc")) or not HEADERS:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C extension tests, but no C compiler or no Python.h was found")
    pytest.skip("no C compiler or no Python.h", allow_module_level=True)

RTOL = 1e-12
FUNCTIONS = ["mass_matrix", "coriolis_matrix", "gravity_vector", "inverse_dynamics", "forward_dynamics",
             "kinetic_energy", "potential_energy", "friction_forces", "linearize", "regressor", "parameter_vector",
             "frame_transform", "frame_jacobian", "frame_jacobian_dot_qd"]


def _load(derivation, folder: Path):
    """Compile ``derivation``'s extension into ``folder`` and import it (not into sys.modules:
    several robots of one name can be loaded side by side)."""
    folder.mkdir(parents=True, exist_ok=True)
    filename, data = build_extension(derivation, optimization="-O1")
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
        if robot not in cache:
            folder = tmp_path_factory.mktemp(f"ext_{robot}")
            cache[robot] = (_load(derivation_of(robot), folder), module_of(robot, str(folder)))
        return cache[robot]

    return get


def _close(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1e-300)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree(ext, module, seed: int, parameters: dict | None = None, smoothing: float | None = None) -> None:
    """Every function of the extension against the NumPy module, one state and a batch whose
    arguments broadcast ((4, 3, n) with (3, n) and (n,))."""
    rng = np.random.default_rng(seed)
    n, nu = len(module.COORDINATES), len(module.EFFORTS)
    kwargs = dict(parameters or {})
    friction = {} if smoothing is None else {"friction_smoothing": smoothing}
    for batch in ((), (4, 3)):
        q = rng.uniform(-1.5, 1.5, batch + (n,))
        qd, qdd, u = rng.normal(size=batch[1:] + (n,)), rng.normal(size=(n,)), rng.normal(size=batch + (nu,))
        calls = [
            ("mass_matrix", (q,), {}), ("coriolis_matrix", (q, qd), {}), ("gravity_vector", (q,), {}),
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


BUNDLED = ["rp_arm", "planar_3r", "cart_pole_damped", "elbow_arm", "mass_spring_damper", "panda", "ur5"]


@pytest.mark.parametrize("robot", BUNDLED)
def test_bundled_robot_agrees_with_numpy(robot, compiled):
    ext, module = compiled(robot)
    _agree(ext, module, seed=len(robot))


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
    _agree(ext, module, seed=5, parameters=values, smoothing=0.05)
    _agree(ext, module, seed=6, parameters={"mp": 0.3, "fc": 0.4}, smoothing=0.0)
    qd = np.array([0.02, -0.04])
    assert not np.allclose(ext.friction_forces(qd, friction_smoothing=0.05), ext.friction_forces(qd))


def test_random_planar_trees(tmp_path, code_dir):
    """Three coordinates: the explicit M, C, N, V; five: the programs."""
    for seed, joints in ((11, 3), (13, 5)):
        derivation, module = random_tree_derivation(seed, joints, str(code_dir))
        _agree(_load(derivation, tmp_path / str(seed)), module, seed=seed)


def test_random_spatial_tree(tmp_path):
    from random_robots3d import random_spatial_tree

    tree = random_spatial_tree(random.Random(21), 4)
    path = tmp_path / "random_spatial.yaml"
    path.write_text(tree.yaml_text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), tmp_path, "random_spatial_21_dynamics")
    _agree(_load(derivation, tmp_path / "ext"), module, seed=21)


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


@pytest.mark.parametrize("robot", ["four_bar"])
def test_closed_loops_are_refused(robot, tmp_path):
    result = CliRunner().invoke(app, ["solve", robot, "--c-extension", "--code", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--c-extension: closed loops are not built yet" in result.output
    assert list(tmp_path.iterdir()) == []


def test_robot_without_efforts_and_parameter_without_default(tmp_path):
    """NU = 0 (u omitted, B of shape (2n, 0)); a parameter without a default is a required
    keyword (TypeError without it, as in the NumPy module) and not in PARAMETERS."""
    path = tmp_path / "double_pendulum.yaml"
    path.write_text("\n".join(ln for ln in (ROBOTS / "double_pendulum.yaml").read_text().splitlines()
                              if "effort:" not in ln) + "\n")
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert not derivation.robot.efforts
    module = import_code(dynderive.render_code(derivation), tmp_path, "passive_pendulum_dynamics")
    _agree(_load(derivation, tmp_path / "passive"), module, seed=9)
    path = tmp_path / "rp_arm.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("m: {value: 1.0, unit: kg,", "m: {unit: kg,"))
    derivation = dynderive.derive(dynderive.load_robot(path))
    ext = _load(derivation, tmp_path / "no_default")
    module = import_code(dynderive.render_code(derivation), tmp_path, "no_default_dynamics")
    assert ext.PARAMETERS == module.PARAMETERS and "m" not in ext.PARAMETERS
    for m in (module, ext):
        with pytest.raises(TypeError, match="missing 1 required keyword-only argument: 'm'"):
            m.mass_matrix(np.zeros(2))
    _agree(ext, module, seed=10, parameters={"m": 2.5})


def test_no_python_headers_is_exit_2(tmp_path, monkeypatch):
    import dynderive.commands.compile as compile_module

    monkeypatch.setattr(compile_module.sysconfig, "get_paths", lambda: {"include": str(tmp_path)})
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c-extension", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.output.startswith("--c-extension:1:1: Python's C headers (Python.h)")
    assert not (tmp_path / "out").exists()


def test_wrench_kernels_call_the_c_targets_wrench_functions_once_it_has_them():
    """Where the C header declares ``<name>_inverse_dynamics_wrenches`` (and the forward one),
    the binding calls them instead of its own helpers."""
    derivation = derivation_of("planar_3r")
    own = render_extension(derivation)
    assert "ext_inverse_dynamics_wrenches(in[0], in[1], in[2], w, p, out[0])" in own
    header = ("void planar_3r_inverse_dynamics_wrenches(const double *q, ...);\n"
              "int planar_3r_forward_dynamics_wrenches(const double *q, ...);\n")
    native = render_extension(derivation, header=header)
    assert "planar_3r_inverse_dynamics_wrenches(in[0], in[1], in[2], w, p, out[0]);" in native
    assert "return planar_3r_forward_dynamics_wrenches(in[0], in[1], in[2], w, p, out[0]);" in native
    assert "ext_inverse_dynamics_wrenches" not in native and "ext_solve" not in native
