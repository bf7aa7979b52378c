"""The programs the generated module runs, built from the robot over one tree (``tree.py``):
the recursive algorithms of ``recursive.py``, the regressor of ``regressor.py``, the
derivatives of ``linearization.py``, and M, C, N, V: from the generalized program (Christoffel
symbols, shared with the sheet) for a robot whose velocity is its configuration's derivative,
else from the tree with Pinocchio's Coriolis matrix (``coriolis.py``)."""

from __future__ import annotations

from collections.abc import Callable

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .coriolis import coriolis_matrix
from .linearization import inverse_dynamics_derivatives_program
from .program import Program
from .recursive import (
    GeneralizedProgram,
    _composite_mass_matrix,
    _newton_euler,
    _potential,
    forward_dynamics_program,
    inverse_dynamics_program,
)
from .regressor import regressor_program
from .tree import ZERO, Tree, efforts


def build_programs(robot: Robot, table: SymbolTable, generalized: Callable[[], GeneralizedProgram] | None,
                   report: Callable[[str], None] = lambda stage: None) -> dict[str, Program]:
    """The programs the generated module runs, by name: ``inverse_dynamics``,
    ``forward_dynamics`` (not for closed loops), ``regressor`` and
    ``inverse_dynamics_derivatives`` for every robot; given ``generalized`` (the structured
    code of 3-D robots and large planar ones, whose explicit M, C, N are too large to print)
    ``mass_matrix``, ``coriolis``, ``gravity`` and ``potential`` too; a small planar robot's
    explicit quantities are short and read like the sheet."""
    programs: dict[str, Program] = {}
    base = Tree(robot, table)
    if generalized is not None and not robot.quaternion_starts:
        shared = generalized()
        programs["mass_matrix"] = shared.part([e for row in shared.mass_matrix for e in row])
        programs["coriolis"] = shared.part(shared.coriolis)
        programs["gravity"] = shared.part(shared.gravity)
        programs["potential"] = shared.part([shared.potential])
    elif generalized is not None:
        zeros = [ZERO] * robot.velocity_count
        for name, outputs in (("mass_matrix", lambda t: [e for row in _composite_mass_matrix(t) for e in row]),
                              ("coriolis", lambda t: [e for row in coriolis_matrix(t) for e in row]),
                              ("gravity", lambda t: _newton_euler(t, zeros, zeros)),
                              ("potential", lambda t: [_potential(t)])):
            tree = base.copy()
            tree.program.outputs = outputs(tree)
            programs[name] = tree.program
    report("program: inverse dynamics" + (" and forward dynamics" if not robot.loops else ""))
    programs["inverse_dynamics"] = inverse_dynamics_program(robot, table, base.copy())
    if not robot.loops:   # closed loops solve a KKT system in the module instead
        programs["forward_dynamics"] = forward_dynamics_program(robot, table, efforts(robot, table), base.copy())
    report("program: regressor")
    programs["regressor"] = regressor_program(robot, table, base.copy())
    report("program: derivatives of inverse dynamics (linearization)")
    programs["inverse_dynamics_derivatives"] = inverse_dynamics_derivatives_program(robot, table, base.copy())
    return programs
