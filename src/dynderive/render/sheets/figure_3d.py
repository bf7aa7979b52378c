"""A kinematic diagram of a 3-D robot for the sheet (TikZ) and the HTML sheet (SVG).

An axonometric view (orthographic, from azimuth ``AZIMUTH`` and elevation ``ELEVATION``,
z up) of the robot at a reference configuration: the zero configuration, or for closed
loops the default assembly. Revolute joints are short cylinders along their axes (the axis
itself drawn through them), prismatic joints boxes along theirs, spherical loop joints
balls; links are bars from each link's joint origin to its children's joint origins (and to
the points where loops and named frames attach, a last link to its centre of mass); the
world is a hatched plate under its frame ``s`` (axes ``x_s``, ``y_s``, ``z_s``), the named
frames short axes. Solids are drawn from the farthest to the nearest.

The positions are computed numerically (NumPy) from the robot's joints as the engine
composes them: a joint frame is the parent's frame moved by the joint's origin (URDF
roll-pitch-yaw), the child's frame that one turned about (or moved along) the axis; the
parameters take their values (1 where a parameter has none).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import sympy

from ...derivation import Derivation
from ...input.urdf_values import axis_rotation
from ...model.joint_kinds import JOINT_KINDS
from ...model.robot import Robot
from ..encode import escape_tex
from .drawing import Drawing, Point, convex_hull, finish, joint_value_text, label_size

#: The view: azimuth of the viewer from the x axis (towards y) and elevation above the xy-plane.
AZIMUTH, ELEVATION = math.radians(30.0), math.radians(20.0)
#: Size of the robot in the drawing (mm): it is scaled to fit, keeping its proportions.
WIDTH_MM, HEIGHT_MM = 85.0, 60.0
#: A revolute joint's cylinder: radius and half length; a prismatic joint's box: half
#: length and half width; a ball joint's radius; the axes of the world frame and of a named
#: frame; the world's plate's half size (mm on the paper).
CYLINDER_MM, BOX_MM, BALL_MM = (2.0, 3.2), (3.6, 1.7), 2.0
AXIS_MM, FRAME_MM, PLATE_MM = 10.0, 6.0, 9.0
#: Points on a cylinder's circles.
SAMPLES = 36

Vector = np.ndarray


def view() -> tuple[Vector, Vector, Vector]:
    """The screen's right and up directions and the direction towards the viewer, in world axes."""
    towards = np.array([math.cos(ELEVATION) * math.cos(AZIMUTH), math.cos(ELEVATION) * math.sin(AZIMUTH),
                        math.sin(ELEVATION)])
    right = np.array([-math.sin(AZIMUTH), math.cos(AZIMUTH), 0.0])
    return right, np.cross(towards, right), towards


def spatial_kinematics(robot: Robot, table: Any, q: list[float],
                       joint_type: Callable[[Any], Any] = Derivation.joint_type) -> dict[str, Any] | None:
    """Every link's frame (rotation, origin), every joint's frame before its motion with its
    axis in world axes, every link's centre of mass, at ``q``; None when something is not a
    finite number (or the robot floats). ``joint_type``: a joint's type, for the placement of
    a joint of several coordinates."""
    values = {table.parameters[p.name]: sympy.Float(p.value if p.value is not None else 1.0) for p in robot.parameters}

    def num(entry: Any) -> float:
        try:
            return float(sympy.sympify(table.expr(entry)).xreplace(values).evalf())
        except (TypeError, ValueError):
            return math.nan

    index = {name: i for i, name in enumerate(robot.coordinates)}
    frames: dict[str, tuple[Vector, Vector]] = {"world": (np.eye(3), np.zeros(3))}
    joints: dict[str, tuple[Vector, Vector, Vector]] = {}
    todo = list(robot.joints)
    while todo:
        ready = [j for j in todo if j.parent in frames]
        if not ready or not all(j.kind.drawn for j in ready):
            return None
        for joint in ready:
            todo.remove(joint)
            R, p = frames[joint.parent]
            x, y, z, roll, pitch, yaw = (num(e) for e in joint.origin)
            R0, p0 = R @ rpy(roll, pitch, yaw), p + R @ np.array([x, y, z])
            axis = np.array([num(e) for e in joint.axis]) if joint.moves else np.array([0.0, 0.0, 1.0])
            axis = axis / (np.linalg.norm(axis) or 1.0)
            if joint.moves and joint.kind.screw is not None:   # its turn about and shift along the axis
                leader, multiplier, offset = robot.driver(joint)   # a <mimic> joint: multiplier * q_leader + offset
                value = multiplier * q[index[leader]] + offset
                geometry = dict(joint.geometry)
                turn, slide = (num(geometry.get(text, text)) * value for text in joint.kind.screw)
                frames[joint.child] = (R0 @ axis_rotation(axis, turn), p0 + R0 @ axis * slide)
            elif joint.moves:   # several coordinates (a universal joint): its type's placement at them
                start = index[joint.kind.names(joint.name)[0][0]]
                kind, entries = joint_type(joint), [sympy.Float(x) for x in q[start:start + joint.kind.nq]]
                unit_axis = tuple(sympy.Float(a) for a in axis)
                geometry = Derivation.joint_geometry(joint, lambda e: sympy.Float(num(e)))
                shift = kind.displacement(sympy.eye(3), entries, unit_axis, geometry)
                frames[joint.child] = (R0 @ np.array(kind.rotation(entries, unit_axis, geometry), dtype=float),
                                       p0 + (0.0 if shift is None else R0 @ np.array(shift, dtype=float).reshape(3)))
            else:
                frames[joint.child] = (R0, p0)
            joints[joint.name] = (R0, p0, R0 @ axis)
    coms = {link.name: frames[link.name][1] + frames[link.name][0] @ np.array([num(e) for e in link.com])
            for link in robot.links}
    numbers = [v for R, p in frames.values() for v in [*R.ravel(), *p]] + [v for c in coms.values() for v in c]
    if not all(map(math.isfinite, numbers)):
        return None
    return {"frames": frames, "joints": joints, "coms": coms, "num": num}


