"""Every robot the engine derives gives a sheet that compiles.

The random robots of the test suite, planar and 3-D, 2 to 12 links, with full-precision
numbers, are derived, rendered and compiled by the product's own LaTeX path; a LaTeX error
fails the test with TeX's first error line. Three of them failed before: the generic 7-DOF arm
("Double subscript": an entry of ``J^b_7`` named ``J^b_7_{11}``), a planar tree whose
drawing held a zero-length ``\\qbezier`` ("Arithmetic overflow") and a 7-link chain with all
sections (a 21-column matrix typeset whole: "Extra alignment tab"). The subscript
composition, the matrices' columns and the drawing's curves are also checked without TeX.
When LaTeX fails anyway, ``solve`` and ``build`` still write the other outputs, keep the .tex
and LaTeX's log, and say where (exit 1).

Floating-base robots: the sheet and the JSON dump. A free rigid body's quantities against
their closed form; the sheet's M, N, C v and C of small robots against the generated NumPy
module at random states (full-precision numbers, random unit quaternions); a large robot's
intermediate-variable form likewise through the JSON; the sheet compiles, is the same bytes
each run, and escapes the robot file's text.

The compile tests need latexmk and pdflatex: skipped locally without them, required in CI
(CI=true).
"""

from __future__ import annotations

import importlib.util
import json
import os
import pickle
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
from dynderive.commands.build import MANIFEST, load_manifest
from dynderive.commands.cli import app
from dynderive.errors import LatexError
from dynderive.mechanics.joint_types.quaternion import quaternion_matrix
from dynderive.mechanics.quasi_velocity import is_step_by_step, quasi_velocity_sheet, skew
from dynderive.render.sheets.figure import _dashes, planar_figure
from dynderive.render.sheets.json import render_json
from dynderive.render.sheets.latex import render_latex
from dynderive.render.sheets.latex_format import Formatter, entry_index, subscript
from dynderive.render.sheets.pdf import _first_error, tikz_available
from dynderive.render.targets.numpy.code import render_code

from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from models import planar_chain_yaml, spatial_chain_yaml  # noqa: E402

runner = CliRunner()
TOOLS = ("latexmk", "pdflatex")
#: The sheet's side margin (pt): an overfull line may reach into it, never beyond.
MARGIN_PT = 2.2 / 2.54 * 72.27


@pytest.fixture
def tex():
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if not missing and not tikz_available():
        missing = ["TikZ (texlive-pictures)"]   # the sheets' drawings
    if missing:
        if os.environ.get("CI"):
            raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
        pytest.skip(f"no TeX engine ({', '.join(missing)} missing)")


def _robot_text(kind: str, n: int, seed: int) -> str:
    if kind == "planar tree":
        return random_planar_tree(random.Random(seed), n).yaml_text
    if kind == "planar chain":
        return planar_chain_yaml(n, seed=seed)
    if kind == "3-D tree":
        return random_spatial_tree(random.Random(seed), n).yaml_text
    return spatial_chain_yaml(n, seed=seed)


def _derive(tmp_path: Path, kind: str, n: int, seed: int):
    path = tmp_path / "robot.yaml"
    path.write_text(_robot_text(kind, n, seed))
    return dynderive.derive(dynderive.load_robot(path))


# ---- subscripts: TeX refuses a second subscript on one atom ("Double subscript") ----------

