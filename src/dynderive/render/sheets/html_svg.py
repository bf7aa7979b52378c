"""The sheet's drawing as inline SVG, for the HTML sheet.

The geometry is the TikZ picture's (``drawing``: items in millimetres, y up, each of one
kind and one style); here each item becomes an SVG element, y turned down, each style the
same strokes and fills as the TikZ style of its name. Labels are SVG text (the coordinate's
letter in italic with its index as a subscript), built from the robot's names, never from
the LaTeX strings.
"""

from __future__ import annotations

import math
from typing import Any

from markupsafe import Markup, escape

from ...derivation import Derivation
from ..encode import escape_tex
from .html_math import Name, name_of

#: Pixels per millimetre of the picture.
PIXELS_PER_MM = 5.0
#: Size of the labels' letters (mm).
FONT_MM = 3.6
#: Each style's SVG attributes (the TikZ styles of ``templates/drawing.tex.j2``; widths in mm).
STYLES = {
    "edge": 'fill="#000" stroke="#000" stroke-width="2.2"',
    "body": 'fill="#e0e0e0" stroke="#e0e0e0" stroke-width="1.5"',
    "joint": 'fill="#fff" stroke="#000" stroke-width="0.18"',
    "shade": 'fill="#e6e6e6" stroke="#000" stroke-width="0.18"',
    "thin": 'fill="none" stroke="#000" stroke-width="0.12"',
    "dashed": 'fill="none" stroke="#000" stroke-width="0.12"',
    "axis": 'fill="none" stroke="#000" stroke-width="0.18"',
    "rail": 'fill="none" stroke="#737373" stroke-width="0.8"',
    "ground": 'fill="#fff" stroke="#000" stroke-width="0.21"',
    "hatch": 'fill="none" stroke="#000" stroke-width="0.12"',
}


def figure_labels(derivation: Derivation, latex: Any) -> dict[str, Name]:
    """The drawing's labels (the LaTeX strings the drawing placed) -> the names they show."""
    table = derivation.symbols
    labels: dict[str, Name] = {latex(q): name_of(str(q)) for q in table.q}
    for frame in derivation.robot.frames:
        labels[r"\mathrm{" + escape_tex(frame.name) + "}"] = (frame.name, "normal", 0, "")
    labels |= {f"{axis}_s": (axis, "", 0, "s") for axis in "xyz"}
    return labels


def svg_figure(figure: dict[str, Any], labels: dict[str, Name]) -> Markup:
    """``figure`` (``drawing.finish``'s dict) as an ``<svg>`` element."""
    width, height = float(figure["width"]), float(figure["height"])

    def point(p: tuple[str, str]) -> str:
        return f"{float(p[0]):.2f} {height - float(p[1]):.2f}"

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" role="img" class="drawing" '
             f'width="{width * PIXELS_PER_MM:.0f}" height="{height * PIXELS_PER_MM:.0f}" '
             f'viewBox="0 0 {width:.2f} {height:.2f}" stroke-linecap="round" stroke-linejoin="round">']
    for item in figure["items"]:
        kind, style = item["kind"], STYLES.get(item["style"], "")
        if kind == "path":
            d = "M" + " L".join(point(p) for p in item["points"]) + (" Z" if item["closed"] else "")
            parts.append(f'<path d="{d}" {style}/>')
            if item["arrow"]:
                (x0, y0), (x1, y1) = [(float(a), float(b)) for a, b in item["points"][-2:]]
                parts.append(_head(point(item["points"][-1]), x1 - x0, y1 - y0))
        elif kind == "circle":
            parts.append(f'<circle cx="{float(item["centre"][0]):.2f}" cy="{height - float(item["centre"][1]):.2f}" '
                         f'r="{item["radius"]}" {style}/>')
        elif kind == "com":
            x, y, r = float(item["centre"][0]), height - float(item["centre"][1]), float(item["radius"])
            parts.append(f'<circle cx="{x:.2f}" cy="{y:.2f}" r="{r:.2f}" {STYLES["joint"]}/>')
            parts.append(f'<path d="M{x:.2f} {y:.2f} L{x + r:.2f} {y:.2f} A{r:.2f} {r:.2f} 0 0 0 {x:.2f} {y - r:.2f} Z '
                         f'M{x:.2f} {y:.2f} L{x - r:.2f} {y:.2f} A{r:.2f} {r:.2f} 0 0 0 {x:.2f} {y + r:.2f} Z" fill="#000"/>')
        elif kind == "arc":
            start, end, r = float(item["start"]), float(item["end"]), float(item["radius"])
            large = 1 if abs(end - start) > 180 else 0
            sweep = 0 if end > start else 1   # counter-clockwise with y up is clockwise with y down
            parts.append(f'<path d="M{point(item["from"])} A{r:.2f} {r:.2f} 0 {large} {sweep} {point(item["to"])}" '
                         f'{STYLES["thin"]}/>')
            tangent = math.radians(end) + math.copysign(math.pi / 2, end - start)
            parts.append(_head(point(item["to"]), math.cos(tangent), math.sin(tangent)))
        else:
            x, y = float(item["at"][0]), height - float(item["at"][1])
            parts.append(_label(x, y, labels.get(item["text"], (item["text"], "normal", 0, ""))))
    parts.append("</svg>")
    return Markup("".join(parts))


def _head(tip: str, dx: float, dy: float) -> str:
    """A filled arrowhead at ``tip`` (SVG coordinates) pointing along (dx, dy) (y up)."""
    angle = math.degrees(math.atan2(-dy, dx))
    x, y = tip.split()
    return (f'<path d="M0 0 L-1.6 -0.55 L-1.6 0.55 Z" fill="#000" '
            f'transform="translate({x} {y}) rotate({angle:.1f})"/>')


def _label(x: float, y: float, name: Name) -> str:
    """A label centred at (x, y): the letters (italic when one letter), a dot accent as a
    combining character, the index as a subscript."""
    letters, variant, dots, index = name
    style = ' font-style="italic"' if len(letters) == 1 and variant != "normal" else ""
    text = escape(letters) + ("\u0307" if dots == 1 else "\u0308" if dots == 2 else "")
    small = (f'<tspan dy="0.9" font-size="{FONT_MM * 0.7:.2f}" font-style="normal">{escape(index)}</tspan>'
             if index else "")
    return (f'<text x="{x:.1f}" y="{y + FONT_MM * 0.35:.1f}" font-size="{FONT_MM}" text-anchor="middle" '
            f'font-family="serif"><tspan{style}>{text}</tspan>{small}</text>')


def configuration_text(derivation: Derivation, values: str, latex: Any) -> list[tuple[Name, str]]:
    """The drawn configuration (``figure["configuration"]``, LaTeX) as (coordinate, value) pairs."""
    names = {latex(q): name_of(str(q)) for q in derivation.symbols.q}
    pairs = [item.partition(" = ") for item in values.split(", ")]
    return [(names.get(left, (left, "normal", 0, "")), value.replace("^\\circ", "\u00b0"))
            for left, _, value in pairs]
