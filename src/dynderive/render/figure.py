"""A drawing of a planar robot for the sheet, at a reference configuration.

LaTeX's own ``picture`` environment draws it: no TikZ, which a minimal TeX install lacks,
and no ``pict2e`` (not in texlive-latex-base/recommended), so straight lines of any slope
are ``\\qbezier`` with the midpoint as control point, circular arcs a few quadratic beziers,
and arrowheads zero-length ``\\vector``s at the nearest slope LaTeX allows (integers up to
4). Links are drawn from their joint point to their children's joint points (a last link
to its centre of mass), moving joints as circles (prismatic: squares), centres of mass as
dots, the world's joints on a hatched base, the world frame ``s`` as two arrows ``x_s``, ``y_s``.
Each coordinate is drawn as what it measures: a revolute joint's as an arc from the joint
frame's zero direction (a dashed line, unless a link or axis already lies there) to the
child link's x-direction, a prismatic joint's as an arrow beside its axis over the travel.
Labels go where they clear the lines (a few candidate places, the first clear one).

The configuration is 30 degrees at every revolute joint and a quarter of the robot's size
along every prismatic one; a robot with closed loops has its independent coordinates there
and the others assembled from its default assembly (that assembly itself if they cannot
be), its loop joints drawn as circles.

>>> figure = planar_figure(derivation, fmt)        # doctest: +SKIP
>>> figure["segments"][0], figure["configuration"]  # doctest: +SKIP
(('10.0', '5.0', '27.3', '15.0'), 'q_{1} = 30^\\circ, ...')
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import sympy

from .encode import escape_tex

#: Size of the robot in the drawing (mm): it is scaled to fit, keeping its proportions.
WIDTH_MM, HEIGHT_MM = 75.0, 45.0
#: Revolute joints' angle in the drawing.
REFERENCE_ANGLE = math.pi / 6
#: Prismatic joints' travel in the drawing, as a fraction of the robot's size.
REFERENCE_TRAVEL = 0.25
#: Radius of a revolute coordinate's arc, length of the world frame's axes, distance of a
#: prismatic coordinate's arrow from its axis, blank around the drawing (mm).
ARC_MM, AXIS_MM, OFFSET_MM, MARGIN_MM = 9.0, 10.0, 3.5, 3.0
#: Length of a named frame's axes (``frames:``).
FRAME_MM = 6.0
#: Dashes of a reference line: on, off (mm).
DASH_MM = (1.2, 0.8)
#: Largest coordinate (mm) a drawing may reach: the robot is scaled to WIDTH_MM x HEIGHT_MM,
#: so only a robot that cannot be evaluated sensibly gets near it (it is then not drawn).
LARGEST_MM = 1000.0

Point = tuple[float, float]
Segment = tuple[Point, Point]


def planar_figure(derivation: Any, fmt: Callable[[Any], str]) -> dict[str, Any] | None:
    """What the sheet's ``picture`` draws (coordinates in mm, as text), or None for 3-D robots
    and robots that cannot be evaluated at the parameters' values (a parameter without one
    is taken as 1)."""
    robot, table = derivation.robot, derivation.symbols
    if not robot.planar:
        return None
    values: dict[sympy.Symbol, float] = {table.parameters[p.name]: (p.value if p.value is not None else 1.0)
                                         for p in robot.parameters}
    links = derivation.steps["kinematics"]
    loops = derivation.steps["loops"] if robot.loops else None
    q = _configuration(robot, table, links, values, loops)
    at = {s: sympy.Float(v) for s, v in (values | dict(zip(table.q, q))).items()}

    def number(expr: Any) -> float:
        return _float(expr, at)

    def written(entry: Any) -> float:
        return number(table.expr(entry))

    joint_points = {link.name: (number(link.joint_origin[0]), number(link.joint_origin[1])) for link in links}
    coms = {link.name: (number(link.com_world[0]), number(link.com_world[1])) for link in links}
    angles = {link.name: number(link.angle) for link in links}
    if not all(map(math.isfinite, [*q, *angles.values(), *(v for p in [*joint_points.values(), *coms.values()] for v in p)])):
        return None
    segments: list[Segment] = []
    children: dict[str, list[str]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint.child)
    for link in links:
        ends = [joint_points[c] for c in children.get(link.name, [])]
        segments += [(joint_points[link.name], end) for end in ends]
        if not ends:
            segments.append((joint_points[link.name], coms[link.name]))
    loop_points = []
    for loop in robot.loops:
        ends = []
        for side, origin in ((loop.parent, loop.origin), (loop.child, loop.child_origin)):
            ox, oy = (written(e) for e in origin[:2])
            if side == "world":
                ends.append((ox, oy))
                continue
            base, phi = joint_points[side], angles[side]
            ends.append((base[0] + math.cos(phi) * ox - math.sin(phi) * oy, base[1] + math.sin(phi) * ox + math.cos(phi) * oy))
            segments.append((base, ends[-1]))
        loop_points.append(ends[0])
    named = []   # the robot's frames: (name, origin, angle), the link drawn out to each
    for frame in robot.frames:
        base, phi = joint_points[frame.link], angles[frame.link]
        fx, fy, ftheta = (written(e) for e in frame.origin[:3])
        point = (base[0] + math.cos(phi) * fx - math.sin(phi) * fy, base[1] + math.sin(phi) * fx + math.cos(phi) * fy)
        named.append((frame.name, point, phi + ftheta))
        segments.append((base, point))
    index = {name: i for i, name in enumerate(robot.coordinates)}
    by_name = {j.name: j for j in robot.joints}
    world = [joint_points[j.child] for j in robot.joints if j.parent == "world"]
    points = [p for s in segments for p in s] + list(coms.values()) + world + [(0.0, 0.0)]
    left, right = min(p[0] for p in points), max(p[0] for p in points)
    bottom, top = min(p[1] for p in points), max(p[1] for p in points)
    size = max(right - left, top - bottom, 1e-9)
    scale = min(WIDTH_MM / max(right - left, size / 4), HEIGHT_MM / max(top - bottom, size / 4))

    def mm(p: Point) -> Point:
        return p[0] * scale, p[1] * scale

    sheet = _Sheet()
    links_mm = [(mm(a), mm(b)) for a, b in segments if abs(a[0] - b[0]) + abs(a[1] - b[1]) > 1e-9 * size]
    for a, b in links_mm:
        sheet.line(a, b)
    for c in coms.values():
        sheet.dot(mm(c), 0.8)
    hatches = []
    for base in world:
        x, y = mm(base)
        sheet.line((x - 5.0, y), (x + 5.0, y))
        for k in range(6):
            hatches.append(((x - 4.5 + 1.8 * k, y), (x - 4.5 + 1.8 * k - 1.5, y - 1.5)))
            sheet.line(*hatches[-1])
    for c in loop_points:
        sheet.dot(mm(c), 1.2)
    # the world frame s
    origin = mm((0.0, 0.0))
    # axes of AXIS_MM, shorter or longer where a joint or centre of mass would sit on a tip
    marks = [mm(p) for p in [*joint_points.values(), *coms.values()]]
    lengths = []
    for unit in ((1.0, 0.0), (0.0, 1.0)):
        lengths.append(next((length for length in (AXIS_MM, 0.7 * AXIS_MM, 1.3 * AXIS_MM, 0.5 * AXIS_MM)
                             if all(math.hypot(m[0] - origin[0] - length * unit[0], m[1] - origin[1] - length * unit[1]) > 3.0
                                    for m in marks)), AXIS_MM))
    x_tip, y_tip = (origin[0] + lengths[0], origin[1]), (origin[0], origin[1] + lengths[1])
    sheet.line(origin, x_tip)
    sheet.line(origin, y_tip)
    frames_drawn = []
    for name, point, angle in named:   # short axes x, y of each named frame
        at_mm = mm(point)
        tips = [_polar(at_mm, FRAME_MM, angle + k * math.pi / 2) for k in (0, 1)]
        for tip in tips:
            sheet.line(at_mm, tip)
        frames_drawn.append({"name": name, "origin": at_mm, "tips": tips, "angle": angle})
    joints = []
    for joint in robot.joints:
        if joint.moves:
            at_mm = mm(joint_points[joint.child])
            sheet.dot(at_mm, 1.2)
            joints.append({"x": f"{at_mm[0]:.1f}", "y": f"{at_mm[1]:.1f}",
                           "label": fmt(table.q[index[joint.name]]), "prismatic": joint.type == "prismatic"})

    # the coordinates' geometry first (arcs, reference lines, arrows), then their labels
    drawn: list[dict[str, Any]] = []
    for joint in robot.joints:
        if not joint.moves:
            continue
        value = q[index[joint.name]]
        label = fmt(table.q[index[joint.name]])
        centre = mm(joint_points[joint.child])
        if joint.type == "revolute":
            end = angles[joint.child]
            start = end - value
            first = _first_segment(links_mm, centre, joint_points, children.get(joint.child, []), mm, coms[joint.child])
            radius = min(ARC_MM, 0.45 * first) if first > 0 else ARC_MM
            radius = max(radius, 3.0)
            pieces = _arc(centre, radius, start, end)
            for piece in pieces:
                sheet.curve(piece)
            reference: list[Segment] = []
            length = radius + 4.0
            if not _covered(centre, start, length, links_mm + [(origin, x_tip), (origin, y_tip)]):
                reference = _dashes(centre, start, length)
                for dash in reference:
                    sheet.line(*dash)
            drawn.append({"kind": "revolute", "label": label, "centre": centre, "radius": radius,
                          "start": start, "end": end, "pieces": pieces, "reference": reference,
                          "head": _head(_polar(centre, radius, end), end + math.copysign(math.pi / 2, value or 1.0))})
        else:
            axis = [written(e) for e in joint.axis[:2]]
            norm = math.hypot(*axis) or 1.0
            phi = angles[joint.child] + math.atan2(axis[1] / norm, axis[0] / norm)
            tip = centre
            tail = (tip[0] - value * scale * math.cos(phi), tip[1] - value * scale * math.sin(phi))
            # beside the axis: the nearest offset on either side that clears what is drawn
            sides = []
            for offset in (OFFSET_MM, OFFSET_MM + 2.5, OFFSET_MM + 5.0):
                for side in (1.0, -1.0):
                    nx, ny = -math.sin(phi) * side * offset, math.cos(phi) * side * offset
                    arrow = ((tail[0] + nx, tail[1] + ny), (tip[0] + nx, tip[1] + ny))
                    sides.append((sheet.clearance_of_segment(arrow), offset, side, arrow))
            room, offset, side, arrow = next((c for c in sides if c[0] >= 1.2), max(sides, key=lambda c: c[0]))
            nx, ny = -math.sin(phi) * side, math.cos(phi) * side
            ticks = [((p[0] + 0.8 * nx, p[1] + 0.8 * ny), (p[0] + (offset + 1.0) * nx, p[1] + (offset + 1.0) * ny))
                     for p in (tail, tip)]
            sheet.line(*arrow)
            for tick in ticks:
                sheet.line(*tick)
            direction = math.atan2(arrow[1][1] - arrow[0][1], arrow[1][0] - arrow[0][0])
            drawn.append({"kind": "prismatic", "label": label, "tail": tail, "tip": tip, "axis": phi, "side": side,
                          "offset": offset,
                          "arrow": arrow, "ticks": ticks, "head": _head(arrow[1], direction)})

    labels: list[tuple[Point, str]] = []
    for item in drawn:
        w, h = _size(item["label"])
        if item["kind"] == "revolute":
            centre, radius, start, end = item["centre"], item["radius"], item["start"], item["end"]
            sign = 1.0 if end >= start else -1.0
            mid = (start + end) / 2
            # in the wedge beyond the arc, else beside it, else opposite
            turns = [end + sign * 0.35, start - sign * 0.35, end + sign * 0.7, start - sign * 0.7,
                     mid + math.pi, end + sign * 1.2, start - sign * 1.2]
            tries = [(mid, extra) for extra in (0.6, 2.0, 3.5)] + [(t, extra) for extra in (0.6, 2.0) for t in turns]
            candidates = [_polar(centre, radius + extra + abs(w * math.cos(t)) + abs(h * math.sin(t)), t)
                          for t, extra in tries]
        else:
            tail, tip, side, phi = item["tail"], item["tip"], item["side"], item["axis"]
            nx, ny = -math.sin(phi) * side, math.cos(phi) * side
            reach = item["offset"] + 1.0 + abs(w * nx) + abs(h * ny)
            candidates = [(tail[0] + f * (tip[0] - tail[0]) + reach * nx, tail[1] + f * (tip[1] - tail[1]) + reach * ny)
                          for f in (0.5, 0.3, 0.7)]
            candidates += [(tail[0] + f * (tip[0] - tail[0]) + (reach + 2.5) * nx,
                            tail[1] + f * (tip[1] - tail[1]) + (reach + 2.5) * ny) for f in (0.5, 0.3, 0.7)]
        place = sheet.place(candidates, w, h)
        sheet.box(place, w, h)
        labels.append((place, item["label"]))
    for item in frames_drawn:   # the frame's name in the quadrant its axes leave free
        label = r"\mathrm{" + escape_tex(item["name"]) + "}"
        w, h = _size(label)
        origin_f, angle = item["origin"], item["angle"]
        candidates = [_polar(origin_f, 1.5 + math.hypot(w, h), angle + turn)
                      for turn in (-3 * math.pi / 4, math.pi + math.pi / 4, -math.pi / 4, 3 * math.pi / 4)]
        place = sheet.place(candidates, w, h)
        sheet.box(place, w, h)
        labels.append((place, label))
    w, h = _size("x_s")
    place = sheet.place([(x_tip[0] + 0.8 + w, x_tip[1]), (x_tip[0] - w, x_tip[1] - 0.8 - h),
                         (x_tip[0] - w, x_tip[1] + 0.8 + h), (x_tip[0] + 0.8 + w, x_tip[1] - 0.8 - h)], w, h)
    sheet.box(place, w, h)
    labels.append((place, "x_s"))
    w, h = _size("y_s")
    place = sheet.place([(y_tip[0], y_tip[1] + 0.8 + h), (y_tip[0] - 0.8 - w, y_tip[1] - h),
                         (y_tip[0] + 0.8 + w, y_tip[1] - h)], w, h)
    sheet.box(place, w, h)
    labels.append((place, "y_s"))

    # shift everything into the picture: its lower-left corner at (0, 0)
    low_x, low_y, high_x, high_y = sheet.extent()
    if not all(math.isfinite(v) and abs(v) < LARGEST_MM for v in (low_x, low_y, high_x, high_y)):
        return None   # a robot that cannot be drawn at this configuration (no picture rather than a broken one)
    dx, dy = MARGIN_MM - low_x, MARGIN_MM - low_y

    def text(p: Point) -> tuple[str, str]:
        return f"{p[0] + dx:.1f}", f"{p[1] + dy:.1f}"

    def bezier(a: Point, b: Point) -> tuple[str, ...]:
        return (*text(a), *text(((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)), *text(b))

    def drawable(curves: Iterable[tuple[str, ...]]) -> list[tuple[str, ...]]:
        """The curves that are not a point at the picture's resolution (0.1 mm): LaTeX's
        ``\\qbezier`` divides by the curve's extent ("Arithmetic overflow" at zero)."""
        return [c for c in curves if not c[0:2] == c[2:4] == c[4:6]]

    coordinates = []
    for item in drawn:
        out: dict[str, Any] = {"kind": item["kind"], "label": item["label"], "head": (*text(item["head"][0]), *item["head"][1])}
        if item["kind"] == "revolute":
            out.update(centre=text(item["centre"]), radius=f"{item['radius']:.1f}",
                       start=f"{math.degrees(item['start']):.1f}", end=f"{math.degrees(item['end']):.1f}",
                       curves=drawable((*text(a), *text(c), *text(b)) for a, c, b in item["pieces"]),
                       lines=drawable(bezier(a, b) for a, b in item["reference"]))
        else:
            out.update(tail=text(item["tail"]), tip=text(item["tip"]), axis=f"{math.degrees(item['axis']):.1f}",
                       curves=[], lines=drawable([bezier(*item["arrow"]), *(bezier(a, b) for a, b in item["ticks"])]))
        coordinates.append(out)
    for joint in joints:
        joint["x"], joint["y"] = text((float(joint["x"]), float(joint["y"])))
    return {
        "width": f"{high_x - low_x + 2 * MARGIN_MM:.1f}", "height": f"{high_y - low_y + 2 * MARGIN_MM:.1f}",
        "segments": drawable(bezier(a, b) for a, b in links_mm),
        "joints": joints, "coms": [text(mm(c)) for c in coms.values()], "bases": [text(mm(base)) for base in world],
        "hatches": drawable(bezier(a, b) for a, b in hatches),
        "loops": [text(mm(p)) for p in loop_points],
        "frame": {"origin": text(origin), "x": f"{lengths[0]:.1f}", "y": f"{lengths[1]:.1f}"},
        "frames": [{"name": item["name"], "lines": drawable(bezier(item["origin"], tip) for tip in item["tips"]),
                    "heads": [(*text(tip), *_head(tip, item["angle"] + k * math.pi / 2)[1])
                              for k, tip in enumerate(item["tips"])]} for item in frames_drawn],
        "coordinates": coordinates,
        "revolute": any(c["kind"] == "revolute" for c in coordinates),
        "prismatic": any(c["kind"] == "prismatic" for c in coordinates),
        "labels": [(*text(p), t) for p, t in labels],
        "configuration": ", ".join(f"{fmt(c)} = {_value_text(v, j.type)}"
                                   for c, v, j in zip(table.q, q, (by_name[n] for n in robot.coordinates))),
    }