@pytest.mark.parametrize(("name", "index", "expected"), [
    ("M", "12", "M_{12}"),
    ("J^b_7", "1,11", "J^b_{7,1,11}"),                         # merged, not J^b_7_{1,11}
    (r"\mathrm{EOM}_{g2}", "3", r"\mathrm{EOM}_{g2,3}"),
    ("x_a^b", "2", "x_{a,2}^b"),
    (r"\left(J^b_{sL_{7}}\right)", "6,7", r"\left(J^b_{sL_{7}}\right)_{6,7}"),   # \left..\right: a new atom
    (r"\left(R_{sL_{1}}\right)^T", "11", r"\left(R_{sL_{1}}\right)^T_{11}"),
    (r"\dot{A}", "21", r"\dot{A}_{21}"),
    (r"\dot J", "12", r"\dot J_{12}"),
    (r"\tilde\Upsilon", "3", r"\tilde\Upsilon_{3}"),
    (r"A_{x} B", "1", r"A_{x} B_{1}"),                            # the subscript belongs to A, not B
    (r"{J_x}", "1", r"{J_x}_{1}"),
])
def test_subscript_is_added_once_per_atom(name, index, expected):
    assert subscript(name, index) == expected


def test_entry_indices_are_unambiguous_beyond_nine():
    assert entry_index(0, 1, 3, 3) == "12" and entry_index(6, 0, 7, 1) == "7"
    big = [entry_index(i, j, 12, 12) for i in range(12) for j in range(12)]
    assert len(set(big)) == len(big) and entry_index(0, 10, 6, 11) == "1,11" != entry_index(10, 0, 11, 6)


def test_wide_matrix_entries_of_a_subscripted_name(tmp_path):
    """A 6 x 11 matrix named J^b_7, entry by entry: every entry named once, one subscript each."""
    derivation = _derive(tmp_path, "planar tree", 2, 0)
    q1, q2 = derivation.symbols.q
    matrix = sympy.Matrix(6, 11, lambda i, j: (i + 2) * sympy.sin(q1 + j * q2) + sympy.cos(q2) ** (j + 1))
    entries = Formatter.of(derivation).matrix("J^b_7", matrix)["entries"]
    names = [e["name"] for e in entries]
    assert len(names) == 66 and len(set(names)) == 66
    assert names[0] == "J^b_{7,1,1}" and names[10] == "J^b_{7,1,11}" and names[-1] == "J^b_{7,6,11}"


def test_matrix_wider_than_amsmath_allows_is_set_entry_by_entry(tmp_path):
    """amsmath's matrix takes MaxMatrixCols (20 in the preamble) columns: a row of 21 short
    entries fits the line by its width but must not be typeset whole ("Extra alignment tab")."""
    derivation = _derive(tmp_path, "planar tree", 2, 0)
    q1 = derivation.symbols.q[0]
    fmt = Formatter.of(derivation)
    assert not fmt.matrix("A", sympy.Matrix(1, 20, lambda i, j: q1))["wide"]
    row = fmt.matrix("A", sympy.Matrix(1, 21, lambda i, j: q1))
    assert row["wide"] and not row["tight"] and len(row["entries"]) == 21 \
        and row["entries"][-1]["name"] == "A_{1,21}"


# ---- the drawing: nothing TikZ cannot draw ---------------------------------------------------

def _degenerate(figure: dict) -> list[dict]:
    """Items of zero length: a path with a repeated point or one point, an arc without sweep."""
    bad = []
    for item in figure["items"]:
        if item["kind"] == "path":
            points = item["points"] + (item["points"][:1] if item["closed"] else [])
            if len(item["points"]) < 2 or any(a == b for a, b in zip(points, points[1:])):
                bad.append(item)
        elif item["kind"] == "arc" and (abs(float(item["end"]) - float(item["start"])) < 1.0
                                        or float(item["radius"]) <= 0):
            bad.append(item)
    return bad


def test_dashes_end_without_a_stub():
    for length in (0.1, 1.2, 2.0, 2.05, 7.9, 13.0):
        dashes = _dashes((0.0, 0.0), 0.7, length)
        assert all(abs(b[0] - a[0]) + abs(b[1] - a[1]) > 0.25 for a, b in dashes), length


