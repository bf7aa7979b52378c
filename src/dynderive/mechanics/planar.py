"""Planar kinematics: COM frames, their world poses and body Jacobians.

A world position is kept as a sum of link-local vectors, each tagged with the angle of the
frame it is written in. Expressing it in another frame rotates each group by the *relative*
angle, which SymPy reduces on its own (``q1 + q2 - q1`` -> ``q2``), so body-frame quantities
come out compact without any trigonometric simplification.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .joint_types import joint_type


def rotated(angle: sympy.Expr, vector: Sequence[sympy.Expr]) -> sympy.Matrix:
    """The plane vector ``vector`` rotated by ``angle``."""
    c, s = sympy.cos(angle), sympy.sin(angle)
    return sympy.Matrix([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]])


@dataclass
class RotatedSum:
    """``sum_i Rot(angle_i) @ vector_i``; consecutive terms of one angle are merged."""

    terms: list[tuple[sympy.Expr, list[sympy.Expr]]] = field(default_factory=list)

    def add(self, angle: sympy.Expr, vector: tuple[sympy.Expr, sympy.Expr]) -> None:
        if vector[0] == 0 and vector[1] == 0:
            return
        if self.terms and self.terms[-1][0] == angle:  # only the last: keeps tails exact
            total = self.terms[-1][1]
            total[0] += vector[0]
            total[1] += vector[1]
            return
        self.terms.append((angle, [vector[0], vector[1]]))

    def tail(self, start: int) -> RotatedSum:
        return RotatedSum([(a, list(v)) for a, v in self.terms[start:]])

    def copy(self) -> RotatedSum:
        return self.tail(0)

    def in_frame(self, frame_angle: sympy.Expr) -> sympy.Matrix:
        """The vector expressed in a frame at ``frame_angle`` (world: 0)."""
        grouped: dict[sympy.Expr, list[sympy.Expr]] = {}
        for angle, (x, y) in self.terms:
            relative = angle - frame_angle
            slot = grouped.setdefault(relative, [sympy.Integer(0), sympy.Integer(0)])
            slot[0] += x
            slot[1] += y
        return sum((rotated(relative, vector) for relative, vector in grouped.items()), sympy.zeros(2, 1))


@dataclass
class JointFrame:
    """Where a moving joint sits on a link's path, for Jacobian columns."""

    coordinate: int            # index into the generalized coordinates
    position_index: int        # how many position terms lie before the joint frame origin
    angle: sympy.Expr          # angle of the joint frame (before its own motion)
    twist: tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass
class PlanarLinkKinematics:
    """Kinematics of one link's COM frame. The joint point and the body Jacobian are worked
    out on first use: the maximal model of a large chain needs only the COM poses, and the
    Jacobians of 30 full-precision links cost seconds."""

    name: str
    angle: sympy.Expr                 # world angle of the link (and COM) frame
    com_position: RotatedSum          # world position of the COM, as a rotated sum
    _origin: RotatedSum = field(repr=False)          # world position of the link frame origin
    _frames: list[JointFrame] = field(repr=False)    # moving joints on the link's path
    _coordinates: int = field(repr=False)

    @property
    def com_world(self) -> sympy.Matrix:
        return self.com_position.in_frame(sympy.Integer(0))

    @cached_property
    def joint_origin(self) -> sympy.Matrix:
        """World position of the link frame origin (joint point)."""
        return self._origin.in_frame(sympy.Integer(0))

    @cached_property
    def body_jacobian(self) -> sympy.Matrix:
        """3 x n: (vx, vy, omega) of the COM frame in its own axes, per joint rate."""
        jacobian = sympy.zeros(3, self._coordinates)
        for frame in self._frames:
            vx, vy, omega = frame.twist
            # velocity of the COM from this joint: the joint's own translation rate, plus
            # omega z x (COM - joint origin); both rotated into the COM frame.
            lever = self.com_position.tail(frame.position_index).in_frame(self.angle)
            own = RotatedSum([(frame.angle, [vx, vy])]).in_frame(self.angle)
            jacobian[0, frame.coordinate] = own[0] - omega * lever[1]
            jacobian[1, frame.coordinate] = own[1] + omega * lever[0]
            jacobian[2, frame.coordinate] = omega
        return jacobian


def planar_kinematics(robot: Robot, table: SymbolTable) -> list[PlanarLinkKinematics]:
    """COM poses and body Jacobians of every link, in the file's link order."""
    index_of = {name: i for i, name in enumerate(robot.coordinates)}
    n = len(robot.coordinates)
    results = []
    for link in robot.links:
        angle = sympy.Integer(0)
        position = RotatedSum()
        frames: list[JointFrame] = []
        for joint in robot.path_to(link.name):
            x, y, theta = (table.expr(e) for e in joint.origin)
            position.add(angle, (x, y))
            angle = angle + theta
            kind = joint_type(joint.type)
            q = table.q[index_of[joint.name]] if kind.moves else sympy.Integer(0)
            axis = tuple(table.expr(e) for e in joint.axis)
            motion = kind.planar(q, axis)  # type: ignore[arg-type]
            if kind.moves:
                frames.append(JointFrame(index_of[joint.name], len(position.terms), angle, motion.twist))
            position.add(angle, motion.shift)
            angle = angle + motion.angle
        origin = position.copy()
        cx, cy = (table.expr(e) for e in link.com)
        position.add(angle, (cx, cy))
        results.append(PlanarLinkKinematics(link.name, angle, position, origin, frames, n))
    return results