class _Sheet:
    """What is drawn so far (mm): lines (kept as points every 0.3 mm), dots and label boxes,
    for placing labels clear of them and for the picture's extent."""

    def __init__(self) -> None:
        self.segments: list[Segment] = []
        self.samples: list[np.ndarray] = []
        self.dots: list[tuple[Point, float]] = []
        self.boxes: list[tuple[Point, float, float]] = []
        self._points: np.ndarray | None = None

    def line(self, a: Point, b: Point) -> None:
        self.segments.append((a, b))
        steps = max(1, int(math.hypot(b[0] - a[0], b[1] - a[1]) / 0.3))
        t = np.linspace(0.0, 1.0, steps + 1)[:, None]
        self.samples.append(np.asarray(a) + t * (np.asarray(b) - np.asarray(a)))
        self._points = None

    def curve(self, piece: tuple[Point, Point, Point]) -> None:
        a, c, b = piece
        previous = a
        for k in range(1, 5):
            t = k / 4
            point = ((1 - t) ** 2 * a[0] + 2 * t * (1 - t) * c[0] + t * t * b[0],
                     (1 - t) ** 2 * a[1] + 2 * t * (1 - t) * c[1] + t * t * b[1])
            self.line(previous, point)
            previous = point

    def dot(self, at: Point, radius: float) -> None:
        self.dots.append((at, radius))

    def box(self, at: Point, half_width: float, half_height: float) -> None:
        self.boxes.append((at, half_width, half_height))

    def clearance(self, at: Point, w: float, h: float) -> float:
        """Distance from a box (centre, half sizes) to everything drawn."""
        return float(self._clearances(np.array([at]), w, h)[0])

    def _clearances(self, centres: np.ndarray, w: float, h: float) -> np.ndarray:
        if self._points is None:
            self._points = np.concatenate(self.samples) if self.samples else np.zeros((0, 2))
        best = np.full(len(centres), np.inf)
        if len(self._points):
            dx = np.maximum(np.abs(self._points[None, :, 0] - centres[:, None, 0]) - w, 0.0)
            dy = np.maximum(np.abs(self._points[None, :, 1] - centres[:, None, 1]) - h, 0.0)
            best = np.minimum(best, np.hypot(dx, dy).min(axis=1))
        for p, r in self.dots:
            dx = np.maximum(np.abs(p[0] - centres[:, 0]) - w, 0.0)
            dy = np.maximum(np.abs(p[1] - centres[:, 1]) - h, 0.0)
            best = np.minimum(best, np.hypot(dx, dy) - r)
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

    def place(self, candidates: list[Point], w: float, h: float, clear: float = 0.5) -> Point:
        """The first candidate clear of everything by ``clear``, else the clearest."""
        room = self._clearances(np.array(candidates), w, h)
        good = np.nonzero(room >= clear)[0]
        return candidates[int(good[0]) if len(good) else int(np.argmax(room))]

    def extent(self) -> tuple[float, float, float, float]:
        xs: list[float] = []
        ys: list[float] = []
        for a, b in self.segments:
            xs += [a[0], b[0]]
            ys += [a[1], b[1]]
        for p, r in self.dots:
            xs += [p[0] - r, p[0] + r]
            ys += [p[1] - r, p[1] + r]
        for p, w, h in self.boxes:
            xs += [p[0] - w, p[0] + w]
            ys += [p[1] - h, p[1] + h]
        return min(xs), min(ys), max(xs), max(ys)


