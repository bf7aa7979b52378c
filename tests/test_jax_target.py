"""The JAX target (``solve --jax``): every function of the NumPy module exists in the JAX module
and agrees with it to 1e-12 relative in float64 (bundled robots, random planar and spatial
trees with full-precision numbers); the functions work under ``jax.jit`` and ``jax.vmap``;
``jax.jacfwd(forward_dynamics)`` equals the generated ``linearize``; the derivative of inverse
dynamics with respect to the parameters is the regressor's (product rule through
``parameter_vector``); float32 stays float32 and close; hostile text and names.

Floating-base robots too: every function of the floating NumPy module exists in the JAX module
and agrees with it to 1e-12 relative in float64 (solo12 from example-robot-data with
``--floating-base``, a random floating tree with full-precision numbers, a tree with spherical
joints and a free box, at random unit quaternions); jax.jit and vmap; ``jax.jacfwd`` of
forward_dynamics composed with integrate (the tangent space) equals the generated
``linearize``; the parameter derivative of inverse dynamics is the regressor's; float32 stays
float32; a large traced batch (held values) agrees; integrate keeps quaternions unit. solo12 is
compared eagerly (compiling its largest bodies under ``jax.jit`` takes minutes); the
transformations run on the smaller robots.

Skipped without ``jax`` (it is in the ``test`` extra). Compile times are measured by
``benchmarks/jax_batch.py``, never here.
"""

from __future__ import annotations

import ast
import importlib.metadata
import inspect
import os
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

if os.environ.get("CI"):   # the JAX target's tests are required in CI (jax is in the test extra)
    import jax
else:
    jax = pytest.importorskip("jax")
jax.config.update("jax_enable_x64", True)
jnp = jax.numpy

import dynderive  # noqa: E402
from dynderive.commands.cli import app  # noqa: E402
from dynderive.render.targets.jax.jax import render_jax  # noqa: E402
from dynderive.render.targets.numpy.code import render_code  # noqa: E402
from dynderive.verify.compiled import compiled_checks  # noqa: E402

from conftest import ROBOTS, derivation_of, import_code, module_of, on_loops  # noqa: E402

RTOL = 1e-12


@cache
def jax_module_of(robot: str, directory: str):
    return import_code(render_jax(derivation_of(robot)), Path(directory), f"{robot}_dynamics_jax")


def _close(actual, expected, what: str, rtol: float = RTOL) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= rtol * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _public(module) -> list[str]:
    return sorted(name for name, value in vars(module).items()
                  if callable(value) and not name.startswith("_") and inspect.isfunction(value)
                  and value.__module__ == module.__name__)


def _states(module, rng, count: int):
    n, nu = len(module.COORDINATES), len(module.EFFORTS)
    q, qd = rng.uniform(-1.2, 1.2, (count, n)), rng.normal(size=(count, n))
    q, qd = on_loops(module, q, qd)
    return q, qd, rng.normal(size=(count, n)), rng.normal(size=(count, nu))


def _arguments(module, name: str, state: dict) -> list[dict]:
    """The calls of ``name`` to compare: positional arguments by their names in the signature."""
    parameters = inspect.signature(getattr(module, name)).parameters.values()
    positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD and p.default is p.empty]
    if "frame" in positional:
        return [{"args": [state[a] for a in positional if a != "frame"] + [frame]} for frame in module.FRAMES]
    return [{"args": [state[a] for a in positional]}]


def _traced(function, args: list, extra: dict):
    """``function(*args, **extra)`` under ``jax.jit``, its strings (frame names) closed over."""
    arrays = [a for a in args if not isinstance(a, str)]

    def call(*values):
        given = iter(values)
        return function(*(a if isinstance(a, str) else next(given) for a in args), **extra)

    return jax.jit(call)(*arrays)


