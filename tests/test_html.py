"""The HTML sheet (``--html``): a self-contained page with the sheet's sections,
MathML equations, the drawing as inline SVG, robot-file text escaped; loaded in a real
browser (Debian's ``chromium`` headless: skipped locally without it, required in CI).

Floating-base robots: one self-contained page with the floating LaTeX sheet's content in
MathML. A free body's page (its M and equations of motion read back from the MathML and
evaluated) and a floating chain's program form (its lines evaluated in order) against the
generated NumPy module at random states; robot-file text escaped; the same bytes from another
process; loaded in a real browser.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from xml.dom import minidom

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.sheets.html import html_context, render_html
from dynderive.render.sheets.html_math import MathFormatter
from dynderive.render.sheets.html_quasi_velocity import quasi_velocity_html_context
from dynderive.render.targets.numpy.code import render_code
from test_sheets_compile import FREE, _chain

from conftest import ROBOTS, ROOT, derivation_of, import_code

runner = CliRunner()
ALL_ROBOTS = sorted(p.name for p in ROBOTS.iterdir() if p.suffix in (".yaml", ".urdf"))
#: Elements that are void in HTML (no end tag).
VOID = {"meta", "br", "hr", "img", "input", "link", "col", "area", "base", "wbr", "source", "track", "embed"}


class _Tags(HTMLParser):
    """Start tags, attributes and the nesting of a page: every element closed in order."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.stack: list[str] = []
        self.problems: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))

    def handle_endtag(self, tag: str) -> None:
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"</{tag}> closes {self.stack[-1:] or 'nothing'}")
        else:
            self.stack.pop()

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def parse(page: str) -> _Tags:
    tags = _Tags()
    tags.feed(page)
    tags.close()
    return tags


def test_page_is_self_contained_and_well_nested():
    page = render_html(derivation_of("rp_arm"))
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    names = {tag for tag, _ in tags.tags}
    assert {"math", "svg", "table", "figure"} <= names
    assert not names & {"script", "link", "img", "iframe", "object", "embed", "base", "form"}
    for tag, attrs in tags.tags:   # no script and nothing fetched: no handlers, no sources, no outside links
        assert not any(name.startswith("on") for name in attrs), (tag, attrs)
        assert "src" not in attrs, (tag, attrs)
        assert attrs.get("href", "#").startswith("#"), (tag, attrs)
        assert attrs.get("xmlns", "http://www.w3.org/2000/svg") == "http://www.w3.org/2000/svg"
    assert not re.search(r"url\(|@import|https?://(?!www\.w3\.org/2000/svg)", page)


def test_sections_quantities_and_checks_of_the_sheet():
    derivation = derivation_of("rp_arm")
    page = render_html(derivation)
    text = "".join(parse(page).text)
    for heading in ("The robot", "Generalized coordinates", "Lagrange's equations", "Manipulator form",
                    "Maximal coordinates", "Constraints", "Change of basis", "Checks"):
        assert f">{heading}<" in page, heading
    context = html_context(derivation)
    assert context["M_g"]["math"] in page and context["EOM_g2"]["math"] in page
    assert len(context["checks"]) == len(derivation.checks) > 0
    assert text.count("passed:") == sum(1 for c in derivation.checks if c.passed and c.method != "skipped")
    # the sheet's names: the rate of q1 is a dotted q with index 1, the link frame sL_1
    assert '<msub><mover accent="true"><mi>q</mi><mo>&#729;</mo></mover><mn>1</mn></msub>' in page
    # sections as asked: without "maximal", no maximal section
    assert ">Maximal coordinates<" not in render_html(derivation, sections=("generalized", "checks"))


def test_wide_matrices_entry_by_entry_as_on_the_sheet():
    from dynderive.render.sheets.latex import sheet_context

    derivation = derivation_of("double_pendulum")
    sections = ("generalized", "maximal", "checks")
    sheet, page = sheet_context(derivation, sections), html_context(derivation, sections)
    pairs = [(sheet[k], page[k]) for k in ("M_g", "C_g", "EOM_g1", "EOM_g2")]
    pairs += [(sheet["maximal"][k], page["maximal"][k])
              for k in ("A_m", "Adot_m", "M_m", "M_tilde", "EOM_g3")]
    for latex, html in pairs:
        assert (html["wide"], html["too_large"], len(html["entries"])) == (
            latex["wide"], latex["too_large"], len(latex["entries"]))
    assert page["EOM_g2"]["wide"] and not page["M_g"]["wide"]   # a wide one listed entry by entry
    shown = render_html(derivation, sections=sections)
    assert all(str(e["name"]) in shown and str(e["math"]) in shown for e in page["EOM_g2"]["entries"])