def _size(label: str) -> tuple[float, float]:
    """Half width and half height (mm) of a math label such as ``q_{1}`` or ``\\theta``."""
    main, _, sub = re.sub(r"\\(?:mathrm|mathit|mathbf|operatorname|boldsymbol)\{", "{", label).partition("_")
    glyphs = len(re.findall(r"\\[A-Za-z]+|[A-Za-z0-9]", main))
    small = len(re.findall(r"\\[A-Za-z]+|[A-Za-z0-9]", sub))
    return (1.8 * glyphs + 1.2 * small) / 2 + 0.1, 1.2


def _polar(centre: Point, radius: float, angle: float) -> Point:
    return centre[0] + radius * math.cos(angle), centre[1] + radius * math.sin(angle)


def _arc(centre: Point, radius: float, start: float, end: float) -> list[tuple[Point, Point, Point]]:
    """A circular arc as quadratic beziers of at most 30 degrees each: (start, control, end)."""
    pieces = max(1, math.ceil(abs(end - start) / (math.pi / 6) - 1e-9))
    step = (end - start) / pieces
    out = []
    for k in range(pieces):
        a, b = start + k * step, start + (k + 1) * step
        out.append((_polar(centre, radius, a), _polar(centre, radius / math.cos(step / 2), (a + b) / 2),
                    _polar(centre, radius, b)))
    return out


