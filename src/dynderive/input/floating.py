"""Where a ``floating`` or ``spherical`` joint may stand (part of validation: ``schema.validate``
calls ``check_floating``): anywhere in a 3-D tree, as in Pinocchio (a floating joint between
the world and the root link floats the robot's base; one from the world to each of several
links, several free bodies; one below a link, a body free relative to it); not in a planar
robot, nor on a robot with loops (issue 30 builds those later).
"""

from __future__ import annotations

from typing import Any

from ..model.robot import Joint

#: Names the generated module of a floating-base robot defines or takes as arguments (besides
#: those of every module, ``names.MODULE_NAMES``): robot symbols may not take them.
FLOATING_MODULE_NAMES = frozenset({"NQ", "NV", "VELOCITIES", "EFFORT_COLUMNS", "neutral_configuration", "integrate", "difference",
                                   "configuration_rate",
                                   "v", "dt", "q_from", "q_to"})


def check_floating(v: Any, top: dict[str, Any], joints: list[Joint], planar: bool) -> None:
    """``floating`` and ``spherical`` joints stand anywhere in a 3-D robot without loops (both
    take the floating-base module)."""
    spherical = [(i, j) for i, j in enumerate(joints) if j.type == "spherical"]
    if spherical and planar:
        for i, _ in spherical:
            v.error(("joints", i, "type"), f"{v.label(('joints', i, 'type'))}: a spherical joint turns in 3-D: "
                    "a planar robot has none (give the robot 3-D origins, inertias and axes)")
        return
    floating = [(i, j) for i, j in enumerate(joints) if j.type == "floating"]
    if not floating:
        if spherical:
            _reserved(v, top, joints, "a robot with spherical joints")
        return
    if planar:
        for i, _ in floating:
            v.error(("joints", i, "type"), f"{v.label(('joints', i, 'type'))}: planar floating joints are not "
                    "built yet (issue 30)")
        return
    _reserved(v, top, joints, "a floating-base robot")


def _reserved(v: Any, top: dict[str, Any], joints: list[Joint], kind: str) -> None:
    """No loops, and no name the floating-base module defines, on a robot with quaternions."""
    if "loops" in top:
        v.error(("loops",), f"loops: closed loops on {kind} are not built yet (issue 30)", key=True)
    parameters = top.get("parameters")
    for name in parameters if isinstance(parameters, dict) else ():
        if name in FLOATING_MODULE_NAMES:
            v.error(("parameters", name), f"parameters.{name}: name '{name}' is reserved by the generated module "
                    f"of {kind}", key=True)
    for i, joint in enumerate(joints):
        if (joint.moves and not joint.multi and joint.name in FLOATING_MODULE_NAMES) or (joint.effort or "") in FLOATING_MODULE_NAMES:
            what, key = ("name", joint.name) if joint.name in FLOATING_MODULE_NAMES else ("effort", joint.effort)
            v.error(("joints", i, what), f"{v.label(('joints', i, what))}: name '{key}' is reserved by the "
                    f"generated module of {kind}")
