"""The universal (Cardan) joint: a turn about its unit axis, then a turn about ``axis2``
(orthogonal to it, in the frame the first turn leaves), Pinocchio's
``JointModelUniversal(axis, axis2)``: rotation ``R(axis, q1) R(axis2, q2)``, velocities the
angles' rates. A product of two revolute motions (``base.Product``): its first column turns
with the second angle."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..joint_variables import unit
from .base import NO_GEOMETRY, Geometry, Product, Segment
from .revolute import Revolute


class Universal(Product):
    spec = JOINT_KINDS["universal"]
    turns = True

    def segments(self, axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Segment]:
        turn = Revolute()
        return [Segment(turn, tuple(axis)), Segment(turn, unit(tuple(geometry["axis2"])))]  # type: ignore[arg-type]

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        import numpy as np

        second = np.asarray(geometry["axis2"], dtype=float)
        return pin.JointModelUniversal(np.asarray(axis, dtype=float), second / np.linalg.norm(second))
