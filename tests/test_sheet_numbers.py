"""Numbers on the sheet as the robot file wrote them (render.numbers; docs/reference/outputs.md).

A robot written with CAD numbers (17 significant digits, a generic joint axis) must show no
number with more digits than its file wrote, on the LaTeX sheet, the HTML page and the printed
equations; ``--digits N`` shortens them to N; fractions the file wrote stay fractions; the JSON
keeps its exact values.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import LatexError
from dynderive.model.written import significant_digits, written_digits
from dynderive.render.numbers import Numbers
from test_sheets_compile import tex  # noqa: F401  (the fixture: skip without TeX, fail in CI)

runner = CliRunner()

CAD_ROBOT = """\
name: cad_arm
title: Two-link arm with CAD numbers
planar: false
parameters:
  g: {value: 9.80665, unit: m/s^2, description: gravity}
gravity: [0, 0, -g]
links:
  - name: upper
    mass: 1.2345678901234567
    com: [0.1234567890123456, 0.0123456789012345, 0.23456789012345678]
    inertia: [0.012345678901234567, 0.023456789012345678, 0.034567890123456789, 0.0012345678901234567, 0, 0]
  - name: fore
    mass: 0.87654321098765432
    com: [0.21098765432109876, 0, 0.0314159265358979]
    inertia: [0.0087654321098765432, 0.0076543210987654321, 0.0065432109876543210, 0, 0, 0]
joints:
  - name: q1
    type: revolute
    parent: world
    child: upper
    origin: {xyz: [0, 0, 0.333], rpy: [0, 0, 0]}
    axis: [0.12345678901234567, 0.45678901234567891, 0.87654321098765432]
    effort: tau1
  - name: q2
    type: revolute
    parent: upper
    child: fore
    origin: {xyz: [0.4567890123456789, 0, 0.0123456789012345], rpy: [0, 0.1234567890123456, 0]}
    axis: [0, 1, 0]
    effort: tau2
"""

THIRDS_ROBOT = """\
name: thirds
title: Pendulum with a third
planar: true
parameters:
  m: {value: 1.5, unit: kg}
  l: {value: 0.75, unit: m}
  g: {value: 9.81, unit: m/s^2}
gravity: [0, -g]
links:
  - name: rod
    mass: m
    com: [l/3, 0]
    inertia: m*l**2/36
joints:
  - name: q1
    type: revolute
    parent: world
    child: rod
    origin: [0, 0, 0]
    effort: tau1
"""

#: A number in LaTeX or text: digits with an optional fraction, not part of a name (``q_{1}``
#: is a subscript: counted too, it has one digit).
NUMBER = re.compile(r"(?<![\w.])(\d+\.?\d*|\.\d+)")


def most_digits(text: str) -> tuple[int, str]:
    """The most significant digits of a number in ``text``, and that number."""
    best = (0, "")
    for match in NUMBER.finditer(text):
        best = max(best, (significant_digits(match.group(1)), match.group(1)))
    return best


def file_digits(text: str) -> int:
    """The most significant digits of a number written in a robot file's text (names skipped)."""
    return max(significant_digits(m) for m in NUMBER.findall(re.sub(r"[A-Za-z_]\w*", " ", text)))


def body(tex_text: str) -> str:
    """The sheet's text after the preamble, without the drawing (TikZ coordinates in mm and
    its ``--`` path operator are not numbers or signs of the equations)."""
    text = tex_text[tex_text.index(r"\begin{document}"):]
    return re.sub(r"\\begin\{tikzpicture\}.*?\\end\{tikzpicture\}", "", text, flags=re.S)