def rpy(roll: float, pitch: float, yaw: float) -> Vector:
    """URDF fixed-axis roll-pitch-yaw: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    return axis_rotation(np.array([0.0, 0.0, 1.0]), yaw) @ axis_rotation(np.array([0.0, 1.0, 0.0]), pitch) @ \
        axis_rotation(np.array([1.0, 0.0, 0.0]), roll)


def reference_configuration(derivation: Derivation) -> list[float]:
    """The drawn configuration: the default assembly for closed loops, else zero."""
    robot = derivation.robot
    if robot.loops:
        assembled = derivation.loop_model.assembled
        if assembled:
            return [float(v) for v in assembled]
    return [0.0] * len(robot.coordinates)


def spatial_figure(derivation: Derivation, fmt: Callable[[Any], str]) -> dict[str, Any] | None:
    """The kinematic diagram (``drawing.finish``'s dict with ``configuration``), or None for
    planar robots and robots that cannot be evaluated."""
    robot, table = derivation.robot, derivation.symbols
    if robot.planar or robot.floating:
        return None
    q = reference_configuration(derivation)
    kin = spatial_kinematics(robot, table, q)
    if kin is None:
        return None
    frames, joints, coms, num = kin["frames"], kin["joints"], kin["coms"], kin["num"]
    right, up, towards = view()

    # what each link joins: its joint origin to its children's, its loops' and frames' points
    reach: dict[str, list[Vector]] = {link.name: [] for link in robot.links}
    origin_of = {j.child: joints[j.name][1] for j in robot.joints}
    for joint in robot.joints:
        if joint.parent != "world":
            reach[joint.parent].append(joints[joint.name][1])
    loop_joints = []
    for loop in robot.loops:
        ends = []
        for side, origin in ((loop.parent, loop.origin), (loop.child, loop.child_origin)):
            values = [num(e) for e in origin] if origin else [0.0] * 6
            R, p = frames[side]
            ends.append((R @ rpy(*values[3:6]), p + R @ np.array(values[:3])))
            if side != "world":
                reach[side].append(ends[-1][1])
        axis = np.array([num(e) for e in loop.axis]) if loop.axis else np.array([0.0, 0.0, 1.0])
        loop_joints.append((loop, ends[0][1], ends[0][0] @ (axis / (np.linalg.norm(axis) or 1.0))))
    named = []
    for frame in robot.frames:
        values = [num(e) for e in frame.origin]
        R, p = frames[frame.link]
        named.append((frame.name, p + R @ np.array(values[:3]), R @ rpy(*values[3:6])))
        reach[frame.link].append(named[-1][1])
    for link in robot.links:
        if not reach[link.name]:
            reach[link.name].append(coms[link.name])
    points = [np.zeros(3), *origin_of.values(), *(p for ps in reach.values() for p in ps),
              *(p for loop, p, _ in loop_joints)]
    flat = np.array([[right @ p, up @ p] for p in points])
    span = flat.max(axis=0) - flat.min(axis=0)
    size = max(float(span.max()), 1e-9)
    scale = min(WIDTH_MM / max(span[0], size / 3), HEIGHT_MM / max(span[1], size / 3))
    if not math.isfinite(scale):
        return None

    def at(p: Vector) -> Point:
        return float(right @ p) * scale, float(up @ p) * scale

    sheet = Drawing()
    _plate(sheet, at, scale)
    solids: list[tuple[float, int, Callable[[], None]]] = []   # (depth, order, draw)
    reach["world"] = [joints[j.name][1] for j in robot.joints if j.parent == "world"]
    reach["world"] += [p for loop, p, _ in loop_joints if "world" in (loop.parent, loop.child)]
    origin_of["world"] = np.zeros(3)
    for link in ["world", *(link.name for link in robot.links)]:
        start = origin_of[link]
        for end in reach[link]:
            if np.linalg.norm(end - start) * scale > 0.05:
                def bar(a: Vector = start, b: Vector = end, name: str = link) -> None:
                    if name == "world":
                        sheet.path([at(a), at(b)], "rail")
                        return
                    sheet.path([at(a), at(b)], "edge", tag=name)
                    sheet.path([at(a), at(b)], "body", tag=name)
                solids.append((float(towards @ (start + end)) / 2, len(solids), bar))
    bars = len(solids)
    for joint in robot.joints:
        if joint.moves:
            _, p, axis = joints[joint.name]
            solids.append((float(towards @ p), len(solids),
                           lambda p=p, axis=axis, joint=joint: _joint(sheet, at, scale, p, axis, joint.kind.glyph, joint.name)))
    for loop, p, axis in loop_joints:
        solids.append((float(towards @ p), len(solids),
                       lambda p=p, axis=axis, loop=loop: _joint(sheet, at, scale, p, axis, JOINT_KINDS[loop.type].glyph, loop.name)))
    # the bars first, the joints over their ends; each from the farthest
    for _, _, draw in sorted(solids, key=lambda s: (s[1] >= bars, s[0], s[1])):
        draw()
    # the frames: the world's, then the named ones
    tips = []
    for k, name in enumerate("xyz"):
        tip = at(np.eye(3)[k] * AXIS_MM / scale)
        sheet.path([at(np.zeros(3)), tip], "axis", arrow=True)
        tips.append((tip, f"{name}_s"))
    for name, p, R in named:
        for k in range(3):
            sheet.path([at(p), at(p + R[:, k] * FRAME_MM / scale)], "axis", arrow=True, tag=name)
    # labels: the coordinates beside their joints, the frames' names beside their origins
    index = {name: i for i, name in enumerate(robot.coordinates)}
    for joint in robot.joints:
        if joint.moves and joint.kind.nq > 1:   # several coordinates (a universal joint): each
            start = index[joint.kind.names(joint.name)[0][0]]
            label = ", ".join(fmt(table.q[start + k]) for k in range(joint.kind.nq))
            _label(sheet, at(joints[joint.name][1]), CYLINDER_MM[1] + 0.8, label, joint.name)
        elif joint.moves:
            leader, multiplier, offset = robot.driver(joint)
            label = fmt(table.expr(multiplier) * table.q[index[leader]] + table.expr(offset))
            _label(sheet, at(joints[joint.name][1]), CYLINDER_MM[1] + 0.8, label, joint.name)
    for name, p, _ in named:
        _label(sheet, at(p), 1.5, r"\mathrm{" + escape_tex(name) + "}", name)
    origin = at(np.zeros(3))
    for tip, label in tips:
        w, h = label_size(label)
        dx, dy = tip[0] - origin[0], tip[1] - origin[1]
        length = math.hypot(dx, dy) or 1.0
        ux, uy = dx / length, dy / length
        sheet.label([(tip[0] + ux * (w + 0.8), tip[1] + uy * (h + 0.8)),
                     (tip[0] - uy * (w + 0.8), tip[1] + ux * (h + 0.8)),
                     (tip[0] + uy * (w + 0.8), tip[1] - ux * (h + 0.8))], label)
    zero = all(v == 0 for v in q)
    angle = {name: is_angle for j in robot.joints if j.owns   # coordinate -> whether an angle
             for name, is_angle in zip(j.kind.names(j.name)[0], j.kind.angle_entries)}
    configuration = ("q = 0" if zero else ", ".join(
        f"{fmt(c)} = {joint_value_text(v, j)}" for c, v, j in
        zip(table.q, q, (angle[n] for n in robot.coordinates))))
    what = f"its {'default assembly' if robot.loops else 'zero configuration'} ${configuration}$"
    view_text = f"azimuth ${math.degrees(AZIMUTH):.0f}^\\circ$, elevation ${math.degrees(ELEVATION):.0f}^\\circ$"
    anchors = {"world": at(np.zeros(3))} | {f"joint:{j.name}": at(joints[j.name][1]) for j in robot.joints}
    anchors |= {f"com:{name}": at(p) for name, p in coms.items()}
    return finish(sheet, f"The robot at {what}, seen from {view_text}.", anchors, configuration=configuration,
                  scale=scale, q=q,
                  view=(f"{math.degrees(AZIMUTH):.0f}", f"{math.degrees(ELEVATION):.0f}"))



def _basis(axis: Vector) -> tuple[Vector, Vector]:
    """Two unit vectors perpendicular to ``axis`` and to each other."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def _joint(sheet: Drawing, at: Callable[[Vector], Point], scale: float, p: Vector, axis: Vector, glyph: str,
           name: str) -> None:
    """A joint's symbol (its type's ``glyph``) at ``p`` along ``axis`` (world units; sizes in mm
    on the paper)."""
    towards = view()[2]
    e1, e2 = _basis(axis)
    if glyph == "ball":
        centre = at(p)
        sheet.circle(centre, BALL_MM, "shade", tag=name)
        sheet.circle((centre[0] - 0.6, centre[1] + 0.6), 0.5, "joint", tag=name)
        return
    if glyph == "box":
        half, width = BOX_MM[0] / scale, BOX_MM[1] / scale
        sheet.path([at(p - axis * (half + 2.0 / scale)), at(p + axis * (half + 2.0 / scale))], "thin")
        corners = [p + sa * half * axis + s1 * width * e1 + s2 * width * e2
                   for sa in (-1, 1) for s1 in (-1, 1) for s2 in (-1, 1)]
        sheet.path(convex_hull([at(c) for c in corners]), "shade", closed=True, tag=name)
        nearest = max(range(8), key=lambda k: (float(towards @ corners[k]), -k))
        for k in range(8):   # the three edges from the corner nearest the viewer
            if bin(k ^ nearest).count("1") == 1:
                sheet.path([at(corners[nearest]), at(corners[k])], "thin")
        return
    radius, half = CYLINDER_MM[0] / scale, CYLINDER_MM[1] / scale
    sheet.path([at(p - axis * (half + 2.5 / scale)), at(p + axis * (half + 2.5 / scale))], "thin")
    turns = [2 * math.pi * k / SAMPLES for k in range(SAMPLES)]
    caps = [[at(p + side * half * axis + radius * (math.cos(t) * e1 + math.sin(t) * e2)) for t in turns]
            for side in (-1.0, 1.0)]
    sheet.path(convex_hull(caps[0] + caps[1]), "shade", closed=True, tag=name)
    front = caps[1] if float(towards @ axis) >= 0 else caps[0]
    sheet.path(front, "joint", closed=True, tag=name)


def _plate(sheet: Drawing, at: Callable[[Vector], Point], scale: float) -> None:
    """The world: a hatched square in the xy-plane around the origin."""
    h = PLATE_MM / scale
    corners = [np.array([sx * h, sy * h, 0.0]) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    sheet.path([at(c) for c in corners], "ground", closed=True)
    for k in range(1, 8):   # diagonals u + v = c across the square
        c = -2 * h + 4 * h * k / 8
        ends = [(-h, c + h), (c + h, -h)] if c <= 0 else [(c - h, h), (h, c - h)]
        sheet.path([at(np.array([u, v, 0.0])) for u, v in ends], "hatch")


def _label(sheet: Drawing, centre: Point, gap: float, label: str, tag: str) -> None:
    w, h = label_size(label)
    turns = [math.radians(turn) for turn in (30, 150, -30, -150, 90, -90, 0, 180)]
    sheet.label([(centre[0] + (gap + extra + w) * math.cos(t), centre[1] + (gap + extra + h) * math.sin(t))
                 for extra in (0.0, 2.5, 5.0) for t in turns], label, tag=tag)
