"""The JSON Schema of the robot file format (version 1), for editors and validators.

``dynderive schema > robot.schema.json``; VS Code's YAML extension picks it up with
``# yaml-language-server: $schema=robot.schema.json`` at the top of a robot file. The schema
checks shape and names; meaning (the tree, positive masses, symbols) is left to dynderive's own
validation, which reports positions.
"""

from __future__ import annotations

from typing import Any

from ..model.joint_kinds import JOINT_KINDS, kinds

IDENTIFIER = "^[A-Za-z_][A-Za-z0-9_]*$"
#: Symbols (parameters, efforts) may not start with '_': the generated module's temporaries do.
SYMBOL = "^[A-Za-z][A-Za-z0-9_]*$"
EXPRESSION: dict[str, Any] = {
    "description": "A number, or an expression in Python syntax over the declared parameters",
    "oneOf": [{"type": "number"}, {"type": "string", "minLength": 1, "maxLength": 1000}],
}


def _vector(sizes: list[int], description: str) -> dict[str, Any]:
    return {"description": description, "type": "array", "items": EXPRESSION,
            "minItems": min(sizes), "maxItems": max(sizes)}


def _joint_types() -> str:
    """The joint types' one-line summaries, with the effort names of a joint of several entries."""
    def efforts(suffixes: tuple[str, ...]) -> str:
        return f" (effort e: e_{suffixes[0]} ... e_{suffixes[-1]})" if suffixes else ""
    return "; ".join(f"{k.name}: {k.summary}{efforts(k.efforts)}" for k in JOINT_KINDS.values())


def _type_keys() -> dict[str, Any]:
    """The keys only some joint types read (the joint specification's ``JointKind.keys``)."""
    keys: dict[str, Any] = {}
    for kind in JOINT_KINDS.values():
        for key in kind.keys:
            text = f"{kind.name} joints only: {key.description}"
            keys[key.name] = _vector([key.size], text) if key.size else {**EXPRESSION, "description": text}
    return keys