def _agree_traced(numpy_module, jax_module, seed: int, count: int, **kwargs) -> None:
    """Every public function of the NumPy module, called on a batch of states, against the JAX
    one under ``jax.jit`` (eager calls: ``test_targets_agree.py``)."""
    assert _public(numpy_module) == _public(jax_module)
    for constant in ("PARAMETERS", "COORDINATES", "EFFORTS", "FRAMES", "PARAMETER_VECTOR"):
        assert getattr(numpy_module, constant) == getattr(jax_module, constant)
    rng = np.random.default_rng(seed)
    q, qd, qdd, u = _states(numpy_module, rng, count)
    state = {"q": q, "qd": qd, "qd_minus": qd, "qdd": qdd, "u": u, "q_guess": q + 1e-3 * rng.normal(size=q.shape),
             # the configuration maps every module has (integrate, difference, configuration_rate)
             "v": qd, "dt": 0.01, "q_from": q, "q_to": q + 0.1 * rng.normal(size=q.shape)}
    if hasattr(numpy_module, "MAXIMAL_COORDINATES"):
        size = len(numpy_module.MAXIMAL_COORDINATES)
        state |= {"qm": rng.uniform(-1, 1, (count, size)), "qmd": rng.normal(size=(count, size))}
    compared = 0
    for name in _public(numpy_module):
        for call in _arguments(numpy_module, name, state):
            extra = {k: v for k, v in kwargs.items() if k in inspect.signature(getattr(numpy_module, name)).parameters}
            expected = getattr(numpy_module, name)(*call["args"], **extra)
            actual = _traced(getattr(jax_module, name), call["args"], extra)
            expected, actual = (expected, actual) if isinstance(expected, tuple) else ((expected,), (actual,))
            for e, a in zip(expected, actual):
                frames = [a for a in call["args"] if isinstance(a, str)]
                _close(a, e, f"{name} {frames}", 1e-10 if name == "assemble" else RTOL)
            compared += 1
    assert compared >= 12
    for frame in numpy_module.FRAMES:   # external wrenches, through J^T w
        wrench = rng.normal(size=(count, 3 if hasattr(numpy_module, "MAXIMAL_COORDINATES") else 6))
        for name, args in (("inverse_dynamics", (q, qd, qdd)), ("forward_dynamics", (q, qd, u))):
            _close(getattr(jax_module, name)(*args, {frame: wrench}), getattr(numpy_module, name)(*args, {frame: wrench}),
                   f"{name} with a wrench at {frame}")


TRANSFORMS = ["rp_arm", "cart_pole_damped", "four_bar", "ur5"]


@pytest.mark.parametrize("robot", TRANSFORMS)
def test_jit_and_vmap(robot, code_dir):
    numpy_module, jax_module = module_of(robot, str(code_dir)), jax_module_of(robot, str(code_dir))
    q, qd, qdd, u = _states(numpy_module, np.random.default_rng(3), 4)
    forward = jax.jit(jax_module.forward_dynamics)
    _close(forward(q, qd, u), numpy_module.forward_dynamics(q, qd, u), "jit forward_dynamics")
    _close(jax.vmap(jax_module.inverse_dynamics)(q, qd, qdd), numpy_module.inverse_dynamics(q, qd, qdd),
           "vmap inverse_dynamics")
    A, B = jax.jit(jax.vmap(jax_module.linearize))(q, qd, u)
    expected = numpy_module.linearize(q, qd, u)
    _close(A, expected[0], "jit vmap linearize A")
    _close(B, expected[1], "jit vmap linearize B")
    parameters = {k: jnp.asarray(v) for k, v in numpy_module.PARAMETERS.items()}   # a pytree, traced
    _close(jax.jit(lambda p: jax_module.mass_matrix(q, **p))(parameters), numpy_module.mass_matrix(q),
           "jit over parameters")


@pytest.mark.parametrize("robot", TRANSFORMS)
@pytest.mark.parametrize("smoothing", [0.0, 0.05])
def test_jacfwd_of_forward_dynamics_is_linearize(robot, smoothing, code_dir):
    numpy_module, jax_module = module_of(robot, str(code_dir)), jax_module_of(robot, str(code_dir))
    q, qd, _, u = _states(numpy_module, np.random.default_rng(4), 2)
    for state in zip(q, qd, u):
        _jacobians_agree(jax_module, *state, smoothing)


def _jacobians_agree(jax_module, q, qd, u, smoothing: float) -> None:
    n = len(q)
    A, B = jax_module.linearize(q, qd, u, friction_smoothing=smoothing)
    by_state = jax.jacfwd(lambda x: jax_module.forward_dynamics(x[:n], x[n:], u, friction_smoothing=smoothing))(
        jnp.concatenate([q, qd]))
    by_effort = jax.jacrev(lambda v: jax_module.forward_dynamics(q, qd, v, friction_smoothing=smoothing))(u)
    _close(by_state, A[n:], "jacfwd(forward_dynamics) vs linearize A", 1e-9)
    _close(by_effort, B[n:], "jacrev(forward_dynamics) vs linearize B", 1e-9)
    assert np.any(np.abs(np.asarray(A[n:])) > 1e-6)


