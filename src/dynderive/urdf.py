"""Read URDF files into the same plain data as a robot YAML file.

Uses the standard library's XML parser (no maintained pure-Python URDF parser keeps source
lines; errors must point at the element's line), with DTDs and entities refused. The URDF
becomes the data of a version-1 robot file, with every value mapped to its element's line,
and goes through the same validator as YAML; ``dynderive import`` writes that data as YAML.

Conventions: the root link is welded to the world (its inertia never enters M(q)), so it
becomes ``world``; ``continuous`` joints are revolute; ``fixed`` joints are merged into the
parent link (mass, centre of mass and inertia combined), so every remaining link moves;
inertial frames with ``rpy`` are rotated into the link axes; efforts are named ``tau_<joint>``
(revolute) and ``f_<joint>`` (prismatic); gravity is ``[0, 0, -g]`` with ``g = 9.81``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any
from xml.parsers import expat

import numpy as np

from .errors import InputError, Problem
from .loader import SourceDocument

Path_ = tuple[Any, ...]


@dataclass
class _Element:
    tag: str
    attrib: dict[str, str]
    line: int
    column: int
    children: list[_Element] = field(default_factory=list)

    def find(self, tag: str) -> _Element | None:
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag: str) -> list[_Element]:
        return [c for c in self.children if c.tag == tag]


def _parse_xml(text: str, file: str) -> _Element:
    """Parse XML with expat, keeping each element's line and column; no DTDs or entities."""
    parser = expat.ParserCreate()
    stack: list[_Element] = []
    roots: list[_Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = _Element(tag, dict(attrs), parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    def refuse(*_: Any) -> None:
        raise ValueError("DTDs and entities are not allowed in URDF files")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code)
        raise InputError(Problem(file, exc.lineno, exc.offset + 1, f"malformed XML: {message}")) from None
    except ValueError as exc:
        raise InputError(Problem(file, parser.CurrentLineNumber, 1, str(exc))) from None
    if not roots:
        raise InputError(Problem(file, 1, 1, "empty XML document"))
    return roots[0]


class _Reader:
    def __init__(self, file: str):
        self.file = file
        self.problems: list[Problem] = []

    def error(self, element: _Element, message: str) -> None:
        self.problems.append(Problem(self.file, element.line, element.column, message))

    def numbers(self, element: _Element | None, attribute: str, count: int, default: list[float]) -> list[float]:
        if element is None or attribute not in element.attrib:
            return list(default)
        parts = element.attrib[attribute].split()
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != count or not all(math.isfinite(v) for v in values):
            self.error(element, f"<{element.tag} {attribute}=\"{element.attrib[attribute]}\">: expected "
                       f"{count} finite number{'s' * (count > 1)}")
            return list(default)
        return values


def _rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _to_rpy(R: np.ndarray) -> list[float]:
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(math.cos(pitch)) < 1e-12:  # gimbal lock: put everything in yaw
        return [0.0, pitch, math.atan2(-R[0, 1], R[1, 1])]
    return [math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])]


def _number(value: float) -> float | int:
    """A float as written in the source (shortest round-trip form), integers as integers."""
    value = float(value)
    if abs(value) < 1e-15:
        return 0
    return int(value) if value == int(value) and abs(value) < 1e15 else value


def _angle(value: float) -> float | int | str:
    """An angle; within 1e-9 of a multiple of pi/2 it is taken as exact (``pi/2``)."""
    value = float(value)
    quarter = round(value / (math.pi / 2))
    if abs(value - quarter * math.pi / 2) > 1e-9:
        return _number(value)
    return {0: 0, 1: "pi/2", -1: "-pi/2", 2: "pi", -2: "-pi"}.get(quarter, f"{quarter}*pi/2")


@dataclass
class _Body:
    mass: float
    com: np.ndarray        # in the link frame
    inertia: np.ndarray    # about the COM, link axes
    element: _Element


def identifier(name: str) -> str:
    cleaned = re.sub(r"\W", "_", name)
    return cleaned if re.match(r"[A-Za-z_]", cleaned) else f"r_{cleaned}"