@pytest.mark.parametrize("robot", ALL_ROBOTS)
def test_every_bundled_page_is_escaped_markup_without_latex(robot):
    page = render_html(derivation_of(robot.rsplit(".", 1)[0]))
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    assert "\\" not in page and "<script" not in page   # no LaTeX leaked into the page (labels, names)
    assert page.count("<svg") == 1   # every bundled robot is drawn: planar, or a 3-D kinematic diagram


def test_deterministic_bytes():
    first = render_html(dynderive.derive(dynderive.load_robot("double_pendulum")))
    second = render_html(dynderive.derive(dynderive.load_robot("double_pendulum")))
    assert first == second


def test_drawings_are_svg_planar_and_3d():
    planar = render_html(derivation_of("double_pendulum"))
    svg = re.search(r"<svg .*?</svg>", planar, re.S).group(0)
    assert svg.count("<circle") >= 2 and "<path" in svg and "<text" in svg   # joints, links, labels
    assert ">q<" in svg or "italic\">q" in svg
    spatial = render_html(derivation_of("bennett"))
    svg = re.search(r"<svg .*?</svg>", spatial, re.S).group(0)
    assert svg.count("<path") > 20 and ">z<" in svg.replace('<tspan font-style="italic">', ">")   # axes, z_s
    assert "default assembly" in spatial and "azimuth 30" in spatial


HOSTILE = '<script>alert("x")</script> & \'quoted\' </math><b>'


def test_robot_text_is_escaped(tmp_path):
    source = (ROBOTS / "rp_arm.yaml").read_text()
    source = source.replace("title: Two-link RP arm (revolute + prismatic)", f"title: {json.dumps(HOSTILE)}")
    source = source.replace("description: mass of each link", f"description: {json.dumps(HOSTILE)}")
    source = source.replace("unit: kg", 'unit: "kg</td><script>"')
    path = tmp_path / "hostile.yaml"
    path.write_text(source)
    page = render_html(dynderive.derive(dynderive.load_robot(path)))
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    assert not any(tag in ("script", "b") for tag, _ in tags.tags)
    assert ("&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp; &#39;quoted&#39; "
            "&lt;/math&gt;&lt;b&gt;") in page
    assert "kg&lt;/td&gt;&lt;script&gt;" in page
    assert HOSTILE in "".join(tags.text)   # the reader sees the text as written


def test_too_large_quantities_follow_the_sheets_rules():
    derivation = derivation_of("rp_arm")
    fmt = MathFormatter.of(derivation)
    q1, q2 = derivation.symbols.q[:2]
    big = sum(sympy.sin(k * q1 + q2) * sympy.cos(q2 + k) for k in range(1, 60))
    matrix = fmt.matrix("M", sympy.Matrix([[big, 0], [0, 1]]))
    # an entry over ENTRY_NODES: shown entry by entry (scrolling sideways), not dropped
    assert not matrix["too_large"] and matrix["wide"] and matrix["math"] is None \
        and len(matrix["entries"]) == 2
    huge = sum(sympy.sin(k * q1 + q2) * sympy.cos(q2 + k) for k in range(1, 1500))
    assert fmt.matrix("M", sympy.Matrix([[huge]]))["too_large"]   # over BROKEN_NODES: left to the JSON
    assert fmt.maybe(big) is None and fmt.maybe(q1 + q2) is not None
    small = fmt.matrix("M", sympy.Matrix([[q1, 0], [0, q2]]))
    assert not small["too_large"] and not small["wide"] and small["zeros"] == 2


def test_template_override_is_escaped_and_sandboxed(tmp_path):
    folder = tmp_path / "templates" / "html"
    folder.mkdir(parents=True)
    (folder / "sheet.html.j2").write_text("<p>{{ robot.title }}</p>{{ M_g.math }}\n")
    source = (ROBOTS / "rp_arm.yaml").read_text().replace("title: Two-link RP arm (revolute + prismatic)",
                                                           'title: "<i>&"')
    path = tmp_path / "arm.yaml"
    path.write_text(source)
    page = render_html(dynderive.derive(dynderive.load_robot(path)), tmp_path / "templates")
    assert page.startswith("<p>&lt;i&gt;&amp;</p><mrow>")