@pytest.mark.parametrize("robot", ["ur5", "four_bar"])
def test_large_batches_hold_values_and_agree(robot, code_dir, monkeypatch):
    """A traced batch of at least ``HOLD_STATES`` states runs the bodies with ``_hold`` (loops in
    the program XLA compiles; none for a small batch), and so does ``jax.vmap`` of the
    single-state function over as many: every function still agrees with the NumPy module, and
    so do forward- and reverse-mode derivatives through the holds (against the generated
    ``linearize``) and float32."""
    numpy_module, jax_module = module_of(robot, str(code_dir)), jax_module_of(robot, str(code_dir))
    count = jax_module.HOLD_STATES + 3
    q, qd, qdd, u = _states(numpy_module, np.random.default_rng(9), count)
    forward = jax_module.forward_dynamics
    def loops(function, *arguments) -> int:
        return jax.jit(function).lower(*arguments).as_text().count("stablehlo.while")

    small = loops(forward, q[:4], qd[:4], u[:4])   # the loops' Newton steps and solves have loops of their own
    held = loops(forward, q, qd, u)
    assert held > small
    assert loops(jax.vmap(forward), q[:4], qd[:4], u[:4]) == small
    assert loops(jax.vmap(forward), q, qd, u) == held
    mapped = jax.jit(jax.vmap(forward))
    _close(mapped(q, qd, u), numpy_module.forward_dynamics(q, qd, u), "jit(vmap) of a held batch")
    _agree_traced(numpy_module, jax_module, seed=9, count=count)
    weights = np.random.default_rng(11).normal(size=(count, n := len(numpy_module.COORDINATES)))
    A, _ = numpy_module.linearize(q, qd, u)
    gradient = jax.jit(jax.vmap(jax.grad(lambda x, v, w, c: jnp.sum(c * forward(x, v, w)), argnums=1)))(q, qd, u, weights)
    _close(gradient, np.einsum("si,sij->sj", weights, A[:, n:, n:]), "vmap(grad) of a held batch", 1e-9)
    dq = np.random.default_rng(10).normal(size=(count, n))
    _, tangent = jax.jit(lambda x, v: jax.jvp(lambda y: forward(y, v, u), (x,), (dq,)))(q, qd)
    _close(tangent, np.einsum("sij,sj->si", A[:, n:, :n], dq), "jvp of a held batch", 1e-9)
    gradient = jax.jit(jax.grad(lambda v: jnp.sum(weights * forward(q, v, u))))(qd)
    _close(gradient, np.einsum("si,sij->sj", weights, A[:, n:, n:]), "grad of a held batch", 1e-9)
    single = jax.jit(forward)(*(a.astype(np.float32) for a in (q, qd, u)))
    assert single.dtype == jnp.float32
    _close(single, numpy_module.forward_dynamics(q, qd, u), "float32 held batch", 1e-3)
    # over CHUNK_STATES states: chunks run by a scan, the last one padded (a new function: a new trace)
    monkeypatch.setattr(jax_module, "CHUNK_STATES", 50)
    chunked = jax.jit(lambda *a: forward(*a)).lower(q, qd, u)
    assert chunked.as_text().count("stablehlo.while") > held   # the chunks' scan
    _close(chunked.compile()(q, qd, u), numpy_module.forward_dynamics(q, qd, u), "chunked batch")
    gradient = jax.jit(jax.grad(lambda v: jnp.sum(weights * forward(q, v, u))))(qd)
    _close(gradient, np.einsum("si,sij->sj", weights, A[:, n:, n:]), "grad of a chunked batch", 1e-9)
    wide = jax.jit(lambda x, v, w: forward(x, v, w))(q.reshape(1, count, n), qd, u)
    _close(wide[0], numpy_module.forward_dynamics(q, qd, u), "chunked batch of two batch axes")


@pytest.mark.parametrize("robot", ["rp_arm", "cart_pole_damped", "slider_crank", "ur5"])
def test_parameter_gradient_of_inverse_dynamics_is_the_regressor(robot, code_dir):
    """tau(p) = Y(q, qd, qdd; p) pi(p): d tau/dp = dY/dp pi + Y dpi/dp, every parameter; and
    where Y does not depend on a parameter (masses, inertias, friction), d tau/dp = Y dpi/dp."""
    module = jax_module_of(robot, str(code_dir))
    names = list(module.PARAMETERS)
    values = jnp.asarray([module.PARAMETERS[k] for k in names]) * 1.1
    q, qd, qdd, _ = _states(module_of(robot, str(code_dir)), np.random.default_rng(6), 2)
    smoothing = 0.05   # friction's sign smoothed: its column then has a derivative

    for state in zip(q, qd, qdd):
        _parameter_derivatives_agree(module, names, values, *state, smoothing)


def _parameter_derivatives_agree(module, names, values, q, qd, qdd, smoothing: float) -> None:
    def keywords(p):
        return dict(zip(names, p))

    tau = jax.jacfwd(lambda p: module.inverse_dynamics(q, qd, qdd, friction_smoothing=smoothing, **keywords(p)))(values)
    Y = module.regressor(q, qd, qdd, friction_smoothing=smoothing, **keywords(values))
    dY = jax.jacfwd(lambda p: module.regressor(q, qd, qdd, friction_smoothing=smoothing, **keywords(p)))(values)
    pi = module.parameter_vector(**keywords(values))
    dpi = jax.jacfwd(lambda p: module.parameter_vector(**keywords(p)))(values)
    _close(tau, jnp.einsum("ijp,j->ip", dY, pi) + Y @ dpi, "d tau/dp", 1e-9)
    inertial = [j for j in range(len(names)) if not np.any(np.asarray(dY[..., j]))]
    assert inertial or names == ["g"], "some parameter enters only through pi"   # a URDF: only g
    _close(tau[:, inertial], (Y @ dpi)[:, inertial], "d tau/dp of the inertial parameters", 1e-9)
    # the gradient with respect to the parameter vector itself: tau = Y pi is linear in pi
    _close(jax.jacfwd(lambda v: Y @ v)(pi), Y, "d tau/d pi")
    _close(Y @ pi, module.inverse_dynamics(q, qd, qdd, friction_smoothing=smoothing, **keywords(values)), "Y pi = tau")