def robot_schema() -> dict[str, Any]:
    parameter = {
        "oneOf": [
            {"type": "number", "description": "default value"},
            {"type": "null", "description": "a symbol without a default"},
            {"type": "object", "additionalProperties": False, "properties": {
                "value": {"type": ["number", "null"]},
                "unit": {"type": "string"},
                "description": {"type": "string"},
            }},
        ]
    }
    inertia = {
        "description": "planar: scalar about the COM; 3-D: [ixx, iyy, izz, ixy, ixz, iyz] or a 3x3 list",
        "oneOf": [EXPRESSION, _vector([6], "[ixx, iyy, izz, ixy, ixz, iyz]"),
                  {"type": "array", "minItems": 3, "maxItems": 3, "items": _vector([3], "row")}],
    }
    link = {
        "type": "object", "additionalProperties": False, "required": ["name", "mass"],
        "properties": {
            "name": {"type": "string", "pattern": IDENTIFIER},
            "mass": EXPRESSION,
            "com": _vector([2, 3], "centre of mass in the link frame"),
            "inertia": inertia,
        },
    }
    origin = {
        "description": "planar: [x, y] or [x, y, theta]; 3-D: {xyz: [..], rpy: [..]} (URDF convention)",
        "oneOf": [
            _vector([2, 3], "[x, y] or [x, y, theta]"),
            {"type": "object", "additionalProperties": False, "properties": {
                "xyz": _vector([3], "translation"), "rpy": _vector([3], "roll, pitch, yaw")}},
        ],
    }
    joint = {
        "type": "object", "additionalProperties": False, "required": ["name", "type", "parent", "child"],
        "properties": {
            "name": {"type": "string", "pattern": IDENTIFIER, "description": "also the coordinate's symbol"},
            "type": {"enum": list(JOINT_KINDS), "description": _joint_types()},
            "parent": {"type": "string", "description": "a link name or world"},
            "child": {"type": "string"},
            "origin": origin,
            "axis": _vector([2, 3], "prismatic axis (planar) or joint axis (3-D)"),
            "effort": {"type": "string", "pattern": SYMBOL},
            "damping": {**EXPRESSION, "description": "viscous damping b: force -b*qd (Rayleigh D = b*qd**2/2)"},
            "friction": {**EXPRESSION, "description": "Coulomb friction fc: force -fc*sign(qd)"},
            "stiffness": {**EXPRESSION, "description": "spring stiffness k: potential k*(q - rest)**2/2"},
            "rest": {**EXPRESSION, "description": "spring rest position (default 0; needs stiffness)"},
            "armature": {**EXPRESSION, "description": "reflected rotor inertia (gear ratio**2 * rotor "
                         "inertia): added to M[i, i]"},
            "mimic": {"type": "object", "additionalProperties": False, "required": ["joint"],
                      "description": "3-D revolute or prismatic joint following another (URDF <mimic>): its "
                                     "variable is multiplier * leader + offset; no coordinate, no effort",
                      "properties": {"joint": {"type": "string", "pattern": IDENTIFIER,
                                               "description": "the leader: a revolute or prismatic joint"},
                                     "multiplier": {"type": "number", "description": "default 1, not 0"},
                                     "offset": {"type": "number", "description": "default 0"}}},
            **_type_keys(),
        },
    }
    loop = {
        "type": "object", "additionalProperties": False, "required": ["name", "type", "parent", "child"],
        "description": "a loop-closing joint between two links of the spanning tree (or a link and world)",
        "properties": {
            "name": {"type": "string", "pattern": IDENTIFIER},
            "type": {"enum": list(kinds(loops=True)),
                     "description": f"planar: {' | '.join(kinds(planar=True, loops=True))}; "
                                    f"3-D: {' | '.join(kinds(planar=False, loops=True))}"},
            "parent": {"type": "string", "description": "a link name or world"},
            "child": {"type": "string", "description": "a link name or world"},
            "origin": origin,
            "child_origin": origin,
            "axis": _vector([2, 3], "prismatic axis (planar, 3-D) or revolute axis (3-D), in the loop frame"),
        },
    }
    frame = {
        "type": "object", "additionalProperties": False, "required": ["name", "link"],
        "description": "a named frame fixed on a link (pose, Jacobian, external wrenches)",
        "properties": {
            "name": {"type": "string", "pattern": IDENTIFIER},
            "link": {"type": "string", "description": "the link it is fixed on"},
            "origin": origin,
        },
    }
    contact = {
        "type": "object", "additionalProperties": False, "required": ["frame"],
        "description": "a frame held by a contact (3-D robots)",
        "properties": {
            "frame": {"type": "string", "description": "a frame of 'frames'"},
            "kind": {"enum": ["point", "surface"], "default": "point",
                     "description": "point: the origin held (3 forces); surface: the whole twist (6)"},
        },
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://dynderive.invalid/schema/robot-v1.json",
        "title": "dynderive robot description (version 1)",
        "type": "object",
        "additionalProperties": False,
        "required": ["name", "gravity", "links", "joints"],
        "properties": {
            "name": {"type": "string", "pattern": IDENTIFIER},
            "title": {"type": "string"},
            "planar": {"type": "boolean", "default": False},
            "parameters": {"type": "object", "propertyNames": {"pattern": SYMBOL},
                           "additionalProperties": parameter},
            "gravity": _vector([2, 3], "world-frame gravity vector"),
            "links": {"type": "array", "minItems": 1, "items": link},
            "joints": {"type": "array", "minItems": 1, "items": joint},
            "loops": {"type": "array", "minItems": 1, "items": loop},
            "independent": {"type": "array", "minItems": 1, "items": {"type": "string", "pattern": IDENTIFIER},
                            "description": "robots with loops: coordinates kept independent"},
            "frames": {"type": "array", "minItems": 1, "items": frame},
            "contacts": {"type": "array", "minItems": 1, "items": contact},
            "maximal": {"type": "object", "additionalProperties": False, "properties": {
                "constraints": {"type": "array", "items": EXPRESSION}}},
        },
    }