def test_solve_and_build_write_and_check_html(tmp_path):
    out = tmp_path / "solve"
    result = runner.invoke(app, ["solve", "rp_arm", "--html", "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.html"]
    assert (out / "rp_arm.html").read_text() == render_html(derivation_of("rp_arm"))
    sections = runner.invoke(app, ["solve", "rp_arm", "--html", "--sections", "generalized", "--out",
                                   str(out), "-q"])
    assert sections.exit_code == 0 and ">Checks<" not in (out / "rp_arm.html").read_text()

    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    build = tmp_path / "build"
    built = runner.invoke(app, ["build", str(robots), "--out", str(build), "--html", "-j", "1"])
    assert built.exit_code == 0, built.output
    assert (build / "rp_arm.html").is_file()
    assert runner.invoke(app, ["build", str(robots), "--out", str(build), "--html", "--check", "-j",
                               "1"]).exit_code == 0
    (build / "rp_arm.html").write_text((build / "rp_arm.html").read_text().replace("Link 1", "Link one"))
    differs = runner.invoke(app, ["build", str(robots), "--out", str(build), "--html", "--check", "-j", "1"])
    assert differs.exit_code == 1 and "rp_arm.html: differs" in differs.output


# --- in a real browser ---------------------------------------------------------------------

#: Injected by the test into a copy of the page (the page itself has no script): writes the
#: laid-out size of every <math> element into the DOM, for --dump-dom to report.
PROBE = """<script>
const sizes = [...document.querySelectorAll("math")].map(m => {
  const r = m.getBoundingClientRect(); return [r.width, r.height]; });
const svg = [...document.querySelectorAll("svg")].map(s => {
  const r = s.getBoundingClientRect(); return [r.width, r.height]; });
const out = document.createElement("pre"); out.id = "probe-sizes";
out.textContent = JSON.stringify({math: sizes, svg: svg}); document.body.appendChild(out);
console.log("probe-done");
</script>"""


def _chromium() -> str:
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must check the HTML sheets in a browser, but chromium was not found")
        pytest.skip("chromium is not installed")
    return found


def sizes_in_chromium(page: str, tmp_path) -> dict:
    """Load ``page`` (with PROBE) in headless Chromium: no console message of its own, and
    the laid-out sizes of its ``<math>`` and ``<svg>`` elements (``{"math": [[w, h], ...], "svg": ...}``)."""
    chromium = _chromium()
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", PROBE + "</body>"), encoding="utf-8")
    run = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr",
                          "--v=0", "--window-size=1000,1400", f"--user-data-dir={tmp_path / 'profile'}",
                          "--dump-dom", probe.as_uri()], capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr[-2000:]
    console = [line for line in run.stderr.splitlines() if ":CONSOLE" in line]
    assert len(console) == 1 and '"probe-done"' in console[0], console   # the page's own: none
    found = re.search(r'<pre id="probe-sizes">(.*?)</pre>', run.stdout, re.S)
    assert found, run.stdout[-500:]
    sizes = json.loads(found.group(1).replace("&quot;", '"'))
    return sizes


@pytest.mark.parametrize("robot", ALL_ROBOTS)
def test_page_loads_in_chromium(robot, tmp_path):
    page = render_html(derivation_of(robot.rsplit(".", 1)[0]))
    assert "<script" not in page
    sizes = sizes_in_chromium(page, tmp_path)
    assert len(sizes["math"]) == page.count("<math") > 10
    empty = [k for k, (w, h) in enumerate(sizes["math"]) if not (w > 0 and h > 0)]
    assert empty == [], f"{len(empty)} <math> elements without size in {robot}"
    assert len(sizes["svg"]) == page.count("<svg") and all(w > 50 and h > 50 for w, h in sizes["svg"])


@pytest.mark.parametrize("robot", ["rp_arm", "four_bar"])
def test_page_does_not_depend_on_what_was_derived_before(robot):
    """The same bytes whether the page comes first or after the code (which derives the
    maximal model, and its multipliers' symbols, before the page's formatter exists)."""
    def fresh():
        return dynderive.derive(dynderive.load_robot(str(ROBOTS / f"{robot}.yaml")))

    first = render_html(fresh())
    after_code = fresh()
    dynderive.render_code(after_code)
    assert render_html(after_code) == first


