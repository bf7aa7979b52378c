"""The sheet and the JSON dump of a floating-base robot (issue 30): a free rigid body's
quantities against their closed form; the sheet's M, N, C v and C of small robots against the
generated NumPy module at random states (full-precision numbers, random unit quaternions);
a large robot's intermediate-variable form likewise through the JSON; the sheet compiles, is
the same bytes each run, and escapes the robot file's text."""

from __future__ import annotations

import importlib.util
import json
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.mechanics.joint_types.quaternion import quaternion_matrix
from dynderive.mechanics.quasi_velocity import is_step_by_step, quasi_velocity_sheet, skew
from dynderive.render.sheets.json import render_json
from dynderive.render.sheets.latex import render_latex
from dynderive.render.targets.numpy.code import render_code

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]

FREE = """name: free_body
title: A free rigid body
planar: false
parameters:
  m: {value: 2.5, unit: kg}
  cx: 0.01
  cy: -0.02
  cz: 0.1
  Ixx: 0.02
  Iyy: 0.03
  Izz: 0.025
  Ixy: 0.001
  Ixz: 0.002
  Iyz: 0.003
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: body, mass: m, com: [cx, cy, cz], inertia: [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]}
joints:
  - {name: root, type: floating, parent: world, child: body}
"""


def _number(rng: random.Random, low: float, high: float) -> str:
    return repr(rng.uniform(low, high))   # every digit of a double


def _inertia(rng: random.Random) -> str:
    a, b, c = (rng.uniform(0.01, 0.05) for _ in range(3))   # a valid tensor: principal moments, small products
    return f"[{a + b!r}, {b + c!r}, {a + c!r}, {rng.uniform(-0.004, 0.004)!r}, {rng.uniform(-0.004, 0.004)!r}, " \
           f"{rng.uniform(-0.004, 0.004)!r}]"


def _vector(rng: random.Random, scale: float) -> str:
    return "[" + ", ".join(_number(rng, -scale, scale) for _ in range(3)) + "]"


def _axis(rng: random.Random) -> str:
    v = np.array([rng.gauss(0, 1) for _ in range(3)])
    return "[" + ", ".join(repr(float(x)) for x in v / np.linalg.norm(v)) + "]"


def _chain(seed: int, scalar: int, root: str = "floating", title: str = "A floating chain") -> str:
    """A floating (or spherical) root with ``scalar`` revolute or prismatic joints in a chain,
    full-precision numbers, generic axes and full inertia tensors, one joint with drives."""
    rng = random.Random(seed)
    links = [f"  - {{name: l0, mass: {_number(rng, 0.5, 3)}, com: {_vector(rng, 0.2)}, inertia: {_inertia(rng)}}}"]
    joints = [f"  - {{name: root, type: {root}, parent: world, child: l0"
              + (f", origin: {{xyz: {_vector(rng, 0.3)}, rpy: {_vector(rng, 1)}}}" if root == "spherical" else "") + "}"]
    for k in range(1, scalar + 1):
        links.append(f"  - {{name: l{k}, mass: {_number(rng, 0.5, 3)}, com: {_vector(rng, 0.2)}, "
                     f"inertia: {_inertia(rng)}}}")
        kind = "prismatic" if k == 2 else "revolute"
        drives = ", armature: 0.0123, stiffness: 2.5, rest: 0.3" if k == 1 else ""
        joints.append(f"  - {{name: q{k}, type: {kind}, parent: l{k - 1}, child: l{k}, origin: {{xyz: "
                      f"{_vector(rng, 0.3)}, rpy: {_vector(rng, 1)}}}, axis: {_axis(rng)}, effort: u{k}{drives}}}")
    return (f"name: chain{seed}\ntitle: {title}\nplanar: false\nparameters:\n  g: 9.81\n"
            f"gravity: [{_number(rng, -1, 1)}, {_number(rng, -1, 1)}, -g]\nlinks:\n"
            + "\n".join(links) + "\njoints:\n" + "\n".join(joints) + "\n")


def _load(tmp_path: Path, text: str, name: str = "robot.yaml"):
    path = tmp_path / name
    path.write_text(text)
    robot = dynderive.load_robot(path)
    return robot, dynderive.derive(robot)


