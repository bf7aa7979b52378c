"""The rigid bodies of a URDF file: their checks, and welding them into the moving links.

A body is a link's ``<inertial>``: mass, centre of mass and inertia about it in link axes.
``check_bodies`` judges masses and inertias once the joints are read (a link welded to the
world never enters the dynamics, so nothing about it is an error); ``merge_bodies`` combines
the bodies welded by fixed joints into the moving link they ride on (parallel-axis theorem).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model.joint_kinds import is_welded
from . import inertia
from . import urdf_symbolic as symbolic
from .loader import SourceDocument
from .urdf_values import Rotation, _Reader
from .urdf_xml import _Element


@dataclass
class Body:
    """A link's <inertial>, and later the merged body of a moving link and what is welded to it."""

    mass: float
    com: np.ndarray        # in the link frame
    inertia: np.ndarray    # about the COM, link axes
    element: _Element
    scale: float = 0.0     # the largest |COM entry| that went into com (for rounding noise)
    written: np.ndarray | None = None  # the inertia as written, in the axes of <inertial><origin>
    axes: np.ndarray | None = None     # those axes in the link frame (written -> inertia)
    impossible: bool = False           # an inertia that misses the triangle inequality, kept as written
    #: the same values as expressions, when some are parameters (``--symbolic``: ``urdf_symbolic``)
    symbolic: symbolic.SymbolicBody | None = None


def check_bodies(reader: _Reader, doc: SourceDocument, bodies: dict[str, Body],
                  joints: list[dict[str, Any]], floating_base: bool = False) -> None:
    """Masses not negative (a massless moving link is fine when links below it carry mass:
    ``urdf._carrying``) and physical inertias, with the
    rounding tolerance of ``inertia.judge`` (within it: corrected, with a note). Links welded
    to the world (fixed joints up to a link without a parent) never enter the dynamics: what
    is wrong with them is a note, not an error. With ``floating_base`` (``--floating-base``)
    the root floats, so no link is welded to the world: every body is judged as a moving one."""
    moved = set(bodies) if floating_base else inertia.moved_links({j["child"]: (j["parent"], not is_welded(j["type"]))
                                                                   for j in joints})
    written = {name: body.written for name, body in bodies.items() if body.written is not None}
    scale = max(map(inertia.size, written.values()), default=0.0)
    for name, body in bodies.items():
        welded = name not in moved
        mass_element = body.element.find("mass") or body.element
        if body.mass < 0:  # massless links are fine (virtual links between joints; the robot derives when M is regular)
            if welded:
                doc.note(mass_element.at, f"link '{name}' mass: must not be negative (got {body.mass:g}); "
                         "ignored: the link is welded to the world, so its mass never enters the dynamics")
            else:
                reader.error(mass_element, f"link '{name}' mass: must not be negative (got {body.mass:g})")
        element = body.element.find("inertia") or body.element
        verdict = inertia.judge(written[name], scale, welded, impossible=True)
        body.impossible = verdict.impossible
        if verdict.error is not None:
            reader.error(element, f"link '{name}' inertia: {verdict.error}")
        if verdict.note is not None:
            doc.note(element.at, f"link '{name}' inertia: {verdict.note}")
        if verdict.tensor is not written[name] and body.axes is not None:
            body.inertia = body.axes @ verdict.tensor @ body.axes.T
            body.written = verdict.tensor   # what an inertia made parameters takes as defaults


def merge_bodies(reader: _Reader, bodies: dict[str, Body], link_elements: dict[str, _Element],
                  frames: dict[str, tuple[str, Rotation, np.ndarray]]) -> dict[str, Body]:
    """Bodies welded together, combined by the parallel-axis theorem, by moving link."""
    merged: dict[str, Body] = {}
    for name in link_elements:
        target, rotation, p = frames[name]
        if target == "world" or name not in bodies:
            continue
        body = bodies[name]
        R = rotation.matrix
        placed = Body(body.mass, R @ body.com + p, R @ body.inertia @ R.T, body.element,
                      max(body.scale, float(np.max(np.abs(p)))), impossible=body.impossible)
        if body.symbolic is not None:
            placed.symbolic = symbolic.SymbolicBody(body.symbolic.mass,
                                                    symbolic.transform(R, p, body.symbolic.com),
                                                    symbolic.rotate(R, body.symbolic.inertia))
        merged[target] = placed if target not in merged else combine(merged[target], placed)

    return merged


def combine(a: Body, b: Body) -> Body:
    """Two rigid bodies welded together (all in one frame): mass, COM, inertia about the COM.
    A massless body without inertia (a frame: a tool flange) leaves ``a`` exactly as it was
    (``(m c + 0) / m`` need not give back ``c`` in floating point)."""
    if not b.mass and not np.any(b.inertia) and b.symbolic is None:
        return a
    mass = a.mass + b.mass
    com = (a.mass * a.com + b.mass * b.com) / mass if mass > 0 else a.com
    inertia = np.zeros((3, 3))
    for body in (a, b):
        inertia += body.inertia
        if body.mass:  # a massless body adds no parallel-axis term, however far away it is
            d = body.com - com
            inertia += body.mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    body = Body(mass, com, inertia, a.element, max(a.scale, b.scale), impossible=a.impossible or b.impossible)
    if a.symbolic is not None or b.symbolic is not None:
        a_, b_ = (x.symbolic or symbolic.of_numbers(x.mass, x.com, x.inertia) for x in (a, b))
        body.symbolic = symbolic.combine(a_, b_)
    return body