@pytest.mark.parametrize("robot", ["rp_arm", "cart_pole_damped", "four_bar", "ur5"])
def test_float32(robot, code_dir):
    numpy_module, jax_module = module_of(robot, str(code_dir)), jax_module_of(robot, str(code_dir))
    q, qd, qdd, u = _states(numpy_module, np.random.default_rng(8), 4)
    single = [a.astype(np.float32) for a in (q, qd, qdd, u)]
    for name, args, expected in (
            ("mass_matrix", single[:1], numpy_module.mass_matrix(q)),
            ("inverse_dynamics", single[:3], numpy_module.inverse_dynamics(q, qd, qdd)),
            ("forward_dynamics", [single[0], single[1], single[3]], numpy_module.forward_dynamics(q, qd, u)),
            ("regressor", single[:3], numpy_module.regressor(q, qd, qdd))):
        actual = jax.jit(getattr(jax_module, name))(*args)
        assert actual.dtype == jnp.float32, name
        _close(actual, expected, f"float32 {name}", 1e-3)
    A, _ = jax_module.linearize(single[0][0], single[1][0], single[3][0])
    assert A.dtype == jnp.float32


def test_assemble_is_traced_and_marks_failure_with_nan(code_dir):
    module = jax_module_of("four_bar", str(code_dir))
    guess = jnp.asarray(module.ASSEMBLED_CONFIGURATION) + 0.05
    assembled = jax.jit(module.assemble)(guess)
    _close(module.loop_constraints(assembled), np.zeros(len(module.LOOPS) * 2), "a_g(assembled)")
    sensitivity = jax.jacfwd(module.assemble)(guess)   # d(assembled)/d(guess): only the independent columns
    dependent = [i for i, c in enumerate(module.COORDINATES) if c not in module.INDEPENDENT_COORDINATES]
    assert np.all(np.isfinite(sensitivity)) and np.allclose(np.asarray(sensitivity)[:, dependent], 0.0, atol=1e-9)
    numpy_module = module_of("four_bar", str(code_dir))
    apart = {"d": 5.0}   # the ground link longer than the other three together: no assembly
    with pytest.raises(ValueError):
        numpy_module.assemble(np.asarray(guess), **apart)
    assert np.all(np.isnan(jax.jit(lambda g: module.assemble(g, **apart))(guess)))


def test_module_is_pure_and_imports_only_jax(code_dir):
    """No subscript is assigned (no in-place write), the only imports are jax's."""
    for robot in ("four_bar", "cart_pole_damped", "ur5", "bennett"):
        tree = ast.parse(render_jax(derivation_of(robot)))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                assert not any(isinstance(t, ast.Subscript) for t in targets), ast.unparse(node)
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [node.module] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
                assert all(n.split(".")[0] == "jax" for n in names), ast.unparse(node)


HOSTILE = 'a """ b\n import os\r\\ \' # c \u202e\x00 \U0001f600 "q'


def test_hostile_text_and_names(tmp_path):
    """A title and a description that would end the docstring, and parameters named like the
    module's imports (``jax``, ``jnp``): encoded, read back exactly, and the module works."""
    text = (ROBOTS / "rp_arm.yaml").read_text()
    title = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    lines = [f'title: "{title}"' if line.startswith("title:") else line for line in text.splitlines()]
    text = "\n".join(lines).replace("description: mass of each link", f'description: "{title}"') + "\n"
    head, body = text.split("\ngravity:")
    head = head.replace("\n  m:", "\n  jnp:").replace("\n  l:", "\n  jax:")
    text = head + "\ngravity:" + re.sub(r"\bl\b", "jax", re.sub(r"\bm\b", "jnp", body))
    path = tmp_path / "rp_arm.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.title == HOSTILE and [p.name for p in derivation.robot.parameters][:2] == ["jnp", "jax"]
    source = render_jax(derivation)
    assert ast.get_docstring(ast.parse(source), clean=False).startswith(f"Equations of motion of {HOSTILE} ")
    module = import_code(source, tmp_path, "hostile_dynamics_jax")
    assert "jnp" in module.PARAMETERS and "jax" in module.PARAMETERS
    rows = compiled_checks(derivation, dynderive.render_code(derivation), module, states=3, seed=2, label="JAX",
                           target="jax", values={"jnp": 1.7, "jax": 0.8})
    assert [row.name for row in rows if row.status != "pass"] == [] and len(rows) >= 12


