"""Read URDF files into the same plain data as a robot YAML file.

Uses the standard library's XML parser (no maintained pure-Python URDF parser keeps source
lines; errors must point at the element's line), with DTDs and entities refused. The URDF
becomes the data of a version-1 robot file, with every value mapped to its element's line,
and goes through the same validator as YAML; ``dynderive import`` writes that data as YAML.

Conventions: the root link is welded to the world (its inertia never enters M(q)), so it
becomes ``world``; ``continuous`` joints are revolute; ``fixed`` joints are merged into the
parent link (mass, centre of mass and inertia combined), so every remaining link moves;
inertial frames with ``rpy`` are rotated into the link axes; a ``planar`` joint is the 3-D
planar joint (x, y, theta in the plane normal to its axis); efforts are named ``tau_<joint>``
(revolute) and ``f_<joint>`` (prismatic; a planar joint's ``f_<joint>_x``, ``_y``, ``_theta``); gravity is ``[0, 0, -g]`` with ``g = 9.81``.

Rotations are composed as matrices (``urdf_values``: only the ``rpy`` written in the file are
snapped to quarter turns). ``<mimic>`` on a fixed joint is ignored with a note in
``document.notes``; on a moving joint it becomes the joint's ``mimic``, as
``pin.buildModelFromUrdf(..., mimic=True)`` models it, checked by the validator like a YAML
file's (``input/mimic.py``); one naming a joint the file does not have, or a fixed one, is
ignored with a note (the joint an independent coordinate, as in Pinocchio's default:
alex_psyonic_hands.urdf names ``index_q1`` for ``Left_index_q1``).
Masses and inertias are judged in ``urdf_bodies`` (with the rounding tolerance of ``inertia``;
links welded to the world get notes, never errors), which also merges the welded bodies.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import yaml

from ..errors import InputError, Problem
from ..model.joint_kinds import is_angle, is_free, is_welded, urdf_types
from ..model.naming import body_jacobian_index, frame_quantity_names
from . import inertia
from .loader import Path_, SourceDocument
from .urdf_bodies import Body, check_bodies, merge_bodies
from .urdf_root import float_root, note_fixed_base
from .urdf_symbolic import Declared, attach, entries, name_parameters, patterns_of, select
from .urdf_values import IDENTITY, Rotation, _number, _numbers, _Reader
from .urdf_xml import _Element, _parse_xml

#: URDF ``type`` attribute -> the robot file's joint type (the joint specification's map).
URDF_TYPES = urdf_types()
#: URDF's planar joint's ``type`` attribute (the 3-D planar joint: x, y and theta in the plane
#: normal to its axis; no mimic, its <dynamics> ignored as Pinocchio's parser does).
URDF_PLANAR = "planar"


def identifier(name: str) -> str:
    cleaned = re.sub(r"\W", "_", name)
    return cleaned if re.match(r"[A-Za-z_]", cleaned) else f"r_{cleaned}"


def read_urdf(text: str, file: str, floating_base: bool = False,
              symbolic: str | tuple[str, ...] | list[str] | None = None) -> SourceDocument:
    """URDF text -> the data of an equivalent robot file, with positions for every value.

    Steps: read the links' inertials and the joints, check the tree, place every link in the
    moving link it is welded to (fixed joints composed as rotation matrices), merge welded
    bodies, and write the moving links and joints as robot-file data. With ``floating_base``
    a ``floating`` joint ``root_joint`` joins the world to the root link (``--floating-base``).
    ``symbolic``: patterns ``LINK.FIELD`` whose inertial values become parameters (``--symbolic``,
    ``urdf_symbolic``), the file's values their defaults.
    """
    root = _parse_xml(text, file)
    reader = _Reader(file)
    doc = SourceDocument(file=file, data=None)
    if root.tag != "robot":
        raise InputError(Problem(file, *root.at, f"expected a <robot> element, got <{root.tag}>"))
    bodies, link_elements = _read_links(root, reader)
    joints = _read_joints(root, reader, doc, link_elements)
    check_bodies(reader, doc, bodies, joints, floating_base)
    reader.raise_problems()

    by_child = _check_tree(reader, joints, link_elements)
    reader.raise_problems()
    roots = [name for name in link_elements if name not in by_child]
    if len(roots) != 1:
        where = root if not roots else link_elements[roots[1]]
        raise InputError(Problem(file, *where.at,
                                 f"a URDF robot needs exactly one root link, found {len(roots)}"
                                 + (f" ({', '.join(roots)})" if roots else "")))
    base = roots[0]
    if floating_base:
        base = float_root(reader, joints, link_elements, base, root, IDENTITY)
        reader.raise_problems()
        by_child[roots[0]] = joints[0]

    frames = _fixed_frames(reader, joints, link_elements, by_child, base)
    patterns = patterns_of(symbolic)
    chosen = select(patterns, bodies, list(link_elements), frames) if patterns else {}
    declared = attach(bodies, chosen, identifier)
    merged = merge_bodies(reader, bodies, link_elements, frames)
    if not floating_base:
        note_fixed_base(doc, joints, frames, base, link_elements[base])
    doc.digits = max(reader.digits, 1)   # the sheet's precision: as written, not as composed
    return _robot_document(root, reader, doc, joints, link_elements, frames, merged, declared)


def _read_links(root: _Element, reader: _Reader) -> tuple[dict[str, Body], dict[str, _Element]]:
    """Every <link>'s element and, where it has an <inertial>, its body (mass, COM, inertia
    rotated into link axes); ``_check_bodies`` judges them once the welds are known."""
    bodies: dict[str, Body] = {}
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
        rotation = Rotation.from_rpy(reader.numbers(origin, "rpy", 3, [0, 0, 0], angles=True))
        mass_element, inertia_element = inertial.find("mass"), inertial.find("inertia")
        if mass_element is None or inertia_element is None:
            reader.error(inertial, f"link '{name}': <inertial> needs <mass> and <inertia>")
            continue
        mass = reader.numbers(mass_element, "value", 1, [0])[0]
        tensor = inertia.from_entries(**{key: reader.numbers(inertia_element, key, 1, [0])[0]
                                         for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")})
        R = rotation.matrix
        with np.errstate(all="ignore"):
            rotated = R @ tensor @ R.T
        bodies[name] = Body(mass, np.array(xyz), rotated, inertial, max(map(abs, xyz)), tensor, R)

    return bodies, link_elements


def _read_joints(root: _Element, reader: _Reader, doc: SourceDocument,
                 link_elements: dict[str, _Element]) -> list[dict[str, Any]]:
    """Every <joint> as a dict (type, links, origin as xyz and a rotation, axis)."""
    joints: list[dict[str, Any]] = []
    for joint in root.findall("joint"):
        name = joint.attrib.get("name", "")
        jtype = joint.attrib.get("type", "")
        parent, child = (getattr(joint.find(role), "attrib", {}).get("link") for role in ("parent", "child"))
        mimic, follows = joint.find("mimic"), None
        if mimic is not None and is_welded(jtype):
            doc.note(mimic.at, f"<mimic> on fixed joint '{name}' ignored")
        elif mimic is not None and jtype == URDF_PLANAR:
            reader.error(mimic, f"joint '{name}': <mimic> on a planar joint is not supported (only revolute, "
                         "continuous and prismatic joints follow a leader)")
        elif mimic is not None:   # checked by the validator (input/mimic.py)
            follows = (mimic, mimic.attrib.get("joint", ""), reader.numbers(mimic, "multiplier", 1, [1.0])[0],
                       reader.numbers(mimic, "offset", 1, [0.0])[0])
        if jtype not in URDF_TYPES:
            reader.error(joint, f"joint '{name}': unknown joint type '{jtype}'")
            continue
        if not parent or not child:
            reader.error(joint, f"joint '{name}': needs <parent link=...> and <child link=...>")
            continue
        for role, link_name in (("parent", parent), ("child", child)):
            if link_name not in link_elements:
                reader.error(joint.find(role) or joint, f"joint '{name}': unknown {role} link '{link_name}'")
        origin = joint.find("origin")
        dynamics = joint.find("dynamics")
        if dynamics is not None and is_welded(jtype):
            doc.note(dynamics.at, f"<dynamics> on fixed joint '{name}' ignored (it has no coordinate)")
            dynamics = None
        elif dynamics is not None and jtype == URDF_PLANAR:
            doc.note(dynamics.at, f"<dynamics> on planar joint '{name}' ignored (as Pinocchio's URDF parser does)")
            dynamics = None
        joints.append({
            "element": joint, "name": name, "type": URDF_TYPES.get(jtype, jtype),
            "parent": parent, "child": child,
            "xyz": np.array(reader.numbers(origin, "xyz", 3, [0, 0, 0])),
            "R": Rotation.from_rpy(reader.numbers(origin, "rpy", 3, [0, 0, 0], angles=True)),
            "axis": reader.numbers(joint.find("axis"), "xyz", 3, [1, 0, 0]),
            "axis_element": joint.find("axis") or joint,
            "dynamics": dynamics,
            "mimic": follows,
            # <dynamics damping friction>: viscous damping and Coulomb friction (0 = none)
            **{key: reader.numbers(dynamics, key, 1, [0.0])[0] for key in ("damping", "friction")},
        })
    return joints


def _fixed_frames(reader: _Reader, joints: list[dict[str, Any]], link_elements: dict[str, _Element],
                  by_child: dict[str, dict[str, Any]], base: str) -> dict[str, tuple[str, Rotation, np.ndarray]]:
    """Each link's frame in the moving link it is welded to (``world`` for the root's): fixed
    joints composed as matrices from the top, without recursion (chains may be long)."""
    frames: dict[str, tuple[str, Rotation, np.ndarray]] = {base: ("world", IDENTITY, np.zeros(3))}
    for name in link_elements:
        chain = []
        current = name
        while current not in frames:
            joint = by_child[current]
            if not is_welded(joint["type"]):
                frames[current] = (current, IDENTITY, np.zeros(3))
                break
            chain.append(joint)
            current = joint["parent"]
        for joint in reversed(chain):
            target, R0, p0 = frames[joint["parent"]]
            frames[joint["child"]] = (target, R0 @ joint["R"], R0.matrix @ joint["xyz"] + p0)
    reader.raise_problems()

    return frames


def _robot_document(root: _Element, reader: _Reader, doc: SourceDocument, joints: list[dict[str, Any]],
                    link_elements: dict[str, _Element], frames: dict[str, tuple[str, Rotation, np.ndarray]],
                    merged: dict[str, Body], declared: list[Declared] | None = None) -> SourceDocument:
    """The moving links and joints as robot-file data, with a position for every value;
    ``declared``: the inertial values made parameters (``--symbolic``), then written as
    expressions of them where they enter a link's values."""
    data: dict[str, Any] = {
        "name": identifier(root.attrib.get("name", "robot")),
        "title": root.attrib.get("name", "robot"),
        "planar": False,
        "parameters": {"g": {"value": 9.81, "unit": "m/s^2", "description": "gravitational acceleration"}},
        "gravity": [0, 0, "-g"],
        "links": [],
        "joints": [],
    }
    positions: dict[Path_, tuple[int, int]] = {(): root.at}
    for key in ("name", "title", "planar", "parameters", "gravity", "links", "joints"):
        positions[(key,)] = root.at
    doc.labels[("name",)] = "<robot name>"
    moving = [j for j in joints if not is_welded(j["type"])]
    carrying = _carrying(moving, frames, merged)
    expressed: list[tuple[dict[str, Any], Any]] = []   # link entries with values that are expressions
    for index, joint in enumerate(moving):
        name = joint["child"]
        element = link_elements[name]
        body = merged.get(name)
        path = ("links", index)
        positions[path] = element.at
        if name not in carrying:
            reader.error(element, f"link '{name}' moves (joint '{joint['name']}') but has no mass, nor has any "
                         "link below it: the joint moves nothing; give the link an <inertial> with a positive mass")
            continue
        if body is None:   # a massless link between joints (a virtual link of a hip): the ones below it carry
            body = Body(0.0, np.zeros(3), np.zeros((3, 3)), element)
        t = body.inertia
        entry = {"name": identifier(name), "mass": _number(body.mass),
                 "com": _numbers(body.com, max(body.scale, float(np.max(np.abs(body.com))))),
                 "inertia": _numbers([t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2]])}
        data["links"].append(entry)
        if body.symbolic is not None:
            expressed.append((entry, body.symbolic))
        doc.labels[path] = f"link '{name}'"
        if body.impossible:
            doc.impossible_inertias.add(path)
        inertial = body.element
        spots = {"name": element, "mass": inertial.find("mass"), "inertia": inertial.find("inertia"),
                 "com": inertial.find("origin")}
        for key in entry:
            spot = spots.get(key) or inertial
            positions[path + (key,)] = spot.at
    all_names = {j["name"] for j in joints}
    moving_names = {j["name"] for j in moving}
    for index, joint in enumerate(moving):
        element = joint["element"]
        parent_owner, R0, p0 = frames[joint["parent"]]
        rotation = R0 @ joint["R"]
        xyz = R0.matrix @ joint["xyz"] + p0
        jname = identifier(joint["name"])
        scale = max(float(np.max(np.abs(joint["xyz"]))), float(np.max(np.abs(p0))))
        entry = {
            "name": jname, "type": joint["type"],
            "parent": "world" if parent_owner == "world" else identifier(parent_owner),
            "child": identifier(joint["child"]),
            "origin": {"xyz": _numbers(xyz, scale), "rpy": rotation.rpy()},
            "axis": [_number(v) for v in joint["axis"]],
            "effort": ("tau_" if is_angle(joint["type"]) else "f_") + jname,
        }
        if is_free(joint["type"]):   # unactuated, no axis (its origin places its frame)
            del entry["axis"], entry["effort"]
        if joint.get("mimic") is not None and joint["mimic"][1] not in moving_names:
            mimic, leader = joint["mimic"][:2]
            why = "a fixed joint, which has no coordinate" if leader in all_names else "which the file does not have"
            doc.note(mimic.at, f"joint '{joint['name']}': its <mimic> names joint '{leader}', {why}: "
                     f"'{joint['name']}' is an independent coordinate (as in Pinocchio's default, "
                     "buildModelFromUrdf without mimic)")
            joint["mimic"] = None
        if joint.get("mimic") is not None:   # no coordinate, no effort of its own: its leader's
            entry.pop("effort", None)
            _, leader, multiplier, offset = joint["mimic"]
            entry["mimic"] = {"joint": identifier(leader), "multiplier": _number(multiplier), "offset": _number(offset)}
        for key in ("damping", "friction"):   # validated as joint keys: finite, not negative
            if joint[key] != 0:
                entry[key] = _number(joint[key])
        data["joints"].append(entry)
        path = ("joints", index)
        doc.labels[path] = f"joint '{joint['name']}'"
        positions[path] = element.at
        for key in entry:
            positions[path + (key,)] = element.at
        if "axis" in entry:   # the axis and its entries
            for key in ((), (0,), (1,), (2,)):
                positions[path + ("axis",) + key] = joint["axis_element"].at
        if joint["dynamics"] is not None:
            for key in ("damping", "friction"):
                positions[path + (key,)] = joint["dynamics"].at
        if joint.get("mimic") is not None:
            doc.labels[path + ("mimic",)] = f"joint '{joint['name']}' <mimic>"
            for key in ((), ("joint",), ("multiplier",), ("offset",)):
                positions[path + ("mimic",) + key] = joint["mimic"][0].at
    if declared:
        _write_parameters(data, positions, declared, expressed)
    _welded_frames(data, positions, doc, link_elements, frames)
    reader.raise_problems()
    doc.data, doc.positions = data, positions
    doc.key_positions = dict(positions)
    return doc


