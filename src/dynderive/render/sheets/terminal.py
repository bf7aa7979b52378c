"""Plain-text summary of a derivation for the terminal (no output flag given)."""

from __future__ import annotations

from typing import Any

import sympy
from sympy.printing.pretty.pretty import PrettyPrinter
from sympy.printing.pretty.stringpict import prettyForm

from ...derivation import Derivation
from ..encode import terminal_text
from ..numbers import DecimalNumbers, Numbers, sheet_digits
from .quasi_velocity import dissipative_forces


class _Printer(DecimalNumbers, PrettyPrinter):
    """``sympy.pretty`` with the sheet's numbers (``render.numbers``): 0.1234, 1.2e-5; the
    velocity of each coordinate in ``primes`` printed as its coordinate with a prime, ``q₁'``
    and ``d₂'``, as the header's ``q'`` (SymPy's own reading of the name ``d2_d``, the velocity
    of a coordinate ``d2``, is ``d_2_d``)."""

    def __init__(self, numbers: Numbers, primes: dict[Any, Any] | None = None):
        super().__init__({"use_unicode": True, "wrap_line": False, "order": "none"})
        self.numbers = numbers
        self.primes = primes or {}

    def _print_Symbol(self, e: Any, bold_name: bool = False) -> Any:
        coordinate = self.primes.get(e)
        if coordinate is None:
            return super()._print_Symbol(e, bold_name)
        return prettyForm(*super()._print_Symbol(coordinate, bold_name).right("'"))

    def _decimal(self, mantissa: str, exponent: int | None) -> Any:
        return prettyForm(mantissa if exponent is None else f"{mantissa}e{exponent}")


def _block(title: str, value: object, printer: _Printer) -> str:
    return f"{title}\n{printer.doprint(value)}\n"


def render_terminal(derivation: Derivation, digits: int | None = None) -> str:
    """The equations of motion as text, numbers as the robot file wrote them (to ``digits``, at most 6 by default);
    velocities as ``q₁'``; a robot with quaternion joints: in quasi-velocities (``_quasi_velocity``)."""
    robot = derivation.robot
    numbers = Numbers(sheet_digits(robot, digits))
    size, equation, blocks, tail = (_quasi_velocity if robot.floating else _generalized)(derivation, numbers)
    parts = [f"{terminal_text(robot.title)} ({robot.name}): {size}", "", f"Equations of motion  {equation}", "",
             *blocks, *tail]
    return "\n".join(parts) + "\n"


def _generalized(derivation: Derivation, numbers: Numbers) -> tuple[str, str, list[str], list[str]]:
    """The robot's size, its equation, M, C, N, F and Y, and its checks."""
    table = derivation.symbols
    printer = _Printer(numbers, dict(zip(table.qd, table.q)))
    robot, quantities = derivation.robot, derivation.quantities
    coords = ", ".join(robot.coordinates)
    if robot.loops:
        loops = derivation.loop_model
        rows = quantities["a_g"].shape[0]
        constraints = (f"{rows} independent loop constraints" if rows == loops.rank else
                       f"{rows} loop constraints of rank {loops.rank} (over-constrained)")
        size = f"{loops.mobility} DOF: coordinates ({coords}), {constraints}"
    else:
        size = f"{len(robot.coordinates)} DOF, coordinates ({coords})"
    equation = "M(q) q'' + C(q, q') q' + N(q)" + (" + F(q')" if "F_g" in quantities else "") + " = Y"
    blocks = [
        _block("M(q) =", quantities["M_g"], printer),
        _block("C(q, q') =", quantities["C_g"], printer),
        _block("N(q) =", quantities["N_g"], printer),
        *([_block("F(q') = (damping and friction)", quantities["F_g"], printer)] if "F_g" in quantities else []),
        _block("Y =", quantities["Y_g"], printer),
    ]
    return size, equation, blocks, ["Checks:", *(f"  {c.summary()}" for c in derivation.checks)]


def _quasi_velocity(derivation: Derivation, numbers: Numbers) -> tuple[str, str, list[str], list[str]]:
    """A robot with quaternion joints: its size, its equation in quasi-velocities, a small
    robot's M, C, N and F (the quasi-velocity sections'), or where a larger one's programs are
    written, and Y."""
    printer = _Printer(numbers)
    robot, table = derivation.robot, derivation.symbols
    steps = derivation.quasi_velocity_steps
    size = (f"NQ = {len(table.q)} coordinates ({', '.join(robot.configuration_names)}), NV = {len(table.qd)} "
            f"velocities ({', '.join(str(v) for v in table.qd)})")
    drives = [d for d in derivation.joint_drives if d.damping != 0 or d.friction != 0]
    equation = ("M(q) v' + C(q, v) v + N(q)" + (" + F(v)" if drives else "")
                + " = Y  (v: the velocities; q' = Q(q) v, the quaternions' rate)")
    if steps.sheet is None:
        blocks = ["This robot's M, C and N are computed by recursive algorithms (programs of intermediate "
                  "variables), too large to print: --latex, --pdf or --html show them line by line, "
                  "--json holds them, --code writes its module.", ""]
    else:
        blocks = [_block("M(q) =", steps.sheet.M, printer), _block("C(q, v) =", steps.sheet.C, printer),
                  _block("N(q) =", steps.sheet.N, printer)]
        if drives:
            blocks.append(_block("F(v) = (damping and friction)", dissipative_forces(derivation), printer))
    blocks.append(_block("Y =", sympy.Matrix(steps.efforts), printer))
    return size, equation, blocks, ["dynderive check runs this robot's numeric checks (and Pinocchio's, when installed)."]

