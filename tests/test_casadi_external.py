"""The C target's CasADi external entry points (``-D<NAME>_CASADI_EXTERNAL``): the generated
``<name>_dynamics.c`` compiled with that macro into a shared library, warning-free as strict
C99, gives ``casadi.external`` Functions ``<name>_casadi_forward_dynamics`` and
``<name>_casadi_inverse_dynamics`` that agree with the NumPy module to 1e-12 relative, whose
CasADi Jacobians (from ``jac_<name>``, no finite differences) equal the NumPy module's
derivative functions, and which work in ``map`` and in an ``nlpsol`` problem. Robots: bundled
ones (friction, a closed loop), a random spatial tree with full-precision numbers; a floating
base gets the functions without Jacobians.

Skipped without casadi or a C compiler; required in CI.
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

if os.environ.get("CI"):  # required in CI: casadi is in the test extra, gcc is on the machine
    import casadi as ca
else:
    ca = pytest.importorskip("casadi")
CC = shutil.which("gcc") or shutil.which("cc")
if CC is None:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the CasADi external tests, but no C compiler was found")
    pytest.skip("no C compiler", allow_module_level=True)

import dynderive  # noqa: E402
from dynderive.render.targets.c.c import render_c  # noqa: E402

from conftest import ROOT, derivation_of, import_code, stable_seed  # noqa: E402

STRICT = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wshadow", "-O1"]
RTOL = 1e-12
FLOATING = ROOT / "tests" / "floating_elbow.urdf"


def _library(derivation, directory: Path) -> tuple[Path, object]:
    """The shared library compiled with the external entry points, and the NumPy module."""
    directory.mkdir(parents=True, exist_ok=True)
    name = derivation.robot.name
    header, source = render_c(derivation)
    (directory / f"{name}_dynamics.h").write_text(header)
    (directory / f"{name}_dynamics.c").write_text(source)
    library = directory / f"lib{name}.so"
    run = subprocess.run([CC, *STRICT, "-shared", "-fPIC", f"-D{name.upper()}_CASADI_EXTERNAL",
                          str(directory / f"{name}_dynamics.c"), "-o", str(library), "-lm"],
                         capture_output=True, text=True)
    assert run.returncode == 0 and not run.stderr, run.stderr
    module = import_code(dynderive.render_code(derivation), directory, f"{name}_external_reference")
    return library, module


def _close(actual, expected, what: str, rtol: float = RTOL) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.size == expected.size, f"{what}: shape {actual.shape}, not {expected.shape}"
    actual = actual.reshape(expected.shape)   # CasADi's column vectors against NumPy's flat ones
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert error <= rtol * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _states(module, rng, count: int):
    n = len(module.COORDINATES)
    nu = len(module.EFFORTS)
    for _ in range(count):
        yield (rng.uniform(-np.pi, np.pi, n), rng.normal(size=n), rng.normal(size=n), rng.normal(size=nu))


def _agree(derivation, directory: Path, seed: int, states: int = 3) -> None:
    library, module = _library(derivation, directory)
    name = derivation.robot.name
    forward = ca.external(f"{name}_casadi_forward_dynamics", str(library))
    inverse = ca.external(f"{name}_casadi_inverse_dynamics", str(library))
    assert forward.name_in() == ["q", "qd", "u"] and forward.name_out() == ["qdd"]
    assert inverse.name_in() == ["q", "qd", "qdd"] and inverse.name_out() == ["tau"]
    q_, qd_, u_ = (ca.MX.sym(s, n) for s, n in (("q", forward.size1_in(0)), ("qd", forward.size1_in(1)),
                                                 ("u", forward.size1_in(2))))
    qdd_ = ca.MX.sym("qdd", inverse.size1_in(2))
    fd, id_ = forward(q_, qd_, u_), inverse(q_, qd_, qdd_)
    fd_jacobian = ca.Function("dfd", [q_, qd_, u_], [ca.jacobian(fd, x) for x in (q_, qd_, u_)])
    id_jacobian = ca.Function("did", [q_, qd_, qdd_], [ca.jacobian(id_, x) for x in (q_, qd_, qdd_)])
    rng = np.random.default_rng(seed)
    for q, qd, qdd, u in _states(module, rng, states):
        _close(forward(q, qd, u), module.forward_dynamics(q, qd, u), "forward_dynamics")
        _close(inverse(q, qd, qdd), module.inverse_dynamics(q, qd, qdd), "inverse_dynamics")
        for got, want, what in zip(fd_jacobian(q, qd, u), module.forward_dynamics_derivatives(q, qd, u),
                                   ("dqdd/dq", "dqdd/dqd", "dqdd/du")):
            _close(got.full(), want, what)
        wanted = (*module.inverse_dynamics_derivatives(q, qd, qdd), module.mass_matrix(q))
        for got, want, what in zip(id_jacobian(q, qd, qdd), wanted, ("dtau/dq", "dtau/dqd", "dtau/dqdd")):
            _close(got, want, what)
    # a map over states, as an optimizer evaluates a trajectory
    states = list(_states(module, rng, 5))
    mapped = forward.map(len(states))(*(np.column_stack([s[k] for s in states]) for k in (0, 1, 3)))
    for k, (q, qd, _, u) in enumerate(states):
        _close(np.asarray(mapped)[:, k], module.forward_dynamics(q, qd, u), "map")


@pytest.mark.parametrize("robot", ["rp_arm", "cart_pole_damped", "four_bar", "elbow_arm"])
def test_bundled_robot(robot, tmp_path):
    _agree(derivation_of(robot), tmp_path / robot, seed=stable_seed(robot))


def test_random_spatial_tree_with_full_precision_numbers(tmp_path):
    from random_robots3d import random_spatial_tree

    tree = random_spatial_tree(random.Random(46), 4)
    path = tmp_path / "random_spatial.yaml"
    path.write_text(tree.yaml_text)
    _agree(dynderive.derive(dynderive.load_robot(path)), tmp_path / "tree", seed=46)


def test_in_an_optimization_with_exact_gradients(tmp_path):
    """Which torque holds the RP arm still at a pose: an NLP over u whose gradient comes from
    jac_ (CasADi would refuse finite differences: they are off by default)."""
    derivation = derivation_of("rp_arm")
    library, module = _library(derivation, tmp_path / "nlp")
    forward = ca.external("rp_arm_casadi_forward_dynamics", str(library))
    q = np.array([0.4, 0.8])
    u = ca.MX.sym("u", 2)
    qdd = forward(q, np.zeros(2), u)
    solver = ca.nlpsol("hold", "ipopt", {"x": u, "f": ca.sumsqr(qdd)},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.hessian_approximation": "limited-memory"})
    result = solver(x0=np.zeros(2))
    assert solver.stats()["success"]
    _close(np.asarray(result["x"]).ravel(), module.gravity_vector(q), "holding torque", rtol=1e-8)   # IPOPT's tol


def test_a_floating_base_has_no_jacobians(tmp_path):
    derivation = dynderive.derive(dynderive.load_robot(FLOATING))
    library, module = _library(derivation, tmp_path / "floating")
    name = derivation.robot.name
    forward = ca.external(f"{name}_casadi_forward_dynamics", str(library))
    rng = np.random.default_rng(7)
    q = module.neutral_configuration()
    qd, u = rng.normal(size=len(module.VELOCITIES)), rng.normal(size=len(module.EFFORTS))
    _close(forward(q, qd, u), module.forward_dynamics(q, qd, u), "forward_dynamics")
    assert not ca.Importer(str(library), "dll").has_function(f"jac_{name}_casadi_forward_dynamics")
    source = (tmp_path / "floating" / f"{name}_dynamics.c").read_text()
    assert "No Jacobians: q holds quaternions" in source


def test_plain_c_is_unchanged_without_the_macro(tmp_path):
    """Without the macro the file is the plain C99 target: no CasADi symbol is compiled."""
    derivation = derivation_of("rp_arm")
    header, source = render_c(derivation)
    (tmp_path / "rp_arm_dynamics.h").write_text(header)
    (tmp_path / "rp_arm_dynamics.c").write_text(source)
    subprocess.run([CC, *STRICT, "-c", "rp_arm_dynamics.c", "-o", "rp_arm.o"], cwd=tmp_path, check=True)
    symbols = subprocess.run(["nm", "rp_arm.o"], capture_output=True, text=True, cwd=tmp_path).stdout
    assert "rp_arm_forward_dynamics" in symbols and "casadi" not in symbols
