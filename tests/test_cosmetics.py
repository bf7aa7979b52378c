"""What the first sheets got wrong in small ways: angles in the drawing's caption beyond a turn,
"1 degrees of freedom", a velocity printed ``d_2_d`` on the terminal, page 1 left half empty
when the drawing does not fit below the tables."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.sheets import figure
from dynderive.render.sheets.drawing import joint_value_text
from dynderive.render.sheets.pdf import tikz_available

from conftest import derivation_of

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
runner = CliRunner()

PENDULUM = """\
name: pendulum
title: Pendulum
planar: true
parameters:
  m: 1.0
  l: 1.0
  g: 9.81
gravity: [0, -g]
links:
  - {name: rod, mass: m, com: [l/2, 0], inertia: m*l**2/12}
joints:
  - {name: q1, type: revolute, parent: world, child: rod, effort: tau1}
"""


# --- angles in the caption ----------------------------------------------------------------

@pytest.mark.parametrize(("degrees", "text"), [
    (-314, "46^\\circ"), (30, "30^\\circ"), (180, "180^\\circ"), (-180, "180^\\circ"), (540, "180^\\circ"),
    (-179.6, "180^\\circ"), (359.6, "0^\\circ"), (-0.3, "0^\\circ"), (-90, "-90^\\circ"), (725, "5^\\circ"),
])
def test_caption_angles_are_wrapped_to_a_half_turn_either_way(degrees, text):
    assert joint_value_text(math.radians(degrees), True) == text


def test_travel_is_not_wrapped():
    assert joint_value_text(-3.14159e3, False) == "-3.14e+03"


def test_sheet_caption_shows_the_wrapped_angle(monkeypatch):
    derivation = derivation_of("rp_arm")
    monkeypatch.setattr(figure, "_configuration", lambda *args: [math.radians(-314), 0.125])
    from dynderive.render.sheets.latex_format import Formatter

    drawn = figure.planar_figure(derivation, Formatter.of(derivation))
    assert drawn["caption"] == r"The robot at $q_{1} = 46^\circ, q_{2} = 0.125$."


# --- "1 degree of freedom" ----------------------------------------------------------------

def test_one_degree_of_freedom_is_singular(tmp_path):
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM)
    derivation = dynderive.derive(dynderive.load_robot(path))
    tex = " ".join(dynderive.render_latex(derivation).split())
    assert "with 1 degree of freedom and generalized coordinate \\[" in tex
    assert "degrees of freedom" not in tex
    from dynderive.render.sheets.html import render_html

    html = render_html(derivation)
    assert "with 1 degree of freedom and generalized coordinate</p>" in html and "1 degrees" not in html
    two = " ".join(dynderive.render_latex(derivation_of("rp_arm")).split())
    assert "with 2 degrees of freedom and generalized coordinates \\[" in two


def test_maximal_constraint_count_message_is_singular_for_one_joint(tmp_path):
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM + "maximal:\n  constraints:\n    - x1 - l*cos(phi1)/2\n")
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"{path}:15:5: maximal.constraints: expected 2 constraints (3 per link minus "
                                     "1 degree of freedom), got 1")


# --- velocities on the terminal -------------------------------------------------------------

def test_terminal_prints_velocities_with_a_prime(tmp_path):
    text = (ROBOTS / "rp_arm.yaml").read_text().split("\nmaximal:")[0].replace("name: q2", "name: d2")
    path = tmp_path / "rp_d.yaml"
    path.write_text(text + "\n")
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 0, result.output
    assert "d₂'⋅m" in result.stdout and "m⋅q₁'" in result.stdout
    assert "d_2_d" not in result.stdout and "qd₁" not in result.stdout
    plain = runner.invoke(app, ["solve", "rp_arm"])
    assert "m⋅q₂'⋅" in plain.stdout and "qd" not in plain.stdout


# --- page 1 ---------------------------------------------------------------------------------

@pytest.fixture
def pdf_tools():
    missing = [t for t in ("latexmk", "pdflatex", "pdftotext") if shutil.which(t) is None]
    if not missing and not tikz_available():
        missing = ["TikZ (texlive-pictures)"]
    if missing:
        if os.environ.get("CI"):
            raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
        pytest.skip(f"no TeX engine ({', '.join(missing)} missing)")


def _pages(pdf: bytes, tmp_path: Path) -> list[str]:
    path = tmp_path / "sheet.pdf"
    path.write_bytes(pdf)
    text = subprocess.run(["pdftotext", "-layout", str(path), "-"], check=True, capture_output=True,
                          text=True).stdout
    return text.split("\f")


@pytest.mark.pdf
def test_text_fills_page_one_when_the_drawing_moves_on(tmp_path, pdf_tools):
    """cart_pole_damped's drawing does not fit below its tables: it floats to the top of page
    2, and the first section starts on page 1 (it used to leave the lower half of page 1 blank)."""
    from dynderive.render.sheets.pdf import compile_pdf_report

    pdf, _, _ = compile_pdf_report(dynderive.render_latex(derivation_of("cart_pole_damped")), "sheet")
    pages = _pages(pdf, tmp_path)
    assert "Generalized coordinates" in pages[0] and "The robot at" not in pages[0]
    assert "The robot at" in pages[1]


@pytest.mark.pdf
def test_drawing_stays_on_page_one_where_it_fits(tmp_path, pdf_tools):
    from dynderive.render.sheets.pdf import compile_pdf_report

    pdf, _, _ = compile_pdf_report(dynderive.render_latex(derivation_of("rp_arm")), "sheet")
    first = _pages(pdf, tmp_path)[0]
    assert "The robot at" in first and first.index("Joint") < first.index("The robot at")