def read_urdf(text: str, file: str) -> SourceDocument:
    """URDF text -> the data of an equivalent robot file, with positions for every value."""
    root = _parse_xml(text, file)
    reader = _Reader(file)
    doc = SourceDocument(file=file, data=None)
    if root.tag != "robot":
        raise InputError(Problem(file, root.line, root.column, f"expected a <robot> element, got <{root.tag}>"))
    bodies: dict[str, _Body] = {}
    link_elements: dict[str, _Element] = {}
    for link in root.findall("link"):
        name = link.attrib.get("name")
        if not name:
            reader.error(link, "<link> without a name")
            continue
        if name in link_elements:
            reader.error(link, f"duplicate link name '{name}'")
            continue
        link_elements[name] = link
        inertial = link.find("inertial")
        if inertial is None:
            continue
        origin = inertial.find("origin")
        xyz = reader.numbers(origin, "xyz", 3, [0, 0, 0])
        rpy = reader.numbers(origin, "rpy", 3, [0, 0, 0])
        mass_element = inertial.find("mass")
        inertia_element = inertial.find("inertia")
        if mass_element is None or inertia_element is None:
            reader.error(inertial, f"link '{name}': <inertial> needs <mass> and <inertia>")
            continue
        mass = reader.numbers(mass_element, "value", 1, [0])[0]
        values = [reader.numbers(inertia_element, key, 1, [0])[0]
                  for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")]
        ixx, ixy, ixz, iyy, iyz, izz = values
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        R = _rpy(*rpy)
        bodies[name] = _Body(mass, np.array(xyz), R @ tensor @ R.T, inertial)

    joints: list[dict[str, Any]] = []
    for joint in root.findall("joint"):
        name = joint.attrib.get("name", "")
        jtype = joint.attrib.get("type", "")
        parent = (joint.find("parent") or _Element("parent", {}, joint.line, joint.column)).attrib.get("link")
        child = (joint.find("child") or _Element("child", {}, joint.line, joint.column)).attrib.get("link")
        if joint.find("mimic") is not None:
            reader.error(joint.find("mimic"), f"joint '{name}': <mimic> joints are not supported")  # type: ignore[arg-type]
            continue
        if jtype in ("floating", "planar"):
            reader.error(joint, f"joint '{name}': {jtype} joints are not supported (only revolute, "
                         "continuous, prismatic and fixed)")
            continue
        if jtype not in ("revolute", "continuous", "prismatic", "fixed"):
            reader.error(joint, f"joint '{name}': unknown joint type '{jtype}'")
            continue
        if not parent or not child:
            reader.error(joint, f"joint '{name}': needs <parent link=...> and <child link=...>")
            continue
        for role, link_name in (("parent", parent), ("child", child)):
            if link_name not in link_elements:
                reader.error(joint.find(role) or joint, f"joint '{name}': unknown {role} link '{link_name}'")
        origin = joint.find("origin")
        joints.append({
            "element": joint, "name": name, "type": "revolute" if jtype == "continuous" else jtype,
            "parent": parent, "child": child,
            "xyz": np.array(reader.numbers(origin, "xyz", 3, [0, 0, 0])),
            "R": _rpy(*reader.numbers(origin, "rpy", 3, [0, 0, 0])),
            "axis": reader.numbers(joint.find("axis"), "xyz", 3, [1, 0, 0]),
            "axis_element": joint.find("axis") or joint,
        })
    if reader.problems:
        raise InputError(reader.problems)

    children = {j["child"] for j in joints}
    roots = [name for name in link_elements if name not in children]
    if len(roots) != 1:
        where = root if not roots else link_elements[roots[1]]
        raise InputError(Problem(file, where.line, where.column,
                                 f"a URDF robot needs exactly one root link, found {len(roots)}"
                                 + (f" ({', '.join(roots)})" if roots else "")))
    base = roots[0]

    # merge fixed joints into their parent (world for the root), children first
    owner = {name: name for name in link_elements}   # link -> the moving link it is merged into
    offset = {name: (np.eye(3), np.zeros(3)) for name in link_elements}  # frame of link in its owner
    by_child = {j["child"]: j for j in joints}

    def resolve(name: str) -> tuple[str, np.ndarray, np.ndarray]:
        if name == base:
            return "world", np.eye(3), np.zeros(3)
        joint = by_child[name]
        if joint["type"] != "fixed":
            return name, np.eye(3), np.zeros(3)
        parent_owner, R0, p0 = resolve(joint["parent"])
        return parent_owner, R0 @ joint["R"], R0 @ joint["xyz"] + p0

    merged: dict[str, _Body] = {}
    for name in link_elements:
        target, R, p = resolve(name)
        owner[name], offset[name] = target, (R, p)
        if target == "world" or name not in bodies:
            continue
        body = bodies[name]
        com = R @ body.com + p
        inertia = R @ body.inertia @ R.T
        if target not in merged:
            merged[target] = _Body(body.mass, com, inertia, body.element)
        else:
            merged[target] = _combine(merged[target], _Body(body.mass, com, inertia, body.element))

    data: dict[str, Any] = {
        "name": identifier(root.attrib.get("name", "robot")),
        "title": root.attrib.get("name", "robot"),
        "planar": False,
        "parameters": {"g": {"value": 9.81, "unit": "m/s^2", "description": "gravitational acceleration"}},
        "gravity": [0, 0, "-g"],
        "links": [],
        "joints": [],
    }
    positions: dict[Path_, tuple[int, int]] = {(): (root.line, root.column)}
    for key in ("name", "title", "planar", "parameters", "gravity", "links", "joints"):
        positions[(key,)] = (root.line, root.column)
    moving = [j for j in joints if j["type"] != "fixed"]
    for index, joint in enumerate(moving):
        name = joint["child"]
        element = link_elements[name]
        body = merged.get(name)
        path = ("links", index)
        positions[path] = (element.line, element.column)
        if body is None:
            reader.error(element, f"link '{name}' moves (joint '{joint['name']}') but has no mass: "
                         "give it an <inertial> with a positive mass")
            continue
        t = body.inertia
        entry = {"name": identifier(name), "mass": _number(body.mass),
                 "com": [_number(c) for c in body.com],
                 "inertia": [_number(v) for v in (t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2])]}
        data["links"].append(entry)
        doc.labels[path] = f"link '{name}'"
        inertial = body.element
        spots = {"name": element, "mass": inertial.find("mass"), "inertia": inertial.find("inertia"),
                 "com": inertial.find("origin")}
        for key in entry:
            spot = spots.get(key) or inertial
            positions[path + (key,)] = (spot.line, spot.column)
    for index, joint in enumerate(moving):
        element = joint["element"]
        parent_owner = owner[joint["parent"]]
        R0, p0 = offset[joint["parent"]]
        R = R0 @ joint["R"]
        xyz = R0 @ joint["xyz"] + p0
        jname = identifier(joint["name"])
        entry = {
            "name": jname, "type": joint["type"],
            "parent": "world" if parent_owner == "world" else identifier(parent_owner),
            "child": identifier(joint["child"]),
            "origin": {"xyz": [_number(v) for v in xyz], "rpy": [_angle(v) for v in _to_rpy(R)]},
            "axis": [_number(v) for v in joint["axis"]],
            "effort": ("tau_" if joint["type"] == "revolute" else "f_") + jname,
        }
        data["joints"].append(entry)
        path = ("joints", index)
        doc.labels[path] = f"joint '{joint['name']}'"
        positions[path] = (element.line, element.column)
        for key in entry:
            positions[path + (key,)] = (element.line, element.column)
        positions[path + ("axis",)] = (joint["axis_element"].line, joint["axis_element"].column)
        for i in range(3):
            positions[path + ("axis", i)] = positions[path + ("axis",)]
    if reader.problems:
        raise InputError(reader.problems)
    doc.data, doc.positions = data, positions
    doc.key_positions = dict(positions)
    return doc


def _combine(a: _Body, b: _Body) -> _Body:
    """Two rigid bodies welded together (all in one frame): mass, COM, inertia about the COM."""
    mass = a.mass + b.mass
    com = (a.mass * a.com + b.mass * b.com) / mass if mass > 0 else a.com
    inertia = np.zeros((3, 3))
    for body in (a, b):
        d = body.com - com
        inertia += body.inertia + body.mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return _Body(mass, com, inertia, a.element)


def to_yaml(data: dict[str, Any], source: str) -> str:
    """The robot data as a version-1 YAML robot file, lists written inline."""
    import yaml

    from . import __version__

    class _Dumper(yaml.SafeDumper):
        pass

    def inline(dumper: yaml.SafeDumper, value: list[Any]) -> Any:
        flat = all(not isinstance(v, (list, dict)) for v in value)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)

    _Dumper.add_representer(list, inline)
    header = (f"# Imported by dynderive {__version__} from {source}: fixed joints merged into their\n"
              "# parent links, inertias rotated into link axes, the root link welded to the world.\n")
    return header + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