def _dashes(start: Point, angle: float, length: float) -> list[Segment]:
    on, off = DASH_MM
    out, s = [], 0.0
    while s < length - 0.25 * on:   # no stub of a dash at the end
        out.append((_polar(start, s, angle), _polar(start, min(s + on, length), angle)))
        s += on + off
    return out


def _covered(at: Point, angle: float, length: float, lines: Iterable[Segment]) -> bool:
    """Whether a drawn line leaves ``at`` in the direction ``angle`` for most of ``length``."""
    for a, b in lines:
        for p, other in ((a, b), (b, a)):
            if math.hypot(p[0] - at[0], p[1] - at[1]) > 0.3:
                continue
            along = math.hypot(other[0] - p[0], other[1] - p[1])
            direction = math.atan2(other[1] - p[1], other[0] - p[0])
            if along > 0.6 * length and abs(math.remainder(direction - angle, 2 * math.pi)) < math.radians(2):
                return True
    return False


def _first_segment(lines: list[Segment], at: Point, joint_points: dict[str, Point], children: list[str],
                   mm: Callable[[Point], Point], com: Point) -> float:
    """Length (mm) of the child link's shortest drawn segment leaving ``at``."""
    ends = [mm(joint_points[c]) for c in children] or [mm(com)]
    lengths = [math.hypot(e[0] - at[0], e[1] - at[1]) for e in ends]
    return min((length for length in lengths if length > 1e-6), default=0.0)


