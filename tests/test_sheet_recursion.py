"""A large robot's sheet states the recursion (issue 32): Newton-Euler and the composite bodies
line by line, each line named by what it means and by its link. The lines printed are the
derivation's: evaluated in the order printed they give the generated module's M, C qd and N;
every name is valid LaTeX; the Panda's sheet fits 15 pages without a line over the margin."""

from __future__ import annotations

import os
import random
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.render.sheets.latex import sheet_context
from dynderive.render.sheets.pdf import tikz_available
from dynderive.render.sheets.recursion import NAMES

from conftest import derivation_of, module_of, text_derivation
from random_robots3d import random_spatial_tree

LARGE = ["panda", "ur5"]


def _printed_lines(derivation) -> list[tuple[sympy.Symbol, sympy.Expr]]:
    """The program lines the sheet defines, in the order it prints them."""
    context = sheet_context(derivation)["recursion"]
    definitions = dict(derivation.recursion.program.lines)
    return [(line["symbol"], definitions[line["symbol"]])
            for part in ("forward", "backward", "composite", "columns") for block in context[part]
            for line in block["lines"] if line["symbol"] is not None]


def _evaluate(derivation, printed, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
    """(tau, M) from the printed lines alone, in their order (a name read before it is printed
    fails), at the parameters' defaults."""
    table, r = derivation.symbols, derivation.recursion
    values: dict[sympy.Basic, float] = {table.parameters[p.name]: p.value for p in derivation.robot.parameters}
    values |= dict(zip(table.q, q)) | dict(zip(table.qd, qd)) | dict(zip(table.qdd, qdd))
    values |= {symbol: float(expr.xreplace(values)) for symbol, expr in r.trig}
    for symbol, expr in printed:
        value = expr.xreplace(values)
        assert value.is_number, f"{symbol} reads {value.free_symbols} before they are printed"
        values[symbol] = float(value)

    def number(expr):
        return float(sympy.sympify(expr).xreplace(values))

    return (np.array([number(e) for e in r.tau]),
            np.array([[number(e) for e in row] for row in r.mass_matrix]))


@pytest.mark.parametrize("robot", [*LARGE, "random tree"])
def test_printed_recursion_gives_the_modules_dynamics(robot, tmp_path):
    if robot == "random tree":   # branches: a link's force summed over two children
        derivation, module = text_derivation("tree7", random_spatial_tree(random.Random(1), 7).yaml_text, str(tmp_path))
        parents = list(derivation.recursion.parents.values())
        assert any(parents.count(p) > 1 for p in set(parents) - {"world"})
    else:
        derivation, module = derivation_of(robot), module_of(robot, str(tmp_path))
    printed = _printed_lines(derivation)
    labelled = {s for s, _ in derivation.recursion.program.lines if s in derivation.recursion.program.labels}
    assert {s for s, _ in printed} == labelled   # every line named, each once
    assert len(labelled) == len(derivation.recursion.program.lines) - len(derivation.recursion.trig)
    rng = np.random.default_rng(32)
    n = len(derivation.robot.coordinates)
    for _ in range(2):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, n))
        tau, M = _evaluate(derivation, printed, q, qd, qdd)
        N = _evaluate(derivation, printed, q, 0 * qd, 0 * qdd)[0]
        Cqd = _evaluate(derivation, printed, q, qd, 0 * qdd)[0] - N
        np.testing.assert_allclose(M, module.mass_matrix(q), atol=1e-10, rtol=0)
        np.testing.assert_allclose(N, module.gravity_vector(q), atol=1e-10, rtol=0)
        np.testing.assert_allclose(Cqd, module.coriolis_matrix(q, qd) @ qd, atol=1e-10, rtol=0)
        np.testing.assert_allclose(tau, M @ qdd + Cqd + N, atol=1e-10, rtol=0)


