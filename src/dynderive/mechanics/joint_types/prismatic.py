"""The prismatic joint: one displacement along its unit axis (Pinocchio's
``JointModelPrismaticUnaligned``, RigidBodyDynamics.jl's ``Prismatic``). A vector-space joint:
the defaults' configuration maps."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..joint_variables import PlanarMotion, unit
from .base import NO_GEOMETRY, ZERO, ZERO3, Column, Geometry, JointType, Vector2


class Prismatic(JointType):
    spec = JOINT_KINDS["prismatic"]

    def displacement(self, origin: sympy.Matrix, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        """``(origin axis) q``: the axis in the parent's axes times the displacement."""
        return origin * sympy.Matrix(axis) * q[0]

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The axis, linear."""
        return [(ZERO3, tuple(axis))]  # type: ignore[list-item]

    def planar(self, q: sympy.Expr, axis: Vector2) -> PlanarMotion:
        ux, uy = unit(axis)
        return PlanarMotion(ZERO, (q * ux, q * uy), (ux, uy, ZERO))

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        return pin.JointModelPrismaticUnaligned(axis)