@pytest.mark.parametrize(("n", "seeds"), [(2, range(6)), (3, range(8)), (4, range(6)), (5, range(4))])
def test_drawings_hold_no_degenerate_path(tmp_path, n, seeds):
    """Every path spans at least the drawing's resolution (0.01 mm) between its points (the
    picture mode's \\qbezier divided by the extent: "Arithmetic overflow" at zero; TikZ draws
    a zero-length path as a dot); coordinates stay within the drawing's size. Seed 3 of the
    3-joint trees drew a last dash of 0.0 mm before."""
    for seed in seeds:
        derivation = _derive(tmp_path, "planar tree", n, seed)
        figure = planar_figure(derivation, Formatter.of(derivation))
        assert figure["items"] and not _degenerate(figure), seed
        width, height = float(figure["width"]), float(figure["height"])
        assert 0 < width < 200 and 0 < height < 200, (seed, width, height)
        points = [p for i in figure["items"] for p in i.get("points", [i.get("centre", i.get("at"))])]
        assert all(0.0 <= float(x) <= width and 0.0 <= float(y) <= height for x, y in points), seed


def test_robot_that_cannot_be_evaluated_is_not_drawn(tmp_path):
    """A parameter without a default is drawn at 1: where that makes a length not real, no
    drawing (rather than a broken picture or an internal error)."""
    path = tmp_path / "arm.yaml"
    path.write_text(
        "name: arm\nplanar: true\ngravity: [0, -9.81]\nparameters: {a: {}}\n"
        "links:\n  - {name: b1, mass: 1, com: ['sqrt(a - 2)', 0], inertia: 0.1}\n"
        "joints:\n  - {name: q1, type: revolute, parent: world, child: b1, origin: [0, 0], effort: u1}\n")
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert planar_figure(derivation, Formatter.of(derivation)) is None


# ---- the random robots compile --------------------------------------------------------------

#: (kind, moving joints, seed, sections): planar 2 to 12 links, 3-D 2 to 7 joints; about 2
#: minutes in all. The sections are the default ones (by size) unless given.
ROBOTS = [
    ("planar tree", 2, 0, None),
    ("planar tree", 3, 3, None),        # the drawing's zero-length last dash
    ("planar tree", 5, 1, None),
    ("planar chain", 7, 0, "all"),      # maximal body Jacobians of 21 columns: "Extra alignment tab"
    ("planar chain", 12, 0, None),      # intermediate-variable form, 12 x 12 matrices entry by entry
    ("3-D tree", 2, 5, None),
    ("3-D tree", 4, 0, None),
    ("3-D tree", 7, 1, None),
    ("3-D chain", 7, 0, None),          # the generic 7-DOF arm: "Double subscript" in J^b_7's entries
]


@pytest.mark.pdf
@pytest.mark.parametrize(("kind", "n", "seed", "sections"), ROBOTS,
                         ids=[f"{k.replace(' ', '-')}-{n}-{s}" + (f"-{c}" if c else "")
                              for k, n, s, c in ROBOTS])
def test_random_robot_sheet_compiles(tmp_path, tex, kind, n, seed, sections):
    from dynderive.render.sheets.latex import parse_sections
    from dynderive.render.sheets.pdf import compile_pdf_report

    chosen = parse_sections(sections) if sections else None
    sheet = dynderive.render_latex(_derive(tmp_path, kind, n, seed), sections=chosen)
    try:
        pdf, pages, overfull = compile_pdf_report(sheet, "sheet")
    except LatexError as exc:
        pytest.fail(f"{kind} {n} (seed {seed}): {exc}", pytrace=False)
    assert pdf.startswith(b"%PDF") and pages >= 1
    # no line sticks out beyond the margin (2.2 cm; issue 32's acceptance)
    assert max(overfull, default=0.0) < MARGIN_PT, overfull


# ---- when LaTeX fails anyway ------------------------------------------------------------

