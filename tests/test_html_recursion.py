"""A large robot's HTML page states the recursion as the LaTeX sheet does (issue 32): the
kinematic data, the recursion in symbols and line by line, each line named by meaning and
link in MathML, instead of hundreds of intermediates ``w_k``; names from the robot file
escaped; the page loads in a real browser (skipped locally without chromium, required in CI).
"""

from __future__ import annotations

import re
from xml.dom import minidom

import pytest

import dynderive
from dynderive.render.sheets.html import html_context, render_html
from dynderive.render.sheets.html_recursion import MATH_NAMES, meaning_markup
from dynderive.render.sheets.latex import sheet_context
from dynderive.render.sheets.latex_format import Formatter
from dynderive.render.sheets.recursion import NAMES
from test_html import parse, sizes_in_chromium

from conftest import ROBOTS, derivation_of

#: MathML of names the Panda's recursion must define (LaTeX: \omega_{3x}, \dot\omega_{3z},
#: \bar\omega_{3x}, F_{7x}, n_{6z}, I^c_{6,xx}, n^{(7)}_{7x}).
OMEGA_3X = '<msub><mi>&#969;</mi><mrow><mn>3</mn><mi>x</mi></mrow></msub>'
NAMED = [
    OMEGA_3X,
    '<msub><mover accent="true"><mi>&#969;</mi><mo>&#729;</mo></mover><mrow><mn>3</mn><mi>z</mi></mrow></msub>',
    '<msub><mover accent="true"><mi>&#969;</mi><mo>&#175;</mo></mover><mrow><mn>3</mn><mi>x</mi></mrow></msub>',
    '<msub><mi>F</mi><mrow><mn>7</mn><mi>x</mi></mrow></msub>',
    '<msub><mi>n</mi><mrow><mn>6</mn><mi>z</mi></mrow></msub>',
    '<msubsup><mi>I</mi><mrow><mn>6</mn><mo>,</mo><mi>x</mi><mi>x</mi></mrow><mi>c</mi></msubsup>',
    '<msubsup><mi>n</mi><mrow><mn>7</mn><mi>x</mi></mrow><mrow><mo>(</mo><mn>7</mn><mo>)</mo></mrow></msubsup>',
]


@pytest.mark.parametrize("robot", ["panda", "ur5"])
def test_large_page_states_the_recursion_not_intermediates(robot):
    derivation = derivation_of(robot)
    assert len(derivation.intermediates) > 300   # what the page listed before: w_1 ... w_858 for the Panda
    page = render_html(derivation)
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    assert 'mathvariant="sans-serif"' not in page and ">Intermediate variables<" not in page   # no w_k
    for heading in ("Kinematic data", "The recursion", "The recursion for this robot", "Forward pass",
                    "Backward pass", "Composite bodies", "Columns of the mass matrix", "Equations of motion"):
        assert f">{heading}<" in page, heading
    context = html_context(derivation)["recursion"]
    latex = sheet_context(derivation)["recursion"]
    # the LaTeX sheet's lines and blocks, in MathML: as many, with the same links and columns
    assert context["lines"] == latex["lines"] > 100
    for part in ("forward", "backward", "composite", "columns"):
        assert [len(b["lines"]) for b in context[part]] == [len(b["lines"]) for b in latex[part]]
        assert [b["index"] for b in context[part]] == [int(re.search(r"\d+", b["title"]).group()) for b in latex[part]]
    names = [str(line["name"]) for part in ("forward", "backward", "composite", "columns")
             for b in context[part] for line in b["lines"] if line["name"] is not None]
    assert len(names) == len(set(names))   # each name defined once
    assert all(str(line["math"]) in page for b in context["forward"] for line in b["lines"])
    assert [row["name"] for row in context["links"]] == [link.name for link in derivation.robot.links]
    if robot == "panda":
        # defined by a line, or shown as it is beside others (the LaTeX test's names)
        shown = " ".join(str(line["name"]) + str(line["math"]) for part in ("forward", "backward", "composite", "columns")
                         for b in context[part] for line in b["lines"])
        assert all(name in shown for name in NAMED), [name for name in NAMED if name not in shown]
        assert "<code>panda_link3</code>" in page and str(context["M_g"]["label"]) in page


def test_every_quantity_has_a_mathml_name():
    assert MATH_NAMES.keys() == NAMES.keys()
    for quantity in MATH_NAMES:
        for primes in (0, 2):
            text = meaning_markup(quantity, {"i": 3, "j": 4, "k": 2, "c": "xy"}, primes)
            element = minidom.parseString(str(text)).documentElement   # well-formed XML, one element
            assert element.tagName in ("msub", "msubsup", "msup"), quantity
            assert ("\u2032\u2032" in element.toxml()) == (primes == 2) and str(text).isascii()


HOSTILE = '<script>alert("x")</script> & \'quoted\' </math><b>'


@pytest.fixture(scope="module")
def hostile_panda(tmp_path_factory):
    """The Panda with a hostile robot name (its title), link and joint name."""
    attribute = HOSTILE.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
    source = (ROBOTS / "panda.urdf").read_text()
    assert source.count('"panda_link3"') == 3 and source.count('"panda_joint3"') == 1
    source = source.replace('<robot name="panda">', f'<robot name="{attribute}">')
    source = source.replace('"panda_link3"', f'"{attribute}3"').replace('"panda_joint3"', f'"j{attribute}"')
    path = tmp_path_factory.mktemp("hostile") / "hostile.urdf"
    path.write_text(source)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert derivation.intermediate_form
    return derivation, render_html(derivation)


def test_robot_file_names_are_escaped(hostile_panda):
    derivation, page = hostile_panda
    tags = parse(page)
    assert tags.problems == [] and tags.stack == []
    assert not any(tag in ("script", "b") for tag, _ in tags.tags)
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp; &#39;quoted&#39; &lt;/math&gt;&lt;b&gt;" in page
    text = "".join(tags.text)
    assert HOSTILE in text   # the title as written
    link = derivation.robot.links[2].name   # as the URDF reader kept it
    assert link != "panda_link3" and f"Link 3 ({link})" in text
    assert derivation.robot.parent_joint(link).name in text


def test_hostile_page_loads_in_chromium(hostile_panda, tmp_path):
    _, page = hostile_panda
    sizes = sizes_in_chromium(page, tmp_path)
    assert len(sizes["math"]) == page.count("<math") > 500
    empty = [k for k, (w, h) in enumerate(sizes["math"]) if not (w > 0 and h > 0)]
    assert empty == [], f"{len(empty)} <math> elements without size"


def test_layout_does_not_depend_on_the_sheet_made_before():
    """The formatters are shared per derivation: a width estimate at the precision of whichever
    sheet was made last (an exact JSON formatter, a ``--digits 3`` sheet) once changed how the
    Panda's recursion grouped its lines (493 against 491 in one run)."""
    derivation = derivation_of("panda")
    first = sheet_context(derivation)["recursion"]
    page = html_context(derivation)["recursion"]["lines"]
    Formatter.of(derivation, exact=True)
    sheet_context(derivation, digits=3)
    render_html(derivation, digits=3)
    again = sheet_context(derivation)["recursion"]
    assert again["lines"] == first["lines"] == page == html_context(derivation)["recursion"]["lines"]
    assert [line["value"] for b in again["forward"] for line in b["lines"]] == \
        [line["value"] for b in first["forward"] for line in b["lines"]]
