"""A drawing of a planar robot for the sheet, at a reference configuration.

LaTeX's own ``picture`` environment draws it (straight lines of any slope as ``\\qbezier``
with the midpoint as control point, circles, labels): no TikZ, which a minimal TeX install
lacks. Links are drawn from their joint point to their children's joint points (a last link
to its centre of mass), moving joints as circles labelled with their coordinate, centres of
mass as dots, the world's joints on a hatched base. The configuration is 30 degrees at every
revolute joint and a quarter of the robot's size along every prismatic one; a robot with
closed loops is drawn at its assembled configuration, its loop joints included.

>>> figure = planar_figure(derivation, fmt)        # doctest: +SKIP
>>> figure["segments"][0], figure["configuration"]  # doctest: +SKIP
(('10.0', '5.0', '27.3', '15.0'), 'q_{1} = 30^\\circ, ...')
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import sympy

#: Size of the drawing (mm): the robot is scaled to fit, keeping its proportions.
WIDTH_MM, HEIGHT_MM = 75.0, 45.0
#: Revolute joints' angle in the drawing.
REFERENCE_ANGLE = math.pi / 6
#: Prismatic joints' travel in the drawing, as a fraction of the robot's size.
REFERENCE_TRAVEL = 0.25


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

    def point(vector: sympy.Matrix) -> tuple[float, float]:
        x, y = (float(sympy.sympify(e).xreplace(at).evalf()) for e in vector[:2])
        return x, y

    joint_points = {link.name: point(link.joint_origin) for link in links}
    coms = {link.name: point(link.com_world) for link in links}
    angles = {link.name: float(sympy.sympify(link.angle).xreplace(at).evalf()) for link in links}
    segments: list[tuple[tuple[float, float], tuple[float, float]]] = []
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
            if side == "world":
                x, y = (float(table.expr(e).xreplace(at).evalf()) for e in origin[:2])
                ends.append((x, y))
                continue
            ox, oy = (float(table.expr(e).xreplace(at).evalf()) for e in origin[:2])
            base, phi = joint_points[side], angles[side]
            ends.append((base[0] + math.cos(phi) * ox - math.sin(phi) * oy, base[1] + math.sin(phi) * ox + math.cos(phi) * oy))
            segments.append((base, ends[-1]))
        loop_points.append(ends[0])
    moving = {j.child: table.q[robot.coordinates.index(j.name)] for j in robot.joints if j.moves}
    by_name = {j.name: j for j in robot.joints}
    world = [joint_points[j.child] for j in robot.joints if j.parent == "world"]
    points = [p for s in segments for p in s] + list(coms.values()) + world
    left, right = min(p[0] for p in points), max(p[0] for p in points)
    bottom, top = min(p[1] for p in points), max(p[1] for p in points)
    size = max(right - left, top - bottom, 1e-9)
    scale = min(WIDTH_MM / max(right - left, size / 4), HEIGHT_MM / max(top - bottom, size / 4))
    margin = 8.0

    def mm(p: tuple[float, float]) -> tuple[str, str]:
        return f"{(p[0] - left) * scale + margin:.1f}", f"{(p[1] - bottom) * scale + margin:.1f}"

    joints = []
    for joint in robot.joints:
        if not joint.moves:
            continue
        at_x, at_y = mm(joint_points[joint.child])
        joints.append({"x": at_x, "y": at_y, "label": fmt(moving[joint.child]), "prismatic": joint.type == "prismatic"})
    return {
        "width": f"{(right - left) * scale + 2 * margin:.1f}", "height": f"{(top - bottom) * scale + 2 * margin:.1f}",
        "segments": [(*mm(a), *mm(((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)), *mm(b)) for a, b in segments
                     if abs(a[0] - b[0]) + abs(a[1] - b[1]) > 1e-9 * size],
        "joints": joints, "coms": [mm(c) for c in coms.values()], "bases": [mm(w) for w in world],
        "loops": [mm(p) for p in loop_points],
        "configuration": ", ".join(f"{fmt(c)} = {_value_text(v, j.type)}"
                                   for c, v, j in zip(table.q, q, (by_name[n] for n in robot.coordinates))),
    }


def _configuration(robot: Any, table: Any, links: list[Any], values: dict[sympy.Symbol, float],
                   loops: Any) -> list[float]:
    """The drawn configuration: the assembled one for closed loops, else 30 degrees per
    revolute joint and a quarter of the robot's size (at q = 0) per prismatic one."""
    if loops is not None and loops.assembled:
        return [float(v) for v in loops.assembled]
    at_zero = {s: sympy.Float(v) for s, v in (values | {c: 0.0 for c in table.q}).items()}
    reach = max([math.hypot(*(float(sympy.sympify(e).xreplace(at_zero).evalf()) for e in link.com_world[:2]))
                 for link in links] + [1e-3])
    kinds = {j.name: j.type for j in robot.joints}
    return [REFERENCE_ANGLE if kinds[name] == "revolute" else REFERENCE_TRAVEL * reach for name in robot.coordinates]


def _value_text(value: float, kind: str) -> str:
    return f"{math.degrees(value):.0f}^\\circ" if kind == "revolute" else f"{value:.3g}"
