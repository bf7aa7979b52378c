"""The C target (``solve --c``): every supported robot compiles with strict warnings as C99
and as C++, and its functions, called through ``ctypes``, agree with the NumPy module at
random full-precision states to 1e-12 relative; hostile names and text; refusals.

Floating-base robots too: every function agrees with the NumPy floating module (which agrees
with Pinocchio's free flyer: ``test_free_flyer.py``) to 1e-12 relative at random unit
quaternions and full-precision states: solo12 from example-robot-data, random floating trees
with full-precision numbers, random trees with spherical joints, a free box with a parameter in
the struct; forward dynamics and linearize refuse a mass matrix that is not positive definite;
``solve --c`` and ``build --c`` write the files.

Needs a C compiler: skipped locally without one, required in CI (CI=true).
"""

from __future__ import annotations

import ctypes
import os
import random
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.codegen.names import c_comment
from dynderive.render.targets.c.c import render_c
from dynderive.verify.checks import random_configurations

from conftest import ROBOTS, derivation_of, import_code, module_of, random_tree_derivation, stable_seed

CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++")
if CC is None:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C target tests, but no C compiler (gcc or cc) was found")
    pytest.skip("no C compiler", allow_module_level=True)
if CXX is None and os.environ.get("CI"):
    raise RuntimeError("CI must compile the C target as C++ too, but g++ was not found")

STRICT = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1"]
RTOL = 1e-12
SUPPORTED = sorted(p.stem for p in ROBOTS.glob("*.yaml")) + ["panda", "ur5"]
P = ctypes.POINTER(ctypes.c_double)


def _write(derivation, directory: Path) -> Path:
    header, source = render_c(derivation)
    name = derivation.robot.name
    (directory / f"{name}_dynamics.h").write_text(header)
    path = directory / f"{name}_dynamics.c"
    path.write_text(source)
    return path


def _compile(path: Path, *flags: str) -> None:
    """Compile ``path`` as strict C99 (and as C++ when g++ exists); assert no diagnostic.
    ``-Wshadow`` too: no local may hide a function of <math.h> (POSIX's ``y0``, ``j1``).
    ``-fPIC``: ``Library`` links this object into its shared library (no second compile)."""
    for command in ([CC, *STRICT, "-Wshadow", "-fPIC", "-c", str(path), "-o", str(path.with_suffix(".o"))],
                    *([[CXX, "-x", "c++", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-c", str(path),
                        "-o", str(path.with_suffix(".cpp.o"))]] if CXX else [])):
        run = subprocess.run(command + list(flags), capture_output=True, text=True)
        assert run.returncode == 0 and not run.stderr, f"{' '.join(command)}:\n{run.stderr}"


class Library:
    """The generated functions of one robot, from a shared library, called on NumPy arrays
    (``flags``: added to the compiler's, e.g. -O0 after STRICT's -O1)."""

    def __init__(self, derivation, directory: Path, *flags: str):
        directory.mkdir(parents=True, exist_ok=True)
        path = _write(derivation, directory)
        _compile(path, *flags)
        shared = path.with_suffix(".so")   # the object _compile checked, at the same level
        subprocess.run([CC, "-shared", str(path.with_suffix(".o")), "-o", str(shared), "-lm"], check=True)
        self.lib = ctypes.CDLL(str(shared))
        self.name = derivation.robot.name
        self.n = len(derivation.symbols.q)
        self.nu = len(derivation.symbols.efforts)
        self.frames = len(derivation.robot.frames)
        self.planar = derivation.robot.planar
        for function, restype in (("kinetic_energy", ctypes.c_double), ("potential_energy", ctypes.c_double)):
            getattr(self.lib, f"{self.name}_{function}").restype = restype

    def call(self, function: str, inputs: list, out_size: int | tuple[int, ...], p=None, frame: int | None = None):
        """``function(*inputs, [frame,] p, *outputs)``: its return value and its outputs
        (concatenated when there are several), pre-filled with NaN."""
        arrays = [np.ascontiguousarray(a, dtype=float) for a in inputs]
        outs = [np.full(size, np.nan) for size in (out_size if isinstance(out_size, tuple) else (out_size,))]
        args = [a.ctypes.data_as(P) for a in arrays]
        if frame is not None:
            args.append(ctypes.c_int(frame))
        params = None if p is None else np.ascontiguousarray(p, dtype=float)
        args.append(None if params is None else params.ctypes.data_as(P))
        result = getattr(self.lib, f"{self.name}_{function}")(*args, *(o.ctypes.data_as(P) for o in outs))
        return result, np.concatenate(outs)

    def value(self, function: str, inputs: list, p=None) -> float:
        arrays = [np.ascontiguousarray(a, dtype=float) for a in inputs]
        params = None if p is None else np.ascontiguousarray(p, dtype=float)
        return getattr(self.lib, f"{self.name}_{function}")(*[a.ctypes.data_as(P) for a in arrays],
                                                             None if params is None else params.ctypes.data_as(P))


