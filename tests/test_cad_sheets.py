"""Sheets of CAD-style robots (every number written with 17 significant digits) read like
round-number ones: decimals of at most 6 digits (the default precision), no integer times a
power of ten, and numbers that read back to the module's values to the printed digits.
A CAD robot's sheet has at most 20 % more pages than the same robot's with round numbers."""

from __future__ import annotations

import html
import random
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render.sheets.html import render_html
from dynderive.render.sheets.latex_format import Formatter
from dynderive.render.sheets.terminal import render_terminal
from dynderive.verify.checks import generated_module
from test_sheets_compile import tex  # noqa: F401  (the fixture: skip without TeX, fail in CI)

from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))   # cad_numbers, models: the round and CAD robots

#: A run of this many digits is a number nobody wrote (a 17-digit CAD value, an exact fraction).
LONG_RUN = re.compile(r"\d{13}")
#: A power of ten in front of a parenthesis: a scale factored out of a sum.
SCALED_SUM = re.compile(r"10\^\{-?\d+\}\s*\\left\(")


def _derive(text: str, folder: Path, name: str):
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return dynderive.derive(dynderive.load_robot(path))


def _body(sheet: str) -> str:
    return sheet.split(r"\begin{document}", 1)[1]


#: (kind, joints, seed): random branching trees up to their generators' sizes (5 planar, 7
#: spatial), the benchmarks' CAD chains beyond (12 links planar, 10 joints 3-D).
CASES = [("planar", 2, 11), ("planar", 5, 12), ("planar", 12, 13), ("spatial", 2, 21), ("spatial", 5, 22),
         ("spatial", 10, 23)]


def _text(kind: str, joints: int, seed: int) -> str:
    from models import planar_chain_yaml, spatial_chain_yaml

    if kind == "planar":
        return random_planar_tree(random.Random(seed), joints).yaml_text if joints <= 5 else planar_chain_yaml(joints, seed)
    return random_spatial_tree(random.Random(seed), joints).yaml_text if joints <= 7 else spatial_chain_yaml(joints, seed)


