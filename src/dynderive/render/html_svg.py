"""The sheet's drawing of a planar robot as inline SVG, for the HTML sheet.

The geometry is the LaTeX picture's (``figure.planar_figure``: millimetres, y up, lines and
arcs as quadratic beziers, arrowheads as directions, labels placed clear of the lines); here
each piece becomes an SVG element, y turned down. Labels are SVG text (the coordinate's
letter in italic with its index as a subscript), built from the robot's names, never from
the LaTeX strings.
"""

from __future__ import annotations

import math
from typing import Any

from markupsafe import Markup, escape

from .encode import escape_tex
from .html_math import Name, name_of

#: Pixels per millimetre of the picture.
PIXELS_PER_MM = 5.0
#: Size of the labels' letters (mm).
FONT_MM = 3.6


def figure_labels(derivation: Any, latex: Any) -> dict[str, Name]:
    """The drawing's labels (the LaTeX strings ``planar_figure`` placed) -> the names they show."""
    table = derivation.symbols
    labels: dict[str, Name] = {latex(q): name_of(str(q)) for q in table.q}
    for frame in derivation.robot.frames:
        labels[r"\mathrm{" + escape_tex(frame.name) + "}"] = (frame.name, "normal", 0, "")
    labels |= {"x_s": ("x", "", 0, "s"), "y_s": ("y", "", 0, "s")}
    return labels


def svg_figure(figure: dict[str, Any], labels: dict[str, Name]) -> Markup:
    """``figure`` (``planar_figure``'s dict) as an ``<svg>`` element."""
    width, height = float(figure["width"]), float(figure["height"])

    def point(x: str, y: str) -> str:
        return f"{float(x):.1f} {height - float(y):.1f}"

    def path(curves: list[tuple[str, ...]]) -> str:
        return " ".join(f"M{point(c[0], c[1])} Q{point(c[2], c[3])} {point(c[4], c[5])}" for c in curves)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" role="img" class="drawing" '
             f'width="{width * PIXELS_PER_MM:.0f}" height="{height * PIXELS_PER_MM:.0f}" '
             f'viewBox="0 0 {width:.1f} {height:.1f}">']
    thin = 'fill="none" stroke="#000" stroke-width="0.2"'
    for b in figure["bases"]:
        x, y = float(b[0]), height - float(b[1])
        parts.append(f'<line x1="{x - 5:.1f}" y1="{y:.1f}" x2="{x + 5:.1f}" y2="{y:.1f}" stroke="#000" stroke-width="0.2"/>')
    if figure["hatches"]:
        parts.append(f'<path d="{path(figure["hatches"])}" {thin}/>')
    frame = figure["frame"]
    ox, oy = float(frame["origin"][0]), float(frame["origin"][1])
    for dx, dy in ((float(frame["x"]), 0.0), (0.0, float(frame["y"]))):
        tip = (f"{ox + dx:.1f}", f"{oy + dy:.1f}")
        parts.append(f'<path d="M{point(*frame["origin"])} L{point(*tip)}" {thin}/>')
        parts.append(_head(point(*tip), dx, dy))
    for f in figure["frames"]:
        if f["lines"]:
            parts.append(f'<path d="{path(f["lines"])}" {thin}/>')
        parts += [_head(point(h[0], h[1]), float(h[2]), float(h[3])) for h in f["heads"]]
    for c in figure["coordinates"]:
        if c["curves"] or c["lines"]:
            parts.append(f'<path d="{path(c["curves"] + c["lines"])}" {thin}/>')
        h = c["head"]
        parts.append(_head(point(h[0], h[1]), float(h[2]), float(h[3])))
    if figure["segments"]:
        parts.append(f'<path d="{path(figure["segments"])}" fill="none" stroke="#000" stroke-width="0.5" '
                     'stroke-linecap="round"/>')
    for c in figure["coms"]:
        parts.append(f'<circle cx="{float(c[0]):.1f}" cy="{height - float(c[1]):.1f}" r="0.8" fill="#000"/>')
    for j in figure["joints"]:
        x, y = float(j["x"]), height - float(j["y"])
        if j["prismatic"]:
            parts.append(f'<rect x="{x - 1.2:.1f}" y="{y - 1.2:.1f}" width="2.4" height="2.4" fill="#fff" '
                         'stroke="#000" stroke-width="0.3"/>')
        else:
            parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="1.2" fill="#fff" stroke="#000" stroke-width="0.3"/>')
    for c in figure["loops"]:
        parts.append(f'<circle cx="{float(c[0]):.1f}" cy="{height - float(c[1]):.1f}" r="1.2" fill="#fff" '
                     'stroke="#000" stroke-width="0.3"/>')
    for x, y, label in figure["labels"]:
        parts.append(_label(float(x), height - float(y), labels.get(label, (label, "normal", 0, ""))))
    parts.append("</svg>")
    return Markup("".join(parts))


def _head(tip: str, dx: float, dy: float) -> str:
    """A filled arrowhead at ``tip`` (SVG coordinates) pointing along (dx, dy) (y up)."""
    angle = math.degrees(math.atan2(-dy, dx))
    x, y = tip.split()
    return (f'<path d="M0 0 L-1.6 -0.6 L-1.6 0.6 Z" fill="#000" '
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


def configuration_text(derivation: Any, values: str, latex: Any) -> list[tuple[Name, str]]:
    """The drawn configuration (``figure["configuration"]``, LaTeX) as (coordinate, value) pairs."""
    names = {latex(q): name_of(str(q)) for q in derivation.symbols.q}
    pairs = []
    for item in values.split(", "):
        left, _, value = item.partition(" = ")
        pairs.append((names.get(left, (left, "normal", 0, "")), value.replace("^\\circ", "\u00b0")))
    return pairs