def test_solve_and_build_write_the_module(tmp_path):
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["solve", "rp_arm", "--jax", "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 0, result.output
    written = tmp_path / "rp_arm_dynamics_jax.py"
    assert written.read_text() == render_jax(derivation_of("rp_arm"))
    result = CliRunner().invoke(app, ["build", str(ROBOTS / "rp_arm.yaml"), "--jax", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0 and (tmp_path / "b" / "rp_arm_dynamics_jax.py").is_file(), result.output
    result = CliRunner().invoke(app, ["build", str(ROBOTS / "rp_arm.yaml"), "--jax", "--out", str(tmp_path / "b"), "--check"])
    assert result.exit_code == 0 and "current" in result.output, result.output


def test_check_backend_jax():
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["check", "cart_pole_damped", "--backend", "jax", "--states", "3", "--quiet"])
    assert result.exit_code == 0, result.output
    rows = [line for line in result.output.splitlines() if line.startswith("JAX ")]
    assert len(rows) >= 11 and all(" pass " in line for line in rows)
    assert any("friction_smoothing" in line for line in rows)


# -- floating base and spherical joints ------------------------------------------------------------
# test_free_flyer and test_spherical skip themselves without Pinocchio: the tests below import
# them, so that the rest of this file runs without it.

runner = CliRunner()

BOX = """name: box
title: A free box with an arm
planar: false
parameters:
  m: {value: 2.0, unit: kg}
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: base, mass: m, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
  - {name: arm, mass: m, com: [0.2, 0, 0], inertia: [0.001, 0.03, 0.03, 0, 0, 0]}
joints:
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 1, 0], effort: tau2}
  - {name: root, type: floating, parent: world, child: base, origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 1.1]}}
frames:
  - {name: tip, link: arm, origin: {xyz: [0.4, 0.05, -0.02]}}
"""


def _floating_tree(seed: int, joints: int) -> str:
    """``test_free_flyer``'s random floating tree of ``joints`` joints, named by its seed."""
    from test_free_flyer import _floating_tree as _base_tree

    return _base_tree(seed, joints).replace("name: floating_tree\n", f"name: floating_tree_{seed}\n", 1)


def _solo12() -> Path:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    paths = [Path(str(dist.locate_file(f))) for f in dist.files or () if str(f).endswith("robots/solo12.urdf")]
    if not paths:
        pytest.skip("solo12.urdf is not in example-robot-data")
    return paths[0]


@cache
def _modules(robot: str, directory: str):
    """(NumPy module, JAX module) of ``robot``: "box", "tree", "spherical" (random spherical
    joints below a floating base: ``test_spherical``'s trees) or "solo12"."""
    folder = Path(directory)
    if robot == "solo12":
        loaded = dynderive.load_robot(_solo12(), floating_base=True)
    else:
        from test_spherical import _tree as spherical_tree

        path = folder / f"{robot}.yaml"
        path.write_text({"box": BOX, "tree": None, "spherical": None}[robot] or
                        (_floating_tree(7, 3) if robot == "tree" else spherical_tree(5, True)))
        loaded = dynderive.load_robot(path)
    derivation = dynderive.derive(loaded)
    name = loaded.name
    return (import_code(render_code(derivation), folder, f"{name}_dynamics"),
            import_code(render_jax(derivation), folder, f"{name}_dynamics_jax"))


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("floating_jax"))


def _floating_states(module, rng, count: int) -> dict:
    """Random states on the manifold: the neutral configuration moved by random velocities
    (random unit quaternions), random rates, accelerations and efforts."""
    nv = module.NV
    return {"q": module.integrate(module.neutral_configuration(), rng.uniform(-2.0, 2.0, (count, nv))),
            "q_from": module.integrate(module.neutral_configuration(), rng.uniform(-2.0, 2.0, (count, nv))),
            "qd": rng.normal(size=(count, nv)), "qd_minus": rng.normal(size=(count, nv)), "qdd": rng.normal(size=(count, nv)), "v": rng.normal(size=(count, nv)),
            "u": rng.normal(size=(count, len(module.EFFORTS)))}


def _calls(module, name: str, state: dict) -> list[list]:
    """The positional arguments of each call of ``name`` to compare (one per frame for frame functions)."""
    parameters = inspect.signature(getattr(module, name)).parameters.values()
    positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD and p.default is p.empty]
    names = {"q_to": "q", "q_from": "q_from"}
    args = [state[names.get(a, a)] for a in positional if a != "frame"]
    return [args + [frame] for frame in module.FRAMES] if "frame" in positional else [args]


