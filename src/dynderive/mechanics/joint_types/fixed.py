"""The fixed joint: no coordinate, no motion (RigidBodyDynamics.jl's ``Fixed``); its child is
welded to its parent. Its configuration space is a point: every map is empty."""

from __future__ import annotations

from collections.abc import Sequence

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..joint_variables import PlanarMotion
from .base import NO_GEOMETRY, ZERO, Column, Geometry, JointType, Vector2


class Fixed(JointType):
    spec = JOINT_KINDS["fixed"]

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[object], geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        return []

    def planar(self, q: sympy.Expr, axis: Vector2) -> PlanarMotion:
        return PlanarMotion(ZERO, (ZERO, ZERO), (ZERO, ZERO, ZERO))
