"""The CasADi target (``solve --casadi``): every function of the NumPy module is a
``casadi.Function`` of the same name in the CasADi module and agrees with it to 1e-12 relative
(bundled robots, a closed loop, a random tree with full-precision numbers, a floating base),
with the parameters as an input (the defaults when left out, other values, a decision
variable); ``casadi.jacobian`` of ``forward_dynamics`` equals ``linearize``; the derivative
functions are the Jacobians of inverse and forward dynamics; the C that ``Function.generate``
writes compiles as C99; hostile text stays out of the code.

Skipped without ``casadi`` (it is in the ``test`` extra); required in CI.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
from functools import cache
from pathlib import Path

import numpy as np
import pytest

if os.environ.get("CI"):  # the CasADi target's tests are required in CI (casadi is in the test extra)
    import casadi
else:
    casadi = pytest.importorskip("casadi")

import dynderive  # noqa: E402
from dynderive.render import api  # noqa: E402
from dynderive.render.targets.casadi.casadi import render_casadi  # noqa: E402
from dynderive.verify.compiled import CasadiModule, compiled_checks  # noqa: E402

from conftest import (  # noqa: E402
    ROBOTS,
    ROOT,
    derivation_of,
    import_code,
    module_of,
    on_loops,
)

RTOL = 1e-12
FLOATING = ROOT / "tests" / "floating_elbow.urdf"


@cache
def casadi_module_of(robot: str, directory: str):
    return import_code(render_casadi(derivation_of(robot)), Path(directory), f"{robot}_dynamics_casadi")


@cache
def floating_modules(directory: str):
    derivation = dynderive.derive(dynderive.load_robot(FLOATING))
    folder = Path(directory)
    return (
        import_code(dynderive.render_code(derivation), folder, "floating_elbow_dynamics"),
        import_code(render_casadi(derivation), folder, "floating_elbow_dynamics_casadi"),
    )


def _close(actual, expected, what: str, rtol: float = RTOL) -> None:
    expected = np.asarray(expected, dtype=float)
    actual = np.asarray(actual, dtype=float).reshape(expected.shape)
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1.0)
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= rtol * scale, (
        f"{what}: error {error:.3g} at scale {scale:.3g}"
    )


def _states(numpy_module, rng, count: int) -> dict:
    """``count`` states by argument name (a loop robot's on its loops, a floating robot's unit
    quaternions)."""
    nu, nv = len(numpy_module.EFFORTS), len(getattr(numpy_module, "VELOCITIES", numpy_module.COORDINATES))
    qd, qdd, u = rng.normal(size=(count, nv)), rng.normal(size=(count, nv)), rng.normal(size=(count, nu))
    if hasattr(numpy_module, "neutral_configuration"):
        q = numpy_module.integrate(numpy_module.neutral_configuration(), rng.normal(size=(count, nv)))
        state = {
            "q_from": q,
            "q_to": numpy_module.integrate(q, 0.5 * rng.normal(size=(count, nv))),
            "v": rng.normal(size=(count, nv)),
            "dt": rng.uniform(0.1, 1.0, count),
        }
    else:
        q, qd = on_loops(numpy_module, rng.uniform(-1.2, 1.2, (count, nv)), qd)
        state = {}
    state |= {"q": q, "qd": qd, "qdd": qdd, "u": u}
    if hasattr(numpy_module, "MAXIMAL_COORDINATES"):
        size = len(numpy_module.MAXIMAL_COORDINATES)
        state |= {"qm": rng.uniform(-1, 1, (count, size)), "qmd": rng.normal(size=(count, size))}
    return state


#: A floating base with a spherical joint (two quaternions: NQ = NV + 2), as in test_joint_types.py.
BALL_ARM = """\
name: ball_arm
planar: false
gravity: [0, 0, -9.81]
links:
- {name: base, mass: 2.1234567890123456, com: [0.1, 0.02, -0.03], inertia: [0.3, 0.2, 0.25, 0.01, 0.0, 0.02]}
- {name: arm, mass: 1.3, com: [0.2, 0.0, 0.01], inertia: [0.1, 0.12, 0.09, 0.0, 0.01, 0.0]}
- {name: hand, mass: 0.7, com: [0.05, 0.01, 0.0], inertia: [0.02, 0.03, 0.025, 0.0, 0.0, 0.001]}
- {name: slide, mass: 0.4, com: [0.0, 0.0, 0.1], inertia: [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]}
joints:
- {name: free, type: floating, parent: world, child: base,
   origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 0.1]}}
