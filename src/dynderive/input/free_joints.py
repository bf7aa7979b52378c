"""Where a ``floating`` or ``spherical`` joint may stand (part of validation: ``schema.validate``
calls ``check_floating``): anywhere in a 3-D tree, as in Pinocchio (a floating joint between
the world and the root link floats the robot's base; one from the world to each of several
links, several free bodies; one below a link, a body free relative to it); not on a 3-D robot
with loops (not built yet).

A planar robot's ``floating`` joint (x, y, theta) is three joints in a row once validated
(``expand_planar_floating``): prismatic ``<joint>_x`` along the joint frame's x axis,
prismatic ``<joint>_y`` along its y axis and revolute ``<joint>_theta``, joined by two massless
links ``<joint>_x_link`` and ``<joint>_y_link``; the fixed-base planar engine then derives it
as any other tree (loops included).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..model.joint_kinds import BALL, PLANE_AS_JOINTS
from ..model.robot import Joint, Link

#: Names the generated module of a floating-base robot defines or takes as arguments (besides
#: those of every module, ``names.MODULE_NAMES``): robot symbols may not take them.
FLOATING_MODULE_NAMES = frozenset({"NQ", "NV", "VELOCITIES", "EFFORT_COLUMNS", "neutral_configuration",
                                   "integrate", "difference", "configuration_rate",
                                   "v", "dt", "q_from", "q_to"})

#: A planar floating joint's coordinates, ``<joint>_x``, ``<joint>_y``, ``<joint>_theta``.
PLANAR_FLOATING = ("x", "y", "theta")


def planar_floating_names(joint: str) -> list[str]:
    """The coordinates (and joints, once expanded) of a planar floating joint."""
    return [f"{joint}_{s}" for s in PLANAR_FLOATING]


def planar_floating_links(joint: str) -> list[str]:
    """The two massless links between a planar floating joint's three joints."""
    return [f"{joint}_x_link", f"{joint}_y_link"]


def check_floating(v: Any, top: dict[str, Any], joints: list[Joint], planar: bool,
                   links: list[Link] | None = None) -> None:
    """``floating`` and ``spherical`` joints stand anywhere in a 3-D robot, loops too (both
    take the floating-base module); a planar ``floating`` joint anywhere in a planar robot,
    its coordinates' and massless links' names free."""
    spherical = [i for i, j in enumerate(joints) if j.type == BALL]
    floating = [(i, j) for i, j in enumerate(joints) if j.kind.free]
    if planar:
        spatial_only = [(i, j) for i, j in enumerate(joints) if not j.kind.planar]
        for i, joint in spatial_only:
            v.report(("joints", i, "type"), f"a {joint.type} joint moves in 3-D: a planar robot has none (give "
                     "the robot 3-D origins, inertias and axes)")
        if floating and not spatial_only:
            _planar_names(v, floating, joints, links or [])
    elif floating or spherical:
        _reserved(v, top, joints, "a floating-base robot" if floating else "a robot with spherical joints")


def _planar_names(v: Any, floating: list[tuple[int, Joint]], joints: list[Joint], links: list[Link]) -> None:
    """A planar floating joint's three joints and two links take names no other joint or link has."""
    joint_names = {j.name: k for k, j in enumerate(joints)}
    link_names = {lk.name: k for k, lk in enumerate(links)}
    taken: dict[str, int] = {}
    for i, joint in floating:
        path = ("joints", i, "name")
        for name, kind, others in ([(n, "joint", joint_names) for n in planar_floating_names(joint.name)]
                                   + [(n, "link", link_names) for n in planar_floating_links(joint.name)]):
            where = (f"{kind} '{name}' at {v.at((kind + 's', others[name]))}" if name in others else
                     f"the floating joint at {v.at(('joints', taken[name]))}" if name in taken else None)
            if where is not None:
                v.report(path, "a planar floating joint is the joints "
                         f"{', '.join(planar_floating_names(joint.name))} and the massless links "
                         f"{', '.join(planar_floating_links(joint.name))}; '{name}' is taken by {where}")
            taken.setdefault(name, i)


def virtual_links(joints: list[Joint], planar: bool) -> list[Link]:
    """The massless links a planar robot's floating joints add (none in 3-D)."""
    return [Link(name, 0, (0, 0), (0,)) for j in joints if planar and j.kind.free
            for name in planar_floating_links(j.name)]


def expand_planar_floating(joints: list[Joint], links: list[Link],
                           positions: dict[str, tuple[int, int]]) -> tuple[list[Joint], list[Link]]:
    """A planar robot's joints and links with each floating joint written as prismatic x,
    prismatic y and revolute theta in a row (in the joint's place, so its coordinates keep its
    place in ``q``), its two massless links after the file's links (which keep their numbers).
    ``positions`` gains the new joints' and links' (the floating joint's)."""
    expanded: list[Joint] = []
    added: list[Link] = []
    for joint in joints:
        if not joint.kind.free:
            expanded.append(joint)
            continue
        x, y, theta = planar_floating_names(joint.name)
        x_link, y_link = planar_floating_links(joint.name)
        along_x, along_y, about = PLANE_AS_JOINTS
        expanded += [replace(joint, name=x, type=along_x, child=x_link, axis=(1, 0), effort=None),
                     Joint(y, along_y, x_link, y_link, (0, 0, 0), (0, 1)),
                     Joint(theta, about, y_link, joint.child, (0, 0, 0), (1, 0))]
        added += [Link(x_link, 0, (0, 0), (0,)), Link(y_link, 0, (0, 0), (0,))]
        where = positions.get(f"joint:{joint.name}", (1, 1))
        positions |= {f"joint:{n}": where for n in (x, y, theta)} | {f"link:{n}": where for n in (x_link, y_link)}
    return expanded, links + added


def _reserved(v: Any, top: dict[str, Any], joints: list[Joint], kind: str) -> None:
    """No ``independent`` list, and no name the floating-base module defines, on a robot with
    quaternions (its loops are solved with their multipliers, without a reduced form)."""
    if "independent" in top and "loops" in top:
        v.error(("independent",), f"independent: {kind} keeps no reduced form of its loops, so it takes no "
                "independent coordinates (forward_dynamics solves the loops with their multipliers)", key=True)
    parameters = top.get("parameters")
    for name in parameters if isinstance(parameters, dict) else ():
        if name in FLOATING_MODULE_NAMES:
            v.error(("parameters", name), f"parameters.{name}: name '{name}' is reserved by the generated module "
                    f"of {kind}", key=True)
    for i, joint in enumerate(joints):
        if (joint.moves and not joint.multi and joint.name in FLOATING_MODULE_NAMES) or (joint.effort or "") in FLOATING_MODULE_NAMES:
            what, key = ("name", joint.name) if joint.name in FLOATING_MODULE_NAMES else ("effort", joint.effort)
            v.report(("joints", i, what), f"name '{key}' is reserved by the generated module of {kind}")
