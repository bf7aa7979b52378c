"""The HTML sheet: the LaTeX sheet's sections and quantities as one self-contained page.

Equations are MathML (``html_math``), the drawing of a planar robot inline SVG
(``html_svg``, the TikZ picture's geometry), the style an inline ``<style>``: no script,
no network, no external file. The quantities, the sections and the size rules (what is
too large to typeset) are the sheet's: the derivation's quantities, the sheet's
``default_sections`` and the LaTeX ``Formatter``'s limits. Text from the robot file reaches
the page only through the HTML environment's autoescaping.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import sympy
from markupsafe import Markup

from ...derivation import Derivation
from ..environment import render
from .centroidal import HtmlNames
from .figure import sheet_figure
from .html_math import (
    MathFormatter,
    accent,
    body_jacobian,
    fenced,
    link_frame,
    mi,
    mrow,
    name_markup,
    page_header,
    sub,
)
from .html_quasi_velocity import quasi_velocity_html_context
from .html_recursion import html_recursion
from .html_svg import configuration_text, figure_labels, svg_figure
from .latex import SheetStyle, joint_rows, shared_context
from .latex_format import ENTRY_NODES, INLINE_NODES, SCALAR_NODES, Formatter, _groups

HTML_TEMPLATE = "html/sheet.html.j2"


def _upright(text: str) -> Markup:
    return mi(text, normal=True)


def html_context(derivation: Derivation, sections: tuple[str, ...] | None = None,
                 digits: int | None = None) -> dict[str, Any]:
    """Every variable the HTML template uses; only the ``sections`` asked for (default the
    sheet's ``default_sections``); numbers to ``digits`` at most (``--digits``)."""
    fmt = MathFormatter.of(derivation, digits=digits)
    style = PageStyle(derivation, fmt)
    shared = shared_context(derivation, style, sections)
    robot = derivation.robot
    gen = derivation.generalized_steps

    links = []
    for t in gen["links"]:
        k = t.index
        links.append({
            "index": k, "name": t.name, "mass": fmt(t.mass), "inertia": fmt(t.inertia),
            "spatial_inertia": fmt(t.spatial_inertia),
            "jacobian": fmt.maybe(t.body_jacobian, INLINE_NODES) is not None,
            # shown where the sheet shows them: both small enough to read
            "pose": all(fmt.maybe(x, INLINE_NODES) is not None for x in (t.com_position, t.body_velocity)),
            "oriented": fmt.maybe(t.orientation, INLINE_NODES) is not None,
            "com": fmt.matrix(fenced(sub("p", link_frame(k))), t.com_position, sub("p", link_frame(k))),
            "velocity": fmt.matrix(fenced(sub("V", link_frame(k), "b")), t.body_velocity, sub("V", link_frame(k), "b")),
            "angle": (fmt.maybe(t.orientation, INLINE_NODES) if robot.planar else
                      fmt.matrix(fenced(sub("R", link_frame(k))), t.orientation, sub("R", link_frame(k)))),
            "jacobian_matrix": style.jacobian(k, t.body_jacobian),
            "kinetic": fmt.maybe(t.kinetic, SCALAR_NODES), "potential": fmt.maybe(t.potential, SCALAR_NODES),
            "frame": link_frame(k),
        })
    return page_header(derivation, fmt, gen["gravity"], joint_rows(derivation, style)) | shared | {
        # a large robot's equations as the recursion that computes them, as on the LaTeX sheet
        "recursion": (html_recursion(derivation, fmt.digits)
                      if derivation.intermediates and "generalized" in shared["sections"] else None),
        "links": links,
        "inertia_groups": [{"names": [sub("\U0001d4dc", str(i)) for i in g["indices"]], "math": g["latex"]}
                           for g in _groups([(link["index"], link["spatial_inertia"]) for link in links])],
        "figure": _figure(derivation),
    }


def _figure(derivation: Derivation) -> dict[str, Any] | None:
    """The TikZ picture's geometry as SVG, and the configuration drawn."""
    latex = Formatter.of(derivation)
    figure = sheet_figure(derivation, latex)
    if figure is None:
        return None
    robot = derivation.robot
    return {"svg": svg_figure(figure, figure_labels(derivation, latex)),
            "configuration": [(name_markup(n), value) for n, value in
                              configuration_text(derivation, figure["configuration"], latex)],
            "loops": bool(robot.loops), "spatial": not robot.planar,
            "what": "" if robot.planar else "its default assembly" if robot.loops else "its zero configuration",
            "view": figure.get("view", ("", ""))}


def _dot(letter: str) -> Markup:
    return accent(letter, "\u02d9")


class PageStyle(SheetStyle):
    """The sections the page shares with the LaTeX sheet (``latex.SheetStyle``) in MathML: each
    matrix named by its letter, labelled as the page writes it; names as written."""

    text = staticmethod(str)
    blank = unknown = None

    def __init__(self, derivation: Derivation, fmt: MathFormatter):
        super().__init__(derivation, fmt)
        self.latex = Formatter.of(derivation, digits=fmt.digits)
        g, m = _upright("g"), _upright("m")
        qg, qm = fenced(sub("q", g)), fenced(sub("q", m))
        self.names = {"a_g": ("a", mrow(sub("a", g), qg)), "a_m": ("a", mrow(sub("a", m), qm)),
                      "h": ("h", mrow(mi("h"), qg)), "H": ("H", mrow(mi("H"), qg)), "Hdot": (_dot("H"), None)}
        for key in self.NAMES.keys() - self.names.keys():
            # the others "letter_index" (the index upright) or "letter_tilde" (no label: in the text)
            letter, _, index = key.partition("_")
            base = {"Y": "\u03a5", "Adot": _dot("A")}.get(letter, letter)
            self.names[key] = ((accent(base, "~"), None) if index == "tilde"
                               else (base, sub(_upright(base) if letter == "EOM" else base, _upright(index))))

    def matrix(self, key: str, value: sympy.Matrix) -> dict[str, Any]:
        base, label = self.names[key]
        return self.fmt.matrix(base, value, label)

    def jacobian(self, k: int, value: sympy.Matrix) -> dict[str, Any]:
        return self.fmt.matrix(fenced(body_jacobian(k)), value, body_jacobian(k))

    def centroidal_names(self) -> HtmlNames:
        return HtmlNames(self.fmt)

    def frame_labels(self, name: str) -> dict[str, Any]:
        return {"theta": sub("\u03b8", _upright(name))}

    def frame_matrix(self, letter: str, name: str, value: sympy.Matrix) -> dict[str, Any]:
        return self.fmt.matrix(sub(_dot("J") if letter == "Jdot" else letter, _upright(name)), value)

    def show(self, value: sympy.Expr) -> Markup:
        return self.fmt(value)

    def scalar(self, value: sympy.Expr, limit: int = ENTRY_NODES) -> Markup | None:
        return self.fmt.maybe(value, limit)


def render_html(derivation: Derivation, template_dir: str | Path | None = None,
                sections: tuple[str, ...] | None = None, digits: int | None = None) -> str:
    """The HTML sheet of ``sections`` (default: the LaTeX sheet's ``default_sections``), numbers
    to ``digits`` significant digits (default: as the robot file wrote them, at most 6). A robot
    with quaternion joints gets the quasi-velocity page (``html_quasi_velocity``)."""
    context = (quasi_velocity_html_context(derivation, digits) if derivation.robot.floating
               else html_context(derivation, sections, digits))
    return render("html", HTML_TEMPLATE, context, template_dir)