def _close(actual, expected, what: str, terms: float = 0.0) -> None:
    """Equal to RTOL of the expected value's size, or of ``terms``, the size of the terms that
    cancel in it, if larger."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    scale = max(float(np.max(np.abs(expected), initial=0.0)), terms, 1e-300)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree(library: Library, module, seed: int, states: int = 4, parameters: dict | None = None) -> None:
    """Every C function through ctypes (the parameters struct, the status codes, a frame index
    out of range) against the NumPy module at random full-precision states, the library compiled
    as strict C99 and C++ with no diagnostic (the C target's own checks; the values of every
    robot class through the extension: ``test_targets_agree.py``)."""
    rng = np.random.default_rng(seed)
    n, nu = library.n, library.nu
    kwargs = parameters or {}
    p = None if parameters is None else [*(parameters[k] for k in module.PARAMETERS), 0.0]   # + friction_smoothing
    for _ in range(states):
        q, qd, qdd = rng.uniform(-1.5, 1.5, n), rng.normal(size=n), rng.normal(size=n)
        u = rng.normal(size=nu)
        _, M = library.call("mass_matrix", [q], n * n, p)
        _close(M.reshape(n, n), module.mass_matrix(q, **kwargs), "mass_matrix")
        _, C = library.call("coriolis_matrix", [q, qd], n * n, p)
        _close(C.reshape(n, n), module.coriolis_matrix(q, qd, **kwargs), "coriolis_matrix")
        _, N = library.call("gravity_vector", [q], n, p)
        _close(N, module.gravity_vector(q, **kwargs), "gravity_vector")
        _, F = library.call("friction_forces", [qd], n, p)
        _close(F, module.friction_forces(qd, **kwargs), "friction_forces")
        _, Y = library.call("generalized_forces", [q, u], n, p)
        _close(Y, module.generalized_forces(q, u, **kwargs), "generalized_forces")
        _, tau = library.call("inverse_dynamics", [q, qd, qdd], n, p)
        _close(tau, module.inverse_dynamics(q, qd, qdd, **kwargs), "inverse_dynamics")
        status, acc = library.call("forward_dynamics", [q, qd, u], n, p)
        assert status == 0
        _close(acc, module.forward_dynamics(q, qd, u, **kwargs), "forward_dynamics")
        status, AB = library.call("linearize", [q, qd, u], (4 * n * n, 2 * n * nu), p)
        A, B = module.linearize(q, qd, u, **kwargs)
        assert status == 0
        _close(AB[:4 * n * n].reshape(2 * n, 2 * n), A, "linearize A")
        _close(AB[4 * n * n:].reshape(2 * n, nu), B, "linearize B")
        count = len(module.PARAMETER_VECTOR)
        _, Y = library.call("regressor", [q, qd, qdd], n * count, p)
        _close(Y.reshape(n, count), module.regressor(q, qd, qdd, **kwargs), "regressor")
        _, pi = library.call("parameter_vector", [], count, p)
        _close(pi, module.parameter_vector(**kwargs), "parameter_vector")
        _close(library.value("kinetic_energy", [q, qd], p), module.kinetic_energy(q, qd, **kwargs), "kinetic_energy")
        _close(library.value("potential_energy", [q], p), module.potential_energy(q, **kwargs), "potential_energy")
        size, twist = (3, 3) if library.planar else (4, 6)
        for index, frame in enumerate(module.FRAMES):
            status, T = library.call("frame_transform", [q], size * size, p, index)
            assert status == 0
            _close(T.reshape(size, size), module.frame_transform(q, frame, **kwargs), f"frame_transform {frame}")
            _, J = library.call("frame_jacobian", [q], twist * n, p, index)
            _close(J.reshape(twist, n), module.frame_jacobian(q, frame, **kwargs), f"frame_jacobian {frame}")
            _, a = library.call("frame_jacobian_dot_qd", [q, qd], twist, p, index)
            _close(a, module.frame_jacobian_dot_qd(q, qd, frame, **kwargs), f"frame_jacobian_dot_qd {frame}")
        status, T = library.call("frame_transform", [q], size * size, p, len(module.FRAMES))
        assert status == 1 and np.all(np.isnan(T))   # no such frame: refused, output untouched


@pytest.mark.parametrize("robot", SUPPORTED)
def test_bundled_robot_agrees_with_numpy(robot, tmp_path, code_dir):
    library = Library(derivation_of(robot), tmp_path)
    _agree(library, module_of(robot, str(code_dir)), seed=stable_seed(robot))


def test_parameters_struct_is_read(tmp_path, code_dir):
    """A parameters struct other than the defaults reaches every function (member order)."""
    library = Library(derivation_of("double_pendulum"), tmp_path)
    module = module_of("double_pendulum", str(code_dir))
    rng = np.random.default_rng(7)
    values = {k: float(v) * (1 + rng.uniform(0.1, 0.9)) for k, v in module.PARAMETERS.items()}
    _agree(library, module, seed=3, states=2, parameters=values)


@pytest.mark.parametrize("seed, joints", [(11, 3), (12, 4), (13, 5)])
def test_random_planar_tree(seed, joints, tmp_path, code_dir):
    """Small trees print the explicit M, C, N, V; five coordinates print the programs."""
    derivation, module = random_tree_derivation(seed, joints, str(code_dir))
    assert derivation.structured_code == (len(derivation.symbols.q) > 4)
    _agree(Library(derivation, tmp_path), module, seed=seed)


def test_parameter_without_default_is_nan(tmp_path, code_dir):
    """A parameter the file gives no value is NaN in the defaults (every result NaN, none
    silently made up), and the struct passed in is used."""
    path = tmp_path / "rp_arm.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("m: {value: 1.0, unit: kg,", "m: {unit: kg,"))
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.parameters[0].value is None
    library = Library(derivation, tmp_path / "c")
    _, M = library.call("mass_matrix", [[0.3, 0.2]], 4)
    assert np.isnan(M[0]) and np.isnan(M[3])
    module = module_of("rp_arm", str(code_dir))
    _, M = library.call("mass_matrix", [[0.3, 0.2]], 4, [1.0, 1.0, 9.81, 0.0])
    _close(M.reshape(2, 2), module.mass_matrix([0.3, 0.2]), "mass_matrix")


@pytest.mark.parametrize("seed", [21, 22])
def test_random_spatial_tree(seed, tmp_path):
    from random_robots3d import random_spatial_tree

    tree = random_spatial_tree(random.Random(seed), 4)
    path = tmp_path / "random_spatial.yaml"
    path.write_text(tree.yaml_text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), tmp_path, f"random_spatial_{seed}_dynamics")
    _agree(Library(derivation, tmp_path / "c"), module, seed=seed)


def test_forward_dynamics_refuses_a_mass_matrix_that_is_not_positive_definite(tmp_path, code_dir):
    library = Library(derivation_of("rp_arm"), tmp_path)
    module = module_of("rp_arm", str(code_dir))
    p = [*(-1.0 if k == "m" else float(v) for k, v in module.PARAMETERS.items()), 0.0]   # a negative mass
    status, qdd = library.call("forward_dynamics", [[0.3, 0.2], [0.1, 0.0], [1.0, 2.0]], 2, p)
    assert status == 1 and np.all(np.isnan(qdd))


def test_no_mutable_globals(tmp_path):
    """The object file holds no writable data (thread-safe): only code and read-only data."""
    if shutil.which("nm") is None:
        pytest.skip("no nm")
    path = _write(derivation_of("double_pendulum"), tmp_path)
    _compile(path)
    symbols = subprocess.run(["nm", str(path.with_suffix(".o"))], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-2] for line in symbols.splitlines() if len(line.split()) >= 2}
    assert "R" in kinds and not kinds & set("BbDdCGgSs"), symbols


def test_sanitizers(tmp_path, code_dir):
    """One robot under -fsanitize=address,undefined: a C driver calls every function and its
    printed results (17 digits) agree with the NumPy module."""
    derivation = derivation_of("ur5")
    path = _write(derivation, tmp_path)
    module = module_of("ur5", str(code_dir))
    n = len(derivation.symbols.q)
    rng = np.random.default_rng(5)
    q, qd, qdd, u = (rng.normal(size=n) for _ in range(4))
    literal = lambda v: "{" + ", ".join(repr(float(x)) for x in v) + "}"   # noqa: E731
    driver = tmp_path / "driver.c"
    driver.write_text(f"""#include <stdio.h>