def test_lines_are_named_by_meaning_not_numbered():
    context = sheet_context(derivation_of("panda"))["recursion"]
    names = [line["name"] for part in ("forward", "backward", "composite", "columns")
             for block in context[part] for line in block["lines"] if line["name"]]
    assert not any(r"\mathsf{w}" in name or "_t" in name for name in names)
    aliases = [line["value"] for part in ("forward", "backward", "composite", "columns")   # name = value, side by side
               for block in context[part] for line in block["lines"] if not line["name"]]
    joined = " ".join(names + aliases)
    for name in (r"\omega_{3x}", r"\dot\omega_{3z}", r"\bar\omega_{3x}", r"F_{7x}", r"N_{7z}",
                 r"f_{6x}", r"n_{6z}", r"I^c_{6,xx}", r"n^{(7)}_{7x}"):
        assert name in joined, name
    assert len(names) == len(set(names))   # each name defined once
    titles = [block["title"] for block in context["forward"]]
    assert titles[0] == r"Link 1 (\texttt{panda\_link1})" and len(titles) == 7


def test_names_are_valid_latex():
    """Every name template yields balanced braces; link names in titles are escaped."""
    for quantity, template in NAMES.items():
        text = template.format(i=3, p=2, j=4, k=3, c="x")
        depth = 0
        for char in text:
            depth += {"{": 1, "}": -1}.get(char, 0)
            assert depth >= 0, quantity
        assert depth == 0, quantity
    robot_text = (Path(__file__).parent.parent / "robots" / "ur5.urdf").read_text()
    assert "wrist_1_link" in robot_text
    context = sheet_context(derivation_of("ur5"))["recursion"]
    assert all("_" not in re.sub(r"\\_", "", b["title"].split("texttt")[1]) for b in context["forward"])


def test_small_robots_keep_their_derivation():
    context = sheet_context(derivation_of("planar_3r"))
    assert context["recursion"] is None and context["lagrange"]


needs_tex = pytest.mark.skipif((shutil.which("pdflatex") is None or not tikz_available()) and not os.environ.get("CI"),
                               reason="no pdflatex or no TikZ")
#: Most pages of a large robot's sheet (issue 32: the Panda's was 38, the UR5's 20).
MOST_PAGES = {"panda": 15, "ur5": 11}


def _compile(tex: str, folder: Path) -> tuple[int, list[float]]:
    """(pages, overfull box widths in pt) of ``tex`` compiled twice (the columns settle)."""
    (folder / "sheet.tex").write_text(tex)
    for _ in range(2):
        subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", "sheet.tex"],
                       cwd=folder, capture_output=True, text=True, timeout=600)
    log = (folder / "sheet.log").read_text(errors="replace")
    pages = re.search(r"Output written on sheet\.pdf \((\d+) pages?", log)
    assert pages, log[-2000:]
    return int(pages.group(1)), [float(w) for w in re.findall(r"Overfull \\hbox \(([\d.]+)pt too wide\)", log)]


@pytest.mark.pdf
@needs_tex
@pytest.mark.parametrize("robot", LARGE)
def test_large_sheet_is_short_and_fits_the_margin(robot, tmp_path):
    pages, boxes = _compile(dynderive.render_latex(derivation_of(robot)), tmp_path)
    assert pages <= MOST_PAGES[robot]
    assert max(boxes, default=0.0) < 1.0, boxes


@pytest.mark.pdf
@needs_tex
def test_random_tree_recursion_fits_the_columns(tmp_path):
    """A random 7-joint 3-D tree (branches: partial sums primed; rotations of CAD frames with
    20-digit entries): before the column-width breaking, lines stuck out by up to 140 pt."""
    path = tmp_path / "robot.yaml"
    path.write_text(random_spatial_tree(random.Random(1), 7).yaml_text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.intermediate_form
    _, boxes = _compile(dynderive.render_latex(derivation, sections=("generalized",)), tmp_path)
    assert max(boxes, default=0.0) < 1.0, boxes
