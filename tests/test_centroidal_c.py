"""Centre of mass and centroidal momentum (DESIGN.md section 11) in the C target and the C
extension, against the NumPy module (itself against Pinocchio: ``test_centroidal.py``).

The C functions (``<name>_total_mass`` ... ``<name>_centroidal_inertia``), compiled as strict
C99 and as C++ with no diagnostic and called through ``ctypes``, agree with the NumPy module to
1e-12 relative at random full-precision states: the Panda (fixed base), the floating elbow (a
floating joint below a revolute one) and random trees with spherical joints on a fixed and a
floating base; a parameters struct is read (the free box's mass). The extension's functions
equal the NumPy module's for one state and for a broadcast batch, with the NumPy module's
types and signatures (the free box; every robot class: ``test_targets_agree.py``). A planar robot has none of them in either.

Needs a C compiler (and Python.h for the extension): skipped locally without, required in CI.
"""

from __future__ import annotations

import ctypes
import inspect
import sysconfig
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render import api
from dynderive.render.targets.c.c import render_c
from dynderive.render.targets.c_extension.c_extension import bindings
from dynderive.verify.checks import random_configurations
from test_c_target import P, compiled_library
from test_free_flyer import BOX, _module
from test_spherical import _tree

from conftest import derivation_of, stable_seed

RTOL = 1e-12
ROOT = Path(__file__).resolve().parents[1]
CENTROIDAL = api.group("centroidal")
#: The ctypes arrays of each function: the API table's arguments (q, qd), then the outputs' sizes.
RESULTS = {name: api.BY_NAME[name].arguments for name in CENTROIDAL}


def _robot(key: str, tmp_path: Path):
    """The robot of ``key``: panda, floating_elbow, spherical_fixed, spherical_floating or box."""
    if key == "box":
        (tmp_path / "box.yaml").write_text(BOX)
        return dynderive.load_robot(tmp_path / "box.yaml")
    if key == "panda":
        return derivation_of("panda").robot
    if key == "floating_elbow":
        return dynderive.load_robot(ROOT / "tests" / "floating_elbow.urdf")
    path = tmp_path / f"{key}.yaml"
    path.write_text(_tree(4, key == "spherical_floating"))
    return dynderive.load_robot(path)


class Library:
    """A robot's generated C, compiled as strict C99 (and as C++ when ``cxx``) with no
    diagnostic and loaded (``test_c_target.compiled_library``), its centroidal functions typed."""

    def __init__(self, derivation, directory: Path, cxx: bool = False, cxx_optimization: str = "-O1"):
        self.name, self.lib = compiled_library(derivation, directory, cxx, cxx_optimization)
        getattr(self.lib, f"{self.name}_total_mass").restype = ctypes.c_double
        for function in CENTROIDAL[1:]:
            getattr(self.lib, f"{self.name}_{function}").restype = None

    def call(self, function: str, inputs: list, size: int, p=None) -> np.ndarray:
        """``function(*inputs, p, out)``: ``out``, pre-filled with NaN."""
        arrays = [np.ascontiguousarray(a, dtype=float) for a in inputs]
        out = np.full(size, np.nan)
        params = None if p is None else np.ascontiguousarray(p, dtype=float)
        getattr(self.lib, f"{self.name}_{function}")(*(a.ctypes.data_as(P) for a in arrays),
                                            None if params is None else params.ctypes.data_as(P),
                                            out.ctypes.data_as(P))
        return out


