"""What every target prints of the constrained solves the same way: the loop solve's sizes
(``loop_sizes``) and the Baumgarte gains
the compiled targets take beside the parameters (``BAUMGARTE``); the refusal of a target that
does not print the loops of a robot with quaternions in q (``refuse_floating_loops``, CasADi)."""

from __future__ import annotations

from ...derivation import Derivation
from ...errors import InputError, Problem

#: A loop robot's Baumgarte gains: (name, default as a C literal, what it does).
BAUMGARTE = (("alpha", "0.0", "Baumgarte gain of forward_dynamics: - 2 alpha A qd (0: none)"),
             ("beta", "0.0", "Baumgarte gain of forward_dynamics: - beta^2 a(q) (0: none)"))


def loop_sizes(derivation: Derivation) -> tuple[int, int, int | None]:
    """(NV, NC, rank of the loop rows: None where it is found at each state, quaternions in q)."""
    rows, rank = derivation.loop_rows
    return len(derivation.symbols.qd), rows, rank


#: The functions of a robot with quaternions in q and closed loops that a target without their
#: printing (CasADi) does not build (its registry's ``NotBuilt`` row, kind "floating_loops").
FLOATING_LOOP_FUNCTIONS = ("forward_dynamics", "loop_constraints", "loop_jacobian", "loop_jacobian_dot_qd",
                           "loop_forces", "assemble")


def refuse_floating_loops(derivation: Derivation, target: str) -> None:
    """Bad input (exit 2, at the first loop joint) for a target that does not print the loops of
    a robot with a floating or spherical joint: rather no file than a forward_dynamics that
    leaves the loops open."""
    robot = derivation.robot
    if not (robot.floating and robot.loops):
        return
    first = robot.loops[0]
    line, column = robot.positions.get(f"loop:{first.name}", robot.positions.get("loops", (1, 1)))
    raise InputError(Problem(robot.source, line, column, f"loop joint '{first.name}': closed loops on a robot with a "
                             f"floating or spherical joint are not built for {target} yet (--code, --jax, --torch, "
                             "--c, --c-extension and --matlab close them)"))