- {name: ball, type: spherical, parent: base, child: arm,
   origin: {xyz: [0.2, 0.1, 0.0], rpy: [0.0, 0.4, 0.0]}}
- {name: wrist, type: revolute, parent: arm, child: hand, origin: {xyz: [0.4, 0.0, 0.0], rpy: [0, 0, 0]},
   axis: [0, 0.6, 0.8]}
- {name: drawer, type: prismatic, parent: base, child: slide, origin: {xyz: [0, 0, 0.1], rpy: [0, 0, 0]},
   axis: [1, 0, 0]}
"""


def test_spherical_joint_derivatives(tmp_path):
    path = tmp_path / "ball_arm.yaml"
    path.write_text(BALL_ARM)
    derivation = dynderive.derive(dynderive.load_robot(path))
    numpy_module = import_code(dynderive.render_code(derivation), tmp_path, "ball_arm_dynamics")
    casadi_module = import_code(render_casadi(derivation), tmp_path, "ball_arm_dynamics_casadi")
    assert casadi_module.NQ == casadi_module.NV + 2
    _derivatives_agree(numpy_module, casadi_module, seed=9)


def _derivatives_agree(numpy_module, casadi_module, seed: int, smoothing: float = 0.0) -> None:
    """casadi.jacobian of forward_dynamics is linearize's lower rows and forward_dynamics_derivatives;
    that of inverse_dynamics is inverse_dynamics_derivatives (dtau/dqdd: the mass matrix)."""
    nq, nv, nu = casadi_module.NQ, casadi_module.NV, casadi_module.NU
    q, qd, qdd, u = (casadi.SX.sym(n, k) for n, k in (("q", nq), ("qd", nv), ("qdd", nv), ("u", nu)))
    p = casadi.DM(casadi_module.default_parameters())
    dq = casadi.SX.sym("dq", nv)  # a floating base's configuration moves on the tangent space, by integrate
    moved = casadi_module.integrate(q, dq) if nq != nv else q + dq
    forward = casadi_module.forward_dynamics(
        moved, qd, u, p, *([0.0, 0.0] if hasattr(casadi_module, "LOOPS") else []), smoothing
    )
    jacobian = casadi.Function(
        "j", [q, dq, qd, u], [casadi.jacobian(forward, casadi.vertcat(dq, qd)), casadi.jacobian(forward, u)]
    )
    inverse = casadi_module.inverse_dynamics(q, qd, qdd, p, smoothing)
    inverse_jacobian = casadi.Function(
        "i",
        [q, qd, qdd],
        [casadi.jacobian(inverse, q), casadi.jacobian(inverse, qd), casadi.jacobian(inverse, qdd)],
    )
    state = _states(numpy_module, np.random.default_rng(seed), 2)
    for q0, qd0, qdd0, u0 in zip(state["q"], state["qd"], state["qdd"], state["u"]):
        A, B = casadi_module.linearize(q0, qd0, u0, p, smoothing)
        expected_A, expected_B = numpy_module.linearize(q0, qd0, u0, friction_smoothing=smoothing)
        _close(np.array(A), expected_A, "linearize A")
        _close(np.array(B), expected_B, "linearize B")
        by_state, by_effort = jacobian(q0, np.zeros(nv), qd0, u0)
        _close(np.array(by_state), np.array(A)[nv:], "jacobian(forward_dynamics) vs linearize A", 1e-9)
        _close(np.array(by_effort), np.array(B)[nv:], "jacobian(forward_dynamics) vs linearize B", 1e-9)
        assert np.any(np.abs(np.array(A)[nv:]) > 1e-6)
        blocks = casadi_module.forward_dynamics_derivatives(q0, qd0, u0, p, smoothing)
        _close(
            np.hstack([np.array(b) for b in blocks]),
            np.hstack([expected_A[nv:], expected_B[nv:]]),
            "forward_dynamics_derivatives",
        )
        dq, dqd = casadi_module.inverse_dynamics_derivatives(q0, qd0, qdd0, p, smoothing)
        by_q, by_qd, by_qdd = inverse_jacobian(q0, qd0, qdd0)
        _close(np.array(dqd), np.array(by_qd), "inverse_dynamics_derivatives dtau/dqd", 1e-9)
        _close(np.array(by_qdd), casadi_module.mass_matrix(q0), "dtau/dqdd", 1e-9)
        if nq == nv:
            _close(np.array(dq), np.array(by_q), "inverse_dynamics_derivatives dtau/dq", 1e-9)


@pytest.mark.parametrize(
    "robot, smoothing", [("elbow_arm", 0.0), ("cart_pole_damped", 0.05), ("four_bar", 0.0)]
)
def test_jacobian_of_forward_dynamics_is_linearize(robot, smoothing, code_dir):
    _derivatives_agree(module_of(robot, str(code_dir)), casadi_module_of(robot, str(code_dir)), 4, smoothing)


def test_free_flyer_derivatives(code_dir):
    _derivatives_agree(*floating_modules(str(code_dir)), seed=6)


def test_parameters_as_decision_variables(code_dir):
    """p symbolic: the Functions are differentiable in p; d tau/dp matches central differences of
    the NumPy module, and an NLP over a parameter recovers it from one torque."""
    numpy_module, module = module_of("elbow_arm", str(code_dir)), casadi_module_of("elbow_arm", str(code_dir))
    p = casadi.SX.sym("p", len(module.PARAMETER_NAMES))
    rng = np.random.default_rng(1)
    q0, qd0, qdd0 = rng.normal(size=(3, module.NV))
    tau = module.inverse_dynamics(q0, qd0, qdd0, p)
    by_parameter = np.array(casadi.Function("d", [p], [casadi.jacobian(tau, p)])(module.default_parameters()))
    assert np.any(np.abs(by_parameter) > 1e-6)
    for index, name in enumerate(module.PARAMETER_NAMES):
        step = 1e-6 * max(1.0, abs(numpy_module.PARAMETERS[name]))
        up = numpy_module.inverse_dynamics(q0, qd0, qdd0, **{name: numpy_module.PARAMETERS[name] + step})
        down = numpy_module.inverse_dynamics(q0, qd0, qdd0, **{name: numpy_module.PARAMETERS[name] - step})
        _close(by_parameter[:, index], (up - down) / (2 * step), f"dtau/d{name}", 1e-6)
    # recover the most influential parameter from a measured torque (a least-squares NLP in it)
    index = int(np.argmax(np.max(np.abs(by_parameter), axis=0)))
    target, defaults = numpy_module.inverse_dynamics(q0, qd0, qdd0), module.default_parameters()
    x = casadi.SX.sym("x")
    guess = casadi.vertcat(casadi.DM(defaults[:index]), x, casadi.DM(defaults[index + 1 :]))
    residual = module.inverse_dynamics(q0, qd0, qdd0, guess) - target
    solver = casadi.nlpsol(
        "s",
        "ipopt",
        {"x": x, "f": casadi.sumsqr(residual)},
        {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"},
    )
    found = float(solver(x0=2.0 * defaults[index])["x"])
    assert abs(found - defaults[index]) < 1e-6 * max(1.0, abs(found))


def test_left_out_inputs_take_the_defaults(code_dir):
    module = casadi_module_of("cart_pole_damped", str(code_dir))
    q, qd, u = np.array([0.1, 0.2]), np.array([0.3, -0.4]), np.array([1.0])
    full = np.array(module.forward_dynamics(q, qd, u, module.default_parameters(), 0.0))
    _close(np.array(module.forward_dynamics(q, qd, u)), full, "positional, p left out")
    _close(np.array(module.forward_dynamics(q=q, qd=qd, u=u)["qdd"]), full, "by keyword, p left out")
    _close(
        np.array(module.parameter_vector()),
        np.array(module.parameter_vector(module.default_parameters())),
        "parameter_vector()",
    )
    assert module.mass_matrix.name_in() == ["q", "p"] and module.linearize.name_out() == ["A", "B"]
    with pytest.raises(ValueError, match="unknown frame"):
        module.frame_transform("no such frame")


#: CasADi's generated functions take work arrays (iw, w) and a memory index they may not use:
#: the one warning left on.
C_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wno-unused-parameter")


@pytest.mark.skipif(not os.environ.get("CI") and shutil.which("gcc") is None, reason="no gcc")
@pytest.mark.parametrize("robot", ["ur5", "cart_pole_damped", "four_bar"])
def test_generated_c_compiles_as_c99(robot, code_dir, tmp_path):
    module = casadi_module_of(robot, str(code_dir))
    for name in ("mass_matrix", "forward_dynamics", "linearize"):
        source = getattr(module, name).generate(f"{robot}_{name}.c", {"with_header": True})
        shutil.move(source, tmp_path / source)
        shutil.move(source[:-2] + ".h", tmp_path / (source[:-2] + ".h"))
        result = subprocess.run(
            ["gcc", *C_FLAGS, "-c", source, "-o", name + ".o"], cwd=tmp_path, capture_output=True, text=True
        )
        assert result.returncode == 0, result.stderr


HOSTILE = 'a """ b\n import os\r\\ \' # c \u202e\x00 \U0001f600 "q'