@pytest.fixture(scope="module")
def cad(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cad") / "cad_arm.yaml"
    path.write_text(CAD_ROBOT)
    return path


@pytest.fixture(scope="module")
def cad_derivation(cad):
    return dynderive.derive(dynderive.load_robot(str(cad)))


def test_written_digits_count_significant_digits_of_the_file():
    assert significant_digits("0.00120") == 2 and significant_digits("1500") == 2
    assert significant_digits("0.1234567890123456") == 16 and significant_digits("0") == 1
    robot = dynderive.load_robot("elbow_arm")   # writes 9.81, 0.25, m2*l2**2/12
    assert written_digits(robot) == 3


def test_cad_sheet_shows_six_digits(cad, cad_derivation):
    """A file of 17-digit numbers: its sheet shows 6 significant digits (and says so); with
    ``--digits 17`` every number the file wrote appears as written."""
    assert file_digits(CAD_ROBOT) == 17
    sheet = body(dynderive.render_latex(cad_derivation))
    digits, number = most_digits(sheet)
    assert digits <= 6, number
    assert "shown to 6 significant digits (the file writes up to 17" in sheet
    # no surd of a normalised axis, no fraction of long integers, no run of 13 digits
    assert r"\sqrt" not in sheet
    assert not re.search(r"\\frac\{\d{4,}\}", sheet) and not re.search(r"\d{13}", sheet)
    assert "Mass $1.23457$" in sheet   # the link mass 1.2345678901234567, rounded
    full = body(dynderive.render_latex(cad_derivation, digits=17))
    assert most_digits(full)[0] <= 17 and "shown to" not in full
    assert "0.1234567890123456" in full and "1.2345678901234567" in full


def test_digits_shortens_every_number(cad_derivation):
    sheet = body(dynderive.render_latex(cad_derivation, digits=4))
    digits, number = most_digits(sheet)
    assert digits <= 4, number
    # signs as the decimals have them, scales multiplied out of the CAD factoring
    assert not re.search(r"[-+] *(\{\})?- ", sheet.replace(r"\\", "\n"))
    assert not re.search(r"10\^\{-[4-9]\d\}", sheet)   # no 7.3e-50 in front of a sum of 1e48s
    assert "Mass $1.235$" in sheet   # the link mass 1.2345678901234567, rounded


def test_written_fractions_stay_fractions(tmp_path):
    path = tmp_path / "thirds.yaml"
    path.write_text(THIRDS_ROBOT)
    derivation = dynderive.derive(dynderive.load_robot(str(path)))
    sheet = dynderive.render_latex(derivation)
    assert r"\frac{l}{3}" in sheet or r"\frac{1}{3}" in sheet
    assert "0.333" not in sheet   # 1/3 is never a rounded decimal
    assert "0.75" in sheet and "1.5" in sheet   # the parameters' defaults as written
    shortened = dynderive.render_latex(derivation, digits=1)
    assert r"\frac{l}{3}" in shortened or r"\frac{1}{3}" in shortened


def test_the_rule_on_single_numbers():
    numbers = Numbers(4)
    assert numbers.decimal(sympy.Rational(1, 3)) is None              # a short fraction
    assert numbers.decimal(sympy.Rational(7, 12)) is None
    assert str(numbers.decimal(sympy.Rational(7, 20))) == "0.35"      # a decimal written 0.35
    assert str(numbers.decimal(sympy.Rational(1234567, 3000000))) == "0.4115"
    assert numbers.decimal(sympy.Integer(12)) is None
    assert numbers.parts(numbers.decimal(sympy.Rational(1, 80000))) == ("1.25", -5)
    assert numbers.parts(numbers.decimal(sympy.Integer(123456789))) == ("1.235", 8)
    axis = sympy.Integer(17573222896111212) * sympy.sqrt(408411658130753469968119867310881) / 408411658130753469968119867310881
    assert numbers.parts(numbers.constant(axis)) == ("0.8696", None)
    assert numbers.constant(sympy.sqrt(2) / 2) is None                # an exact surd stays


@pytest.mark.pdf
def test_cad_sheets_compile(cad_derivation, tex):  # noqa: F811
    from dynderive.render.sheets.pdf import compile_pdf_report

    for digits in (None, 4):
        try:
            pdf, pages, _ = compile_pdf_report(dynderive.render_latex(cad_derivation, digits=digits), "cad")
        except LatexError as exc:
            pytest.fail(f"--digits {digits}: {exc}", pytrace=False)
        assert pdf.startswith(b"%PDF") and pages >= 1


def test_html_page_obeys_the_rule(cad_derivation):
    from dynderive.render.sheets.html import render_html

    page = html.unescape(render_html(cad_derivation))   # the minus sign is a character reference
    numbers = " ".join(re.findall(r"<mn>([^<]*)</mn>", page))
    assert numbers and most_digits(numbers)[0] <= 6
    assert "<msqrt>" not in page and "<mn>1.23457</mn>" in page and "shown to 6 significant digits" in page
    assert "1.2345678901234567" in html.unescape(render_html(cad_derivation, digits=17))
    short = html.unescape(render_html(cad_derivation, digits=3))
    assert most_digits(" ".join(re.findall(r"<mn>([^<]*)</mn>", short)))[0] <= 3
    assert "<mn>1.23</mn>" in short


def test_printed_equations_obey_the_rule(cad):
    result = runner.invoke(app, ["solve", str(cad), "--quiet", "--digits", "3"])
    assert result.exit_code == 0, result.output
    assert most_digits(result.output.split("Checks:")[0])[0] <= 3


def test_json_keeps_exact_values(cad, tmp_path):
    result = runner.invoke(app, ["solve", str(cad), "--json", "--latex", "--digits", "3", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads((tmp_path / "cad_arm.json").read_text())
    mass = document["quantities"]["M_g"]
    assert "sqrt" in mass["sympy"] and r"\sqrt" in mass["latex"]   # exact, as before
    assert "Mass $1.23$" in (tmp_path / "cad_arm.tex").read_text()   # the sheet, shortened


def test_build_digits_reach_the_sheet(cad, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["build", str(cad), "--latex", "--digits", "2", "--out", str(out), "-j", "1"])
    assert result.exit_code == 0, result.output
    assert most_digits(body((out / "cad_arm.tex").read_text()))[0] <= 2


@pytest.mark.parametrize(("command", "value", "message"), [
    (["solve", "rp_arm", "--latex"], "0", "--digits:1:1: expected a whole number of significant digits from 1 to 100, got '0'"),
    (["solve", "rp_arm", "--latex"], "four", "--digits:1:1: expected a whole number of significant digits"),
    (["solve", "rp_arm", "--latex"], "2.5", "--digits:1:1: expected a whole number of significant digits"),
    (["solve", "rp_arm", "--html"], "101", "--digits:1:1: expected a whole number of significant digits"),
    (["solve", "rp_arm", "--code"], "4", "--digits:1:1: --digits shortens the numbers of the sheet"),
    (["build", "--latex"], "-3", "--digits:1:1: expected a whole number of significant digits"),
    (["build", "--code"], "4", "--digits:1:1: --digits shortens the numbers of the sheet"),
])
def test_bad_digits_are_one_line_input_errors(tmp_path, command, value, message):
    out = tmp_path / "out"
    result = runner.invoke(app, [*command, "--digits", value, "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith(message)
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    assert not out.exists()


URDF_ROBOT = """\
<robot name="urdf_arm">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.125 0 0.05" rpy="0 0 0"/><mass value="2.345"/>
      <inertia ixx="0.0123" iyy="0.0234" izz="0.0345" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="tool">
    <inertial><origin xyz="0.01 0.02 0" rpy="0 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" iyy="0.002" izz="0.003" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="q1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit effort="10" velocity="1" lower="-1" upper="1"/></joint>
  <joint name="weld" type="fixed"><parent link="arm"/><child link="tool"/>
    <origin xyz="0.25 0 0" rpy="0 0 0.3"/></joint>
</robot>
"""


def test_urdf_precision_is_what_its_attributes_wrote(tmp_path):
    path = tmp_path / "urdf_arm.urdf"
    path.write_text(URDF_ROBOT)
    robot = dynderive.load_robot(str(path))
    assert robot.digits == 4   # 2.345, 0.0123 ...; not pi/2's 17 digits, nor the welded body's sums
    sheet = body(dynderive.render_latex(dynderive.derive(robot)))
    digits, number = most_digits(sheet)
    assert digits <= 4, number