#include "ur5_dynamics.h"
int main(void)
{{
    const double q[] = {literal(q)}, qd[] = {literal(qd)}, qdd[] = {literal(qdd)}, u[] = {literal(u)};
    double M[{n * n}], C[{n * n}], N[{n}], tau[{n}], acc[{n}], J[{6 * n}], A[{4 * n * n}], B[{2 * n * n}], Y[{n * len(module.PARAMETER_VECTOR)}];
    int i, status;
    ur5_mass_matrix(q, 0, M); ur5_coriolis_matrix(q, qd, 0, C); ur5_gravity_vector(q, 0, N);
    ur5_inverse_dynamics(q, qd, qdd, 0, tau); status = ur5_forward_dynamics(q, qd, u, 0, acc);
    ur5_frame_jacobian(q, 0, 0, J);
    if (ur5_linearize(q, qd, u, 0, A, B) != 0) return 2;
    ur5_regressor(q, qd, qdd, 0, Y);
    for (i = 0; i < {n * n}; i++) printf("%.17g %.17g\\n", M[i], C[i]);
    for (i = 0; i < {n}; i++) printf("%.17g %.17g %.17g\\n", N[i], tau[i], acc[i]);
    for (i = 0; i < {6 * n}; i++) printf("%.17g\\n", J[i]);
    for (i = 0; i < {4 * n * n}; i++) printf("%.17g\\n", A[i]);
    printf("%d %.17g\\n", status, ur5_kinetic_energy(q, qd, 0) + ur5_potential_energy(q, 0));
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
    numbers = [float(x) for x in result.stdout.split()]
    k = 2 * n * n
    MC = np.array(numbers[:k]).reshape(n * n, 2)
    _close(MC[:, 0].reshape(n, n), module.mass_matrix(q), "mass_matrix")
    _close(MC[:, 1].reshape(n, n), module.coriolis_matrix(q, qd), "coriolis_matrix")
    rest = np.array(numbers[k:k + 3 * n]).reshape(n, 3)
    _close(rest[:, 0], module.gravity_vector(q), "gravity_vector")
    _close(rest[:, 1], module.inverse_dynamics(q, qd, qdd), "inverse_dynamics")
    _close(rest[:, 2], module.forward_dynamics(q, qd, u), "forward_dynamics")
    J = np.array(numbers[k + 3 * n:k + 3 * n + 6 * n]).reshape(6, n)
    _close(J, module.frame_jacobian(q, module.FRAMES[0]), "frame_jacobian")
    A = np.array(numbers[k + 9 * n:k + 9 * n + 4 * n * n]).reshape(2 * n, 2 * n)
    _close(A, module.linearize(q, qd, u)[0], "linearize A")
    status, energy = numbers[-2:]
    assert status == 0
    _close(energy, module.kinetic_energy(q, qd) + module.potential_energy(q), "energy")


HOSTILE = 'a */ int x; /* b\n#include <stdlib.h>\r\\ ??/ ??= // c \u202e\x00 \U0001f600 "q\' */'


def _decode(text: str) -> str:
    return re.sub(r"\\(x[0-9a-f]{2}|u[0-9a-f]{4}|U[0-9a-f]{8}|.)",
                  lambda m: chr(int(m.group(1)[1:], 16)) if len(m.group(1)) > 1 else m.group(1), text)


def test_c_comment_cannot_break_out():
    text = c_comment(HOSTILE)
    assert _decode(text) == HOSTILE
    assert "*/" not in text and "/*" not in text and "//" not in text and "??" not in text
    assert all(" " <= c <= "~" for c in text)


def _hostile_robot(tmp_path: Path, parameter: str = "m") -> Path:
    text = (ROBOTS / "rp_arm.yaml").read_text()
    title = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    lines = []
    for line in text.splitlines():
        if line.startswith("title:"):
            line = f'title: "{title}"'
        lines.append(line)
    text = "\n".join(lines).replace("description: mass of each link", f'description: "{title}"') + "\n"
    if parameter != "m":
        text = text.replace("\n  m:", f"\n  {parameter}:").replace("m*", f"{parameter}*").replace(" m\n", f" {parameter}\n")
    path = tmp_path / "rp_arm.yaml"
    path.write_text(text)
    return path


def test_hostile_text_compiles_as_c_and_cpp(tmp_path):
    derivation = dynderive.derive(dynderive.load_robot(_hostile_robot(tmp_path)))
    assert derivation.robot.title == HOSTILE and derivation.robot.parameters[0].description == HOSTILE
    path = _write(derivation, tmp_path)
    _compile(path)
    header = path.with_suffix(".h").read_text()
    assert not [ln for ln in header.splitlines() if ln.startswith("#include")]
    assert all(ln.count("/*") == ln.count("*/") <= 1 for ln in header.splitlines())
    assert _decode(header.splitlines()[0].split("equations of motion of ", 1)[1][:-3]) == HOSTILE


@pytest.mark.parametrize("name", ["new", "NAN", "double", "RP_ARM_NQ", "RP_ARM_NC"])
def test_parameter_names_that_are_not_c_names_are_refused(tmp_path, name):
    path = _hostile_robot(tmp_path, name)
    robot = dynderive.load_robot(path)
    assert name in [p.name for p in robot.parameters]
    result = CliRunner().invoke(app, ["solve", str(path), "--c", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    line = [ln for ln in result.output.splitlines() if f"'{name}'" in ln][0]
    where = line.split(": ")[0].split(":")
    assert where[0].endswith("rp_arm.yaml") and int(where[1]) > 1 and f"parameter name '{name}'" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["_arm", "my__arm"])
def test_robot_names_that_are_not_c_prefixes_are_refused(tmp_path, name):
    path = tmp_path / "arm.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("name: rp_arm", f"name: {name}"))
    result = CliRunner().invoke(app, ["solve", str(path), "--c", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert f"arm.yaml:4:7: --c: robot name '{name}' is not a C identifier" in result.output
    assert not (tmp_path / "out").exists()


def test_smoothed_friction_from_the_struct(tmp_path, code_dir):
    """friction_smoothing (the struct's last member) reaches the
    friction, inverse and forward dynamics as the NumPy module's keyword does."""
    library = Library(derivation_of("cart_pole_damped"), tmp_path)
    module = module_of("cart_pole_damped", str(code_dir))
    p = [*map(float, module.PARAMETERS.values()), 0.05]
    q, qd, u = np.array([0.3, -0.7]), np.array([0.02, -0.04]), np.array([1.5])
    for eps, struct in ((0.05, p), (0.0, None)):
        _, F = library.call("friction_forces", [qd], 2, struct)
        _close(F, module.friction_forces(qd, friction_smoothing=eps), "friction_forces")
        _, acc = library.call("forward_dynamics", [q, qd, u], 2, struct)
        _close(acc, module.forward_dynamics(q, qd, u, friction_smoothing=eps), "forward_dynamics")
        _, tau = library.call("inverse_dynamics", [q, qd, acc], 2, struct)
        _close(tau, module.inverse_dynamics(q, qd, acc, friction_smoothing=eps), "inverse_dynamics")
        _, AB = library.call("linearize", [q, qd, u], (16, 4), struct)
        A, B = module.linearize(q, qd, u, friction_smoothing=eps)
        _close(AB[:16].reshape(4, 4), A, "linearize A")
        _close(AB[16:].reshape(4, 1), B, "linearize B")
    assert abs(F[0]) > 1e-3   # the exact sign: the full Coulomb force at 0.02 m/s


@pytest.mark.parametrize("robot", ["four_bar", "spatial_four_bar"])
def test_loop_robots_are_built(robot, tmp_path):
    """Closed loops are no longer refused (``tests/test_c_loops.py`` checks their functions)."""
    result = CliRunner().invoke(app, ["solve", robot, "--c", "--code", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert f"{robot}_loop_forces(" in (tmp_path / f"{robot}_dynamics.h").read_text()
    assert (tmp_path / f"{robot}_dynamics.py").exists()


def test_solve_writes_header_and_source(tmp_path):
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    header = (tmp_path / "rp_arm_dynamics.h").read_text()
    source = (tmp_path / "rp_arm_dynamics.c").read_text()
    assert "#define RP_ARM_NQ 2" in header and "extern const rp_arm_parameters rp_arm_default_parameters;" in header
    assert 'extern "C"' in header and [ln for ln in source.splitlines() if ln.startswith("#include")] == \
        ["#include <math.h>", '#include "rp_arm_dynamics.h"']
    assert "malloc" not in source and "static double" not in source
    _compile(tmp_path / "rp_arm_dynamics.c")


def test_user_c_template(tmp_path):
    """--template-dir overrides the C target's templates by file name; a fault in it is the user's (exit 2
    at its file and line), and a correct one may encode text with |c_comment."""
    folder = tmp_path / "templates" / "c"
    folder.mkdir(parents=True)
    (folder / "dynamics.h.j2").write_text("/* {{ 'a */ b' | c_comment }} */\n/* {{ name }} {{ nq }} */\n")
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c", "--out", str(tmp_path / "out"),
                                      "--template-dir", str(tmp_path / "templates")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "rp_arm_dynamics.h").read_text() == "/* a *\\/ b */\n/* rp_arm 2 */\n"
    (folder / "dynamics.h.j2").write_text("/* ok */\n{{ no_such_variable }}\n")
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--c", "--out", str(tmp_path / "again"),
                                      "--template-dir", str(tmp_path / "templates")])
    assert result.exit_code == 2 and "dynamics.h.j2:2:" in result.output and "no_such_variable" in result.output
    assert not (tmp_path / "again").exists()


def test_robot_without_efforts(tmp_path):
    """NU = 0 (a passive pendulum): no unused argument or empty array breaks -Werror."""
    path = tmp_path / "double_pendulum.yaml"
    path.write_text("\n".join(ln for ln in (ROBOTS / "double_pendulum.yaml").read_text().splitlines()
                              if "effort:" not in ln) + "\n")
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert not derivation.robot.efforts
    module = import_code(dynderive.render_code(derivation), tmp_path, "passive_pendulum_dynamics")
    _agree(Library(derivation, tmp_path / "c"), module, seed=9, states=2)
    assert "#define DOUBLE_PENDULUM_NU 0" in (tmp_path / "c" / "double_pendulum_dynamics.h").read_text()


def test_fast_printer_means_what_the_sympy_printer_means(tmp_path):
    """FastCPrinter (program lines) and CPrinter (SymPy's C99CodePrinter) compiled side by
    side give the same values on expressions with signs, fractions, powers and functions."""
    import sympy

    from dynderive.render.codegen.c_syntax import CPrinter, FastCPrinter

    x, y, z = sympy.symbols("x y z")
    names = {x: "v[0]", y: "v[1]", z: "v[2]"}
    half, third = sympy.Rational(1, 2), sympy.Rational(-1, 3)
    expressions = [
        -x * y + half * z, third * x / (y * z), (x + y) ** 2 - (y - z) ** 3, x ** -2 + (y + 1) ** -3,
        -sympy.Float("0.1") * x - 2 * y ** 9, sympy.sin(x + y) * sympy.cos(z) ** 2 / (1 + x ** 2),
        sympy.sqrt(x ** 2 + y ** 2) - sympy.Abs(z), sympy.exp(-x) * third, -(x - y) * (y - z) / 7,
        sympy.Float("-1.25") + x * y * z, 1 / (x + y) - half / z, (-x) ** 3 * third * y,
        sympy.Mul(-1, x, sympy.Pow(y + z, -1, evaluate=False), evaluate=False),
    ]
    lines = ["#include <math.h>"]
    for index, expr in enumerate(expressions):
        for kind, printer in (("fast", FastCPrinter(dict(names))), ("general", CPrinter(dict(names)))):
            lines.append(f"double {kind}{index}(const double *v) {{ return {printer.doprint(expr)}; }}")
    source = tmp_path / "printers.c"
    source.write_text("\n".join(lines) + "\n")
    shared = tmp_path / "printers.so"
    subprocess.run([CC, *STRICT, "-Wno-missing-prototypes", "-shared", "-fPIC", str(source), "-o", str(shared), "-lm"],
                   check=True)
    lib = ctypes.CDLL(str(shared))
    rng = np.random.default_rng(3)
    for _ in range(5):
        v = np.ascontiguousarray(rng.uniform(0.2, 2.0, 3) * rng.choice([-1, 1], 3))
        for index, expr in enumerate(expressions):
            fast, general = (getattr(lib, f"{kind}{index}") for kind in ("fast", "general"))
            fast.restype = general.restype = ctypes.c_double
            a, b = fast(v.ctypes.data_as(P)), general(v.ctypes.data_as(P))
            exact = float(expr.subs({x: v[0], y: v[1], z: v[2]}))
            assert abs(a - exact) <= 1e-13 * max(1.0, abs(exact)) and abs(b - exact) <= 1e-13 * max(1.0, abs(exact)), \
                (index, a, b, exact)


def test_forward_dynamics_and_linearize_are_one_body_each_sine_once():
    """forward_dynamics and linearize compute M and Newton-Euler in their own body (issue 28's
    speed): no call of mass_matrix or inverse_dynamics, and each sin(q[k]) / cos(q[k]) once
    (two calls of sin are never merged by a C compiler: they may set errno)."""
    _, source = render_c(derivation_of("panda"))
    for function in ("forward_dynamics", "linearize"):
        body = source.split(f"int panda_{function}(", 1)[1].split("\n}\n", 1)[0]
        assert "panda_mass_matrix(" not in body and "panda_inverse_dynamics(" not in body, function
        calls = re.findall(r"\b(?:sin|cos)\(q\[\d\]\)", body)
        assert calls and len(calls) == len(set(calls)), (function, sorted(calls))


# -- floating base and spherical joints ------------------------------------------------------------
# test_free_flyer and test_spherical skip themselves without Pinocchio: the tests below import
# them, so that the rest of this file runs without it.

# STRICT without its -O1 (FloatingLibrary compiles at -O0)
C99_STRICT = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wshadow"]


def compiled_library(derivation, directory: Path, cxx: bool = False,
                     cxx_optimization: str = "-O1") -> tuple[str, ctypes.CDLL]:
    """(name, library) of ``derivation``'s generated C, compiled unoptimized as strict C99 (and
    as C++ when ``cxx``, at ``cxx_optimization``: -O1's flow analysis adds warnings, but a
    megabyte of C takes five times as long as at -O0), with no diagnostic, and loaded."""
    header, source = render_c(derivation)
    name = derivation.robot.name
    (directory / f"{name}_dynamics.h").write_text(header)
    path = directory / f"{name}_dynamics.c"
    path.write_text(source)
    shared = path.with_suffix(".so")
    for command in ([CC, *C99_STRICT, "-O0", "-shared", "-fPIC", str(path), "-o", str(shared), "-lm"],
                    *([[CXX, "-x", "c++", "-Wall", "-Wextra", "-Werror", "-Wshadow", cxx_optimization, "-c",
                        str(path), "-o", str(path.with_suffix(".cpp.o"))]] if CXX and cxx else [])):
        run = subprocess.run(command, capture_output=True, text=True)
        assert run.returncode == 0 and not run.stderr, f"{' '.join(command)}:\n{run.stderr}"
    return name, ctypes.CDLL(str(shared))


class FloatingLibrary:
    """A floating-base robot's generated C, compiled (C99, and C++ when ``cxx``, with no
    diagnostic) and loaded. Unoptimized: solo12's 0.9 MB of C takes 30 s at -O1."""

    def __init__(self, derivation, directory: Path, cxx: bool = False):
        self.name, self.lib = compiled_library(derivation, directory, cxx)
        name = self.name
        for function in ("kinetic_energy", "potential_energy"):
            getattr(self.lib, f"{name}_{function}").restype = ctypes.c_double
        for function in ("mass_matrix", "coriolis_matrix", "gravity_vector", "inverse_dynamics", "regressor",
                         "parameter_vector", "neutral_configuration", "integrate", "difference", "configuration_rate"):
            getattr(self.lib, f"{name}_{function}").restype = None

    def call(self, function: str, inputs: list, sizes: tuple[int, ...], p=None, frame: int | None = None,
             parameters: bool = True, dt: float | None = None):
        """``function(*inputs, [dt,] [frame,] [p,] *outputs)``: its return value and outputs."""
        arrays = [np.ascontiguousarray(a, dtype=float) for a in inputs]
        outs = [np.full(size, np.nan) for size in sizes]
        args = [a.ctypes.data_as(P) for a in arrays]
        if dt is not None:
            args.append(ctypes.c_double(dt))
        if frame is not None:
            args.append(ctypes.c_int(frame))
        if parameters:
            args.append(None if p is None else np.ascontiguousarray(p, dtype=float).ctypes.data_as(P))
        result = getattr(self.lib, f"{self.name}_{function}")(*args, *(o.ctypes.data_as(P) for o in outs))
        return result, outs


def _close_floating(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float).ravel(), np.asarray(expected, dtype=float).ravel()
    assert actual.shape == expected.shape, what
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree_floating(library: FloatingLibrary, module, robot, seed: int, states: int = 3, p=None,
                    values: dict | None = None) -> None:
    """Every C function against the NumPy module at random full-precision states (random unit
    quaternions)."""
    rng = np.random.default_rng(seed)
    nq, nv, nu = module.NQ, module.NV, len(module.EFFORTS)
    values = values or {}
    _, (neutral,) = library.call("neutral_configuration", [], (nq,), parameters=False)
    _close_floating(neutral, module.neutral_configuration(), "neutral_configuration")
    count = len(module.PARAMETER_VECTOR)
    _, (pi,) = library.call("parameter_vector", [], (count,), p)
    _close_floating(pi, module.parameter_vector(**values), "parameter_vector")
    for _ in range(states):
        q, q1 = random_configurations(robot, rng, 2)
        qd, qdd, u = rng.normal(size=nv), rng.normal(size=nv), rng.normal(size=nu)
        for function, inputs, sizes, expected in (
                ("mass_matrix", [q], (nv * nv,), module.mass_matrix(q, **values)),
                ("coriolis_matrix", [q, qd], (nv * nv,), module.coriolis_matrix(q, qd, **values)),
                ("gravity_vector", [q], (nv,), module.gravity_vector(q, **values)),
                ("inverse_dynamics", [q, qd, qdd], (nv,), module.inverse_dynamics(q, qd, qdd, **values)),
                ("forward_dynamics", [q, qd, u], (nv,), module.forward_dynamics(q, qd, u, **values)),
                ("regressor", [q, qd, qdd], (nv * count,), module.regressor(q, qd, qdd, **values)),
                ("linearize", [q, qd, u], (4 * nv * nv, 2 * nv * nu), module.linearize(q, qd, u, **values))):
            result, outs = library.call(function, inputs, sizes, p)
            assert result in (None, 0), function   # void, or 0: M positive definite
            for out, value in zip(outs, expected if function == "linearize" else (expected,)):
                _close_floating(out, value, function)
        for function, inputs, expected in (("kinetic_energy", [q, qd], module.kinetic_energy(q, qd, **values)),
                                           ("potential_energy", [q], module.potential_energy(q, **values))):
            arrays = [np.ascontiguousarray(a) for a in inputs]
            pointer = None if p is None else np.ascontiguousarray(p, dtype=float).ctypes.data_as(P)
            c_function = getattr(library.lib, f"{library.name}_{function}")
            _close_floating(c_function(*(a.ctypes.data_as(P) for a in arrays), pointer), expected, function)
        for index, frame in enumerate(module.FRAMES):
            for function, inputs, size, expected in (
                    ("frame_transform", [q], 16, module.frame_transform(q, frame, **values)),
                    ("frame_jacobian", [q], 6 * nv, module.frame_jacobian(q, frame, **values)),
                    ("frame_jacobian_dot_qd", [q, qd], 6, module.frame_jacobian_dot_qd(q, qd, frame, **values))):
                result, (out,) = library.call(function, inputs, (size,), p, frame=index)
                assert result == 0
                _close_floating(out, expected, f"{function} {frame}")
            assert library.call("frame_transform", [q], (16,), p, frame=len(module.FRAMES))[0] == 1
        _, (moved,) = library.call("integrate", [q, qd], (nq,), parameters=False, dt=0.3)
        _close_floating(moved, module.integrate(q, qd, 0.3), "integrate")
        _, (velocity,) = library.call("difference", [q, q1], (nv,), parameters=False)
        _close_floating(velocity, module.difference(q, q1), "difference")
        _, (rate,) = library.call("configuration_rate", [q, qd], (nq,), parameters=False)
        _close_floating(rate, module.configuration_rate(q, qd), "configuration_rate")


@pytest.mark.pinocchio
def test_solo12_agrees_with_the_numpy_module(tmp_path):
    from test_free_flyer import _example_robot, _module

    robot = dynderive.load_robot(_example_robot("solo_description/robots/solo12.urdf"), floating_base=True)
    derivation = dynderive.derive(robot)
    library, module = FloatingLibrary(derivation, tmp_path), _module(derivation, tmp_path)
    _agree_floating(library, module, derivation.robot, seed=1)


@pytest.mark.parametrize("seed", [0, 3])
def test_random_floating_trees_agree_with_the_numpy_module(seed, tmp_path):
    from test_free_flyer import _floating_tree, _module

    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(seed))
    derivation = dynderive.derive(dynderive.load_robot(path))
    library, module = FloatingLibrary(derivation, tmp_path), _module(derivation, tmp_path)
    _agree_floating(library, module, derivation.robot, seed=seed)


@pytest.mark.parametrize("floating", [False, True])
def test_random_trees_with_spherical_joints_agree_with_the_numpy_module(floating, tmp_path):
    from test_free_flyer import _module
    from test_spherical import _tree as _spherical_tree

    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_spherical_tree(7, floating))
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert any(j.type == "spherical" for j in derivation.robot.joints)
    library, module = FloatingLibrary(derivation, tmp_path), _module(derivation, tmp_path)
    _agree_floating(library, module, derivation.robot, seed=7)


def test_parameters_struct_and_a_mass_matrix_that_is_not_positive_definite(tmp_path):
    from test_free_flyer import BOX, _module

    (tmp_path / "box.yaml").write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(tmp_path / "box.yaml"))
    library, module = FloatingLibrary(derivation, tmp_path, cxx=True), _module(derivation, tmp_path)
    _agree_floating(library, module, derivation.robot, seed=5, p=[2.5, 9.7, 0.0], values={"m": 2.5, "g": 9.7})
    q, nv = module.neutral_configuration(), module.NV
    for function, sizes in (("forward_dynamics", (nv,)), ("linearize", (4 * nv * nv, 2 * nv))):
        result, outs = library.call(function, [q, np.zeros(nv), np.zeros(1)], sizes, p=[-1.0, 9.81, 0.0])
        assert result == 1 and all(np.isnan(o).all() for o in outs), function


def test_solve_and_build_write_the_c_of_a_floating_robot(tmp_path):
    from test_free_flyer import BOX

    (tmp_path / "box.yaml").write_text(BOX)
    runner = CliRunner()
    result = runner.invoke(app, ["solve", str(tmp_path / "box.yaml"), "--c", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    header = (tmp_path / "out" / "box_dynamics.h").read_text()
    assert "#define BOX_NQ 8" in header and "#define BOX_NV 7" in header and "box_integrate" in header
    assert not (tmp_path / "out" / "box_dynamics.py").exists()   # --c alone: the C only
    result = runner.invoke(app, ["build", str(tmp_path / "box.yaml"), "--c", "--code", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "b" / "box_dynamics.c").read_text() == (tmp_path / "out" / "box_dynamics.c").read_text()
    assert (tmp_path / "b" / "box_dynamics.py").is_file()
