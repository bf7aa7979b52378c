"""What the URDF reader shares with its helpers (``urdf.py``, ``urdf_bodies.py``,
``urdf_root.py``): ``_Reader`` (the file's problems and the numbers read from attributes),
written angles snapped to exact quarter turns (``snap``) and ``Rotation`` (a rotation matrix
with the ``rpy`` it was written with until it is composed); ``axis_rotation`` (Rodrigues) also
serves the MJCF reader and the 3-D drawing."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError, Problem
from ..model.expressions import LARGEST
from ..model.written import significant_digits
from .urdf_xml import _Element, numbers_in


class _Reader:
    def __init__(self, file: str):
        self.file = file
        self.problems: list[Problem] = []
        #: the most significant digits of a number read (the sheet's precision)
        self.digits = 0

    def error(self, element: _Element, message: str) -> None:
        self.problems.append(Problem(self.file, *element.at, message))

    def raise_problems(self) -> None:
        """Stop the reading with every problem found so far, if any."""
        if self.problems:
            raise InputError(self.problems)

    def numbers(self, element: _Element | None, attribute: str, count: int, default: list[float],
                angles: bool = False) -> list[float]:
        """``count`` numbers of an attribute; ``angles``: an angle of whole quarter turns
        (1.5707963267948966, exactly pi/2 then) does not count among the digits written."""
        if element is None or attribute not in element.attrib:
            return list(default)
        text = element.attrib[attribute]
        values, bad = numbers_in(text)
        if bad is not None or len(values) != count or not all(math.isfinite(v) for v in values):
            why = f" ({bad!r} is not one: write numbers as 1, -0.5 or 2.5e-3)" if bad is not None else ""
            self.error(element, f"<{element.tag} {attribute}=\"{text}\">: expected "
                       f"{count} finite number{'s' * (count > 1)}{why}")
            return list(default)
        if any(abs(v) > LARGEST for v in values):
            self.error(element, f"<{element.tag} {attribute}=\"{text}\">: out of range (a robot's numbers are "
                       "at most 1e10 in size: products of them must stay within a double)")
            return list(default)
        for word, value in zip(text.split(), values):
            if not (angles and snap(value)[1] is not None):
                self.digits = max(self.digits, significant_digits(word))
        return values


#: A written angle within this distance of a multiple of pi/2 is that multiple, exactly.
SNAP = 1e-9
#: Only angles of at most this many quarter turns (one full turn either way) are snapped.
SNAP_QUARTERS = 4

#: An angle: its value, and the number of quarter turns when it is exactly a multiple of pi/2.
Angle = tuple[float, int | None]


def snap(value: float) -> Angle:
    """A written angle: within ``SNAP`` of ``k*pi/2`` (``|k| <= 4``) it is exactly ``k`` quarter turns.

    Applied only to angles as written in the file (``rpy`` of joint and inertial origins), never
    to angles computed by composing rotations.
    """
    quarters = round(value / (math.pi / 2)) if math.isfinite(value) and abs(value) < 10 else None
    if quarters is None or abs(quarters) > SNAP_QUARTERS or abs(value - quarters * (math.pi / 2)) > SNAP:
        return value, None
    return quarters * (math.pi / 2), quarters


_QUARTER_COS_SIN = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))


def _cos_sin(angle: Angle) -> tuple[float, float]:
    value, quarters = angle
    if quarters is not None:
        return _QUARTER_COS_SIN[quarters % 4]
    return math.cos(value), math.sin(value)


def rpy_matrix(roll: Angle, pitch: Angle, yaw: Angle) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw ``Rz(yaw) Ry(pitch) Rx(roll)``; exact for quarter turns."""
    (cr, sr), (cp, sp), (cy, sy) = _cos_sin(roll), _cos_sin(pitch), _cos_sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def axis_rotation(axis: Any, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def matrix_to_rpy(R: np.ndarray) -> tuple[float, float, float]:
    """Roll, pitch, yaw whose ``rpy_matrix`` reproduces ``R`` to rounding, also near gimbal lock.

    Pitch and yaw come from the first column (pitch in [-pi/2, pi/2]); roll from the matrix
    with that yaw and pitch undone, ``Ry(p)^T Rz(y)^T R = Rx(roll)``, whose entries are of
    order one even where the classic ``atan2(r21, r22)`` divides two numbers near zero. Near
    gimbal lock the yaw is poorly determined, but that de-rotation absorbs its error into roll.
    """
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    yaw = math.atan2(R[1, 0], R[0, 0])
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    undo_yaw = np.array([[cy, sy, 0.0], [-sy, cy, 0.0], [0.0, 0.0, 1.0]])
    undo_pitch = np.array([[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]])
    X = undo_pitch @ (undo_yaw @ R)
    roll = math.atan2(X[2, 1] - X[1, 2], X[1, 1] + X[2, 2])
    return roll, pitch, yaw


@dataclass(frozen=True)
class Rotation:
    """A rotation matrix, with the ``rpy`` it was written with until it is composed."""

    matrix: np.ndarray
    written: tuple[Angle, Angle, Angle] | None = None

    @classmethod
    def from_rpy(cls, rpy: list[float]) -> Rotation:
        angles = (snap(rpy[0]), snap(rpy[1]), snap(rpy[2]))
        return cls(rpy_matrix(*angles), angles)

    @property
    def is_identity(self) -> bool:
        return bool(np.array_equal(self.matrix, np.eye(3)))

    def __matmul__(self, other: Rotation) -> Rotation:
        if self.is_identity:
            return other
        if other.is_identity:
            return self
        return Rotation(self.matrix @ other.matrix)

    def rpy(self) -> list[float | int | str]:
        """``rpy`` entries for the robot file: as written (snapped) if not composed; otherwise
        extracted from the matrix, exact quarter turns only when the matrix is exactly one."""
        if self.written is not None:
            return [_angle(a) for a in self.written]
        angles = matrix_to_rpy(self.matrix)
        quarters = tuple((0.0, round(a / (math.pi / 2))) for a in angles)
        if np.array_equal(rpy_matrix(*quarters), self.matrix):  # type: ignore[arg-type]
            return [_angle(a) for a in quarters]
        return [_angle((a, None)) for a in angles]


IDENTITY = Rotation(np.eye(3), ((0.0, 0), (0.0, 0), (0.0, 0)))


def _angle(angle: Angle) -> float | int | str:
    value, quarters = angle
    if quarters is None:
        return 0 if abs(value) < 1e-15 else _number(value)
    if quarters % 2:
        return {1: "pi/2", -1: "-pi/2"}.get(quarters, f"{quarters}*pi/2")
    return {0: 0, 2: "pi", -2: "-pi"}.get(quarters, f"{quarters // 2}*pi")


def _number(value: float) -> float | int:
    """A float as written in the source (shortest round-trip form), integers as integers."""
    value = float(value)
    return int(value) if value == int(value) and abs(value) < 1e15 else value


def _numbers(values: Any, scale: float | None = None) -> list[float | int]:
    """Entries of a computed vector or tensor; those below 1e-15 of ``scale`` (default: the
    largest entry), i.e. rounding noise of the products that made them, are written as 0."""
    values = [float(v) for v in np.ravel(values)]
    scale = max((abs(v) for v in values), default=0.0) if scale is None else scale
    return [0 if abs(v) <= 1e-15 * scale else _number(v) for v in values]