#: The slopes LaTeX's ``\\vector`` takes: coprime integers up to 4.
_SLOPES = [(a, b) for a in range(-4, 5) for b in range(-4, 5) if (a, b) != (0, 0) and math.gcd(a, b) == 1]


def _head(tip: Point, direction: float) -> tuple[Point, tuple[str, str]]:
    """An arrowhead at ``tip`` pointing along ``direction``: the nearest slope ``\\vector`` takes."""
    a, b = min(_SLOPES, key=lambda s: (abs(math.remainder(math.atan2(s[1], s[0]) - direction, 2 * math.pi)), s))
    return tip, (str(a), str(b))


def _configuration(robot: Any, table: Any, links: list[Any], values: dict[sympy.Symbol, float],
                   loops: Any) -> list[float]:
    """The drawn configuration: the assembled one for closed loops, else 30 degrees per
    revolute joint and a quarter of the robot's size (at q = 0) per prismatic one; for closed
    loops that for the independent coordinates, with the others assembled."""
    at_zero = {s: sympy.Float(v) for s, v in (values | {c: 0.0 for c in table.q}).items()}
    reach = max([r for r in (math.hypot(*(_float(e, at_zero) for e in link.com_world[:2])) for link in links)
                 if math.isfinite(r)] + [1e-3])
    kinds = {j.name: j.type for j in robot.joints}
    reference = [REFERENCE_ANGLE if kinds[name] == "revolute" else REFERENCE_TRAVEL * reach for name in robot.coordinates]
    if loops is None or not loops.assembled:
        return reference
    # the independent coordinates at the reference, the dependent ones assembled from the
    # default assembly (its branch); the default assembly itself where that fails
    start = [reference[i] if i in loops.independent else v for i, v in enumerate(loops.assembled)]
    found = _assemble(loops, table, values, start)
    return found if found is not None else [float(v) for v in loops.assembled]


