"""The HTML sheet (``--html``, issue 32): a self-contained page with the sheet's sections,
MathML equations, the drawing as inline SVG, robot-file text escaped; loaded in a real
browser (Debian's ``chromium`` headless: skipped locally without it, required in CI).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser

import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.sheets.html import html_context, render_html
from dynderive.render.sheets.html_math import MathFormatter

from conftest import ROBOTS, derivation_of

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
    pairs += [(sheet["maximal"][k], page["maximal"][k]) for k in ("A_m", "Adot_m", "M_m", "M_tilde", "EOM_g3")]
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
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp; &#39;quoted&#39; &lt;/math&gt;&lt;b&gt;" in page
    assert "kg&lt;/td&gt;&lt;script&gt;" in page
    assert HOSTILE in "".join(tags.text)   # the reader sees the text as written


def test_too_large_quantities_follow_the_sheets_rules():
    derivation = derivation_of("rp_arm")
    fmt = MathFormatter.of(derivation)
    q1, q2 = derivation.symbols.q[:2]
    big = sum(sympy.sin(k * q1 + q2) * sympy.cos(q2 + k) for k in range(1, 60))
    matrix = fmt.matrix("M", sympy.Matrix([[big, 0], [0, 1]]))
    # an entry over ENTRY_NODES: shown entry by entry (scrolling sideways), not dropped
    assert not matrix["too_large"] and matrix["wide"] and matrix["math"] is None and len(matrix["entries"]) == 2
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
    sections = runner.invoke(app, ["solve", "rp_arm", "--html", "--sections", "generalized", "--out", str(out), "-q"])
    assert sections.exit_code == 0 and ">Checks<" not in (out / "rp_arm.html").read_text()

    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    build = tmp_path / "build"
    built = runner.invoke(app, ["build", str(robots), "--out", str(build), "--html", "-j", "1"])
    assert built.exit_code == 0, built.output
    assert (build / "rp_arm.html").is_file()
    assert runner.invoke(app, ["build", str(robots), "--out", str(build), "--html", "--check", "-j", "1"]).exit_code == 0
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
    run = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
                          "--window-size=1000,1400", f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
                          probe.as_uri()], capture_output=True, text=True, timeout=180)
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
