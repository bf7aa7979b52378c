"""The solution sheet compiles to a PDF whose text holds the worked solution.

Needs latexmk + pdflatex + pdftotext. Skipped locally without them; required in CI
(CI=true), where .ci/run installs TeX Live.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

pytestmark = pytest.mark.pdf
TOOLS = ("latexmk", "pdflatex", "pdftotext")
missing = [t for t in TOOLS if shutil.which(t) is None]
if missing:
    if os.environ.get("CI"):
        raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
    pytest.skip(f"no TeX engine ({', '.join(missing)} missing)", allow_module_level=True)


def _text(pdf) -> str:
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout
    return text.replace("\u2019", "'").replace("\u2212", "-")


@pytest.fixture(scope="module")
def rp_pdf(tmp_path_factory):
    out = tmp_path_factory.mktemp("pdf")
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--latex", "--pdf", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_pdf_holds_the_worked_solution(rp_pdf):
    text = _text(rp_pdf / "rp_arm.pdf")
    for phrase in ("Kinetic energy, potential energy and Lagrangian", "Lagrange's equations",
                   "Manipulator form", "Coriolis matrix", "Christoffel", "passed"):
        assert phrase in text, phrase
    for symbol in ("Tg =", "Vg =", "Lg = Tg - Vg", "Mg =", "Ng ="):
        assert symbol in text, symbol
    assert "∂Lg" in text


def test_tex_compiles_with_plain_pdflatex(rp_pdf, tmp_path):
    shutil.copy(rp_pdf / "rp_arm.tex", tmp_path / "sheet.tex")
    result = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", "sheet.tex"],
                            cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-2000:]


@pytest.mark.parametrize("robot", ["double_pendulum", "cart_pole", "elbow_arm", "panda"])
def test_other_bundled_sheets_compile(tmp_path, robot):
    result = CliRunner().invoke(app, ["solve", robot, "--pdf", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / f"{robot}.pdf").read_bytes().startswith(b"%PDF")


def test_pdf_is_reproducible(rp_pdf, tmp_path):
    result = CliRunner().invoke(app, ["solve", "rp_arm", "--pdf", "--out", str(tmp_path)])
    assert result.exit_code == 0
    assert (tmp_path / "rp_arm.pdf").read_bytes() == (rp_pdf / "rp_arm.pdf").read_bytes()


def test_large_arm_sheet_stays_short(tmp_path):
    """The 7-DOF arm's sheet states the recursion (Newton-Euler, composite bodies) line by
    line, each quantity named by its meaning and link, instead of hundreds of pages."""
    result = CliRunner().invoke(app, ["solve", "panda", "--pdf", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    info = subprocess.run(["pdfinfo", str(tmp_path / "panda.pdf")], capture_output=True, text=True).stdout
    pages = int(next(line.split()[-1] for line in info.splitlines() if line.startswith("Pages:")))
    assert pages <= 15
    text = " ".join(_text(tmp_path / "panda.pdf").split())
    assert "Forward pass" in text and "Backward pass" in text and "too large to typeset" not in text
