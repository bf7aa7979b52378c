"""The helical (screw) joint: one angle about its unit axis, moving ``pitch`` along the axis
per radian (Pinocchio's ``JointModelHelicalUnaligned(axis, pitch)``): the rotation of a
revolute joint and the displacement ``pitch * q`` along the same axis, one velocity entry
whose motion column has both parts. A vector-space joint: the defaults' configuration maps."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..rotations import axis_angle
from .base import NO_GEOMETRY, Column, Geometry, JointType


class Helical(JointType):
    spec = JOINT_KINDS["helical"]
    turns = True

    def rotation(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                 geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        return axis_angle(tuple(axis), q[0])  # type: ignore[arg-type]

    def displacement(self, origin: sympy.Matrix, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        """``(origin axis) pitch q``."""
        return origin * sympy.Matrix(axis) * (geometry["pitch"] * q[0])

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The axis, angular, and ``pitch`` times it, linear (the axis reads the same in the
        joint and the child frame)."""
        return [(tuple(axis), tuple(geometry["pitch"] * a for a in axis))]  # type: ignore[list-item]

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        return pin.JointModelHelicalUnaligned(axis, geometry["pitch"])