@pytest.fixture
def broken_templates(tmp_path) -> Path:
    """A sheet template whose LaTeX does not compile (a double subscript)."""
    folder = tmp_path / "templates"
    folder.mkdir()
    (folder / "sheet.tex.j2").write_text(
        "\\documentclass{article}\n\\begin{document}\nRobot \\VAR{robot.name}: $x_1_2$\n\\end{document}\n")
    return folder


def test_latex_error_survives_the_worker_processes():
    error = pickle.loads(pickle.dumps(LatexError("Double subscript. (line 3)", "the log")))
    assert (error.detail, error.log) == ("Double subscript. (line 3)", "the log")
    assert str(error) == "LaTeX failed to compile the sheet: Double subscript. (line 3)"


def test_first_error_names_the_line():
    log = "This is pdfTeX\n! Double subscript.\nl.12 $x_1_\n                2$\n! Emergency stop.\n"
    assert _first_error(log) == "Double subscript. (line 12)"
    assert _first_error("no errors here\n") == "no error line in the log"


@pytest.mark.pdf
def test_solve_writes_the_other_outputs_when_latex_fails(tmp_path, tex, broken_templates):
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", "rp_arm", "--pdf", "--code", "--json", "--out", str(out),
                                 "--template-dir", str(broken_templates)])
    assert result.exit_code == 1
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.json", "rp_arm.log", "rp_arm.tex",
                                                     "rp_arm_dynamics.py"]
    assert "$x_1_2$" in (out / "rp_arm.tex").read_text()
    assert "! Double subscript." in (out / "rp_arm.log").read_text()
    lines = result.stderr.strip().splitlines()
    assert lines[-1] == (f"dynderive: LaTeX failed to compile {out / 'rp_arm.tex'}: "
                         f"Double subscript. (line 3); the log is {out / 'rp_arm.log'}")
    assert f"wrote {out / 'rp_arm.log'}" in lines and "error" not in result.stderr.replace("LaTeX failed", "")
    assert "def mass_matrix" in (out / "rp_arm_dynamics.py").read_text()


@pytest.mark.pdf
def test_build_writes_the_other_outputs_when_latex_fails(tmp_path, tex, broken_templates):
    out = tmp_path / "out"
    args = ["build", str(ROOT / "robots" / "rp_arm.yaml"), "--out", str(out), "--pdf", "--code",
            "--template-dir", str(broken_templates)]
    check = runner.invoke(app, [*args, "--check"])   # --check writes nothing, so names no log
    assert check.exit_code == 1 and not out.exists()
    assert "LaTeX failed to compile the sheet: Double subscript. (line 3)" in check.stderr
    result = runner.invoke(app, args)
    assert result.exit_code == 1
    assert f"the log is {out / 'rp_arm.log'}" in result.stderr and "failed" in result.stdout
    assert {"rp_arm.tex", "rp_arm.log", "rp_arm_dynamics.py"} <= {p.name for p in out.iterdir()}
    assert not (out / "rp_arm.pdf").exists()
    # not recorded: the next build tries again rather than calling the robot up to date
    assert (out / MANIFEST).is_file() and load_manifest(out) == {}
    assert runner.invoke(app, args).exit_code == 1


# ---- floating base: the sheet and the JSON of a free body and floating chains ----------------

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
    # a valid tensor: principal moments, small products
    a, b, c = (rng.uniform(0.01, 0.05) for _ in range(3))
    return f"[{a + b!r}, {b + c!r}, {a + c!r}, {rng.uniform(-0.004, 0.004)!r}, " \
           f"{rng.uniform(-0.004, 0.004)!r}, {rng.uniform(-0.004, 0.004)!r}]"


def _vector(rng: random.Random, scale: float) -> str:
    return "[" + ", ".join(_number(rng, -scale, scale) for _ in range(3)) + "]"


def _axis(rng: random.Random) -> str:
    v = np.array([rng.gauss(0, 1) for _ in range(3)])
    return "[" + ", ".join(repr(float(x)) for x in v / np.linalg.norm(v)) + "]"