def _assemble(loops: Any, table: Any, values: dict[sympy.Symbol, float], start: list[float]) -> list[float] | None:
    """``a_g(q) = 0`` solved for the dependent coordinates from ``start`` (Gauss-Newton, least
    squares steps), or None when it does not converge."""
    at = {s: sympy.Float(v) for s, v in values.items()}
    residual = sympy.lambdify([table.q], loops.constraints.xreplace(at), "numpy")
    jacobian = sympy.lambdify([table.q], loops.jacobian[:, list(loops.dependent)].xreplace(at), "numpy")
    q = np.array(start, dtype=float)
    for _ in range(50):
        r = np.asarray(residual(q), dtype=float).reshape(-1)
        if not np.all(np.isfinite(r)):
            return None
        if np.max(np.abs(r), initial=0.0) < 1e-12:
            return [float(v) for v in q]
        J = np.asarray(jacobian(q), dtype=float).reshape(len(r), -1)
        q[list(loops.dependent)] -= np.linalg.lstsq(J, r, rcond=None)[0]
    return None


def _float(expr: Any, at: dict[sympy.Symbol, sympy.Float]) -> float:
    """``expr`` at ``at``; NaN where it is not a finite real number (nothing to draw there)."""
    try:
        return float(sympy.sympify(expr).xreplace(at).evalf())
    except (TypeError, ValueError):
        return math.nan


def _value_text(value: float, kind: str) -> str:
    return f"{math.degrees(value):.0f}^\\circ" if kind == "revolute" else f"{value:.3g}"
