"""The centre of mass and the centroidal momentum on the sheets, in the JSON and in ``check``.

The sheet of a 3-D robot has the section "Centre of mass and centroidal momentum": a small
robot's steps (each link's centre of mass and world Jacobians, p_G, J_G, A_G column by column;
with a floating root in its joint's frame, then rotated), a large one's pointer to the
generated functions; both compile. The JSON's m_total, p_G, J_G, A_G equal the NumPy module's
total_mass, center_of_mass, center_of_mass_jacobian and centroidal_momentum_matrix at random
states (unit quaternions) and the defaults. ``dynderive check`` prints the centroidal rows
(the links' momenta summed link by link, central differences, Pinocchio) and they pass; a
module whose A_G has one row's sign flipped, or whose CoM Jacobian is off, fails them.
Planar robots have none of it.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.render.sheets.html import render_html
from dynderive.render.sheets.json import render_json
from dynderive.render.sheets.latex import render_latex
from dynderive.render.sheets.pdf import tikz_available
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify import checks
from dynderive.verify.centroidal_checks import DIFFERENCES, MOMENTA, PINOCCHIO

from conftest import ROBOTS, import_code

runner = CliRunner()
ROOT = Path(__file__).resolve().parent
FLOATING_ELBOW = ROOT / "floating_elbow.urdf"
SECTION = r"\section{Centre of mass and centroidal momentum}"
NAMES = ("m_total", "p_G", "J_G", "A_G")

#: A free body and a floating chain with one revolute joint: small robots, step by step.
FREE = """name: free_body
title: A free rigid body
planar: false
parameters:
  m: {value: 2.5, unit: kg}
  cx: 0.01
  cy: -0.02
  cz: 0.1
  g: 9.81