def _write_parameters(data: dict[str, Any], positions: dict[Path_, tuple[int, int]], declared: list[Declared],
                      expressed: list[tuple[dict[str, Any], Any]]) -> None:
    """The inertial values made parameters (``--symbolic``): named, declared with the file's
    values as defaults, and written into the links' values that depend on them."""
    named = name_parameters(data, declared)
    for item in declared:
        positions[("parameters", named[item.symbol].name)] = item.at
    for entry, body in expressed:
        for key, texts in entries(body, named).items():
            values = entry[key] if key != "mass" else [entry["mass"]]
            values = [number if expr is None else expr for number, expr in zip(values, texts)]
            entry[key] = values if key != "mass" else values[0]


def _carrying(moving: list[dict[str, Any]], frames: dict[str, tuple[str, Rotation, np.ndarray]],
              merged: dict[str, Body]) -> set[str]:
    """The moving links that have mass or inertia, or a moving link below them that has:
    the others' joints move nothing (a massless link with massive links below it is fine, as
    long as the mass matrix stays regular, which the derivation checks)."""
    parent = {j["child"]: frames[j["parent"]][0] for j in moving}
    carrying: set[str] = set()
    for name, body in merged.items():
        if body.mass == 0 and not np.any(body.inertia):
            continue
        while name in parent and name not in carrying:
            carrying.add(name)
            name = parent[name]
    return carrying