def _module(derivation, tmp_path: Path):
    path = tmp_path / f"{derivation.robot.name}_dynamics.py"
    path.write_text(render_code(derivation))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _states(robot, derivation, seed: int, count: int = 3):
    """Random q (unit quaternions), v, vdot."""
    rng = np.random.default_rng(seed)
    where_q, _ = robot.offsets()
    nq, nv = len(derivation.symbols.q), len(derivation.symbols.qd)
    for _ in range(count):
        q = rng.normal(size=nq)
        for joint in (j for j in robot.joints if j.multi):
            start = where_q[joint.name] + (3 if joint.type == "floating" else 0)
            q[start:start + 4] /= np.linalg.norm(q[start:start + 4])
        yield q, rng.normal(size=nv), rng.normal(size=nv)


def _numeric(derivation, value):
    """``value`` (a matrix of the sheet) as a function of q, v, vdot at the defaults."""
    table = derivation.symbols
    value = value.xreplace(table.defaults(derivation.robot) | {u: 0 for u in table.efforts.values()})
    f = sympy.lambdify([table.q, table.qd, table.qdd], value, modules="numpy")
    return lambda q, v, a: np.array(f(q, v, a), dtype=float)


def _close(actual, expected, tolerance: float = 1e-12) -> None:
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tolerance * scale)


def test_free_body_closed_form(tmp_path):
    """M = [[m 1, -m [c]x], [m [c]x, I_c - m [c]x^2]] (the com offset terms), N the weight in
    body axes R^T g at the centre of mass, C v Euler's terms, all exactly."""
    robot, derivation = _load(tmp_path, FREE)
    sheet = quasi_velocity_sheet(robot, derivation.symbols)
    p = derivation.symbols.parameters
    m, c = p["m"], sympy.Matrix([p["cx"], p["cy"], p["cz"]])
    inertia = sympy.Matrix([[p["Ixx"], p["Ixy"], p["Ixz"]], [p["Ixy"], p["Iyy"], p["Iyz"]],
                            [p["Ixz"], p["Iyz"], p["Izz"]]])
    K = skew(c)
    expected = sympy.zeros(6, 6)
    expected[:3, :3], expected[:3, 3:], expected[3:, :3] = m * sympy.eye(3), -m * K, m * K
    expected[3:, 3:] = inertia - m * K * K
    assert (sheet.M - expected).applyfunc(sympy.expand) == sympy.zeros(6, 6)
    q, v = derivation.symbols.q, sympy.Matrix(derivation.symbols.qd)
    R = quaternion_matrix(*q[3:])
    weight = m * R.T * sympy.Matrix([0, 0, -p["g"]])   # the weight in body axes
    expected_N = -sympy.Matrix([*weight, *c.cross(weight)])
    assert (sheet.N - expected_N).applyfunc(sympy.expand) == sympy.zeros(6, 1)
    lin, ang = v[:3, 0], v[3:, 0]
    v_c = lin + ang.cross(c)   # the centre of mass's velocity: Newton-Euler there, its moment carried to the origin
    force = m * ang.cross(v_c)
    moment = c.cross(force) + ang.cross(inertia * ang)
    assert (sheet.Cv - sympy.Matrix([*force, *moment])).applyfunc(sympy.expand) == sympy.zeros(6, 1)
    assert sympy.expand(sheet.T - (v.T * expected * v)[0, 0] / 2) == 0
    # the frame at the centre of mass: Euler's m (vdot + w x v) = m R^T g, I wdot + w x I w = 0
    robot, derivation = _load(tmp_path, FREE.replace("com: [cx, cy, cz]", "com: [0, 0, 0]"), "centred.yaml")
    centred = quasi_velocity_sheet(robot, derivation.symbols)
    assert (centred.Cv - sympy.Matrix([*(m * ang.cross(lin)), *ang.cross(inertia * ang)])).applyfunc(
        sympy.expand) == sympy.zeros(6, 1)
    assert (centred.N - sympy.Matrix([*(-weight), 0, 0, 0])).applyfunc(sympy.expand) == sympy.zeros(6, 1)
    assert (centred.M - sympy.diag(m * sympy.eye(3), inertia)).applyfunc(sympy.expand) == sympy.zeros(6, 6)


