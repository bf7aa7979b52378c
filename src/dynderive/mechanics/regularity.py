"""Is the mass matrix regular? A robot whose ``M(q)`` is singular at the default parameters
(a point mass on its own joint axis, two coaxial joints in a row) has no forward dynamics:
refuse it as bad input, naming the coordinate(s) that move no inertia, before any work.

The test runs the composite-rigid-body program of ``recursive.py`` once on numbers, at a
generic configuration (a singularity of every configuration shows there; one of a special
configuration, such as a prismatic joint at the axis of a revolute one, is a property of
the robot, not an error).
"""

from __future__ import annotations

import math
import random

import numpy as np
import sympy

from ..errors import InputError, Problem
from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .recursive import mass_matrix_program

#: Smallest eigenvalue of M, relative to the largest, still taken as regular.
RELATIVE_TOLERANCE = 1e-10


def numeric_mass_matrix(robot: Robot, table: SymbolTable, q: list[float],
                        parameters: dict[sympy.Symbol, float]) -> np.ndarray:
    """``M(q)`` at numbers, line by line through the CRBA program (no large expression)."""
    program = mass_matrix_program(robot, table)   # NV x NV
    values: dict[sympy.Basic, sympy.Basic] = {s: sympy.Float(v) for s, v in parameters.items()}
    values |= {s: sympy.Float(v) for s, v in zip(table.q, q)}
    for target, expr in program.lines:
        values[target] = sympy.Float(expr.xreplace(values).evalf(17))
    n = len(table.qd)
    flat = [float(sympy.sympify(e).xreplace(values).evalf(17)) for e in program.outputs]
    return np.array(flat, dtype=float).reshape(n, n)


def check_mass_matrix(robot: Robot, table: SymbolTable) -> None:
    """Raise ``InputError`` if ``M(q)`` is singular at the defaults (skipped when a parameter
    the masses or geometry use has no default)."""
    defaults = table.defaults(robot)
    if any(p.value is None for p in robot.parameters):
        return
    rng = random.Random(20261123)
    q = [rng.uniform(0.3, 1.2) * rng.choice((-1, 1)) for _ in table.q]
    # a floating joint's entries (a unit quaternion) at its neutral pose; columns by joint
    coordinates = labels = list(robot.coordinates)
    if robot.floating:
        q, coordinates = _floating_neutral(robot, table, q)
        labels = [str(s) for s in table.qd]   # the velocities: a floating joint has six
    try:
        M = numeric_mass_matrix(robot, table, q, defaults)
    except (TypeError, ValueError, ZeroDivisionError, OverflowError):
        return   # not a number at the defaults: the validator reports such values
    if not np.all(np.isfinite(M)):
        return
    eigenvalues, vectors = np.linalg.eigh((M + M.T) / 2)
    largest = max(float(np.max(np.abs(eigenvalues))), 1e-300)
    if eigenvalues[0] > RELATIVE_TOLERANCE * largest:
        return
    null = vectors[:, 0] / np.max(np.abs(vectors[:, 0]))
    involved = [i for i in np.argsort(-np.abs(null)) if abs(null[i]) > 0.1]
    names = list(dict.fromkeys(labels[i] for i in involved))
    first = coordinates[involved[0]]
    line, column = robot.positions.get(f"joint:{first}", (1, 1))
    index = next(i for i, j in enumerate(robot.joints) if j.name == first)
    if len(names) == 1:
        what = (f"coordinate '{names[0]}' moves no mass or inertia (a point mass on its own joint axis, "
                "or a link without inertia turning about its centre of mass?)")
    else:
        combination = " + ".join(f"{_coefficient(null[i])}{labels[i]}" for i in involved)
        what = (f"the motion {combination} of coordinates {', '.join(repr(n) for n in names)} moves no "
                "mass or inertia (coaxial joints in a row?)")
    raise InputError(Problem(robot.source, line, column,
                             f"joints[{index}] '{first}': the mass matrix is singular at the default "
                             f"parameters: {what}"))


def _floating_neutral(robot: Robot, table: SymbolTable, q: list[float]) -> tuple[list[float], list[str]]:
    """``q`` with each floating joint's seven entries at (0, 0, 0, 0, 0, 0, 1) and each
    spherical joint's four at (0, 0, 0, 1), and the joint of each velocity column (a floating
    joint owns six, a spherical joint three)."""
    where_q = robot.offsets()[0]
    columns: list[str] = []
    for joint in (j for j in robot.joints if j.owns):
        (nq, nv), start = joint.sizes, where_q[joint.name]
        if joint.multi:   # floating: (0, 0, 0, 0, 0, 0, 1); spherical: (0, 0, 0, 1)
            q[start:start + nq] = [0.0] * (nq - 1) + [1.0]
        columns += [joint.name] * nv
    return q, columns


def _coefficient(value: float) -> str:
    text = f"{value:.3g}"
    return "" if math.isclose(value, 1.0) else ("-" if math.isclose(value, -1.0) else f"{text} ")