@pytest.fixture(scope="module")
def cad_robots(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cad")
    return {(kind, joints): _derive(_text(kind, joints, seed), folder, f"cad_{kind}_{joints}")
            for kind, joints, seed in CASES}


@pytest.mark.parametrize("case", [c[:2] for c in CASES], ids=lambda c: f"{c[0]}{c[1]}")
def test_no_long_numbers_and_no_scaled_sums(cad_robots, case):
    """The LaTeX sheet, the HTML page and the printed equations of a random CAD robot: no run
    of 13 digits, no ``10^{-k} (...)``, and the sentence saying the precision."""
    derivation = cad_robots[case]
    sheet = _body(dynderive.render_latex(derivation))
    assert not LONG_RUN.search(sheet), LONG_RUN.search(sheet)
    assert not SCALED_SUM.search(sheet), sheet[SCALED_SUM.search(sheet).start() - 80:][:200]
    assert "Numbers are shown to 6 significant digits (the file writes up to 17" in sheet
    page = html.unescape(render_html(derivation))
    numbers = " ".join(re.findall(r"<mn>([^<]*)</mn>", page))
    assert numbers and not LONG_RUN.search(numbers)
    assert "shown to 6 significant digits" in page
    printed = render_terminal(derivation)
    assert printed and not LONG_RUN.search(printed)


def _latex_value(text: str, values: dict[str, float]) -> float:
    """A sheet entry's LaTeX, parsed back by SymPy (``\\dot{q}_{k}`` read as a symbol first)."""
    from sympy.parsing.latex import parse_latex

    text = re.sub(r"\\dot\{([A-Za-z]+)\}_\{(\d+)\}", r"\1dot_{\2}", text)
    expr = parse_latex(text)
    return float(expr.subs({s: values[str(s)] for s in expr.free_symbols}))


@pytest.mark.parametrize("case", [("planar", 5), ("spatial", 2)], ids=lambda c: f"{c[0]}{c[1]}")
def test_mass_matrix_reads_back_to_the_printed_digits(cad_robots, case):
    """Each entry of M as the sheet prints it, parsed back from its LaTeX, equals the module's
    M at a random state to the printed precision (6 digits: a few 1e-6 of M's scale), and to
    1e-11 with every digit shown (``--digits 17``): the numbers are the module's, rounded."""
    pytest.importorskip("antlr4")
    derivation = cad_robots[case]
    module = generated_module(dynderive.render_code(derivation), derivation.robot.name)
    table = derivation.symbols
    rng = np.random.default_rng(5)
    q = rng.uniform(-1.5, 1.5, len(table.q))
    values = {f"q_{{{k + 1}}}": float(x) for k, x in enumerate(q)}
    M = module.mass_matrix(q)
    symbolic = derivation.quantities["M_g"]
    for name, value in reversed(derivation.intermediates):   # the sheet's w_k lines, substituted
        symbolic = symbolic.xreplace({name: value})
    for digits, tolerance in ((None, 2e-5), (17, 1e-11)):
        fmt = Formatter(derivation, digits=digits)
        worst = 0.0
        for i, j in sorted({(0, k) for k in range(M.shape[0])} | {(k, k) for k in range(M.shape[0])}):
            text = re.sub(r"\\mathrm\{([^}]*)\}", r"\1", str(fmt(symbolic[i, j])))   # a row and the diagonal
            worst = max(worst, abs(_latex_value(text, values) - M[i, j]))
        assert worst <= tolerance * np.max(np.abs(M)), (digits, worst)


@pytest.mark.parametrize("case", [("planar", 5), ("spatial", 2)], ids=lambda c: f"{c[0]}{c[1]}")
def test_mass_matrix_mathml_reads_back_to_the_printed_digits(cad_robots, case):
    """The HTML page's M entries (MathML), evaluated back, equal the module's M to the printed
    digits (and to 1e-11 with every digit shown)."""
    from dynderive.render.sheets.html_math import MathFormatter
    from test_html import _symbols, _value

    derivation = cad_robots[case]
    module = generated_module(dynderive.render_code(derivation), derivation.robot.name)
    rng = np.random.default_rng(6)
    q = rng.uniform(-1.5, 1.5, len(derivation.symbols.q))
    names, values = _symbols(derivation, q, np.zeros_like(q), np.zeros_like(q))
    M = module.mass_matrix(q)
    symbolic = derivation.quantities["M_g"]
    for name, value in reversed(derivation.intermediates):
        symbolic = symbolic.xreplace({name: value})
    for digits, tolerance in ((None, 2e-5), (17, 1e-11)):
        fmt = MathFormatter(derivation, digits)
        worst = max(abs(float(_value(str(fmt(symbolic[i, j])), names, values)) - M[i, j])
                    for i in range(M.shape[0]) for j in range(i, M.shape[1]))
        assert worst <= tolerance * np.max(np.abs(M)), (digits, worst)


@pytest.mark.pdf
@pytest.mark.parametrize("robot", ["chain4", "four_bar"])
def test_cad_sheet_pages_within_a_fifth_of_the_round_sheet(robot, tex, tmp_path):  # noqa: F811
    """The 4-joint chain and the four-bar of ``benchmarks/cad_numbers.py``, with round numbers
    and with 17-digit CAD numbers (the same robot moved by up to 1 %): the CAD sheet's PDF has
    at most 20 % more pages than the round one's."""
    from cad_numbers import planar_chain_yaml, yaml_numbers

    from dynderive.render.sheets.pdf import compile_pdf_report

    if robot == "chain4":
        texts = {"round": planar_chain_yaml(4, round_numbers=True), "CAD": planar_chain_yaml(4)}
    else:
        shipped = (ROOT / "robots" / "four_bar.yaml").read_text()
        texts = {"round": yaml_numbers(shipped, False, 1), "CAD": yaml_numbers(shipped, True, 1)}
    pages = {}
    for variant, text in texts.items():
        derivation = _derive(text, tmp_path, f"{robot}_{variant}")
        _, pages[variant], _ = compile_pdf_report(dynderive.render_latex(derivation), f"{robot}_{variant}")
    assert pages["CAD"] <= 1.2 * pages["round"], pages


def test_small_terms_are_shown_not_rounded_away():
    """A coefficient far below the others prints with its power of ten, never as 0: the sheet
    drops only what is zero in exact arithmetic."""
    import sympy

    from dynderive.render.numbers import Numbers
    from dynderive.render.printers import SheetLatexPrinter

    x, y = sympy.symbols("x y")
    tiny = sympy.Rational(123456789, 10**25)   # 1.23456789e-17
    text = SheetLatexPrinter({}, Numbers(6)).doprint(sympy.Rational(7, 10) * x + tiny * y)
    assert r"1.23457 \cdot 10^{-17} y" in text and "0.7 x" in text
