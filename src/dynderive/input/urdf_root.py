"""A URDF's floating base: ``--floating-base`` joins the world to the root link by a
``floating`` joint ``root_joint`` (as ``pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())``
does), and without it a root that carries several moving subtrees (a legged robot's trunk)
gets a note that it is welded to the world and how to float it."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model.joint_kinds import FREE, is_free, is_welded
from .loader import SourceDocument
from .urdf_xml import _Element

#: The name ``--floating-base`` gives its joint (Pinocchio's ``root_joint``).
ROOT_JOINT = "root_joint"
#: The link the floating joint hangs from while the URDF is read: a name no URDF can hold (XML
#: forbids NUL), so it never clashes; it becomes ``world``.
_WORLD = "\0world"


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
