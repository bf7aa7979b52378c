"""A URDF's floating base: ``--floating-base`` joins the world to the root link by a
``floating`` joint ``root_joint`` (as ``pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())``
does), and without it a root that carries several moving subtrees (a legged robot's trunk)
gets a note that it is welded to the world and how to float it. A ``planar`` joint is read
as three joints in a row (``split_planar``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model.joint_kinds import FREE, PLANE_AS_JOINTS, is_free, is_welded
from .free_joints import planar_floating_links, planar_floating_names
from .loader import SourceDocument
from .urdf_xml import _Element

#: The name ``--floating-base`` gives its joint (Pinocchio's ``root_joint``).
ROOT_JOINT = "root_joint"
#: The link the floating joint hangs from while the URDF is read: a name no URDF can hold (XML
#: forbids NUL), so it never clashes; it becomes ``world``.
_WORLD = "\0world"

#: URDF's planar joint's ``type`` attribute: read as three joints in a row (``split_planar``).
URDF_PLANAR = "planar"


def float_root(reader: Any, joints: list[dict[str, Any]], link_elements: dict[str, _Element], base: str,
               robot: _Element, identity: Any) -> str:
    """Add the joint ``root_joint`` (type floating) from a new world link to ``base``, first
    (its coordinates come first, as in Pinocchio); returns the new root link's name."""
    floating = next((j for j in joints if is_free(j["type"])), None)
    if floating is not None:
        reader.error(floating["element"], f"joint '{floating['name']}' is floating already: leave out --floating-base")
        return base
    clash = next((j for j in joints if j["name"] == ROOT_JOINT), None)
    if clash is not None:
        reader.error(clash["element"], f"joint '{ROOT_JOINT}': --floating-base names its joint '{ROOT_JOINT}', "
                     "and this URDF already has a joint of that name")
        return base
    link_elements[_WORLD] = robot
    joints.insert(0, {
        "element": link_elements[base], "name": ROOT_JOINT, "type": FREE, "parent": _WORLD, "child": base,
        "xyz": np.zeros(3), "R": identity, "axis": [1, 0, 0], "axis_element": link_elements[base],
        "dynamics": None, "damping": 0.0, "friction": 0.0,
    })
    return _WORLD


def note_fixed_base(doc: SourceDocument, joints: list[dict[str, Any]], frames: dict[str, Any], base: str,
                    element: _Element) -> None:
    """A note when the root link (welded to the world) carries two or more moving subtrees and
    no joint of the URDF floats: a legged robot or humanoid loaded with its trunk fixed."""
    if any(is_free(j["type"]) for j in joints):
        return
    subtrees = [j for j in joints if not is_welded(j["type"]) and frames[j["parent"]][0] == "world"]
    if len(subtrees) >= 2:
        doc.note(element.at, f"the root link '{base}' carries {len(subtrees)} moving subtrees and is welded "
                 "to the world (a fixed base); for a floating base (legged robots, humanoids) pass "
                 "--floating-base")


def split_planar(reader: Any, doc: SourceDocument, joints: list[dict[str, Any]], link_elements: dict[str, _Element],
                 frames: dict[str, Any], identity: Any) -> None:
    """Each ``planar`` joint (motion in the plane normal to its axis, in its joint frame) as
    prismatic ``<joint>_x`` along ``e1``, prismatic ``<joint>_y`` along ``e2 = axis x e1`` and
    revolute ``<joint>_theta`` about the axis, in its place, joined by the massless links
    ``<joint>_x_link`` and ``<joint>_y_link``. ``e1`` is the joint frame's x axis projected on
    the plane (its y axis when the axis is nearer x than y): for the axis z, x and y."""
    names = {j["name"] for j in joints}
    for index in [k for k, j in enumerate(joints) if j["type"] == URDF_PLANAR][::-1]:
        joint = joints[index]
        n = np.asarray(joint["axis"], dtype=float)
        length = float(np.linalg.norm(n))
        if not np.isfinite(length) or length < 1e-12:
            reader.error(joint["axis_element"], f"joint '{joint['name']}': axis has zero length")
            continue
        n = n / length
        guess = np.eye(3)[1 if abs(n[0]) > abs(n[1]) else 0]
        e1 = guess - (guess @ n) * n
        e1 = e1 / np.linalg.norm(e1)
        axes = [_exact(e1), _exact(np.cross(n, e1)), joint["axis"]]
        x, y, theta = planar_floating_names(joint["name"])
        links = planar_floating_links(joint["name"])
        clash = next((m for m in (x, y, theta) if m in names), None) or next((m for m in links if m in link_elements), None)
        if clash is not None:
            reader.error(joint["element"], f"joint '{joint['name']}': a planar joint is read as the joints {x}, {y}, "
                         f"{theta} and the massless links {links[0]}, {links[1]}; the URDF has a "
                         f"{'joint' if clash in names else 'link'} '{clash}' already")
            continue
        if joint["dynamics"] is not None:
            doc.note(joint["dynamics"].at, f"<dynamics> on planar joint '{joint['name']}' ignored (as "
                     "Pinocchio's URDF parser does)")
        for link in links:
            link_elements[link] = joint["element"]
            frames[link] = (link, identity, np.zeros(3))
        ends = [joint["parent"], *links, joint["child"]]
        parts = []
        for k, (name, kind) in enumerate(zip((x, y, theta), PLANE_AS_JOINTS)):
            parts.append(joint | {"name": name, "type": kind, "parent": ends[k], "child": ends[k + 1],
                                  "axis": axes[k], "dynamics": None, "damping": 0.0, "friction": 0.0, "mimic": None,
                                  "virtual": k < 2}   # its child is a massless link of the split
                         | ({} if k == 0 else {"xyz": np.zeros(3), "R": identity}))
        joints[index:index + 1] = parts


def _exact(vector: np.ndarray) -> list[float]:
    """An in-plane axis, its entries within 1e-15 of 0 or +-1 written exactly."""
    return [float(round(v)) if abs(v - round(v)) < 1e-15 else float(v) for v in vector]
