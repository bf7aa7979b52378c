"""The revolute joint: one angle about its unit axis (Pinocchio's ``JointModelRevoluteUnaligned``,
RigidBodyDynamics.jl's ``Revolute``). A vector-space joint: the defaults' configuration maps."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..joint_variables import PlanarMotion
from ..rotations import axis_angle
from .base import NO_GEOMETRY, ONE, ZERO, ZERO3, Column, Geometry, JointType, Vector2


class Revolute(JointType):
    spec = JOINT_KINDS["revolute"]
    turns = True

    def rotation(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        """Rodrigues' rotation by ``q[0]`` about ``axis`` (``spatial.axis_angle``)."""
        return axis_angle(tuple(axis), q[0])  # type: ignore[arg-type]

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The axis, angular (the axis is the same in the joint and the child frame)."""
        return [(tuple(axis), ZERO3)]  # type: ignore[list-item]

    def planar(self, q: sympy.Expr, axis: Vector2) -> PlanarMotion:
        return PlanarMotion(q, (ZERO, ZERO), (ZERO, ZERO, ONE))

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        return pin.JointModelRevoluteUnaligned(axis)
