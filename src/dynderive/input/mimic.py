"""Validation of a joint's ``mimic`` (URDF ``<mimic>``): the joint follows another, its
variable being ``multiplier * q_leader + offset``, so it has no coordinate of its own
(DESIGN.md section 10). Part of validation: ``schema._joints`` calls ``read_mimic`` per
joint, ``schema.validate`` calls ``check_mimics`` once every joint is read.

Rules: only a revolute or prismatic joint follows, a revolute or prismatic joint with a
coordinate of its own (not fixed, floating, spherical, nor itself a follower: so no chain and
no cycle of followers); the multiplier is a finite non-zero number, the offset a finite
number; a follower has no effort of its own (its drive acts on its leader's coordinate, through
the multiplier); one spring per coordinate (on the leader or on one of its followers). Built
on fixed-base 3-D robots and on robots with floating or spherical joints (the one tree of
``mechanics/tree.py``). Not built yet (refused): followers in planar robots and in robots
with loops.
"""

from __future__ import annotations

import math
from typing import Any

from ..model.joint_kinds import JOINT_KINDS
from ..model.naming import did_you_mean
from ..model.robot import Joint, Mimic

MIMIC_KEYS = ("joint", "multiplier", "offset")
#: Joint types that may follow, or lead (the joint specification's ``follows``).
COUPLED_TYPES = tuple(name for name, kind in JOINT_KINDS.items() if kind.follows)


def read_mimic(v: Any, item: dict[str, Any], path: tuple[Any, ...], jtype: str | None) -> Mimic | None:
    """The ``mimic`` block of one joint entry, checked on its own; problems go to ``v``."""
    if "mimic" not in item:
        return None
    mpath = path + ("mimic",)
    if jtype is not None and jtype not in COUPLED_TYPES:
        v.report(mpath, f"a {jtype} joint cannot mimic another (only {' and '.join(COUPLED_TYPES)} joints can)",
                 key=True)
        return None
    block = v.mapping(item["mimic"], mpath, MIMIC_KEYS, required=("joint",))
    if block is None or "joint" not in block:
        return None
    leader = v.identifier(block["joint"], mpath + ("joint",), "leader joint name")
    numbers = []
    for key, default in (("multiplier", 1), ("offset", 0)):
        value = block.get(key, default)
        kpath = mpath + (key,)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not _finite(value):
            v.report(kpath, f"expected a finite number, got {value!r}")
            value = None
        elif key == "multiplier" and value == 0:
            v.report(kpath, "multiplier 0 does not move the joint (make it type: fixed)")
            value = None
        numbers.append(value)
    if "effort" in item:
        epath = path + ("effort",)
        v.report(epath, "a mimic joint has no effort of its own (its drive acts on its leader's coordinate, "
                 f"through the multiplier): put the effort on joint {block['joint']!r}", key=True)
    return None if leader is None or None in numbers else Mimic(leader, *numbers)


def _finite(value: float) -> bool:
    try:
        return math.isfinite(float(value))
    except OverflowError:   # an integer beyond a double
        return False


def check_mimics(v: Any, top: dict[str, Any], joints: list[Joint], planar: bool) -> None:
    """Each follower's leader exists and has a coordinate of its own; what is not built yet
    is refused at the follower's ``mimic``."""
    by_name = {j.name: j for j in joints}
    springs: dict[str, list[int]] = {}
    for i, joint in enumerate(joints):
        if joint.mimic is None:
            if joint.stiffness is not None:
                springs.setdefault(joint.name, []).append(i)
            continue
        mpath, lpath = ("joints", i, "mimic"), ("joints", i, "mimic", "joint")
        if planar or "loops" in top:   # not built yet
            v.report(mpath, "mimic joints are built for 3-D robots only" if planar
                     else "mimic joints in a robot with loops are not built yet", key=True)
            continue
        name = joint.mimic.joint
        leader = by_name.get(name)
        if leader is None:
            v.report(lpath, f"unknown joint {name!r}" + did_you_mean(name, by_name))
        elif leader is joint:
            v.report(lpath, "a joint cannot mimic itself")
        elif leader.mimic is not None:
            v.report(lpath, f"joint '{name}' mimics joint '{leader.mimic.joint}' itself: a joint can only "
                     "mimic a joint with a coordinate of its own (mimic the first one, multipliers and "
                     "offsets composed)")
        elif leader.type not in COUPLED_TYPES:
            v.report(lpath, f"joint '{name}' is {leader.type}: only revolute and prismatic joints can be "
                     "mimicked")
        elif joint.stiffness is not None:
            springs.setdefault(name, []).append(i)
    for leader, indices in springs.items():
        for i in indices[1:]:
            spath = ("joints", i, "stiffness")
            v.report(spath, f"coordinate '{leader}' already has a spring (on joint "
                     f"'{joints[indices[0]].name}'): one spring per coordinate, on a leader or on one of its "
                     "mimic joints", key=True)