def _welded_frames(data: dict[str, Any], positions: dict[Path_, tuple[int, int]], doc: SourceDocument,
                   link_elements: dict[str, _Element], frames: dict[str, tuple[str, Rotation, np.ndarray]]) -> None:
    """Links welded by fixed joints to a moving link (a tool flange, a hand, a sensor mount)
    become the robot's ``frames``, named as the link, so their pose and Jacobian stay at hand
    after their inertia joins the moving link's. Links welded to the world are not frames."""
    entries: list[dict[str, Any]] = []
    taken: set[str] = set()
    for name, element in link_elements.items():
        if name not in frames:
            continue
        owner, rotation, p = frames[name]
        if owner in (name, "world"):
            continue
        frame = identifier(name)
        clash = next((q for q in frame_quantity_names(frame, False) if body_jacobian_index(q, len(data["links"]))), None)
        if clash or frame in taken:   # the frame is a convenience: left out rather than refuse the URDF
            why = f"its Jacobian would be {clash}, link {clash[3:]}'s body Jacobian" if clash else "another frame has its name"
            doc.note(element.at, f"link '{name}' (welded to '{owner}') is not made a frame: {why}")
            continue
        taken.add(frame)
        path = ("frames", len(entries))
        entries.append({"name": frame, "link": identifier(owner),
                        "origin": {"xyz": _numbers(p, float(np.max(np.abs(p)))), "rpy": rotation.rpy()}})
        doc.labels[path] = f"frame '{name}'"
        for key in ((), ("name",), ("link",), ("origin",)):
            positions[path + key] = element.at
    if entries:
        data["frames"] = entries
        positions[("frames",)] = positions[()]