# --- floating base: a free body's page and a floating chain's program form -----------------

#: The free body with hostile text where a robot file holds free text.
HOSTILE_FREE = (FREE.replace("title: A free rigid body", f"title: {json.dumps(HOSTILE)}")
                .replace("m: {value: 2.5, unit: kg}", f'm: {{value: 2.5, unit: "kg</td><script>", '
                                                      f"description: {json.dumps(HOSTILE)}}}"))


def _robot(folder: Path, text: str, name: str):
    path = folder / f"{name}.yaml"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(render_code(derivation), folder, f"{name}_floating_html")
    return path, derivation, render_html(derivation), module


@pytest.fixture(scope="module")
def free(tmp_path_factory):
    """(path, derivation, page, module) of the free body, hostile text included."""
    return _robot(tmp_path_factory.mktemp("free"), HOSTILE_FREE, "free")


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """A floating base and three scalar joints: the program form (``is_step_by_step`` False)."""
    return _robot(tmp_path_factory.mktemp("chain"), _chain(8, 3), "chain")


# --- MathML read back -------------------------------------------------------------------

_OPERATORS = {"+": "+", "\u2212": "-", "-": "-", "\u2062": "*", "\u00b7": "*", "(": "(", ")": ")", ",": ","}


def _key(node: minidom.Element) -> str:
    return node.toxml().encode("ascii", "xmlcharrefreplace").decode()


def _python(node: minidom.Element, names: dict[str, str]) -> str:
    """A MathML presentation tree (SymPy's printer's) as Python: names by ``names`` (element's
    XML -> variable), numbers, + - times, fractions, powers, sin/cos and matrices."""
    key = _key(node)
    if key in names:
        return names[key]
    kids = [c for c in node.childNodes if c.nodeType == c.ELEMENT_NODE]
    text = "".join(c.data for c in node.childNodes if c.nodeType == c.TEXT_NODE).strip()
    tag = node.tagName
    if tag == "mn":
        return "(" + text.replace("\u2212", "-") + ")"
    if tag == "mo":
        return _OPERATORS[text]
    if tag == "mi" and text in ("sin", "cos", "sqrt"):
        return text
    if tag == "mfrac":
        return f"(({_python(kids[0], names)})/({_python(kids[1], names)}))"
    if tag == "msup":
        return f"(({_python(kids[0], names)})**({_python(kids[1], names)}))"
    if tag == "msqrt":
        return f"sqrt({''.join(_python(k, names) for k in kids)})"
    if tag == "mtable":
        return "[" + ",".join("[" + ",".join(_python(td, names) for td in tr.getElementsByTagName("mtd"))
                              + "]" for tr in kids) + "]"
    if tag in ("mrow", "mtd", "math"):
        if any(k.tagName == "mtable" for k in kids):   # [ table ]
            return _python(next(k for k in kids if k.tagName == "mtable"), names)
        return "".join(_python(k, names) for k in kids)
    raise AssertionError(f"unexpected MathML {key[:200]}")


def _value(markup: str, names: dict[str, str], values: dict[str, float]) -> np.ndarray:
    node = minidom.parseString(f"<math>{markup}</math>").documentElement
    return np.array(eval(_python(node, names),   # noqa: S307
                         {"__builtins__": {}, "sin": math.sin, "cos": math.cos, "sqrt": math.sqrt}, values),
                    dtype=float)


def _symbols(derivation, q, v, a) -> tuple[dict[str, str], dict[str, float]]:
    """Names (each symbol's MathML -> a variable) and values: the state, parameter defaults,
    efforts zero."""
    table, robot = derivation.symbols, derivation.robot
    fmt = MathFormatter(derivation)
    values = ({str(table.parameters[p.name]): p.value for p in robot.parameters}
              | {str(u): 0.0 for u in table.efforts.values()})
    values |= {str(s): float(x) for s, x in [*zip(table.q, q), *zip(table.qd, v), *zip(table.qdd, a)]}
    names, variables = {}, {}
    for k, s in enumerate([*table.q, *table.qd, *table.qdd, *table.parameters.values(),
                           *table.efforts.values()]):
        names[_key(minidom.parseString(str(fmt(s))).documentElement)] = f"s{k}"
        variables[f"s{k}"] = values[str(s)]
    return names, variables


