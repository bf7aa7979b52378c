"""The 3-D planar joint: x and y in the plane normal to its unit axis (default z), then the
angle theta about the axis; coordinates ``<joint>_x, <joint>_y, <joint>_theta``, velocities
their rates (a vector-space joint, NQ = NV = 3). A product of two prismatic motions and a
revolute one (``base.Product``): its x and y columns turn with theta.

The plane's x direction ``e1`` is the joint frame's x axis projected on the plane (its y axis
when the normal is nearer x than y), ``e2 = axis x e1``: for the axis z, x and y (the URDF
reader's convention). Pinocchio's ``JointModelPlanar`` (axis z) stores ``(x, y, cos theta,
sin theta)`` and the local velocity ``(R(theta)^T (xdot, ydot), thetadot)``; ``check``'s
reference is the composite of the three motions, which has these rates as its velocity."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..joint_variables import unit
from .base import NO_GEOMETRY, Geometry, Product, Segment, basis
from .prismatic import Prismatic
from .revolute import Revolute


def plane_axes(normal: Sequence[sympy.Expr]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``e1`` and ``e2`` of the plane normal to the unit ``normal`` (module docstring)."""
    n = sympy.Matrix(normal)
    nearer_x = n[0].is_number and n[1].is_number and abs(n[0]) > abs(n[1])
    guess = sympy.Matrix(basis(1 if nearer_x else 0))
    e1 = guess - guess.dot(n) * n
    e1 = sympy.Matrix(unit(tuple(e1)))
    return tuple(e1), tuple(n.cross(e1))


class Planar(Product):
    spec = JOINT_KINDS["planar"]

    def segments(self, axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Segment]:
        e1, e2 = plane_axes(axis)
        return [Segment(Prismatic(), e1), Segment(Prismatic(), e2), Segment(Revolute(), tuple(axis))]  # type: ignore[arg-type]

    def typical(self) -> list[float]:
        """0.2 along x and y, half a radian about the axis."""
        return [0.2, 0.2, 0.5]

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        """The composite of its three motions (velocities the rates, as here)."""
        import numpy as np

        e1, e2 = (np.array([float(x) for x in e], dtype=float) for e in plane_axes([sympy.Float(a) for a in axis]))
        composite = pin.JointModelComposite(pin.JointModelPrismaticUnaligned(e1))
        composite.addJoint(pin.JointModelPrismaticUnaligned(e2))
        composite.addJoint(pin.JointModelRevoluteUnaligned(np.asarray(axis, dtype=float)))
        return composite
