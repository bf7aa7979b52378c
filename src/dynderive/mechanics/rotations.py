"""Rotations from angles, tidied as they are built: URDF roll-pitch-yaw and Rodrigues' axis-angle
(the joint types and the kinematics read them)."""

from __future__ import annotations

import sympy

from .tidy import is_small, quick_tidy

#: Pieces larger than this (operations) are composed without tidying.
PIECE_LIMIT = 250  # tree nodes


def _tidy(matrix: sympy.Matrix) -> sympy.Matrix:
    return matrix.applyfunc(lambda e: quick_tidy(e) if is_small(e, PIECE_LIMIT) else e)


def rpy_matrix(roll: sympy.Expr, pitch: sympy.Expr, yaw: sympy.Expr) -> sympy.Matrix:
    """URDF fixed-axis roll-pitch-yaw: ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    return _tidy(_rot("z", yaw) * _rot("y", pitch) * _rot("x", roll))


def _rot(axis: str, angle: sympy.Expr) -> sympy.Matrix:
    c, s = sympy.cos(angle), sympy.sin(angle)
    if axis == "x":
        return sympy.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return sympy.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return sympy.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def axis_angle(axis: tuple[sympy.Expr, sympy.Expr, sympy.Expr], angle: sympy.Expr) -> sympy.Matrix:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues); ``[0, 0, -1]`` is Rz(-q)."""
    for index, name in enumerate("xyz"):
        others = [axis[i] for i in range(3) if i != index]
        if all(o == 0 for o in others) and axis[index] in (1, -1):
            return _rot(name, axis[index] * angle)
    K = sympy.Matrix([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return _tidy(sympy.eye(3) + sympy.sin(angle) * K + (1 - sympy.cos(angle)) * K * K)
