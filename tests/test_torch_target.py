"""The PyTorch target (``solve --torch``), what is PyTorch's own: ``solve`` and ``build`` write the
module, which imports only torch and writes nothing in place; batches of several leading
dimensions equal the states one by one; float32 stays float32 and close to float64;
``torch.autograd.functional.jacobian`` of ``forward_dynamics`` equals
``forward_dynamics_derivatives`` (planar, with smoothed friction, closed loops, a ball joint
through ``integrate``) and a parameter's gradient its finite difference; ``torch.compile`` of
``forward_dynamics`` and ``mass_matrix`` gives the eager numbers; ``check`` and ``simulate
--backend torch`` run it; the checks that raise on a value raise as the NumPy module's;
hostile text and parameters named like the module's names; without torch, a note.

Agreement with the NumPy module for every robot class is the registry's agreement test (every
target with a ``load``); ``check --backend torch`` is run here once. Skipped without ``torch``
(it is in the ``test`` extra; CI installs the CPU wheel first).
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

if os.environ.get("CI"):   # the PyTorch target's tests are required in CI (torch is in the test extra)
    import torch
else:
    torch = pytest.importorskip("torch")

import dynderive  # noqa: E402
from dynderive.commands.cli import app  # noqa: E402
from dynderive.render.targets.torch.harness import NumpyFacade  # noqa: E402
from dynderive.render.targets.torch.printer import render_torch  # noqa: E402

from conftest import ROBOTS, derivation_of, import_code, on_loops  # noqa: E402

runner = CliRunner()
F64 = torch.float64

#: A ball joint (quaternion in q) under a damped wrist, with a frame: the tangent-space functions.
BALL_ARM = """name: ball_arm
title: An arm on a ball joint
planar: false
parameters:
  m: {value: 1.5, unit: kg}
  l: {value: 0.8, unit: m}
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: rod, mass: m, com: [0, 0, -l/2], inertia: [0.08, 0.08, 0.002, 0, 0, 0]}
  - {name: hand, mass: m/3, com: [0.1, 0, 0], inertia: [0.001, 0.004, 0.004, 0, 0, 0]}
joints:
  - {name: ball, type: spherical, parent: world, child: rod, origin: {xyz: [0, 0, 1]}}
  - {name: wrist, type: revolute, parent: rod, child: hand, origin: {xyz: [0, 0, -l]}, axis: [0, 1, 0], effort: tau,
     damping: 0.1, friction: 0.05}
frames:
  - {name: tip, link: hand, origin: {xyz: [0.2, 0, 0]}}
