"""The 3-D floating joint (free flyer): configuration ``[x, y, z, qx, qy, qz, qw]``, the child
frame's position in the joint frame and a unit quaternion; velocity ``[vx, vy, vz, wx, wy,
wz]``, the child frame's linear and angular velocity in its own frame (Pinocchio's
``JointModelFreeFlyer``, Lie group SE(3)): nq = 7, nv = 6, motion subspace the identity.

``integrate`` is the pose times the exponential of the twist ``v dt`` (its quaternion
normalized and kept in the hemisphere of q's, as Pinocchio's SE(3)), ``difference`` the
logarithm of ``M0^-1 M1``, the rate ``(R(q) v_linear, 1/2 q * (w, 0))``.

A planar robot's ``floating`` joint (x, y, theta) is not this type: the loader expands it
into a prismatic, a prismatic and a revolute joint (``input/free_joints.py``,
``expand_planar_floating``), vector-space joints, before any mechanics runs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ..program import _dot
from .base import NO_GEOMETRY, ZERO3, Column, Geometry, Let, basis, keep
from .quaternion import exp3, exp6_translation, inverse, log3, log6_translation, multiply, normalized, rotate
from .spherical import Spherical


class Floating(Spherical):
    spec = JOINT_KINDS["floating"]

    def displacement(self, origin: sympy.Matrix, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr] = (),
                     geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        """``origin (x, y, z)``."""
        return origin * sympy.Matrix(q[:3])

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr] = (), geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The 6 x 6 identity: three linear unit columns, then three angular ones."""
        return [(ZERO3, basis(k)) for k in range(3)] + [(basis(k), ZERO3) for k in range(3)]

    def tangent_seed(self, q: Sequence[sympy.Symbol], let: Let = keep) -> list[dict[sympy.Symbol, sympy.Expr]]:
        """The position's tangent ``R(quaternion) e_k``, then the quaternion's."""
        R = self.rotation(q)
        return [{q[r]: let(R[r, k]) for r in range(3)} for k in range(3)] + super().tangent_seed(q[3:7], let)

    def integrate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
                  dt: sympy.Expr) -> list[sympy.Expr]:
        linear, r = [let(x * dt) for x in v[:3]], [let(x * dt) for x in v[3:]]
        quaternion = q[3:7]
        step, theta = exp3(let, r)
        shift = rotate(let, quaternion, exp6_translation(let, linear, r, theta))
        moved = normalized(let, multiply(let, quaternion, step))
        sign = let(sympy.Piecewise((-1, _dot(moved[:3], quaternion[:3]) + moved[3] * quaternion[3] < 0), (1, True)))
        return [let(a + b) for a, b in zip(q[:3], shift)] + [let(sign * x) for x in moved]

    def difference(self, let: Let, q0: Sequence[sympy.Expr], q1: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        back = inverse(let, q0[3:7])
        relative = normalized(let, multiply(let, back, q1[3:7]))
        w, theta = log3(let, relative)
        p = rotate(let, back, [let(b - a) for a, b in zip(q0[:3], q1[:3])])
        return [*log6_translation(let, p, w, theta), *w]

    def rate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        return [*rotate(let, q[3:7], v[:3]), *super().rate(let, q[3:7], v[3:])]

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        return pin.JointModelFreeFlyer()