def _states(derivation, seed: int, count: int = 2):
    rng = np.random.default_rng(seed)
    nq, nv = len(derivation.symbols.q), len(derivation.symbols.qd)
    for _ in range(count):
        q = rng.normal(size=nq)
        q[3:7] /= np.linalg.norm(q[3:7])   # the root's quaternion
        yield q, rng.normal(size=nv), rng.normal(size=nv)


def _close(actual, expected, tolerance: float = 1e-11) -> None:
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tolerance * scale)


def _matrix(shown: dict, page: str, names: dict[str, str], values: dict[str, float], quantity) -> np.ndarray:
    """A matrix of the page, whole or entry by entry (``wide``: each entry at the place of the
    sheet's quantity's next nonzero entry, row by row)."""
    if not shown["wide"]:
        assert str(shown["math"]) in page
        return _value(str(shown["math"]), names, values).reshape(quantity.shape)
    places = [(i, j) for i in range(quantity.rows) for j in range(quantity.cols) if quantity[i, j] != 0]
    assert len(places) == len(shown["entries"]) > 0
    matrix = np.zeros(quantity.shape)
    for (i, j), entry in zip(places, shown["entries"]):
        assert f'<math display="block">{entry["name"]}<mo>=</mo>{entry["math"]}</math>' in page
        matrix[i, j] = _value(str(entry["math"]), names, values)
    return matrix


def test_floating_page_is_self_contained_and_well_nested(free):
    _, _, page, _ = free
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    names = {tag for tag, _ in tags.tags}
    assert {"math", "table", "mtable"} <= names
    assert not names & {"script", "link", "img", "iframe", "object", "embed", "base", "form", "b"}
    for tag, attrs in tags.tags:
        assert not any(name.startswith("on") for name in attrs) and "src" not in attrs, (tag, attrs)
    assert "\\" not in page and not re.search(r"url\(|@import|https?://", page)
    for heading in ("The robot", "Configuration and quasi-velocities", "Kinematics and energies",
                    "Equations of motion"):
        assert f">{heading}<" in page, heading
    assert "Kane's" in page and "Euler's equations in body" in page \
        and "intermediate-variable form" not in page


def test_floating_robot_text_is_escaped(free):
    _, _, page, _ = free
    tags = parse(page)
    # <title>, <h1>, the description
    assert page.count("&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp; &#39;quoted&#39; "
                      "&lt;/math&gt;&lt;b&gt;") == 3
    assert "kg&lt;/td&gt;&lt;script&gt;" in page   # the unit
    assert HOSTILE in "".join(tags.text)


def test_free_body_mathml_agrees_with_the_module(free):
    """M and the equations of motion (EOM = M vdot + C v + N, no efforts) read from the page's
    MathML equal the module's mass matrix and inverse dynamics; so do N and C v."""
    _, derivation, page, module = free
    context, sheet = quasi_velocity_html_context(derivation), derivation.quasi_velocity_steps.sheet
    assert not context["M"]["wide"] and context["EOM"]["wide"]   # both forms read
    for q, v, a in _states(derivation, 1):
        names, values = _symbols(derivation, q, v, a)
        _close(_matrix(context["M"], page, names, values, sheet.M), module.mass_matrix(q))
        _close(_matrix(context["EOM"], page, names, values, sheet.EOM).ravel(),
               module.inverse_dynamics(q, v, a))
        _close(_matrix(context["N"], page, names, values, sheet.N).ravel(), module.gravity_vector(q))
        _close(_matrix(context["Cv"], page, names, values, sheet.Cv).ravel(),
               module.inverse_dynamics(q, v, 0 * a) - module.gravity_vector(q))
    # the floating names: q_w, omega_x, a dotted v_x
    assert "<msub><mi>q</mi><mi>w</mi></msub>" in page and "<msub><mi>&#969;</mi><mi>x</mi></msub>" in page
    assert '<msub><mover accent="true"><mi>v</mi><mo>&#729;</mo></mover><mi>x</mi></msub>' in page