def _close(actual, expected, what: str) -> None:
    """Equal to 1e-12 relative to the largest entry (at least 1, as the C target's floating tests)."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _c_agrees(library: Library, module, robot, seed: int, p=None, values: dict | None = None) -> None:
    """Every centroidal C function against the NumPy module at random full-precision states
    (random unit quaternions), outputs pre-filled with NaN."""
    values = values or {}
    rng = np.random.default_rng(seed)
    params = None if p is None else np.ascontiguousarray(p, dtype=float)
    total = getattr(library.lib, f"{library.name}_total_mass")(None if params is None else params.ctypes.data_as(P))
    _close(total, module.total_mass(**values), "total_mass")
    for _ in range(3):
        (q,) = random_configurations(robot, rng, 1)
        states = {"q": q, "qd": rng.normal(size=robot.velocity_count)}
        for name in CENTROIDAL[1:]:
            arrays = [states[a] for a in RESULTS[name]]
            expected = getattr(module, name)(*arrays, **values)
            out = library.call(name, arrays, expected.size, p)
            _close(out.reshape(expected.shape), expected, name)


@pytest.mark.parametrize("key", ["panda", "floating_elbow", "spherical_fixed", "spherical_floating"])
def test_c_functions_agree_with_the_numpy_module(key, tmp_path):
    robot = _robot(key, tmp_path)
    derivation = dynderive.derive(robot)
    header, _ = render_c(derivation)
    for name in CENTROIDAL:
        assert f"{robot.name}_{name}(" in header, name
    assert "double *Ig)" in header   # not I: <complex.h> defines it
    # C++ too (the Panda's: test_c_target); the spherical trees' megabyte of C at -O0 (-O1: five
    # times as long; -O1's flow warnings: the floating elbow here, the free box in test_c_target)
    library = Library(derivation, tmp_path, cxx=key != "panda",
                      cxx_optimization="-O0" if key.startswith("spherical") else "-O1")
    module = _module(derivation, tmp_path)
    _c_agrees(library, module, derivation.robot, seed=stable_seed(key))


def test_c_reads_the_parameters_struct(tmp_path):
    """The free box's mass from the struct: total_mass, the CoM Jacobian and A_G follow it."""
    derivation = dynderive.derive(_robot("box", tmp_path))
    library, module = Library(derivation, tmp_path), _module(derivation, tmp_path)
    _c_agrees(library, module, derivation.robot, seed=3, p=[2.5, 9.7, 0.0], values={"m": 2.5, "g": 9.7})
    assert module.total_mass(m=2.5) == pytest.approx(5.0)


def test_planar_robots_have_none_in_c_or_the_extension():
    derivation = derivation_of("rp_arm")
    header, source = render_c(derivation)
    assert "center_of_mass" not in header + source and "centroidal" not in header + source
    assert not {b.name for b in bindings(derivation)} & set(CENTROIDAL)


HEADERS = (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()


@pytest.mark.skipif(not HEADERS, reason="no Python.h")
@pytest.mark.parametrize("key", ["box"])
def test_extension_functions_equal_the_numpy_modules(key, tmp_path):
    """One state and a batch whose arguments broadcast ((4, 3, NQ) with (3, NV)), the same
    types (a 0-d array for total_mass, as the NumPy module's) and signatures; the box with its
    mass as a keyword (the values for every robot class: ``test_targets_agree.py``)."""
    from test_c_extension import _load

    robot = _robot(key, tmp_path)
    derivation = dynderive.derive(robot)
    ext, module = _load(derivation, tmp_path / "ext"), _module(derivation, tmp_path)
    assert [b.name for b in bindings(derivation) if b.name in CENTROIDAL] == list(CENTROIDAL)
    rng = np.random.default_rng(stable_seed(key))
    values = {"m": 2.5} if key == "box" else {}
    got, want = ext.total_mass(**values), module.total_mass(**values)
    _close(got, want, "total_mass")
    assert type(got) is type(want) and np.shape(got) == np.shape(want)
    for batch in ((), (4, 3)):
        q = random_configurations(robot, rng, int(np.prod(batch))).reshape(batch + (-1,))
        states = {"q": q, "qd": rng.normal(size=batch[1:] + (robot.velocity_count,))}
        for name in CENTROIDAL[1:]:
            arrays = [states[a] for a in RESULTS[name]]
            got, want = getattr(ext, name)(*arrays, **values), getattr(module, name)(*arrays, **values)
            _close(got, want, f"{name} {batch}")
            assert type(got) is type(want), name
    for name in CENTROIDAL:
        assert inspect.signature(getattr(ext, name)) == inspect.signature(getattr(module, name)), name