def test_hostile_text_and_names(tmp_path):
    """A title and a parameter's description that would end the docstring: encoded, read back
    exactly, and the module works; a frame name that is not an identifier is refused at its
    position (Functions are named by frame index, FRAMES holds the names as string literals)."""
    text = (ROBOTS / "elbow_arm.yaml").read_text()
    encoded = (
        HOSTILE.replace("\\", "\\\\")
        .replace('"', '\\"')
        .replace("\n", "\\n")
        .replace("\r", "\\r")
        .replace("\x00", "\\0")
        .replace("\u202e", "\\u202e")
        .replace("\U0001f600", "\\U0001f600")
    )
    lines = [f'title: "{encoded}"' if line.startswith("title:") else line for line in text.splitlines()]
    text = (
        "\n".join(lines).replace("description: mass of the waist (column)", f'description: "{encoded}"')
        + "\n"
    )
    path = tmp_path / "elbow_arm.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.robot.title == HOSTILE and derivation.robot.parameters[0].description == HOSTILE
    source = render_casadi(derivation)
    docstring = ast.get_docstring(ast.parse(source), clean=False)
    assert (
        docstring.startswith(f"Equations of motion of {HOSTILE} ")
        and HOSTILE in docstring.split("m1 [kg]: ")[1]
    )
    module = import_code(source, tmp_path, "hostile_dynamics_casadi")
    rows = compiled_checks(derivation, dynderive.render_code(derivation), CasadiModule(module), states=2, seed=2,
                           label="CasADi", target="casadi")
    assert [row.name for row in rows if row.status != "pass"] == [] and len(rows) >= 12
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "elbow_arm.yaml").write_text(
        text.replace("  - name: wrist ", '  - name: "wr\\"is\'t\\\\ \\n */ x" ')
    )
    with pytest.raises(dynderive.InputError, match="frame name must be an identifier"):
        dynderive.load_robot(bad / "elbow_arm.yaml")