def test_damping_is_on_the_page_and_in_the_equations(tmp_path):
    """A damped joint: F read back from the page equals the module's ``friction_forces``, the
    EOM (which holds it) its inverse dynamics, and both equations name F."""
    text = _chain(11, 1).replace("rest: 0.3}", "rest: 0.3, damping: 0.1712345678901234}")
    _, derivation, _, module = _robot(tmp_path, text, "damped")
    # every digit shown (--digits 17): the page's numbers read back to the module's rounding
    page = render_html(derivation, digits=17)
    context, sheet = quasi_velocity_html_context(derivation, 17), derivation.quasi_velocity_steps.sheet
    assert context["F"] is not None and "<mo>+</mo><mi>N</mi><mo>+</mo><mi>F</mi>" in page
    for q, v, a in _states(derivation, 2):
        names, values = _symbols(derivation, q, v, a)
        _close(_value(str(context["F"]), names, values).ravel(), module.friction_forces(v))
        assert np.count_nonzero(module.friction_forces(v)) == 1
        _close(_matrix(context["EOM"], page, names, values, sheet.EOM).ravel(),
               module.inverse_dynamics(q, v, a))


def test_same_bytes_from_another_process(free, tmp_path):
    """``solve --html`` in a process with another hash seed writes the page rendered here."""
    path, derivation, page, _ = free
    out = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), "--html", "--out", str(out), "-q"],
                   check=True, env=os.environ | {"PYTHONHASHSEED": "7", "PYTHONPATH": str(ROOT / "src")})
    assert sorted(p.name for p in out.iterdir()) == ["free_body.html"]
    assert (out / "free_body.html").read_text(encoding="utf-8") == page
    assert render_html(derivation) == page   # and again in this one


def test_large_robot_as_the_programs_lines(chain):
    """The program form: every line shown once, named w_k; evaluated in order from the
    page's MathML, its tau, M and N equal the module's."""
    _, derivation, _, module = chain
    page = render_html(derivation, digits=17)   # every digit shown: the lines evaluate to the module's rounding
    assert derivation.quasi_velocity_steps.sheet is None
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    assert "intermediate-variable form" in page and "Kane's" not in page
    context = quasi_velocity_html_context(derivation, 17)
    lines = [line for group in context["groups"] for line in group["lines"]]
    assert len(lines) == context["line_count"] > 50 and f"In all, {len(lines)} lines." in page
    assert [g["key"] for g in context["groups"]] == ["shared", "tau", "M", "N"]
    nv = len(derivation.symbols.qd)
    for q, v, a in _states(derivation, 2):
        names, values = _symbols(derivation, q, v, a)
        for k, line in enumerate(lines):
            shown = str(line["name"]) + "<mo>=</mo>" + str(line["math"])
            assert shown in page
            names[_key(minidom.parseString(str(line["name"])).documentElement)] = f"w{k}"
            values[f"w{k}"] = float(_value(str(line["math"]), names, values))
        tau = [float(_value(str(t["math"]), names, values)) for t in context["tau"]]
        _close(tau, module.inverse_dynamics(q, v, a), 1e-10)
        _close([float(_value(str(n["math"]), names, values)) for n in context["N"]], module.gravity_vector(q),
               1e-10)
        M = module.mass_matrix(q)
        upper = [M[i, j] for i in range(nv) for j in range(i, nv) if M[i, j] != 0]
        _close([float(_value(str(m["math"]), names, values)) for m in context["M"]], upper, 1e-10)
    assert 'mathvariant="sans-serif"' in page   # the lines' names, as the LaTeX sheet's \mathsf{w}_k


def test_build_writes_the_page_and_the_refusal_is_gone(free, tmp_path):
    path, _, page, _ = free
    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "free.yaml").write_text(path.read_text())
    result = runner.invoke(app, ["build", str(folder), "--out", str(tmp_path / "b"), "-j", "1", "--html"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "b" / "free_body.html").read_text(encoding="utf-8") == page
    checked = runner.invoke(app, ["build", str(folder), "--out", str(tmp_path / "b"), "-j", "1", "--html",
                                  "--check"])
    assert checked.exit_code == 0, checked.output
    from dynderive.commands.solve import form_note

    built, _, missing = form_note(dynderive.load_robot(path)).partition("except")
    assert "every output is built" in built and "--html" not in missing and "HTML" not in missing


@pytest.mark.parametrize("which", ["free", "chain"])
def test_floating_page_loads_in_chromium(which, request, tmp_path):
    page = request.getfixturevalue(which)[2]
    sizes = sizes_in_chromium(page, tmp_path)
    assert len(sizes["math"]) == page.count("<math") > 10
    empty = [k for k, (w, h) in enumerate(sizes["math"]) if not (w > 0 and h > 0)]
    assert empty == [], f"{len(empty)} <math> elements without size"