"""


def _solve(folder: Path, robot: str, *extra: str):
    """``dynderive solve ROBOT --torch`` into ``folder``, the written module imported."""
    result = runner.invoke(app, ["solve", robot, "--torch", *extra, "--out", str(folder), "--quiet"])
    assert result.exit_code == 0, result.output
    written = next(folder.glob("*_dynamics_torch.py"))
    return import_code(written.read_text(), folder, f"{written.stem}_{folder.name}")


@pytest.fixture(scope="module")
def modules(tmp_path_factory):
    """The PyTorch modules ``solve --torch`` writes, by robot (written once)."""
    cache: dict[str, object] = {}

    def module(robot: str):
        if robot not in cache:
            folder = tmp_path_factory.mktemp(re.sub(r"\W", "_", robot))
            if robot == "ball_arm":
                (folder / "ball_arm.yaml").write_text(BALL_ARM)
                robot_path = str(folder / "ball_arm.yaml")
            else:
                robot_path = robot
            cache[robot] = _solve(folder, robot_path)
        return cache[robot]

    return module


def _states(module, count: int, seed: int = 0):
    """(q, qd, u) float64 tensors of ``count`` states (on the loops; unit quaternions)."""
    rng = np.random.default_rng(seed)
    nv = getattr(module, "NV", len(module.COORDINATES))
    qd = rng.uniform(-1.0, 1.0, (count, nv))
    if hasattr(module, "integrate"):
        q = module.integrate(module.neutral_configuration(), torch.from_numpy(rng.uniform(-1.0, 1.0, (count, nv)))).numpy()
    else:
        q = rng.uniform(-1.0, 1.0, (count, len(module.COORDINATES)))
    if hasattr(module, "LOOPS"):
        q, qd = on_loops(NumpyFacade(module), q, qd)
    u = rng.uniform(-1.0, 1.0, (len(q), len(module.EFFORTS)))
    return torch.from_numpy(np.asarray(q)), torch.from_numpy(np.asarray(qd)), torch.from_numpy(u)


def _close(actual, expected, rtol: float, what: str) -> None:
    actual, expected = torch.as_tensor(actual, dtype=F64), torch.as_tensor(expected, dtype=F64)
    assert actual.shape == expected.shape, f"{what}: shape {tuple(actual.shape)} != {tuple(expected.shape)}"
    scale = max(1.0, float(expected.abs().max()))
    error = float((actual - expected).abs().max())
    assert torch.isfinite(actual).all() and error <= rtol * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def test_solve_and_build_write_the_module_which_imports_only_torch_and_writes_nothing_in_place(tmp_path):
    result = runner.invoke(app, ["solve", "rp_arm", "--torch", "--out", str(tmp_path / "s"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["rp_arm_dynamics_torch.py"]
    assert (tmp_path / "s" / "rp_arm_dynamics_torch.py").read_text() == render_torch(derivation_of("rp_arm"))
    built = tmp_path / "b"
    result = runner.invoke(app, ["build", str(ROBOTS / "rp_arm.yaml"), "--torch", "--out", str(built)])
    assert result.exit_code == 0 and (built / "rp_arm_dynamics_torch.py").is_file(), result.output
    result = runner.invoke(app, ["build", str(ROBOTS / "rp_arm.yaml"), "--torch", "--out", str(built), "--check"])
    assert result.exit_code == 0 and "current" in result.output, result.output
    for robot in ("rp_arm", "four_bar", "cart_pole_damped", "bennett"):
        tree = ast.parse(render_torch(derivation_of(robot)))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                assert not any(isinstance(t, ast.Subscript) for t in targets), (robot, ast.unparse(node))
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [node.module] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
                assert names == ["torch"], (robot, ast.unparse(node))
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                assert not node.func.attr.endswith("_") or node.func.attr.startswith("_"), ast.unparse(node)


@pytest.mark.parametrize("robot", ["rp_arm", "four_bar", "ball_arm"])
def test_batches_of_several_leading_dimensions_are_the_states_one_by_one(robot, modules):
    module = modules(robot)
    q, qd, u = _states(module, 6)
    shape = (2, 3)
    batch = [t.reshape(shape + t.shape[-1:]) for t in (q, qd, u)]
    calls = {"forward_dynamics": lambda q, qd, u: module.forward_dynamics(q, qd, u),
             "mass_matrix": lambda q, qd, u: module.mass_matrix(q),
             "inverse_dynamics": lambda q, qd, u: module.inverse_dynamics(q, qd, qd),
             "linearize": lambda q, qd, u: module.linearize(q, qd, u),
             "regressor": lambda q, qd, u: module.regressor(q, qd, qd)}
    for name, call in calls.items():
        together = call(*batch)
        together = together if isinstance(together, tuple) else (together,)
        for index in range(6):
            alone = call(q[index], qd[index], u[index])
            alone = alone if isinstance(alone, tuple) else (alone,)
            for whole, one in zip(together, alone, strict=True):
                assert whole.shape[:2] == shape
                _close(whole.reshape((6,) + whole.shape[2:])[index], one, 1e-13, f"{robot} {name} state {index}")
    broadcast = module.mass_matrix(q[:3].reshape(3, 1, -1).expand(3, 4, -1))   # a stride-0 batch
    assert broadcast.shape[:2] == (3, 4)


@pytest.mark.parametrize("robot", ["rp_arm", "four_bar", "ball_arm", "cart_pole_damped"])
def test_float32_stays_float32_and_close(robot, modules):
    module = modules(robot)
    q, qd, u = _states(module, 5, seed=3)
    exact = module.forward_dynamics(q, qd, u)
    single = module.forward_dynamics(q.float(), qd.float(), u.float())
    assert exact.dtype == F64 and single.dtype == torch.float32
    _close(single, exact, 1e-3, f"{robot} float32 forward_dynamics")
    for result in (module.mass_matrix(q[0].float()), module.inverse_dynamics(q.float(), qd.float(), qd.float()),
                   module.linearize(q.float(), qd.float(), u.float())[0], module.regressor(q.float(), qd.float(), qd.float())):
        assert result.dtype == torch.float32
    assert module.parameter_vector().dtype == F64   # no tensor given: float64


@pytest.mark.parametrize("robot, smoothing", [("rp_arm", 0.0), ("cart_pole_damped", 0.05), ("four_bar", 0.0),
                                              ("ball_arm", 0.05)])
def test_autograd_jacobian_of_forward_dynamics_is_forward_dynamics_derivatives(robot, smoothing, modules):
    """With quaternions in q, through integrate at zero (the tangent space the derivatives are on)."""
    module = modules(robot)
    jacobian = torch.autograd.functional.jacobian
    q, qd, u = (t[0] for t in _states(module, 1, seed=5))
    friction = {"friction_smoothing": smoothing}
    by_q, by_qd, by_u = module.forward_dynamics_derivatives(q, qd, u, **friction)
    if hasattr(module, "integrate"):
        zero = torch.zeros(module.NV, dtype=F64)
        traced_q = jacobian(lambda v: module.forward_dynamics(module.integrate(q, v), qd, u, **friction), zero)
    else:
        traced_q = jacobian(lambda x: module.forward_dynamics(x, qd, u, **friction), q)
    _close(traced_q, by_q, 1e-9, f"{robot} d qdd / d q")
    _close(jacobian(lambda x: module.forward_dynamics(q, x, u, **friction), qd), by_qd, 1e-9, f"{robot} d qdd / d qd")
    _close(jacobian(lambda x: module.forward_dynamics(q, qd, x, **friction), u), by_u, 1e-9, f"{robot} d qdd / d u")


def test_gradient_with_respect_to_a_parameter_is_its_difference_quotient(modules):
    module = modules("rp_arm")
    q, qd, u = _states(module, 4, seed=7)
    mass = torch.tensor(1.3, dtype=F64, requires_grad=True)
    module.inverse_dynamics(q, qd, qd, m=mass).sum().backward()
    step = 1e-6
    quotient = (module.inverse_dynamics(q, qd, qd, m=1.3 + step).sum()
                - module.inverse_dynamics(q, qd, qd, m=1.3 - step).sum()) / (2 * step)
    assert abs(float(mass.grad) - float(quotient)) <= 1e-6 * max(1.0, abs(float(quotient)))
    assert float(mass.grad) != 0.0


def test_torch_compile_of_forward_dynamics_and_mass_matrix_gives_the_eager_numbers(modules):
    module = modules("rp_arm")
    q, qd, u = _states(module, 8, seed=9)
    torch._dynamo.reset()
    _close(torch.compile(module.forward_dynamics)(q, qd, u), module.forward_dynamics(q, qd, u), 1e-12, "compiled FD")
    _close(torch.compile(module.mass_matrix)(q), module.mass_matrix(q), 1e-12, "compiled M")


def test_values_the_numpy_module_refuses_are_refused(modules):
    """assemble raises where Newton's method does not close the loops, a negative smoothing
    raises: as in the NumPy module (the JAX module returns NaN instead)."""
    module = modules("four_bar")
    guess = torch.tensor(module.ASSEMBLED_CONFIGURATION, dtype=F64)
    _close(module.loop_constraints(module.assemble(guess)), torch.zeros(len(module.loop_constraints(guess))), 1e-10,
           "assembled")
    with pytest.raises(ValueError, match="could not be solved"):
        module.assemble(guess, d=5.0)   # the ground link longer than the other three together
    damped = modules("cart_pole_damped")
    q, qd, u = _states(damped, 2)
    with pytest.raises(ValueError, match="friction_smoothing must not be negative"):
        damped.forward_dynamics(q, qd, u, friction_smoothing=-1.0)


def test_check_and_simulate_backend_torch(tmp_path):
    result = runner.invoke(app, ["check", "cart_pole_damped", "--backend", "torch", "--states", "3", "--quiet"])
    assert result.exit_code == 0, result.output
    rows = [line for line in result.output.splitlines() if line.startswith("PyTorch ")]
    assert len(rows) >= 11 and all(" pass " in line for line in rows), rows
    assert any("friction_smoothing" in line for line in rows)
    csv = tmp_path / "trajectory.csv"
    result = runner.invoke(app, ["simulate", "rp_arm", "--backend", "torch", "--duration", "0.2", "--csv", str(csv),
                                 "--quiet"])
    assert result.exit_code == 0, result.output
    reference = tmp_path / "numpy.csv"
    result = runner.invoke(app, ["simulate", "rp_arm", "--duration", "0.2", "--csv", str(reference), "--quiet"])
    assert result.exit_code == 0, result.output
    ours, theirs = (np.loadtxt(p, delimiter=",", skiprows=1) for p in (csv, reference))
    assert ours.shape == theirs.shape and np.allclose(ours, theirs, rtol=1e-9, atol=1e-12)


HOSTILE = 'a """ b\n import os\r\\ \' # c \u202e\x00 \U0001f600 "q'


