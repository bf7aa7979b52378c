"""The spherical (ball) joint: configuration a unit quaternion ``[qx, qy, qz, qw]``, velocity
the child frame's angular velocity in its own frame (Pinocchio's ``JointModelSpherical``,
Lie group SO(3)): nq = 4, nv = 3.

``integrate`` is the quaternion times the exponential of ``v dt``, normalized (no change of
hemisphere, as Pinocchio's SO(3)); ``difference`` the logarithm of ``q0^-1 q1``; the rate
``1/2 q * (w, 0)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from .base import NO_GEOMETRY, ONE, ZERO, ZERO3, Column, Geometry, JointType, Let, basis, keep
from .quaternion import (
    exp3,
    inverse,
    log3,
    multiply,
    normalized,
    quaternion_matrix,
    quaternion_rate,
    quaternion_seeds,
)


class Spherical(JointType):
    """The ball joint; the free flyer (``free_flyer.py``) extends it, its quaternion at
    ``quaternion_start``."""

    spec = JOINT_KINDS["spherical"]

    def rotation(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr] = (),
                 geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        return quaternion_matrix(*q[self.quaternion_start:self.quaternion_start + 4])

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr] = (), geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The three angular unit columns."""
        return [(basis(k), ZERO3) for k in range(3)]

    def tangent_seed(self, q: Sequence[sympy.Symbol], let: Let = keep) -> list[dict[sympy.Symbol, sympy.Expr]]:
        return quaternion_seeds(let, q)

    def typical(self) -> list[float]:
        """The neutral configuration (the identity quaternion)."""
        return [float(e) for e in self.neutral()]

    def neutral(self) -> list[sympy.Expr]:
        return [ZERO] * (self.nq - 1) + [ONE]

    def integrate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
                  dt: sympy.Expr) -> list[sympy.Expr]:
        step, _ = exp3(let, [let(x * dt) for x in v])
        return list(normalized(let, multiply(let, q, step)))

    def difference(self, let: Let, q0: Sequence[sympy.Expr], q1: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        relative = normalized(let, multiply(let, inverse(let, q0), q1))
        return list(log3(let, relative)[0])

    def rate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        return quaternion_rate(let, q, v)

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        return pin.JointModelSpherical()