def test_solve_writes_the_module(tmp_path):
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["solve", "rp_arm", "--casadi", "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 0, result.output
    written = tmp_path / "rp_arm_dynamics_casadi.py"
    assert written.read_text() == render_casadi(derivation_of("rp_arm"))
    imports = {n.names[0].name for n in ast.parse(written.read_text()).body if isinstance(n, ast.Import)}
    assert imports == {"casadi", "numpy"}
    assert not re.search(r"^\s*(exec|eval)\(", written.read_text(), re.MULTILINE)


def test_over_constrained_loops_are_refused_at_their_position(tmp_path):
    """The Bennett linkage's loop rows have rank 2 of 5: its solves need an SVD, which casadi.SX
    has not; --casadi says so at the robot file's loops (exit 2), writing nothing."""
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["solve", "bennett", "--casadi", "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 2, result.output
    assert "bennett.yaml:" in result.output and "over-constrained loops" in result.output
    assert not (tmp_path / "bennett_dynamics_casadi.py").exists()


def test_one_node_per_operation_of_the_programs(code_dir):
    """The SX graph keeps the engine's common subexpressions: each Function runs about as many
    instructions as its program has operations (a tree would repeat every shared value)."""
    from dynderive.render.targets.casadi.casadi import casadi_context

    module = casadi_module_of("ur5", str(code_dir))
    programs = {p.name: p for p in casadi_context(derivation_of("ur5"))["programs"]}
    for name, body in (
        ("mass_matrix", "_mass_matrix_body"),
        ("inverse_dynamics", "_inverse_dynamics_body"),
        ("forward_dynamics", "_forward_dynamics_body"),
    ):
        function = getattr(module, name)
        inputs = sum(function.numel_in(i) for i in range(function.n_in()))
        outputs = sum(function.numel_out(i) for i in range(function.n_out()))
        assert function.n_instructions() <= 1.2 * programs[body].operations + inputs + 2 * outputs, name


def test_a_note_when_casadi_is_not_installed(monkeypatch):
    """The module is generated text, written without CasADi: solve says how to install it."""
    import importlib.util

    from dynderive.render.targets.casadi import CASADI

    assert CASADI.missing_note() is None
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "casadi" else real(name, *a)
    )
    assert 'pip install "dynderive[casadi]"' in CASADI.missing_note()


# -- check --backend casadi ------------------------------------------------------------------------


def _check_rows(robot: str) -> dict[str, str]:
    """``dynderive check ROBOT --backend casadi --json``: its CasADi rows, name -> status."""
    import json

    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    result = CliRunner().invoke(app, ["check", robot, "--backend", "casadi", "--states", "4", "--json", "-q"])
    assert result.exit_code == 0, result.output
    rows = {row["name"]: row["status"] for row in json.loads(result.stdout)["checks"]}
    return {name: status for name, status in rows.items() if name.startswith("CasADi ")}


def test_check_backend_casadi_rp_arm():
    """Every Function of rp_arm's CasADi module, called with column vectors and the vector p,
    gives the NumPy module's numbers: one pass row per function of the API table (a planar
    robot's maximal form and the configuration maps too), none missing."""
    rows = _check_rows(str(ROBOTS / "rp_arm.yaml"))
    names = [f.name for f in api.API if f.group in ("dynamics", "maximal", "configuration")
             and f.name != "maximal_friction_forces"]   # no friction: the NumPy module has none either
    assert rows == {f"CasADi {name} == NumPy module": "pass" for name in names}


def test_check_backend_casadi_frames_loops_floating():
    """Frames (their Functions by index, and wrenches as J^T w), a closed loop (``assemble``
    a skip row, as the table of what is not built says) and a floating base (the configuration
    maps, without p)."""
    rows = _check_rows("elbow_arm")
    assert rows["CasADi frame_jacobian (frame wrist) == NumPy module"] == "pass"
    assert rows["CasADi inverse_dynamics with wrenches at every frame == NumPy module"] == "pass"
    assert rows["CasADi centroidal_momentum_matrix == NumPy module"] == "pass"
    assert rows["CasADi forward_dynamics with wrenches at every frame == NumPy module"] == "pass"
    assert all(status == "pass" for status in rows.values()) and len(rows) == 34   # 9 centroidal, 2 contacts, 4 maps
    rows = _check_rows("four_bar")
    assert rows.pop("CasADi not built: assemble") == "skip"
    assert rows["CasADi reduced_forward_dynamics == NumPy module"] == "pass"
    assert rows["CasADi maximal_forward_dynamics == NumPy module"] == "pass"
    assert all(status == "pass" for status in rows.values()) and len(rows) == 24 + 13   # the maps' 4, the maximal form's 13
    rows = _check_rows(str(FLOATING))
    assert rows["CasADi integrate == NumPy module"] == "pass"
    assert rows["CasADi difference == NumPy module"] == "pass"
    assert all(status == "pass" for status in rows.values())


def test_check_backend_casadi_needs_casadi(monkeypatch):
    """Without CasADi, ``--backend casadi`` is refused at the option before any work."""
    import sys

    from dynderive.errors import InputError
    from dynderive.render.targets.casadi import CASADI

    monkeypatch.setitem(sys.modules, "casadi", None)
    with pytest.raises(InputError, match="--backend casadi needs the casadi package"):
        CASADI.require()