def test_hostile_text_and_parameters_named_like_the_modules_names(tmp_path):
    """A title and a description that would end the docstring, parameters named ``torch`` and
    ``tensor``: encoded, read back exactly, and the module computes what the NumPy module does."""
    text = (ROBOTS / "rp_arm.yaml").read_text()
    title = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") \
        .replace("\x00", "\\0").replace("\u202e", "\\u202e").replace("\U0001f600", "\\U0001f600")
    lines = [f'title: "{title}"' if line.startswith("title:") else line for line in text.splitlines()]
    text = "\n".join(lines).replace("description: mass of each link", f'description: "{title}"') + "\n"
    head, body = text.split("\ngravity:")
    head = head.replace("\n  m:", "\n  torch:").replace("\n  l:", "\n  tensor:")
    text = head + "\ngravity:" + re.sub(r"\bl\b", "tensor", re.sub(r"\bm\b", "torch", body))
    path = tmp_path / "rp_arm.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.title == HOSTILE and [p.name for p in derivation.robot.parameters][:2] == ["torch", "tensor"]
    module = _solve(tmp_path / "out", str(path))
    assert ast.get_docstring(ast.parse(render_torch(derivation)), clean=False).startswith(
        f"Equations of motion of {HOSTILE} ")
    numpy_module = import_code(dynderive.render_code(derivation), tmp_path, "hostile_dynamics")
    q, qd, u = _states(module, 4, seed=11)
    values = {"torch": 1.7, "tensor": 0.8}
    for name, arguments in (("forward_dynamics", (q, qd, u)), ("mass_matrix", (q,)), ("linearize", (q, qd, u))):
        ours = getattr(module, name)(*arguments, **values)
        theirs = getattr(numpy_module, name)(*(a.numpy() for a in arguments), **values)
        for a, b in zip(ours if isinstance(ours, tuple) else (ours,), theirs if isinstance(theirs, tuple) else (theirs,),
                        strict=True):
            _close(a, torch.from_numpy(np.asarray(b)), 1e-12, f"hostile {name}")


WITHOUT = """\
import sys
sys.modules["torch"] = None
from dynderive.__main__ import run
sys.argv = ["dynderive", *sys.argv[1:]]
run()
"""


def test_solve_torch_without_torch_writes_the_module_with_a_note_and_check_refuses(tmp_path):
    def without(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-c", WITHOUT, *args], capture_output=True, text=True, timeout=600)

    done = without("solve", "rp_arm", "--torch", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "PyTorch is not installed here" in done.stdout + done.stderr
    assert (tmp_path / "rp_arm_dynamics_torch.py").is_file()
    refused = without("check", "rp_arm", "--backend", "torch")
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert (refused.stdout + refused.stderr).strip().splitlines()[-1].startswith("--backend:1:1: ")