def _check_tree(reader: _Reader, joints: list[dict[str, Any]],
                link_elements: dict[str, _Element]) -> dict[str, dict[str, Any]]:
    """Each link is the child of at most one joint, and no chain of joints closes on itself
    (same words as the YAML validator). Returns the parent joint of each child link."""
    by_child: dict[str, dict[str, Any]] = {}
    for joint in joints:
        first = by_child.setdefault(joint["child"], joint)
        if first is not joint:
            where = joint["element"].find("child") or joint["element"]
            reader.error(where, f"joint '{joint['name']}': link '{joint['child']}' already has a parent "
                         f"joint (joint '{first['name']}'); robots must be trees")
    done: set[str] = set()   # links whose chain up to a root (or a reported cycle) is walked
    for name in link_elements:
        seen: dict[str, int] = {}   # the current walk, in order (a dict: linear time)
        current = name
        while current in by_child and current not in seen and current not in done:
            seen[current] = len(seen)
            current = by_child[current]["parent"]
        done.update(seen)
        if current in seen:
            loop = list(seen)[seen[current]:] + [current]
            joint = by_child[current]
            reader.error(joint["element"], f"joint '{joint['name']}': links {' -> '.join(loop)} form a "
                         "cycle not connected to 'world'")
    return by_child


def to_yaml(data: dict[str, Any], source: str) -> str:
    """The robot data as a version-1 YAML robot file, lists written inline."""
    from .._version import __version__

    class _Dumper(yaml.SafeDumper):
        pass

    def inline(dumper: yaml.SafeDumper, value: list[Any]) -> Any:
        flat = all(not isinstance(v, (list, dict)) for v in value)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)

    _Dumper.add_representer(list, inline)
    if source.lower().endswith(".xml"):
        header = (f"# Imported by dynderive {__version__} from {source} (compiled by MuJoCo): bodies without\n"
                  "# joints merged into the link they ride on, a body's joints chained through massless links.\n")
    else:
        header = (f"# Imported by dynderive {__version__} from {source}: fixed joints merged into their\n"
                  "# parent links, inertias rotated into link axes, the root link welded to the world.\n")
    return header + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