gravity: [0, 0, -g]
links:
  - {name: body, mass: m, com: [cx, cy, cz], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
joints:
  - {name: root, type: floating, parent: world, child: body}
"""
FLOATING_ARM = """name: floating_arm
title: A floating base with one arm
planar: false
parameters:
  g: 9.81
gravity: [0.1, -0.2, -g]
links:
  - {name: base, mass: 3.1, com: [0.05, -0.02, 0.01], inertia: [0.05, 0.06, 0.07, 0.001, -0.002, 0.003]}
  - {name: arm, mass: 0.9, com: [0.2, 0.01, -0.03], inertia: [0.01, 0.02, 0.015, 0.0005, 0.0, -0.001]}
joints:
  - {name: root, type: floating, parent: world, child: base}
  - {name: q1, type: revolute, parent: base, child: arm, origin: {xyz: [0.1, 0.05, 0.2], rpy: [0.3, -0.2, 0.1]},
     axis: [0.2, 0.9, 0.4], effort: u1}
"""


def _robot(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


def _derivation(source):
    return dynderive.derive(dynderive.load_robot(source))


@pytest.fixture
def tex():
    missing = [t for t in ("latexmk", "pdflatex") if shutil.which(t) is None]
    if not missing and not tikz_available():
        missing = ["TikZ (texlive-pictures)"]
    if missing:
        if os.environ.get("CI"):
            raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
        pytest.skip(f"no TeX engine ({', '.join(missing)} missing)")


# ---- the sheets -----------------------------------------------------------------------------

@pytest.mark.parametrize(("which", "steps"), [("elbow_arm", True), ("floating_elbow", False), ("free", True),
                                             ("floating_arm", True)])
def test_sheet_shows_the_section_and_compiles(which, steps, tex, tmp_path):
    source = {"elbow_arm": "elbow_arm", "floating_elbow": str(FLOATING_ELBOW),
              "free": str(_robot(tmp_path, FREE, "free")),
              "floating_arm": str(_robot(tmp_path, FLOATING_ARM, "arm"))}[which]
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", source, "--latex", "--pdf", "--html", "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output + result.stderr
    name = dynderive.load_robot(source).name
    sheet = (out / f"{name}.tex").read_text()
    assert (out / f"{name}.pdf").read_bytes().startswith(b"%PDF")
    assert sheet.count(SECTION) == 1
    section = sheet[sheet.index(SECTION):]
    html = (out / f"{name}.html").read_text()
    assert html.count('<section id="centroidal">') == 1
    if steps:   # each link's centre of mass and Jacobians, p_G, J_G, A_G column by column
        derivation = _derivation(source)
        links = derivation.centroidal_steps.links
        for part in links:
            assert rf"\paragraph{{Link {part.index} (" in section
        assert section.count(r"\paragraph{Column ") == len(derivation.symbols.qd)
        floating = derivation.robot.floating
        assert (r"\bar{p}_{G} = " if floating else r"\[ p_{G} = ") in section
        assert ("p_G = p_B + R_B" in section) == floating
        assert "run to pages" not in section
    else:
        assert "the generated module computes them" in section and r"\paragraph{Column" not in section


def test_planar_robots_have_no_section():
    derivation = _derivation("rp_arm")
    assert derivation.centroidal_steps is None and "A_G" not in derivation.keys()
    assert SECTION not in render_latex(derivation) and 'id="centroidal"' not in render_html(derivation)


def test_large_robots_derive_nothing_symbolic():
    assert _derivation("spatial_four_bar").centroidal_steps is None   # loops: the tree's A_G, in the code
    derivation = _derivation(str(FLOATING_ELBOW))
    assert derivation.centroidal_steps is None
    assert not set(NAMES) & set(json.loads(render_json(derivation))["quantities"])


def test_sheet_is_the_same_bytes_each_run(tmp_path):
    path = _robot(tmp_path, FLOATING_ARM, "arm")
    first = render_latex(_derivation(path))
    assert render_latex(_derivation(path)) == first and SECTION in first


# ---- the JSON against the module ----------------------------------------------------------

def _states(derivation, rng, count=3):
    robot = derivation.robot
    for _ in range(count):
        q = rng.uniform(-1.5, 1.5, len(robot.configuration_names))
        for start in robot.quaternion_starts:
            q[start:start + 4] = rng.normal(size=4)
            q[start:start + 4] /= np.linalg.norm(q[start:start + 4])
        yield q


@pytest.mark.parametrize("which", ["elbow_arm", "free", "floating_arm"])
def test_json_quantities_equal_the_module(which, tmp_path):
    source = {"elbow_arm": "elbow_arm", "free": _robot(tmp_path, FREE, "free"),
              "floating_arm": _robot(tmp_path, FLOATING_ARM, "arm")}[which]
    derivation = _derivation(source)
    document = json.loads(render_json(derivation))
    quantities = document["quantities"]
    assert set(NAMES) <= set(quantities)
    nv = len(derivation.symbols.qd)
    assert [quantities[k]["shape"] for k in NAMES] == [[1, 1], [3, 1], [3, nv], [6, nv]]
    assert all(quantities[k]["description"] and quantities[k]["latex"] for k in NAMES)
    table = derivation.symbols
    defaults = table.defaults(derivation.robot)
    values = {k: sympy.sympify(quantities[k]["sympy"], locals=table.locals()) for k in NAMES}
    functions = {k: sympy.lambdify([table.q], sympy.sympify(v).xreplace(defaults), modules="numpy")
                 for k, v in values.items()}
    module = import_code(render_code(derivation), tmp_path)
    for q in _states(derivation, np.random.default_rng(3)):
        got = {k: np.array(f(q), dtype=float) for k, f in functions.items()}
        np.testing.assert_allclose(got["m_total"], module.total_mass(), rtol=1e-12)
        np.testing.assert_allclose(got["p_G"].ravel(), module.center_of_mass(q), atol=1e-12)
        np.testing.assert_allclose(got["J_G"], module.center_of_mass_jacobian(q), atol=1e-12)
        np.testing.assert_allclose(got["A_G"], module.centroidal_momentum_matrix(q), atol=1e-12)


def test_a_frame_may_not_be_named_g_on_a_3d_robot(tmp_path):
    text = (ROBOTS / "elbow_arm.yaml").read_text().replace("- name: wrist", "- name: G")
    with pytest.raises(InputError, match="p_G"):
        dynderive.load_robot(_robot(tmp_path, text, "framed"))


# ---- check ------------------------------------------------------------------------------------

def _centroidal_rows(output: str) -> dict[str, str]:
    """The centroidal rows of ``check``'s table: name -> status."""
    rows = {}
    for name in (MOMENTA, DIFFERENCES.format(along="integrate"), DIFFERENCES.format(along="q"), PINOCCHIO):
        for line in output.splitlines():
            if line.startswith(name):
                rows[name] = line[len(name):].split()[0]
    return rows


@pytest.mark.parametrize("which", ["elbow_arm", "floating_elbow", "floating_arm"])
def test_check_prints_the_rows_and_they_pass(which, tmp_path):
    source = {"elbow_arm": "elbow_arm", "floating_elbow": str(FLOATING_ELBOW),
              "floating_arm": str(_robot(tmp_path, FLOATING_ARM, "arm"))}[which]
    result = runner.invoke(app, ["check", source, "-q"])
    assert result.exit_code == 0, result.output
    rows = _centroidal_rows(result.stdout)
    expected = 3 if importlib_pinocchio() else 2
    assert len(rows) == expected and set(rows.values()) == {"pass"}, rows
    along = "q" if which == "elbow_arm" else "integrate"
    assert DIFFERENCES.format(along=along) in rows


def importlib_pinocchio() -> bool:
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return False
    return True


def test_planar_check_has_no_centroidal_rows():
    result = runner.invoke(app, ["check", "rp_arm", "-q"])
    assert result.exit_code == 0 and "centroidal" not in result.stdout


def _wrong(monkeypatch, attribute: str, change):
    """``check``'s generated module with ``attribute`` replaced by ``change(original)``."""
    original = checks.generated_module

    def broken(source: str, name: str):
        module = original(source, name)
        setattr(module, attribute, change(getattr(module, attribute)))
        return module

    monkeypatch.setattr(checks, "generated_module", broken)


@pytest.mark.parametrize("which", ["elbow_arm", "floating_arm"])
def test_a_flipped_row_of_a_g_fails(which, monkeypatch, tmp_path):
    source = {"elbow_arm": "elbow_arm", "floating_arm": _robot(tmp_path, FLOATING_ARM, "arm")}[which]
    derivation = _derivation(source)
    flip = np.ones((6, 1))
    flip[4] = -1.0   # the angular momentum's y row
    _wrong(monkeypatch, "centroidal_momentum_matrix", lambda f: lambda q, **p: f(q, **p) * flip)
    rows = {row.name: row.status for row in checks.run_checks(derivation, render_code(derivation), states=4)}
    assert rows[MOMENTA] == "FAIL"
    if importlib_pinocchio():
        assert rows[PINOCCHIO] == "FAIL"


def test_a_wrong_com_jacobian_fails(monkeypatch):
    derivation = _derivation("elbow_arm")
    _wrong(monkeypatch, "center_of_mass_jacobian", lambda f: lambda q, **p: f(q, **p) * 1.01)
    rows = {row.name: row.status for row in checks.run_checks(derivation, render_code(derivation), states=4)}
    assert rows[DIFFERENCES.format(along="q")] == "FAIL" and rows[MOMENTA] == "pass"