@pytest.mark.parametrize(("seed", "scalar", "root"), [(1, 0, "floating"), (2, 1, "floating"), (3, 2, "floating"),
                                                       (4, 1, "spherical")])
def test_sheet_quantities_equal_the_module(seed, scalar, root, tmp_path):
    robot, derivation = _load(tmp_path, _chain(seed, scalar, root))
    assert is_step_by_step(robot)
    sheet = quasi_velocity_sheet(robot, derivation.symbols)
    module = _module(derivation, tmp_path)
    M, N, Cv, C = (_numeric(derivation, x) for x in (sheet.M, sheet.N, sheet.Cv, sheet.C))
    T, V, EOM = (_numeric(derivation, sympy.Matrix([x]) if not isinstance(x, sympy.MatrixBase) else x)
                 for x in (sheet.T, sheet.V, sheet.EOM))
    for q, v, a in _states(robot, derivation, seed):
        _close(M(q, v, a), module.mass_matrix(q))
        _close(N(q, v, a).ravel(), module.gravity_vector(q))
        _close(Cv(q, v, a).ravel(), module.inverse_dynamics(q, v, 0 * a) - module.gravity_vector(q))
        _close(C(q, v, a), module.coriolis_matrix(q, v))
        _close(T(q, v, a).ravel(), [module.kinetic_energy(q, v)])
        _close(V(q, v, a).ravel(), [module.potential_energy(q)])
        _close(EOM(q, v, a).ravel(), module.inverse_dynamics(q, v, a))   # at zero efforts
    efforts = derivation.symbols.efforts
    assert list(sheet.Y) == [0] * (6 if root == "floating" else 3) + [efforts[f"u{k}"] for k in range(1, scalar + 1)]


def _json_values(document: dict, derivation, q, v, a, printed: dict | None = None) -> dict[str, np.ndarray]:
    """M_g, N_g, EOM_g2 and Y_g of a JSON dump at one state (efforts zero), its intermediates
    evaluated in order; an expanded dump's quantities are printed once into ``printed``."""
    table = derivation.symbols
    names = table.locals() | {name: sympy.Symbol(name) for name in document.get("intermediates", {})}
    keys = ("M_g", "N_g", "EOM_g2", "Y_g")
    if "intermediates" not in document:   # expanded: NumPy
        printed = {} if printed is None else printed
        for key in keys:
            if key not in printed:
                printed[key] = _numeric(derivation, sympy.Matrix(sympy.sympify(document["quantities"][key]["sympy"],
                                                                               locals=names)))
        return {key: printed[key](q, v, a) for key in keys}
    known = (table.defaults(derivation.robot) | {u: 0 for u in table.efforts.values()}
             | dict(zip(table.q, q)) | dict(zip(table.qd, v)) | dict(zip(table.qdd, a)))
    for name, entry in document.get("intermediates", {}).items():
        known[names[name]] = sympy.sympify(entry["sympy"], locals=names).xreplace(known)
    return {key: np.array(sympy.Matrix(sympy.sympify(document["quantities"][key]["sympy"], locals=names))
                          .xreplace(known), dtype=float) for key in keys}


