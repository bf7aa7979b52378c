"""Plain-text summary of a derivation for the terminal (no output flag given)."""

from __future__ import annotations

import sympy

from ..derivation import Derivation
from .encode import terminal_text


def _block(title: str, value: object) -> str:
    art = sympy.pretty(value, use_unicode=True, wrap_line=False, order="none")
    return f"{title}\n{art}\n"


def render_terminal(derivation: Derivation) -> str:
    robot, q = derivation.robot, derivation.quantities
    coords = ", ".join(robot.coordinates)
    if robot.loops:
        loops = derivation.steps["loops"]
        rows = q["a_g"].shape[0]
        constraints = (f"{rows} independent loop constraints" if rows == loops.rank else
                       f"{rows} loop constraints of rank {loops.rank} (over-constrained)")
        size = f"{loops.mobility} DOF: coordinates ({coords}), {constraints}"
    else:
        size = f"{len(robot.coordinates)} DOF, coordinates ({coords})"
    parts = [
        f"{terminal_text(robot.title)} ({robot.name}): {size}",
        "",
        "Equations of motion  M(q) q'' + C(q, q') q' + N(q)" + (" + F(q')" if "F_g" in q else "") + " = Y",
        "",
        _block("M(q) =", q["M_g"]),
        _block("C(q, q') =", q["C_g"]),
        _block("N(q) =", q["N_g"]),
        *([_block("F(q') = (damping and friction)", q["F_g"])] if "F_g" in q else []),
        _block("Y =", q["Y_g"]),
        "Checks:",
    ]
    parts += [f"  {c.summary()}" for c in derivation.checks]
    return "\n".join(parts) + "\n"
