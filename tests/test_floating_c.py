"""The C target of floating-base robots (``render/targets/c/c.py``): the header and
source compile as strict C99 and as C++ with no diagnostic, and every function agrees with the
NumPy floating module (which agrees with Pinocchio's free flyer: ``test_free_flyer.py``) to
1e-12 relative at random unit quaternions and full-precision states: solo12 from
example-robot-data, random floating trees with full-precision numbers, a free box with a
parameter in the struct; forward dynamics and linearize refuse a mass matrix that is not
positive definite; ``solve --c`` and ``build --c`` write the files.

Skipped without a C compiler, required when CI is set (as ``test_c_target.py``)."""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.c.c import render_c
from dynderive.verify.checks import random_configurations

CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++")
if CC is None:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C target tests, but no C compiler (gcc or cc) was found")
    pytest.skip("no C compiler", allow_module_level=True)

from test_free_flyer import BOX, _example_robot, _floating_tree, _module  # noqa: E402
from test_spherical import _tree as _spherical_tree  # noqa: E402

STRICT = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wshadow"]
RTOL = 1e-12
P = ctypes.POINTER(ctypes.c_double)


class Library:
    """A floating-base robot's generated C, compiled (C99, and C++ when ``cxx``, with no
    diagnostic) and loaded. Unoptimized: solo12's 0.9 MB of C takes 30 s at -O1."""

    def __init__(self, derivation, directory: Path, cxx: bool = False):
        header, source = render_c(derivation)
        self.name = name = derivation.robot.name
        (directory / f"{name}_dynamics.h").write_text(header)
        path = directory / f"{name}_dynamics.c"
        path.write_text(source)
        shared = path.with_suffix(".so")
        for command in ([CC, *STRICT, "-O0", "-shared", "-fPIC", str(path), "-o", str(shared), "-lm"],
                        *([[CXX, "-x", "c++", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-O1", "-c", str(path),
                            "-o", str(path.with_suffix(".cpp.o"))]] if CXX and cxx else [])):
            run = subprocess.run(command, capture_output=True, text=True)
            assert run.returncode == 0 and not run.stderr, f"{' '.join(command)}:\n{run.stderr}"
        self.lib = ctypes.CDLL(str(shared))
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


def _close(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float).ravel(), np.asarray(expected, dtype=float).ravel()
    assert actual.shape == expected.shape, what
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree(library: Library, module, robot, seed: int, states: int = 3, p=None, values: dict | None = None) -> None:
    """Every C function against the NumPy module at random full-precision states (random unit
    quaternions)."""
    rng = np.random.default_rng(seed)
    nq, nv, nu = module.NQ, module.NV, len(module.EFFORTS)
    values = values or {}
    _, (neutral,) = library.call("neutral_configuration", [], (nq,), parameters=False)
    _close(neutral, module.neutral_configuration(), "neutral_configuration")
    count = len(module.PARAMETER_VECTOR)
    _, (pi,) = library.call("parameter_vector", [], (count,), p)
    _close(pi, module.parameter_vector(**values), "parameter_vector")
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
                _close(out, value, function)
        for function, inputs, expected in (("kinetic_energy", [q, qd], module.kinetic_energy(q, qd, **values)),
                                           ("potential_energy", [q], module.potential_energy(q, **values))):
            arrays = [np.ascontiguousarray(a) for a in inputs]
            pointer = None if p is None else np.ascontiguousarray(p, dtype=float).ctypes.data_as(P)
            _close(getattr(library.lib, f"{library.name}_{function}")(*(a.ctypes.data_as(P) for a in arrays), pointer),
                   expected, function)
        for index, frame in enumerate(module.FRAMES):
            for function, inputs, size, expected in (
                    ("frame_transform", [q], 16, module.frame_transform(q, frame, **values)),
                    ("frame_jacobian", [q], 6 * nv, module.frame_jacobian(q, frame, **values)),
                    ("frame_jacobian_dot_qd", [q, qd], 6, module.frame_jacobian_dot_qd(q, qd, frame, **values))):
                result, (out,) = library.call(function, inputs, (size,), p, frame=index)
                assert result == 0
                _close(out, expected, f"{function} {frame}")
            assert library.call("frame_transform", [q], (16,), p, frame=len(module.FRAMES))[0] == 1
        _, (moved,) = library.call("integrate", [q, qd], (nq,), parameters=False, dt=0.3)
        _close(moved, module.integrate(q, qd, 0.3), "integrate")
        _, (velocity,) = library.call("difference", [q, q1], (nv,), parameters=False)
        _close(velocity, module.difference(q, q1), "difference")
        _, (rate,) = library.call("configuration_rate", [q, qd], (nq,), parameters=False)
        _close(rate, module.configuration_rate(q, qd), "configuration_rate")


@pytest.mark.pinocchio
def test_solo12_agrees_with_the_numpy_module(tmp_path):
    robot = dynderive.load_robot(_example_robot("solo_description/robots/solo12.urdf"), floating_base=True)
    derivation = dynderive.derive(robot)
    _agree(Library(derivation, tmp_path), _module(derivation.robot, tmp_path), derivation.robot, seed=1)


@pytest.mark.parametrize("seed", [0, 3])
def test_random_floating_trees_agree_with_the_numpy_module(seed, tmp_path):
    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(seed))
    derivation = dynderive.derive(dynderive.load_robot(path))
    _agree(Library(derivation, tmp_path), _module(derivation.robot, tmp_path), derivation.robot, seed=seed)


@pytest.mark.parametrize("floating", [False, True])
def test_random_trees_with_spherical_joints_agree_with_the_numpy_module(floating, tmp_path):
    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_spherical_tree(7, floating))
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert any(j.type == "spherical" for j in derivation.robot.joints)
    _agree(Library(derivation, tmp_path), _module(derivation.robot, tmp_path), derivation.robot, seed=7)


def test_parameters_struct_and_a_mass_matrix_that_is_not_positive_definite(tmp_path):
    (tmp_path / "box.yaml").write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(tmp_path / "box.yaml"))
    library, module = Library(derivation, tmp_path, cxx=True), _module(derivation.robot, tmp_path)
    _agree(library, module, derivation.robot, seed=5, p=[2.5, 9.7, 0.0], values={"m": 2.5, "g": 9.7})
    q, nv = module.neutral_configuration(), module.NV
    for function, sizes in (("forward_dynamics", (nv,)), ("linearize", (4 * nv * nv, 2 * nv))):
        result, outs = library.call(function, [q, np.zeros(nv), np.zeros(1)], sizes, p=[-1.0, 9.81, 0.0])
        assert result == 1 and all(np.isnan(o).all() for o in outs), function


def test_solve_and_build_write_the_c_of_a_floating_robot(tmp_path):
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
