"""Every robot the engine derives gives a sheet that compiles (issue 26, item 4).

The random robots of the test suite, planar and 3-D, 2 to 12 links, with full-precision
numbers, are derived, rendered and compiled by the product's own LaTeX path; a LaTeX error
fails the test with TeX's first error line. Three of them failed before: the generic 7-DOF arm
("Double subscript": an entry of ``J^b_7`` named ``J^b_7_{11}``), a planar tree whose
drawing held a zero-length ``\\qbezier`` ("Arithmetic overflow") and a 7-link chain with all
sections (a 21-column matrix typeset whole: "Extra alignment tab"). The subscript
composition, the matrices' columns and the drawing's curves are also checked without TeX.
When LaTeX fails anyway, ``solve`` and ``build`` still write the other outputs, keep the .tex
and LaTeX's log, and say where (exit 1).

The compile tests need latexmk and pdflatex: skipped locally without them, required in CI
(CI=true).
"""

from __future__ import annotations

import os
import pickle
import random
import shutil
import sys
from pathlib import Path

import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.build import MANIFEST, load_manifest
from dynderive.commands.cli import app
from dynderive.errors import LatexError
from dynderive.render.sheets.figure import _dashes, planar_figure
from dynderive.render.sheets.latex_format import Formatter, entry_index, subscript
from dynderive.render.sheets.pdf import _first_error, tikz_available

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
    assert row["wide"] and not row["tight"] and len(row["entries"]) == 21 and row["entries"][-1]["name"] == "A_{1,21}"


# ---- the drawing: nothing TikZ cannot draw ---------------------------------------------------

def _degenerate(figure: dict) -> list[dict]:
    """Items of zero length: a path with a repeated point or one point, an arc without sweep."""
    bad = []
    for item in figure["items"]:
        if item["kind"] == "path":
            points = item["points"] + (item["points"][:1] if item["closed"] else [])
            if len(item["points"]) < 2 or any(a == b for a, b in zip(points, points[1:])):
                bad.append(item)
        elif item["kind"] == "arc" and (abs(float(item["end"]) - float(item["start"])) < 1.0 or float(item["radius"]) <= 0):
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
                         ids=[f"{k.replace(' ', '-')}-{n}-{s}" + (f"-{c}" if c else "") for k, n, s, c in ROBOTS])
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
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.json", "rp_arm.log", "rp_arm.tex", "rp_arm_dynamics.py"]
    assert "$x_1_2$" in (out / "rp_arm.tex").read_text()
    assert "! Double subscript." in (out / "rp_arm.log").read_text()
    lines = result.stderr.strip().splitlines()
    assert lines[-1] == (f"dynderive: LaTeX failed to compile {out / 'rp_arm.tex'}: Double subscript. (line 3); "
                         f"the log is {out / 'rp_arm.log'}")
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