@pytest.mark.parametrize(("seed", "scalar"), [(5, 1), (6, 3)])   # small: expanded; large: intermediates
def test_json_round_trips_and_agrees_with_the_module(seed, scalar, tmp_path):
    robot, derivation = _load(tmp_path, _chain(seed, scalar))
    document = json.loads(render_json(derivation))
    assert document["NQ"] == 7 + scalar and document["NV"] == 6 + scalar and document["floating"] is True
    assert document["coordinates"][:7] == [f"root_{s}" for s in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    assert document["velocities"][:6] == [f"root_{s}" for s in ("vx", "vy", "vz", "wx", "wy", "wz")]
    assert ("intermediates" in document) == (not is_step_by_step(robot))
    assert document["quantities"]["M_g"]["shape"] == [6 + scalar, 6 + scalar]
    module = _module(derivation, tmp_path)
    printed: dict = {}
    for q, v, a in _states(robot, derivation, seed, count=2):
        values = _json_values(document, derivation, q, v, a, printed)
        _close(values["M_g"], module.mass_matrix(q))
        _close(values["N_g"].ravel(), module.gravity_vector(q))
        _close(values["EOM_g2"].ravel() + values["Y_g"].ravel(), module.inverse_dynamics(q, v, a))


@pytest.fixture
def tex():
    missing = [t for t in ("latexmk", "pdflatex") if shutil.which(t) is None]
    if missing:
        if os.environ.get("CI"):
            raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
        pytest.skip(f"no TeX engine ({', '.join(missing)} missing)")


HOSTILE = r"Evil \input{/etc/passwd} $x$ & 100% #1 _a ^b ~c {d}"


@pytest.mark.parametrize(("text", "small"), [(FREE, True), (_chain(7, 2), True), (_chain(8, 3), False)])
def test_sheet_compiles(text, small, tex, tmp_path):
    text = text.replace("title: A free rigid body", f"title: '{HOSTILE}'").replace(
        "title: A floating chain", f"title: '{HOSTILE}'")
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    assert is_step_by_step(robot) == small
    result = runner.invoke(app, ["solve", str(path), "--pdf", "--latex", "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 0, result.output + result.stderr
    sheet = (tmp_path / "out" / f"{robot.name}.tex").read_text()
    assert (tmp_path / "out" / f"{robot.name}.pdf").read_bytes().startswith(b"%PDF")
    assert r"\input{/etc" not in sheet and r"\textbackslash{}input\{/etc/passwd\}" in sheet
    assert ("intermediate-variable form" in sheet) == (not small)
    assert ("Kane's" in sheet) == small


def test_same_input_same_bytes(tmp_path):
    """Two processes (other hash seeds): the same sheet and JSON."""
    path = tmp_path / "robot.yaml"
    path.write_text(_chain(9, 1))
    outputs = []
    for seed in ("1", "2"):
        out = tmp_path / f"out{seed}"
        subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), "--latex", "--json", "--out", str(out),
                        "-q"], check=True, env=os.environ | {"PYTHONHASHSEED": seed, "PYTHONPATH": str(ROOT / "src")})
        outputs.append([(out / f"chain9.{ext}").read_bytes() for ext in ("tex", "json")])
    assert outputs[0] == outputs[1]


def test_build_writes_the_sheet_and_json(tmp_path):
    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "free.yaml").write_text(FREE)
    result = runner.invoke(app, ["build", str(folder), "--out", str(tmp_path / "b"), "-j", "1", "--latex", "--json"])
    assert result.exit_code == 0, result.output
    assert "Kane's" in (tmp_path / "b" / "free_body.tex").read_text()
    assert json.loads((tmp_path / "b" / "free_body.json").read_text())["NV"] == 6


def test_latex_direct_render_is_deterministic(tmp_path):
    robot, derivation = _load(tmp_path, FREE)
    first = render_latex(derivation)
    _, again = _load(tmp_path, FREE, "again.yaml")
    assert render_latex(again).replace("again.yaml", "robot.yaml") == first


@pytest.mark.parametrize("root, suffixes", [("floating", ("fx", "fy", "fz", "tx", "ty", "tz")),
                                            ("spherical", ("tx", "ty", "tz"))])
def test_an_actuated_root_takes_its_efforts_at_its_velocity_columns(root, suffixes, tmp_path):
    """``effort: w`` on a floating (spherical) root: Y holds w_fx ... w_tz (w_tx ... w_tz) at the
    root's velocity columns, the sheet's joint table names them, the JSON lists them."""
    text = _chain(7, 1, root).replace("child: l0", "child: l0, effort: w", 1)
    robot, derivation = _load(tmp_path, text)
    efforts = derivation.symbols.efforts
    assert robot.efforts == (*(f"w_{s}" for s in suffixes), "u1")
    assert list(derivation.quasi_velocity_steps.sheet.Y) == [efforts[f"w_{s}"] for s in suffixes] + [efforts["u1"]]
    document = json.loads(render_json(derivation))
    assert document["efforts"] == list(robot.efforts)
    latex = render_latex(derivation)
    assert all(rf"w_{{\mathrm{{{s}}}}}" in latex for s in suffixes)
    assert "unactuated" not in latex