def _chain(seed: int, scalar: int, root: str = "floating", title: str = "A floating chain") -> str:
    """A floating (or spherical) root with ``scalar`` revolute or prismatic joints in a chain,
    full-precision numbers, generic axes and full inertia tensors, one joint with drives."""
    rng = random.Random(seed)
    links = [f"  - {{name: l0, mass: {_number(rng, 0.5, 3)}, com: {_vector(rng, 0.2)}, "
             f"inertia: {_inertia(rng)}}}"]
    joints = [f"  - {{name: root, type: {root}, parent: world, child: l0"
              + (f", origin: {{xyz: {_vector(rng, 0.3)}, rpy: {_vector(rng, 1)}}}" if root == "spherical"
                 else "") + "}"]
    for k in range(1, scalar + 1):
        links.append(f"  - {{name: l{k}, mass: {_number(rng, 0.5, 3)}, com: {_vector(rng, 0.2)}, "
                     f"inertia: {_inertia(rng)}}}")
        kind = "prismatic" if k == 2 else "revolute"
        drives = ", armature: 0.0123, stiffness: 2.5, rest: 0.3" if k == 1 else ""
        joints.append(f"  - {{name: q{k}, type: {kind}, parent: l{k - 1}, child: l{k}, origin: {{xyz: "
                      f"{_vector(rng, 0.3)}, rpy: {_vector(rng, 1)}}}, axis: {_axis(rng)}, "
                      f"effort: u{k}{drives}}}")
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
    # the centre of mass's velocity: Newton-Euler there, its moment carried to the origin
    v_c = lin + ang.cross(c)
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


@pytest.mark.parametrize(("seed", "scalar", "root"), [(1, 0, "floating"), (2, 1, "floating"),
                                                       (3, 2, "floating"), (4, 1, "spherical")])
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
    assert list(sheet.Y) == ([0] * (6 if root == "floating" else 3)
                             + [efforts[f"u{k}"] for k in range(1, scalar + 1)])


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
                printed[key] = _numeric(derivation, sympy.Matrix(
                    sympy.sympify(document["quantities"][key]["sympy"], locals=names)))
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


HOSTILE = r"Evil \input{/etc/passwd} $x$ & 100% #1 _a ^b ~c {d}"


@pytest.mark.parametrize(("text", "small"), [(FREE, True), (_chain(7, 2), True), (_chain(8, 3), False)])
def test_sheet_compiles(text, small, tex, tmp_path):
    text = text.replace("title: A free rigid body", f"title: '{HOSTILE}'").replace(
        "title: A floating chain", f"title: '{HOSTILE}'")
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    assert is_step_by_step(robot) == small
    result = runner.invoke(app,
                           ["solve", str(path), "--pdf", "--latex", "--out", str(tmp_path / "out"), "-q"])
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
        subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), "--latex", "--json", "--out",
                        str(out), "-q"],
                       check=True, env=os.environ | {"PYTHONHASHSEED": seed, "PYTHONPATH": str(ROOT / "src")})
        outputs.append([(out / f"chain9.{ext}").read_bytes() for ext in ("tex", "json")])
    assert outputs[0] == outputs[1]


def test_build_writes_the_sheet_and_json(tmp_path):
    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "free.yaml").write_text(FREE)
    result = runner.invoke(app, ["build", str(folder), "--out", str(tmp_path / "b"), "-j", "1", "--latex",
                                 "--json"])
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
    assert list(derivation.quasi_velocity_steps.sheet.Y) == ([efforts[f"w_{s}"] for s in suffixes]
                                                            + [efforts["u1"]])
    document = json.loads(render_json(derivation))
    assert document["efforts"] == list(robot.efforts)
    latex = render_latex(derivation)
    assert all(rf"w_{{\mathrm{{{s}}}}}" in latex for s in suffixes)
    assert "unactuated" not in latex
