"""The pieces of a sheet's drawing, shared by the planar drawing (``figure``) and the 3-D
kinematic diagram (``figure_3d``), and what the TikZ picture and the HTML sheet's SVG draw.

A drawing is a list of items in millimetres (y up), each of one kind and one style:

- ``path``: a polyline (``closed``: a polygon; ``arrow``: an arrowhead at its end),
- ``circle``: a circle (centre, radius),
- ``arc``: a circular arc from ``start`` to ``end`` (degrees, counter-clockwise positive),
  with an arrowhead at its end,
- ``com``: the centre-of-mass symbol (a circle with two black quarters),
- ``label``: math text (LaTeX) centred at a point.

The styles (the keys of ``HALF_WIDTH``) are named by what they draw: ``edge`` and ``body`` (a link: its
outline, then its fill, each a thick stroke with round joins, so that two points give a
rounded bar and more a rounded plate), ``joint`` (a joint's symbol, white with a black
outline), ``shade`` (a 3-D joint's body), ``thin``, ``dashed``, ``axis`` (a frame's axis, an
arrow), ``rail`` (a prismatic joint's guide), ``ground`` and ``hatch`` (the world).
:func:`finish` turns the items into text with two decimals (fixed, so the output is the same
bytes on every machine), shifted so that the drawing's lower-left corner is at the margin,
and drops what is shorter than the text's resolution (TikZ has nothing to draw there).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

Point = tuple[float, float]
Segment = tuple[Point, Point]

#: Blank around the drawing (mm).
MARGIN_MM = 3.0
#: Largest extent (mm) a drawing may reach: a robot that cannot be evaluated sensibly gets
#: near it (it is then not drawn).
LARGEST_MM = 1000.0
#: Width of a link's bar (mm) and of its outline.
BAR_MM, OUTLINE_MM = 2.2, 0.35
#: Half the width (mm) each style's strokes take, for placing the labels clear of them.
HALF_WIDTH = {"edge": BAR_MM / 2, "body": BAR_MM / 2, "joint": 0.2, "shade": 0.2, "thin": 0.1, "dashed": 0.1,
              "axis": 0.15, "rail": 0.4, "ground": 0.2, "hatch": 0.1}


class Drawing:
    """The items drawn so far (mm), and what they cover, for placing labels clear of them."""

    def __init__(self) -> None:
        self.items: list[dict[str, Any]] = []
        self._samples: list[np.ndarray] = []   # rows x, y, half width
        self._points: np.ndarray | None = None
        self.boxes: list[tuple[Point, float, float]] = []

    # -- the items ---------------------------------------------------------------------------
    def path(self, points: list[Point], style: str, closed: bool = False, arrow: bool = False, tag: str = "") -> None:
        if len(points) < 1:
            return
        self.items.append({"kind": "path", "style": style, "points": list(points), "closed": closed, "arrow": arrow,
                           "tag": tag})
        ends = list(points) + ([points[0]] if closed else [])
        for a, b in zip(ends, ends[1:]):
            self._cover(a, b, HALF_WIDTH[style])
        if closed and style in ("body", "shade", "joint", "ground"):   # a filled polygon covers its inside
            for p in _inside(points):
                self._cover(p, p, 0.0)

    def circle(self, centre: Point, radius: float, style: str, tag: str = "") -> None:
        self.items.append({"kind": "circle", "style": style, "centre": centre, "radius": radius, "tag": tag})
        self._cover(centre, centre, radius + HALF_WIDTH[style])

    def arc(self, centre: Point, radius: float, start: float, end: float, style: str = "thin", tag: str = "") -> None:
        """An arc (angles in radians) with an arrowhead at ``end``."""
        self.items.append({"kind": "arc", "style": style, "centre": centre, "radius": radius,
                           "start": start, "end": end, "tag": tag})
        steps = max(2, int(abs(end - start) * radius / 0.3))
        for k in range(steps):
            t0, t1 = start + (end - start) * k / steps, start + (end - start) * (k + 1) / steps
            self._cover(polar(centre, radius, t0), polar(centre, radius, t1), HALF_WIDTH[style])

    def com(self, centre: Point, radius: float, tag: str = "") -> None:
        self.items.append({"kind": "com", "style": "joint", "centre": centre, "radius": radius, "tag": tag})
        self._cover(centre, centre, radius)

    def label(self, candidates: list[Point], text: str, clear: float = 0.5, tag: str = "") -> None:
        """``text`` (math) at the first candidate clear of everything by ``clear``, else the clearest."""
        w, h = label_size(text)
        room = self._clearances(np.array(candidates), w, h)
        good = np.nonzero(room >= clear)[0]
        at = candidates[int(good[0]) if len(good) else int(np.argmax(room))]
        self.boxes.append((at, w, h))
        self.items.append({"kind": "label", "style": "label", "at": at, "text": text, "tag": tag})

    # -- what is covered -----------------------------------------------------------------------
    def _cover(self, a: Point, b: Point, half: float) -> None:
        steps = max(1, int(math.hypot(b[0] - a[0], b[1] - a[1]) / 0.3))
        t = np.linspace(0.0, 1.0, steps + 1)[:, None]
        xy = np.asarray(a) + t * (np.asarray(b) - np.asarray(a))
        self._samples.append(np.hstack([xy, np.full((len(xy), 1), half)]))
        self._points = None

    def _clearances(self, centres: np.ndarray, w: float, h: float) -> np.ndarray:
        if self._points is None:
            self._points = np.concatenate(self._samples) if self._samples else np.zeros((0, 3))
        best = np.full(len(centres), np.inf)
        if len(self._points):
            dx = np.maximum(np.abs(self._points[None, :, 0] - centres[:, None, 0]) - w, 0.0)
            dy = np.maximum(np.abs(self._points[None, :, 1] - centres[:, None, 1]) - h, 0.0)
            best = np.minimum(best, (np.hypot(dx, dy) - self._points[None, :, 2]).min(axis=1))
        for p, bw, bh in self.boxes:
            gx = np.abs(centres[:, 0] - p[0]) - w - bw
            gy = np.abs(centres[:, 1] - p[1]) - h - bh
            inside = (gx < 0) & (gy < 0)
            best = np.minimum(best, np.where(inside, np.maximum(gx, gy), np.hypot(np.maximum(gx, 0.0), np.maximum(gy, 0.0))))
        return best

    def clearance_of_segment(self, segment: Segment) -> float:
        (ax, ay), (bx, by) = segment
        steps = max(1, int(math.hypot(bx - ax, by - ay) / 0.5))
        t = np.linspace(0.0, 1.0, steps + 1)[:, None]
        return float(self._clearances(np.array([ax, ay]) + t * np.array([bx - ax, by - ay]), 0.0, 0.0).min())

    def extent(self) -> tuple[float, float, float, float]:
        """Lower-left and upper-right corners of everything drawn (strokes' widths included)."""
        points = np.concatenate(self._samples) if self._samples else np.zeros((1, 3))
        low = points[:, :2] - points[:, 2:]
        high = points[:, :2] + points[:, 2:]
        xs = [float(low[:, 0].min()), float(high[:, 0].max())] + [p[0] + s * w for p, w, _ in self.boxes for s in (-1, 1)]
        ys = [float(low[:, 1].min()), float(high[:, 1].max())] + [p[1] + s * h for p, _, h in self.boxes for s in (-1, 1)]
        return min(xs), min(ys), max(xs), max(ys)


def _inside(points: list[Point]) -> list[Point]:
    """A few points inside a convex polygon (its centroid and halfway to each corner)."""
    cx = sum(p[0] for p in points) / len(points)
    cy = sum(p[1] for p in points) / len(points)
    return [(cx, cy)] + [((cx + p[0]) / 2, (cy + p[1]) / 2) for p in points]


def label_size(label: str) -> tuple[float, float]:
    """Half width and half height (mm) of a math label such as ``q_{1}`` or ``\\theta``."""
    main, _, sub = re.sub(r"\\(?:mathrm|mathit|mathbf|operatorname|boldsymbol)\{", "{", label).partition("_")
    glyphs = len(re.findall(r"\\[A-Za-z]+|[A-Za-z0-9]", main))
    small = len(re.findall(r"\\[A-Za-z]+|[A-Za-z0-9]", sub))
    return (1.8 * glyphs + 1.2 * small) / 2 + 0.1, 1.2


def polar(centre: Point, radius: float, angle: float) -> Point:
    return centre[0] + radius * math.cos(angle), centre[1] + radius * math.sin(angle)


def convex_hull(points: list[Point]) -> list[Point]:
    """The convex hull, counter-clockwise from the lowest-leftmost point (Andrew's monotone
    chain); points closer than 0.01 mm are one."""
    unique = sorted({(round(p[0], 2), round(p[1], 2)) for p in points})
    if len(unique) <= 2:
        return unique

    def cross(o: Point, a: Point, b: Point) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[Point] = []
    for p in unique:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 1e-9:
            lower.pop()
        lower.append(p)
    upper: list[Point] = []
    for p in reversed(unique):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 1e-9:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def number(value: float) -> str:
    """A coordinate as text: two decimals, never ``-0.00``."""
    text = f"{value:.2f}"
    return "0.00" if text == "-0.00" else text


def finish(drawing: Drawing, caption: str, anchors: dict[str, Point], **extra: Any) -> dict[str, Any] | None:
    """The drawing as text for the templates (see the module's docstring), or None when it
    reaches beyond ``LARGEST_MM`` or holds something not finite (nothing sensible to draw).
    ``anchors`` (named points: joints, centres of mass) are shifted with the drawing."""
    low_x, low_y, high_x, high_y = drawing.extent()
    if not all(math.isfinite(v) and abs(v) < LARGEST_MM for v in (low_x, low_y, high_x, high_y)):
        return None
    dx, dy = MARGIN_MM - low_x, MARGIN_MM - low_y

    def at(p: Point) -> tuple[str, str]:
        return number(p[0] + dx), number(p[1] + dy)

    items = []
    for item in drawing.items:
        kind, out = item["kind"], {"kind": item["kind"], "style": item["style"], "tag": item.get("tag", "")}
        if kind == "path":
            points = [at(p) for p in item["points"]]
            kept = [p for i, p in enumerate(points) if i == 0 or p != points[i - 1]]
            if item["closed"]:
                while len(kept) > 1 and kept[-1] == kept[0]:
                    kept.pop()
            if len(kept) < 2:
                continue   # a point: nothing to draw (a zero-length path)
            out |= {"points": kept, "closed": item["closed"] and len(kept) > 1, "arrow": item["arrow"]}
        elif kind in ("circle", "com"):
            if item["radius"] < 0.05:
                continue
            out |= {"centre": at(item["centre"]), "radius": number(item["radius"])}
        elif kind == "arc":
            start, end = math.degrees(item["start"]), math.degrees(item["end"])
            if abs(end - start) < 1.0 or item["radius"] < 0.05:
                continue   # too short to show an arc with its arrowhead
            out |= {"centre": at(item["centre"]), "from": at(polar(item["centre"], item["radius"], item["start"])),
                    "to": at(polar(item["centre"], item["radius"], item["end"])),
                    "radius": number(item["radius"]), "start": number(start), "end": number(end)}
        else:
            out |= {"at": at(item["at"]), "text": item["text"]}
        items.append(out)
    return {"width": number(high_x - low_x + 2 * MARGIN_MM), "height": number(high_y - low_y + 2 * MARGIN_MM),
            "items": items, "caption": caption, "anchors": {k: at(p) for k, p in anchors.items()}, **extra}


def joint_value_text(value: float, angle: bool) -> str:
    """A joint coordinate in a drawing's caption (LaTeX): a revolute angle in whole degrees,
    wrapped to (-180, 180] (an assembled loop may sit at -314 degrees: shown as 46), a travel
    to 3 significant digits."""
    if not angle:
        return f"{value:.3g}"
    if not math.isfinite(value):
        return f"{math.degrees(value):.0f}^\\circ"
    degrees = (round(math.degrees(value)) + 180) % 360 - 180
    return f"{180 if degrees == -180 else degrees}^\\circ"