def _agree_floating_traced(numpy_module, jax_module, seed: int, count: int) -> int:
    """Every public function of the NumPy module against the JAX one on a batch of states
    under ``jax.jit``; the number of calls compared."""
    assert _public(numpy_module) == _public(jax_module)
    for constant in ("PARAMETERS", "COORDINATES", "VELOCITIES", "EFFORTS", "FRAMES", "PARAMETER_VECTOR", "NQ", "NV",
                     "EFFORT_COLUMNS"):
        assert getattr(numpy_module, constant) == getattr(jax_module, constant), constant
    state = _floating_states(numpy_module, np.random.default_rng(seed), count)
    compared = 0
    for name in _public(numpy_module):
        for args in _calls(numpy_module, name, state):
            expected = getattr(numpy_module, name)(*args)
            function = getattr(jax_module, name)
            actual = _traced(function, args, {})
            expected, actual = (expected, actual) if isinstance(expected, tuple) else ((expected,), (actual,))
            for e, a in zip(expected, actual, strict=True):
                _close(a, e, f"{name} {[a for a in args if isinstance(a, str)]}")
            compared += 1
    return compared


def test_jit_vmap_and_parameters(folder):
    numpy_module, jax_module = _modules("box", folder)
    s = _floating_states(numpy_module, np.random.default_rng(5), 4)
    q, qd, qdd, u = s["q"], s["qd"], s["qdd"], s["u"]
    _close(jax.jit(jax_module.forward_dynamics)(q, qd, u), numpy_module.forward_dynamics(q, qd, u), "jit forward")
    _close(jax.vmap(jax_module.inverse_dynamics)(q, qd, qdd), numpy_module.inverse_dynamics(q, qd, qdd),
           "vmap inverse_dynamics")
    A, B = jax.vmap(jax_module.linearize)(q, qd, u)
    expected = numpy_module.linearize(q, qd, u)
    _close(A, expected[0], "vmap linearize A")
    _close(B, expected[1], "vmap linearize B")
    _close(jax.vmap(jax_module.integrate, in_axes=(0, 0, None))(q, qd, 0.3), numpy_module.integrate(q, qd, 0.3),
           "vmap integrate")
    _close(jax.jit(jax.vmap(jax_module.difference))(s["q_from"], q), numpy_module.difference(s["q_from"], q),
           "jit vmap difference")
    parameters = {k: jnp.asarray(v) * 1.2 for k, v in numpy_module.PARAMETERS.items()}   # a pytree, traced
    _close(jax.jit(lambda p: jax_module.mass_matrix(q, **p))(parameters),
           numpy_module.mass_matrix(q, **{k: v * 1.2 for k, v in numpy_module.PARAMETERS.items()}),
           "jit over parameters")


@pytest.mark.parametrize("robot", ["box", "tree", "spherical"])
def test_jacfwd_through_integrate_is_linearize(robot, folder):
    """A (2 NV x 2 NV) on the tangent space: d forward_dynamics(integrate(q, dq), qd + dqd)/d(dq, dqd)
    at 0 is its lower half; d forward_dynamics/du is B's."""
    numpy_module, jax_module = _modules(robot, folder)
    s = _floating_states(numpy_module, np.random.default_rng(7), 1)
    nv = jax_module.NV
    for q, qd, u in zip(s["q"], s["qd"], s["u"]):
        A, B = jax_module.linearize(q, qd, u)
        assert A.shape == (2 * nv, 2 * nv) and B.shape == (2 * nv, len(jax_module.EFFORTS))
        _close(A, numpy_module.linearize(q, qd, u)[0], "linearize A")

        def moved(x, q=q, qd=qd, u=u):
            return jax_module.forward_dynamics(jax_module.integrate(q, x[:nv]), qd + x[nv:], u)

        by_state = jax.jacfwd(moved)(jnp.zeros(2 * nv))
        by_effort = jax.jacrev(lambda w, q=q, qd=qd: jax_module.forward_dynamics(q, qd, w))(u)
        _close(by_state, A[nv:], "jacfwd(forward_dynamics o integrate) vs linearize A", 1e-9)
        _close(by_effort, B[nv:], "jacrev(forward_dynamics) vs linearize B", 1e-9)
        _close(A[:nv], np.hstack([np.zeros((nv, nv)), np.eye(nv)]), "A's upper rows")
        assert np.any(np.abs(np.asarray(A[nv:, :nv])) > 1e-6)
        # the tangent of integrate at dq = 0 is configuration_rate: finite, no NaN from |w| = 0
        rate = jax.jacfwd(lambda x, q=q: jax_module.integrate(q, x))(jnp.zeros(nv)) @ qd
        _close(rate, numpy_module.configuration_rate(q, qd), "d integrate/d v at 0 = configuration_rate")
        # and difference is integrate's inverse to first order: d difference(q, integrate(q, x))/dx = I at 0
        inverse = jax.jacfwd(lambda x, q=q: jax_module.difference(q, jax_module.integrate(q, x)))(jnp.zeros(nv))
        _close(inverse, np.eye(nv), "d difference(q, integrate(q, x))/dx at 0", 1e-12)


