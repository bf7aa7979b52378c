"""The programs the generated module runs, built from the robot (the recursive algorithms of
``recursive.py``, the regressor of ``regressor.py``, and M, C, N, V from the generalized
program where the robot's explicit quantities are too large to print)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .program import Program
from .recursive import GeneralizedProgram, forward_dynamics_program, inverse_dynamics_program
from .regressor import regressor_program


def build_programs(robot: Robot, table: SymbolTable, efforts: Sequence[sympy.Expr],
                   generalized: GeneralizedProgram | None,
                   report: Callable[[str], None] = lambda stage: None) -> dict[str, Program]:
    """The programs the generated module runs, by name: ``inverse_dynamics``,
    ``forward_dynamics`` (``efforts`` is ``Y_g``; not for closed loops) and ``regressor``
    (``mechanics/regressor.py``) for every robot; given ``generalized``
    (3-D robots and large planar ones, whose explicit M, C, N are too large to print)
    ``mass_matrix``, ``coriolis``, ``gravity`` and ``potential`` from it; a small planar
    robot's explicit quantities are short and read like the sheet."""
    programs: dict[str, Program] = {}
    if generalized is not None:
        programs["mass_matrix"] = generalized.part([e for row in generalized.mass_matrix for e in row])
        programs["coriolis"] = generalized.part(generalized.coriolis)
        programs["gravity"] = generalized.part(generalized.gravity)
        programs["potential"] = generalized.part([generalized.potential])
    report("program: inverse dynamics" + (" and forward dynamics" if not robot.loops else ""))
    programs["inverse_dynamics"] = inverse_dynamics_program(robot, table)
    if not robot.loops:   # closed loops solve a KKT system in the module instead
        programs["forward_dynamics"] = forward_dynamics_program(robot, table, efforts)
    report("program: regressor")
    programs["regressor"] = regressor_program(robot, table)
    return programs
