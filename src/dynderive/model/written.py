"""How many significant digits the numbers of a robot file were written with: the precision
of the sheet's decimals (``render.numbers``). Plain Python, no SymPy."""

from __future__ import annotations

import re
from decimal import Decimal

from .robot import Robot

#: A number literal in an expression's text (not the digits of a name such as ``m1``).
_LITERAL = re.compile(r"(?<![\w.])(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def significant_digits(literal: str) -> int:
    """Significant digits of a written number, trailing zeros not counted: ``0.00120`` -> 2,
    ``1500`` -> 2, ``0.1234567890123456`` -> 16."""
    value = Decimal(literal.strip().lstrip("+-"))
    return len(value.normalize().as_tuple().digits) if value else 1


def written_in(value: object) -> int:
    """The most significant digits of a number written in ``value``: a YAML number (a float as
    read, its shortest form) or the literals of an expression's text."""
    if isinstance(value, bool) or value is None:
        return 0
    if isinstance(value, int):
        return significant_digits(str(value))
    if isinstance(value, float):
        return significant_digits(repr(value)) if value == value and abs(value) != float("inf") else 0
    if isinstance(value, str):
        return max((significant_digits(m) for m in _LITERAL.findall(value)), default=0)
    if isinstance(value, (tuple, list)):
        return max((written_in(v) for v in value), default=0)
    return 0


def written_digits(robot: Robot) -> int:
    """The most significant digits of a number the robot's file wrote: ``robot.digits`` when
    the reader counted them (URDF: its attributes), else those of the robot's expressions."""
    if robot.digits is not None:
        return robot.digits
    values: list[object] = [robot.gravity, robot.maximal_constraints or ()]
    values += [p.value for p in robot.parameters]
    values += [(lk.mass, lk.com, lk.inertia) for lk in robot.links]
    values += [(j.origin, j.axis, j.damping, j.friction, j.stiffness, j.rest, j.armature) for j in robot.joints]
    values += [(lp.origin, lp.child_origin, lp.axis) for lp in robot.loops]
    values += [f.origin for f in robot.frames]
    return written_in(values)


__all__ = ["significant_digits", "written_digits", "written_in"]