def test_parameter_gradient_of_inverse_dynamics_of_a_floating_robot_is_the_regressor(folder):
    """tau(p) = Y(q, qd, qdd; p) pi(p): d tau/dp = dY/dp pi + Y dpi/dp; the mass m enters
    only through pi, so there d tau/dm = Y dpi/dm."""
    _, module = _modules("box", folder)
    names = list(module.PARAMETERS)
    values = jnp.asarray([module.PARAMETERS[k] for k in names]) * 1.1
    s = _floating_states(_modules("box", folder)[0], np.random.default_rng(8), 2)

    def keywords(p):
        return dict(zip(names, p))

    for q, qd, qdd in zip(s["q"], s["qd"], s["qdd"]):
        tau = jax.jacfwd(lambda p, q=q, qd=qd, qdd=qdd: module.inverse_dynamics(q, qd, qdd, **keywords(p)))(values)
        Y = module.regressor(q, qd, qdd, **keywords(values))
        dY = jax.jacfwd(lambda p, q=q, qd=qd, qdd=qdd: module.regressor(q, qd, qdd, **keywords(p)))(values)
        pi = module.parameter_vector(**keywords(values))
        dpi = jax.jacfwd(lambda p: module.parameter_vector(**keywords(p)))(values)
        _close(tau, jnp.einsum("ijp,j->ip", dY, pi) + Y @ dpi, "d tau/dp", 1e-9)
        inertial = [j for j in range(len(names)) if not np.any(np.asarray(dY[..., j]))]
        assert [names[j] for j in inertial] == ["m"]
        _close(tau[:, inertial], (Y @ dpi)[:, inertial], "d tau/dm", 1e-9)
        _close(Y @ pi, module.inverse_dynamics(q, qd, qdd, **keywords(values)), "Y pi = tau")
        assert np.any(np.abs(np.asarray(tau)) > 1e-6)


def test_float32_stays_float32(folder):
    numpy_module, jax_module = _modules("box", folder)
    s = _floating_states(numpy_module, np.random.default_rng(9), 4)
    single = {k: v.astype(np.float32) for k, v in s.items()}
    for name, args in (("mass_matrix", "q"), ("inverse_dynamics", "q qd qdd"), ("forward_dynamics", "q qd u"),
                       ("regressor", "q qd qdd"), ("integrate", "q v"), ("difference", "q_from q"),
                       ("configuration_rate", "q v")):
        actual = getattr(jax_module, name)(*(single[a] for a in args.split()))
        assert actual.dtype == jnp.float32, name
        _close(actual, getattr(numpy_module, name)(*(s[a] for a in args.split())), f"float32 {name}", 1e-3)
    A, B = jax_module.linearize(single["q"][0], single["qd"][0], single["u"][0])
    assert A.dtype == B.dtype == jnp.float32
    assert jax_module.integrate(single["q"], single["v"], np.float32(0.1)).dtype == jnp.float32


def test_large_traced_batch_holds_values_and_agrees(folder):
    """A traced batch of at least HOLD_STATES states runs the bodies with ``_hold`` (loops XLA
    cannot fuse through): every function still agrees, and so do derivatives through the holds."""
    numpy_module, jax_module = _modules("box", folder)
    count = jax_module.HOLD_STATES + 3
    s = _floating_states(numpy_module, np.random.default_rng(10), count)
    q, qd, u = s["q"], s["qd"], s["u"]
    forward = jax_module.forward_dynamics

    def loops(*arguments) -> int:
        return jax.jit(forward).lower(*arguments).as_text().count("stablehlo.while")

    assert loops(q, qd, u) > loops(q[:4], qd[:4], u[:4]) == 0
    assert _agree_floating_traced(numpy_module, jax_module, seed=10, count=count) >= 14
    nv = jax_module.NV
    A, _ = numpy_module.linearize(q, qd, u)
    weights = np.random.default_rng(11).normal(size=(count, nv))
    gradient = jax.jit(jax.grad(lambda v: jnp.sum(weights * forward(q, v, u))))(qd)
    _close(gradient, np.einsum("si,sij->sj", weights, A[:, nv:, nv:]), "grad of a held batch", 1e-9)


