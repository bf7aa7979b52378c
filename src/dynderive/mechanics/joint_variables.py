"""What the scalar joint types' planar motion is (``PlanarMotion``, answered by
``joint_types``' ``planar``), and how a joint's variable depends on the coordinates
(``Coupling``: a URDF ``<mimic>`` joint follows its leader's).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy

from ..model.robot import Robot

Vector2 = tuple[sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class PlanarMotion:
    """Child frame relative to the joint frame: rotate by ``angle``, then shift by ``shift``."""

    angle: sympy.Expr
    shift: Vector2
    #: Unit twist (vx, vy, omega) in the joint frame: the velocity per unit coordinate rate.
    twist: tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Coupling:
    """How a moving joint's variable depends on the coordinates: ``multiplier * q[coordinate]
    + offset`` (1 and 0 for a joint with a coordinate of its own; a URDF ``<mimic>`` joint
    follows its leader's coordinate). The joint's motion per unit rate of that coordinate is
    its unit twist times ``multiplier``."""

    coordinate: int
    multiplier: sympy.Expr
    variable: sympy.Expr


def couplings(robot: Robot, table: Any) -> dict[str, Coupling]:
    """The ``Coupling`` of every moving joint with a single coordinate, by joint name."""
    index = {name: i for i, name in enumerate(robot.coordinates)}
    found = {}
    for joint in (j for j in robot.joints if j.moves and j.kind.nq == 1):
        leader, multiplier, offset = robot.driver(joint)
        k = index[leader]
        m, o = table.expr(multiplier), table.expr(offset)
        found[joint.name] = Coupling(k, m, m * table.q[k] + o)
    return found


def unit(axis: tuple[sympy.Expr, ...]) -> tuple[sympy.Expr, ...]:
    """Normalise an axis; numbers stay exact (``[3, 4]`` -> ``(3/5, 4/5)``)."""
    norm = sympy.sqrt(sum(a**2 for a in axis))
    if norm == 1:
        return tuple(axis)
    return tuple(sympy.radsimp(a / norm) for a in axis)


@dataclass(frozen=True)
class ScalarMotion:
    """One one-coordinate screw motion on a joint's path, as the sheet's kinematics compose
    them: its type (revolute, prismatic, helical), unit axis, own keys and ``Coupling``. A
    one-coordinate joint is one; a product joint (universal, 3-D planar) one per coordinate."""

    kind: Any
    axis: tuple[sympy.Expr, ...]
    geometry: Any
    coupling: Coupling


def scalar_motions(robot: Robot, table: Any, joint: Any, coupling: dict[str, Coupling]) -> list[ScalarMotion]:
    """A moving joint of a robot without quaternions as its one-coordinate motions, in order
    (``coupling``: the robot's ``couplings``)."""
    from . import joint_types

    kind, geometry = joint_types.of(joint), joint_types.geometry_of(joint, table.expr)
    axis = unit(tuple(table.expr(e) for e in joint.axis)) if joint.kind.takes_axis else ()
    if kind.nq == 1:
        return [ScalarMotion(kind, axis, geometry, coupling[joint.name])]
    start = robot.offsets()[0][joint.name]
    return [ScalarMotion(s.kind, s.axis, s.geometry, Coupling(start + k, sympy.Integer(1), table.q[start + k]))
            for k, s in enumerate(kind.segments(axis, geometry))]
