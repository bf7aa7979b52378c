"""A drawing of a planar robot for the sheet (TikZ) and the HTML sheet (SVG), at a reference
configuration.

Each link is a body: the convex hull of its joint point, its children's joint points, the
points where loops and named frames attach to it, and its centre of mass, drawn as a
rounded bar or plate with an outline (``drawing``), so a centre of mass always lies on its
link. Revolute joints are small circles, prismatic joints a block on a guide (the guide
hatched when it is the world's), the world's pivots a hatched pedestal, the world frame
``s`` two arrows ``x_s``, ``y_s``, the named frames short arrows. Each coordinate is drawn as
what it measures: a revolute joint's as an arc (with an arrowhead) from the joint frame's
zero direction (a dashed line, unless a link or axis already lies there) to the child
link's x-direction, a prismatic joint's as an arrow beside its axis over the travel. Labels
go where they clear what is drawn (a few candidate places, the first clear one).

The configuration is 30 degrees at every revolute joint and a quarter of the robot's size
along every prismatic one; a robot with closed loops has its independent coordinates there
and the others assembled from its default assembly (that assembly itself if they cannot
be), its loops drawn closed.

>>> figure = planar_figure(derivation, fmt)        # doctest: +SKIP
>>> figure["configuration"]                         # doctest: +SKIP
'q_{1} = 30^\\circ, q_{2} = 30^\\circ'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import sympy

from ...derivation import Derivation
from ...model.robot import Robot
from ..encode import escape_tex
from .drawing import Drawing, Point, Segment, convex_hull, finish, joint_value_text, label_size, polar
from .figure_3d import spatial_figure

#: Size of the robot in the drawing (mm): it is scaled to fit, keeping its proportions.
WIDTH_MM, HEIGHT_MM = 80.0, 50.0
#: Revolute joints' angle in the drawing.
REFERENCE_ANGLE = math.pi / 6
#: Prismatic joints' travel in the drawing, as a fraction of the robot's size.
REFERENCE_TRAVEL = 0.25
#: Radius of a revolute coordinate's arc, length of the world frame's axes, distance of a
#: prismatic coordinate's arrow from its axis (mm).
ARC_MM, AXIS_MM, OFFSET_MM = 9.0, 10.0, 3.5
#: Length of a named frame's axes (``frames:``).
FRAME_MM = 6.0
#: Dashes of a reference line: on, off (mm).
DASH_MM = (1.2, 0.8)
#: Radius of a revolute joint's circle, of the centre-of-mass symbol; half length and half
#: width of a prismatic joint's block (mm).
JOINT_MM, COM_MM, BLOCK_MM = 1.1, 0.9, (2.6, 1.6)


def sheet_figure(derivation: Derivation, fmt: Callable[[Any], str]) -> dict[str, Any] | None:
    """The sheet's drawing: the planar drawing, or a 3-D robot's kinematic diagram
    (``figure_3d``); None when the robot cannot be drawn."""
    if derivation.robot.planar:
        return planar_figure(derivation, fmt)
    return spatial_figure(derivation, fmt)


def planar_figure(derivation: Derivation, fmt: Callable[[Any], str]) -> dict[str, Any] | None:
    """The drawing (``drawing.finish``'s dict, with ``configuration``: the drawn coordinates
    as LaTeX), or None for 3-D robots and robots that cannot be evaluated at the parameters'
    values (a parameter without one is taken as 1)."""
    robot, table = derivation.robot, derivation.symbols
    if not robot.planar:
        return None
    values: dict[sympy.Symbol, float] = {table.parameters[p.name]: (p.value if p.value is not None else 1.0)
                                         for p in robot.parameters}
    links = derivation.link_kinematics
    loops = derivation.loop_model if robot.loops else None
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

    def on(link: str, local: Point) -> Point:
        base, phi = joint_points[link], angles[link]
        return (base[0] + math.cos(phi) * local[0] - math.sin(phi) * local[1],
                base[1] + math.sin(phi) * local[0] + math.cos(phi) * local[1])

    # each link's body: its joint, its children's joints, its loop and frame points, its COM
    body: dict[str, list[Point]] = {link.name: [joint_points[link.name], coms[link.name]] for link in links}
    for joint in robot.joints:
        if joint.parent != "world":
            body[joint.parent].append(joint_points[joint.child])
    loop_points: list[tuple[Point, bool]] = []   # (where, on the world)
    for loop in robot.loops:
        ends = []
        for side, origin in ((loop.parent, loop.origin), (loop.child, loop.child_origin)):
            local = (written(origin[0]), written(origin[1])) if origin else (0.0, 0.0)
            ends.append(local if side == "world" else on(side, local))
            if side != "world":
                body[side].append(ends[-1])
        loop_points.append((ends[0], "world" in (loop.parent, loop.child)))
    named = []   # the robot's frames: (name, origin, angle)
    for frame in robot.frames:
        fx, fy, ftheta = (written(e) for e in frame.origin[:3])
        point = on(frame.link, (fx, fy))
        named.append((frame.name, point, angles[frame.link] + ftheta))
        body[frame.link].append(point)
    index = {name: i for i, name in enumerate(robot.coordinates)}
    by_name = {j.name: j for j in robot.joints}
    world = [joint_points[j.child] for j in robot.joints if j.parent == "world" and not j.kind.slides]
    world += [p for p, grounded in loop_points if grounded]
    points = [p for ps in body.values() for p in ps] + [(0.0, 0.0)]
    left, right = min(p[0] for p in points), max(p[0] for p in points)
    bottom, top = min(p[1] for p in points), max(p[1] for p in points)
    size = max(right - left, top - bottom, 1e-9)
    scale = min(WIDTH_MM / max(right - left, size / 4), HEIGHT_MM / max(top - bottom, size / 4))
    if not math.isfinite(scale):
        return None

    def mm(p: Point) -> Point:
        return p[0] * scale, p[1] * scale

    sheet = Drawing()
    # the world: a hatched pedestal under each pivot, a hatched guide under each slider
    slides = []
    for joint in robot.joints:
        if not joint.kind.slides:
            continue
        axis = [written(e) for e in joint.axis[:2]]
        norm = math.hypot(*axis) or 1.0
        phi = angles[joint.child] + math.atan2(axis[1] / norm, axis[0] / norm)
        tip = mm(joint_points[joint.child])
        travel = q[index[joint.name]] * scale
        tail = (tip[0] - travel * math.cos(phi), tip[1] - travel * math.sin(phi))
        slides.append((joint, phi, tail, tip))
    for joint, phi, _, tip in slides:
        if joint.parent == "world":   # the guide around the block
            a, b = polar(tip, -BLOCK_MM[0] - 6.0, phi), polar(tip, BLOCK_MM[0] + 6.0, phi)
            _ground(sheet, a, b, phi - math.pi / 2, BLOCK_MM[1])
    for base in world:
        x, y = mm(base)
        sheet.path([(x, y), (x - 2.2, y - 3.6), (x + 2.2, y - 3.6)], "ground", closed=True)
        _ground(sheet, (x - 4.0, y - 3.6), (x + 4.0, y - 3.6), -math.pi / 2, 0.0)
    # the links, each over its parent; the guides of the sliders on them
    for link in links:
        hull = convex_hull([mm(p) for p in body[link.name]])
        if len(hull) >= 2:
            sheet.path(hull, "edge", closed=True, tag=link.name)
            sheet.path(hull, "body", closed=True, tag=link.name)
    for joint, phi, tail, _ in slides:
        if joint.parent != "world":
            low, high = sorted((0.0, q[index[joint.name]] * scale))
            sheet.path([polar(tail, low - 1.0, phi), polar(tail, high + BLOCK_MM[0] + 1.5, phi)], "rail")
    # the joints and the centres of mass
    for joint, phi, _, tip in slides:
        u, v = (math.cos(phi), math.sin(phi)), (-math.sin(phi), math.cos(phi))
        sheet.path([(tip[0] + su * BLOCK_MM[0] * u[0] + sv * BLOCK_MM[1] * v[0],
                     tip[1] + su * BLOCK_MM[0] * u[1] + sv * BLOCK_MM[1] * v[1])
                    for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))], "joint", closed=True, tag=joint.name)
    for joint in robot.joints:
        if joint.kind.angle:
            sheet.circle(mm(joint_points[joint.child]), JOINT_MM, "joint", tag=joint.name)
    for p, _ in loop_points:
        sheet.circle(mm(p), JOINT_MM, "joint", tag="loop")
    for link in links:
        sheet.com(mm(coms[link.name]), COM_MM, tag=link.name)
    # the world frame s: axes of AXIS_MM, shorter or longer where a joint or COM would sit on a tip
    origin = mm((0.0, 0.0))
    marks = [mm(p) for p in [*joint_points.values(), *coms.values()]]
    lengths = []
    for unit in ((1.0, 0.0), (0.0, 1.0)):
        lengths.append(next((length for length in (AXIS_MM, 0.7 * AXIS_MM, 1.3 * AXIS_MM, 0.5 * AXIS_MM)
                             if all(math.hypot(m[0] - origin[0] - length * unit[0], m[1] - origin[1] - length * unit[1]) > 3.0
                                    for m in marks)), AXIS_MM))
    x_tip, y_tip = (origin[0] + lengths[0], origin[1]), (origin[0], origin[1] + lengths[1])
    sheet.path([origin, x_tip], "axis", arrow=True)
    sheet.path([origin, y_tip], "axis", arrow=True)
    for name, point, angle in named:   # short axes x, y of each named frame
        for k in (0, 1):
            arrow_tip = polar(mm(point), FRAME_MM, angle + k * math.pi / 2)
            sheet.path([mm(point), arrow_tip], "axis", arrow=True, tag=name)

    # the coordinates (arcs, reference lines, arrows), then their labels
    links_mm = [(mm(joint_points[link.name]), mm(p)) for link in links for p in body[link.name][1:]]
    children: dict[str, list[str]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint.child)
    places: list[tuple[list[Point], str, str]] = []
    for joint in robot.joints:
        if not joint.moves:
            continue
        value = q[index[joint.name]]
        label = fmt(table.q[index[joint.name]])
        w, h = label_size(label)
        centre = mm(joint_points[joint.child])
        if joint.kind.angle:
            end = angles[joint.child]
            start = end - value
            first = _first_segment(centre, [mm(p) for p in body[joint.child][1:]])
            radius = max(min(ARC_MM, 0.45 * first) if first > 0 else ARC_MM, 4.0)
            sheet.arc(centre, radius, start, end, tag=joint.name)
            length = radius + 4.0
            if not _covered(centre, start, length, links_mm + [(origin, x_tip), (origin, y_tip)]):
                for dash in _dashes(centre, start, length):
                    sheet.path(list(dash), "dashed", tag=joint.name)
            sign = 1.0 if end >= start else -1.0
            mid = (start + end) / 2
            # in the wedge beyond the arc, else beside it, else opposite
            turns = [end + sign * 0.35, start - sign * 0.35, end + sign * 0.7, start - sign * 0.7,
                     mid + math.pi, end + sign * 1.2, start - sign * 1.2]
            tries = [(mid, extra) for extra in (0.6, 2.0, 3.5)] + [(t, extra) for extra in (0.6, 2.0) for t in turns]
            places.append(([polar(centre, radius + extra + abs(w * math.cos(t)) + abs(h * math.sin(t)), t)
                            for t, extra in tries], label, joint.name))
        else:
            _, phi, tail, tip = next(s for s in slides if s[0] is joint)
            # beside the axis: the nearest offset on either side that clears what is drawn
            sides = []
            for offset in (OFFSET_MM + BLOCK_MM[1], OFFSET_MM + BLOCK_MM[1] + 2.5, OFFSET_MM + BLOCK_MM[1] + 5.0):
                for side in (1.0, -1.0):
                    nx, ny = -math.sin(phi) * side * offset, math.cos(phi) * side * offset
                    arrow = ((tail[0] + nx, tail[1] + ny), (tip[0] + nx, tip[1] + ny))
                    sides.append((sheet.clearance_of_segment(arrow), offset, side, arrow))
            _, offset, side, arrow = next((c for c in sides if c[0] >= 1.2), max(sides, key=lambda c: c[0]))
            nx, ny = -math.sin(phi) * side, math.cos(phi) * side
            if math.hypot(arrow[1][0] - arrow[0][0], arrow[1][1] - arrow[0][1]) > 1.0:
                sheet.path(list(arrow), "thin", arrow=True, tag=joint.name)
            for p in (tail, tip):
                sheet.path([(p[0] + (BLOCK_MM[1] + 0.5) * nx, p[1] + (BLOCK_MM[1] + 0.5) * ny),
                            (p[0] + (offset + 1.0) * nx, p[1] + (offset + 1.0) * ny)], "thin", tag=joint.name)
            reach = offset + 1.0 + abs(w * nx) + abs(h * ny)
            places.append(([(tail[0] + f * (tip[0] - tail[0]) + (reach + extra) * nx,
                             tail[1] + f * (tip[1] - tail[1]) + (reach + extra) * ny)
                            for extra in (0.0, 2.5) for f in (0.5, 0.3, 0.7)], label, joint.name))
    for candidates, label, tag in places:
        sheet.label(candidates, label, tag=tag)
    for name, point, angle in named:   # the frame's name in the quadrant its axes leave free
        label = r"\mathrm{" + escape_tex(name) + "}"
        w, h = label_size(label)
        sheet.label([polar(mm(point), 1.5 + math.hypot(w, h), angle + turn)
                     for turn in (-3 * math.pi / 4, math.pi + math.pi / 4, -math.pi / 4, 3 * math.pi / 4)], label,
                    tag=name)
    w, h = label_size("x_s")
    sheet.label([(x_tip[0] + 0.8 + w, x_tip[1]), (x_tip[0] - w, x_tip[1] - 0.8 - h),
                 (x_tip[0] - w, x_tip[1] + 0.8 + h), (x_tip[0] + 0.8 + w, x_tip[1] - 0.8 - h)], "x_s")
    sheet.label([(y_tip[0], y_tip[1] + 0.8 + h), (y_tip[0] - 0.8 - w, y_tip[1] - h),
                 (y_tip[0] + 0.8 + w, y_tip[1] - h)], "y_s")
    configuration = ", ".join(f"{fmt(c)} = {joint_value_text(v, j.kind.angle)}"
                              for c, v, j in zip(table.q, q, (by_name[n] for n in robot.coordinates)))
    anchors = {"world": origin} | {f"joint:{j.name}": mm(joint_points[j.child]) for j in robot.joints}
    anchors |= {f"com:{link.name}": mm(coms[link.name]) for link in links}
    anchors |= {f"loop:{loop.name}": mm(p) for loop, (p, _) in zip(robot.loops, loop_points)}
    return finish(sheet, f"The robot at ${configuration}$" + (", its loops closed." if robot.loops else "."),
                  anchors, configuration=configuration, scale=scale, q=q)


def _ground(sheet: Drawing, a: Point, b: Point, down: float, gap: float) -> None:
    """The world along ``a``-``b``: a line ``gap`` below it (towards ``down``) and hatches beyond."""
    ox, oy = gap * math.cos(down), gap * math.sin(down)
    a, b = (a[0] + ox, a[1] + oy), (b[0] + ox, b[1] + oy)
    sheet.path([a, b], "ground")
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    dx, dy = 1.4 * math.cos(down), 1.4 * math.sin(down)
    count = max(2, int(length / 1.6))
    for k in range(count + 1):
        s = 0.5 + (length - 1.0) * k / count
        p = (a[0] + s * ux, a[1] + s * uy)
        sheet.path([p, (p[0] + dx - 1.0 * ux, p[1] + dy - 1.0 * uy)], "hatch")


def _dashes(start: Point, angle: float, length: float) -> list[Segment]:
    on, off = DASH_MM
    out, s = [], 0.0
    while s < length - 0.25 * on:   # no stub of a dash at the end
        out.append((polar(start, s, angle), polar(start, min(s + on, length), angle)))
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


def _first_segment(at: Point, ends: list[Point]) -> float:
    """Length (mm) of the child link's shortest reach from ``at`` to its other points."""
    lengths = [math.hypot(e[0] - at[0], e[1] - at[1]) for e in ends]
    return min((length for length in lengths if length > 1e-6), default=0.0)


def _configuration(robot: Robot, table: Any, links: list[Any], values: dict[sympy.Symbol, float],
                   loops: Any) -> list[float]:
    """The drawn configuration: the assembled one for closed loops, else 30 degrees per
    revolute joint and a quarter of the robot's size (at q = 0) per prismatic one; for closed
    loops that for the independent coordinates, with the others assembled."""
    at_zero = {s: sympy.Float(v) for s, v in (values | {c: 0.0 for c in table.q}).items()}
    reach = max([r for r in (math.hypot(*(_float(e, at_zero) for e in link.com_world[:2])) for link in links)
                 if math.isfinite(r)] + [1e-3])
    angle = {j.name: j.kind.angle for j in robot.joints}
    reference = [REFERENCE_ANGLE if angle[name] else REFERENCE_TRAVEL * reach for name in robot.coordinates]
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