def test_integrate_keeps_quaternions_unit(folder):
    numpy_module, jax_module = _modules("tree", folder)
    qx = next(i for i, name in enumerate(jax_module.COORDINATES) if name.endswith("_qx"))   # the base's quaternion
    rng = np.random.default_rng(12)
    q = numpy_module.integrate(numpy_module.neutral_configuration(), rng.uniform(-3, 3, (256, jax_module.NV)))
    step = jax.jit(jax_module.integrate)
    for dt in (0.01, 0.7, 5.0):
        for _ in range(20):
            q = step(q, rng.normal(size=(256, jax_module.NV)) * 3.0, dt)
        norms = np.linalg.norm(np.asarray(q)[:, qx:qx + 4], axis=-1)
        assert np.max(np.abs(norms - 1.0)) < 1e-13
    single = jax.jit(jax_module.integrate)(q.astype(np.float32), rng.normal(size=jax_module.NV).astype(np.float32))
    assert np.max(np.abs(np.linalg.norm(np.asarray(single)[:, qx:qx + 4], axis=-1) - 1.0)) < 1e-6


def test_module_of_a_floating_robot_is_pure_and_imports_only_jax(folder):
    """No subscript is assigned (no in-place write), the only imports are jax's; the manifold
    functions and their bodies (printed from the joint types) branch on no value (``jnp.where``)."""
    _, jax_module = _modules("box", folder)
    tree = ast.parse(Path(jax_module.__file__).read_text())
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            assert not any(isinstance(t, ast.Subscript) for t in targets), ast.unparse(node)
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [node.module] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
            assert all(n.split(".")[0] == "jax" for n in names), ast.unparse(node)
        if isinstance(node, ast.FunctionDef) and node.name in ("integrate", "difference", "configuration_rate",
                                                               "_integrate_body", "_difference_body",
                                                               "_configuration_rate_body", "_sqrt"):
            assert not any(isinstance(n, (ast.If, ast.IfExp, ast.While)) for n in ast.walk(node)), node.name


def test_solve_build_and_check_write_and_check_the_module(tmp_path):
    path = tmp_path / "box.yaml"
    path.write_text(BOX)
    derivation = dynderive.derive(dynderive.load_robot(path))
    result = runner.invoke(app, ["solve", str(path), "--jax", "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, result.output
    assert "every output is built except the MATLAB derivation script" in result.stderr
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["box_dynamics_jax.py"]
    assert (tmp_path / "a" / "box_dynamics_jax.py").read_text() == render_jax(derivation)
    result = runner.invoke(app, ["solve", str(path), "--jax", "--code", "--out", str(tmp_path / "b"), "-q"])
    assert result.exit_code == 0 and sorted(p.name for p in (tmp_path / "b").iterdir()) == [
        "box_dynamics.py", "box_dynamics_jax.py"], result.output
    result = runner.invoke(app, ["build", str(path), "--jax", "--out", str(tmp_path / "d"), "-j", "1"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "d").iterdir() if not p.name.startswith(".")) == ["box_dynamics_jax.py"]
    result = runner.invoke(app, ["build", str(path), "--jax", "--out", str(tmp_path / "d"), "--check", "-j", "1"])
    assert result.exit_code == 0 and "current" in result.output, result.output
    result = runner.invoke(app, ["check", str(path), "--backend", "jax", "--states", "3", "--json", "-q"])
    assert result.exit_code == 0, result.output
    import json

    rows = {row["name"]: row["status"] for row in json.loads(result.stdout)["checks"]}
    jax_rows = [name for name in rows if name.startswith("JAX ")]
    assert len(jax_rows) == 33 and all(rows[name] == "pass" for name in jax_rows)   # 9 centroidal, 2 contacts, 2 wrenches
    assert rows["JAX forward_dynamics with wrenches at every frame == NumPy module"] == "pass"
    assert "JAX frame_jacobian (frame tip) == NumPy module" in rows and "JAX integrate == NumPy module" in rows


def test_hostile_title_and_parameters_named_like_the_imports(tmp_path):
    """A title that would end the docstring, and a parameter named ``jnp`` (the module imports
    ``jax.numpy`` as ``_jnp``): encoded, read back exactly, and the module agrees."""
    title = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    text = BOX.replace("title: A free box with an arm", f'title: "{title}"').replace("  m: {", "  jnp: {") \
        .replace("mass: m,", "mass: jnp,")
    path = tmp_path / "box.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.title == HOSTILE
    source = render_jax(derivation)
    assert ast.get_docstring(ast.parse(source), clean=False).startswith(f"Equations of motion of {HOSTILE} ")
    module = import_code(source, tmp_path, "hostile_floating_dynamics_jax")
    numpy_module = import_code(render_code(derivation), tmp_path, "hostile_floating_dynamics")
    q = numpy_module.integrate(numpy_module.neutral_configuration(), np.linspace(-1, 1, numpy_module.NV))
    _close(module.mass_matrix(q, jnp=1.7), numpy_module.mass_matrix(q, jnp=1.7), "mass_matrix with jnp = 1.7")
    _close(module.parameter_vector(jnp=1.7), numpy_module.parameter_vector(jnp=1.7), "parameter_vector")
    assert not np.allclose(module.mass_matrix(q, jnp=1.7), module.mass_matrix(q))
