"""The Python extension of a floating-base robot's C target (``solve --c-extension``,
``render/targets/c_extension/c_extension.py``): every function agrees with the floating NumPy module
(which agrees with Pinocchio's free flyer: ``test_floating_base.py``) to 1e-12 relative at
random unit quaternions, one state and a broadcast batch: solo12 from example-robot-data,
random trees with spherical joints on a fixed and a floating base, a
free box with parameters; the same constants, signatures and errors; NaN where M is not
positive definite; ``solve``/``build --c-extension`` and ``check --backend c``; a failing
compiler; hostile text.

Needs a C compiler and Python's headers: skipped locally without them, required in CI (CI=true).
Each robot is compiled once per session, at -O0 (solo12's 0.9 MB of C: 8 s; the CLI uses -O2).
"""

from __future__ import annotations

import inspect
import json
import os
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
from dynderive.render.targets.c_extension.c_extension import bindings, render_extension
from dynderive.verify.checks import random_configurations

HEADERS = (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()
if not (shutil.which("gcc") or shutil.which("cc")) or not HEADERS:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C extension tests, but no C compiler or no Python.h was found")
    pytest.skip("no C compiler or no Python.h", allow_module_level=True)

from test_c_extension import _load as _load_extension  # noqa: E402
from test_floating_base import BOX, _example_robot, _module  # noqa: E402
from test_spherical import _tree as _spherical_tree  # noqa: E402

RTOL = 1e-12
runner = CliRunner()
#: The box with a frame at the arm's tip.
FRAMED = BOX + "frames:\n  - {name: tip, link: arm, origin: {xyz: [0.4, 0, 0]}}\n"


def _load(derivation, folder: Path):
    """The extension compiled at -O0 (solo12's C takes minutes at -O1) and imported."""
    return _load_extension(derivation, folder, "-O0")


@pytest.fixture(scope="session")
def compiled(tmp_path_factory):
    """``compiled(key, text_or_path)`` -> (extension, NumPy module, robot), built once per key."""
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
            cache[key] = (_load(derivation, folder / "ext"), _module(derivation.robot, folder), derivation.robot)
        return cache[key]

    return get


def _close(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree(ext, module, robot, seed: int, values: dict | None = None) -> None:
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
                _close(got[0], want[0], f"{name} A {batch}")
                _close(got[1], want[1], f"{name} B {batch}")
            else:
                _close(got, want, f"{name} {batch}")
                assert type(got) is type(want), f"{name}: {type(got)} != {type(want)}"


@pytest.mark.pinocchio
def test_solo12_agrees_with_the_numpy_module(compiled):
    path = _example_robot("solo_description/robots/solo12.urdf")
    ext, module, robot = compiled("solo12", path)
    assert (ext.NQ, ext.NV, len(ext.FRAMES)) == (19, 18, len(module.FRAMES))
    _agree(ext, module, robot, seed=1)


@pytest.mark.parametrize("floating", [False, True])
def test_random_trees_with_spherical_joints_agree_with_the_numpy_module(floating, compiled):
    ext, module, robot = compiled(f"spherical_{floating}", _spherical_tree(7, floating))
    assert any(j.type == "spherical" for j in robot.joints)
    assert any(j.type == "floating" for j in robot.joints) == floating
    _agree(ext, module, robot, seed=7)


def test_keyword_parameters_constants_and_signatures(compiled):
    ext, module, robot = compiled("box", FRAMED)
    _agree(ext, module, robot, seed=5, values={"m": 2.5, "g": 9.7})
    for constant in ("NQ", "NV", "COORDINATES", "VELOCITIES", "EFFORTS", "FRAMES", "PARAMETERS", "PARAMETER_VECTOR"):
        assert getattr(ext, constant) == getattr(module, constant), constant
    functions = sorted(n for n, v in vars(module).items() if inspect.isfunction(v) and not n.startswith("_"))
    assert sorted(b.name for b in bindings(dynderive.derive(robot))) == functions
    for name in functions:
        assert inspect.signature(getattr(ext, name)) == inspect.signature(getattr(module, name)), name
    big = random_configurations(robot, np.random.default_rng(2), 300)   # the batch loop without the GIL
    _close(ext.integrate(big, np.ones(module.NV), 0.1), module.integrate(big, np.ones(module.NV), 0.1), "300 states")
    _close(ext.forward_dynamics(q=big, qd=np.ones(module.NV), m=3.0), module.forward_dynamics(big, np.ones(module.NV),
                                                                                               m=3.0), "keywords")


def test_errors_are_the_numpy_modules(compiled):
    ext, module, _ = compiled("box", FRAMED)
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


def test_a_mass_matrix_that_is_not_positive_definite_is_nan(compiled):
    """A negative mass: the C target refuses to factor M; forward_dynamics and linearize give
    NaN (every state of the batch: the parameters are one), the other functions numbers."""
    ext, module, robot = compiled("box", FRAMED)
    qs = random_configurations(robot, np.random.default_rng(3), 2)
    v, u = np.zeros(module.NV), np.ones(1)
    assert np.all(np.isnan(ext.forward_dynamics(qs, v, u, m=-1.0)))
    assert np.all(np.isnan(ext.forward_dynamics(qs[0], v, m=-1.0)))   # one state: the fast path's keywords
    for A, B in (ext.linearize(qs, v, u, m=-1.0), ext.linearize(qs[0], v, m=-1.0)):
        assert np.all(np.isnan(A)) and np.all(np.isnan(B))
    _close(ext.mass_matrix(qs, m=-1.0), module.mass_matrix(qs, m=-1.0), "M at m = -1")
    assert np.all(np.isfinite(ext.forward_dynamics(qs, v, u)))


HOSTILE = 'a */ int x; /* b\n#include <stdlib.h>\r\\ ??/ ??= // c \u202e\x00 \U0001f600 "q\' */ 7'


def test_hostile_text_stays_out_of_the_binding_and_the_c(tmp_path, compiled):
    encoded = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    text = FRAMED.replace("title: A free box with an arm", f'title: "{encoded}"')
    text = text.replace("m: {value: 2.0, unit: kg}", f'm: {{value: 2.0, unit: kg, description: "{encoded}"}}')
    (tmp_path / "box.yaml").write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(tmp_path / "box.yaml"))
    assert derivation.robot.title == HOSTILE
    source = render_extension(derivation)
    assert "stdlib" not in source and all(ord(c) < 128 for c in source)
    plain = render_extension(dynderive.derive(dynderive.load_robot(_write(tmp_path / "plain", FRAMED))))
    assert source == plain   # the title and the descriptions never reach the binding
    from dynderive.render.targets.c.c import render_c

    for c_text in render_c(derivation):   # in the C target: comments, printable ASCII
        assert all(ord(c) < 128 for c in c_text) and not any(line.lstrip().startswith("#include <stdlib")
                                                             for line in c_text.splitlines())
    ext = _load(derivation, tmp_path / "ext")
    _, module, robot = compiled("box", FRAMED)
    _agree(ext, module, robot, seed=9)


def _write(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "box.yaml").write_text(text)
    return folder / "box.yaml"


def test_solve_build_and_check_on_the_command_line(tmp_path):
    path = _write(tmp_path, FRAMED)
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
    assert len(compiled_rows) == 21 and all(rows[n] == "pass" for n in compiled_rows)


def test_failing_compiler_keeps_the_other_outputs_and_the_log(tmp_path, monkeypatch):
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
    from test_floating_sheet import _chain  # full-precision numbers, generic axes, full inertias

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
