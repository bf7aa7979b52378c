"""Unit quaternions ``(x, y, z, w)`` as program lines: the rotation matrix, products, the
exponential and logarithm of SO(3) and SE(3) (Pinocchio's ``liegroup/special-orthogonal.hpp``
and ``special-euclidean.hpp``, ``spatial/explog.hpp``), shared by the ``floating`` and
``spherical`` joint types.

Every target prints these lines (``Derivation.configuration_programs``): below an angle of
``SMALL`` the exponential and the logarithm take their series, and the closed forms divide by ``t`` (the angle, or 1 when small), so no branch
divides by zero, in values or derivatives, when a target evaluates both (``jnp.where``).
Branches are ``sympy.Piecewise``.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy

from ..program import _add, _cross, _dot
from .base import Let

#: Below this angle the exponential and the logarithm use their series.
SMALL = sympy.Float("1e-4")
HALF = sympy.Rational(1, 2)
Quaternion = tuple[sympy.Expr, sympy.Expr, sympy.Expr, sympy.Expr]


def quaternion_matrix(qx: sympy.Expr, qy: sympy.Expr, qz: sympy.Expr, qw: sympy.Expr) -> sympy.Matrix:
    """The rotation matrix of the quaternion ``qw + qx i + qy j + qz k`` (unit; as Eigen's
    ``Quaternion::toRotationMatrix``: a polynomial, no normalization)."""
    return sympy.Matrix([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])


def multiply(let: Let, a: Sequence[sympy.Expr], b: Sequence[sympy.Expr]) -> Quaternion:
    """The product ``a b``: ``(s v + t u + u x v, s t - u . v)`` for ``a = (u, s)``, ``b = (v, t)``."""
    u, s, v, t = a[:3], a[3], b[:3], b[3]
    vector = _add(_add([s * x for x in v], [t * x for x in u]), _cross(u, v))
    return (*(let(x) for x in vector), let(s * t - _dot(u, v)))  # type: ignore[return-value]


def rotate(let: Let, quaternion: Sequence[sympy.Expr], vector: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    """``vector`` rotated by the unit ``quaternion``: ``v + w t + u x t``, ``t = 2 u x v``."""
    u, w = quaternion[:3], quaternion[3]
    t = [let(2 * x) for x in _cross(u, vector)]
    return tuple(let(a + w * b + c) for a, b, c in zip(vector, t, _cross(u, t)))


def normalized(let: Let, quaternion: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    norm = let(sympy.sqrt(_dot(quaternion[:3], quaternion[:3]) + quaternion[3] ** 2))
    return tuple(let(x / norm) for x in quaternion)


def inverse(let: Let, quaternion: Sequence[sympy.Expr]) -> Quaternion:
    """The conjugate over the squared norm (the inverse of any nonzero quaternion)."""
    n2 = let(_dot(quaternion[:3], quaternion[:3]) + quaternion[3] ** 2)
    return (*(let(-x / n2) for x in quaternion[:3]), let(quaternion[3] / n2))  # type: ignore[return-value]


def _angle(let: Let, theta: sympy.Expr) -> tuple[sympy.Basic, sympy.Expr]:
    """Whether the angle is small, and ``t``: the angle, or 1 when small."""
    small = theta < SMALL
    return small, let(sympy.Piecewise((1, small), (theta, True)))


def exp3(let: Let, r: Sequence[sympy.Expr]) -> tuple[Quaternion, sympy.Expr]:
    """The unit quaternion of ``exp(r)`` (a rotation by ``|r|`` about ``r``), and the angle."""
    theta = let(sympy.sqrt(_dot(r, r)))
    small, t = _angle(let, theta)
    half_sinc = let(sympy.Piecewise((HALF - theta**2 / 48, small), (sympy.sin(t / 2) / t, True)))
    return (*(let(half_sinc * x) for x in r), let(sympy.cos(theta / 2))), theta  # type: ignore[return-value]


def exp6_translation(let: Let, linear: Sequence[sympy.Expr], r: Sequence[sympy.Expr],
                     theta: sympy.Expr) -> tuple[sympy.Expr, ...]:
    """The translation of ``exp((linear, r))`` (SE(3), in the moving frame):
    ``l + a r x l + b r x (r x l)``, ``a = (1 - cos t)/t^2``, ``b = (t - sin t)/t^3``."""
    small, t = _angle(let, theta)
    a = let(sympy.Piecewise((HALF - theta**2 / 24, small), ((1 - sympy.cos(t)) / t**2, True)))
    b = let(sympy.Piecewise((sympy.Rational(1, 6) - theta**2 / 120, small), ((t - sympy.sin(t)) / t**3, True)))
    rl = [let(x) for x in _cross(r, linear)]
    rrl = _cross(r, rl)
    return tuple(let(x + a * y + b * z) for x, y, z in zip(linear, rl, rrl))


def log3(let: Let, quaternion: Sequence[sympy.Expr]) -> tuple[tuple[sympy.Expr, ...], sympy.Expr]:
    """The rotation vector ``w`` with ``exp(w)`` the unit ``quaternion`` (angle in [0, pi]: the
    quaternion taken with ``w >= 0``), and its angle."""
    flip = let(sympy.Piecewise((-1, quaternion[3] < 0), (1, True)))
    h = [let(flip * x) for x in quaternion[:3]]
    c = let(flip * quaternion[3])
    s = let(sympy.sqrt(_dot(h, h)))
    theta = let(2 * sympy.atan2(s, c))
    small = theta < SMALL
    scale = let(sympy.Piecewise((2 + theta**2 / 12, small),
                                (theta / sympy.Piecewise((1, sympy.Eq(s, 0)), (s, True)), True)))
    return tuple(let(scale * x) for x in h), theta


def log6_translation(let: Let, p: Sequence[sympy.Expr], w: Sequence[sympy.Expr],
                     theta: sympy.Expr) -> tuple[sympy.Expr, ...]:
    """The linear part of ``log`` of the pose ``(exp(w), p)`` (SE(3)): ``p - 1/2 w x p + k w x
    (w x p)``, ``k = (1 - t sin t / (2 (1 - cos t))) / t^2``."""
    small, t = _angle(let, theta)
    k = let(sympy.Piecewise((sympy.Rational(1, 12) + theta**2 / 720, small),
                            ((1 - t * sympy.sin(t) / (2 * (1 - sympy.cos(t)))) / t**2, True)))
    wp = [let(x) for x in _cross(w, p)]
    return tuple(let(x - HALF * y + k * z) for x, y, z in zip(p, wp, _cross(w, wp)))


def quaternion_seeds(let: Let, quaternion: Sequence[sympy.Symbol]) -> list[dict[sympy.Symbol, sympy.Expr]]:
    """Per local angular velocity entry ``k``, the quaternion's tangent ``1/2 quaternion * (e_k, 0)``."""
    u, s = quaternion[:3], quaternion[3]
    seeds = []
    for k in range(3):
        axis = [sympy.Integer(int(r == k)) for r in range(3)]
        spin = _add([s * a for a in axis], _cross(u, axis))   # 1/2 quat * (axis, 0)
        seeds.append({**{quaternion[r]: let(HALF * spin[r]) for r in range(3)}, quaternion[3]: let(-HALF * u[k])})
    return seeds


def quaternion_rate(let: Let, quaternion: Sequence[sympy.Expr], w: Sequence[sympy.Expr]) -> list[sympy.Expr]:
    """``d quaternion/dt = 1/2 quaternion * (w, 0)`` at the local angular velocity ``w``."""
    product = multiply(let, quaternion, (*w, sympy.Integer(0)))
    return [let(HALF * x) for x in product]


__all__ = ["SMALL", "exp3", "exp6_translation", "inverse", "log3", "log6_translation", "multiply", "normalized",
           "quaternion_matrix", "quaternion_rate", "quaternion_seeds", "rotate"]
