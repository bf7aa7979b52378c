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
    """The equations of motion as text, numbers as the robot file wrote them (to ``digits``);
    velocities as ``q₁'``; a robot with quaternion joints: in quasi-velocities (``_quasi_velocity``)."""
    if derivation.robot.floating:
        return _quasi_velocity(derivation, digits)
    table = derivation.symbols
    printer = _Printer(Numbers(sheet_digits(derivation.robot, digits)), dict(zip(table.qd, table.q)))
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
        _block("M(q) =", q["M_g"], printer),
        _block("C(q, q') =", q["C_g"], printer),
        _block("N(q) =", q["N_g"], printer),
        *([_block("F(q') = (damping and friction)", q["F_g"], printer)] if "F_g" in q else []),
        _block("Y =", q["Y_g"], printer),
        "Checks:",
    ]
    parts += [f"  {c.summary()}" for c in derivation.checks]
    return "\n".join(parts) + "\n"


def _quasi_velocity(derivation: Derivation, digits: int | None = None) -> str:
    """A robot with quaternion joints: its equations as text: a small robot's (the quasi-velocity sections' M, C,
    N, F and Y in quasi-velocities), or, for a larger one, where its programs are written."""
    printer = _Printer(Numbers(sheet_digits(derivation.robot, digits)))
    robot, table = derivation.robot, derivation.symbols
    steps = derivation.quasi_velocity_steps
    head = (f"{terminal_text(robot.title)} ({robot.name}): NQ = {len(table.q)} coordinates "
            f"({', '.join(robot.configuration_names)}), NV = {len(table.qd)} velocities "
            f"({', '.join(str(v) for v in table.qd)})")
    drives = [d for d in derivation.joint_drives if d.damping != 0 or d.friction != 0]
    equation = "M(q) v' + C(q, v) v + N(q)" + (" + F(v)" if drives else "") + " = Y"
    parts = [head, "", f"Equations of motion  {equation}  (v: the velocities; q' = Q(q) v, the quaternions' rate)", ""]
    if steps.sheet is None:
        parts += ["This robot's M, C and N are computed by recursive algorithms (programs of intermediate "
                  "variables), too large to print: --latex, --pdf or --html show them line by line, "
                  "--json holds them, --code writes its module.", ""]
    else:
        sheet = steps.sheet
        parts += [_block("M(q) =", sheet.M, printer), _block("C(q, v) =", sheet.C, printer),
                  _block("N(q) =", sheet.N, printer)]
        if drives:
            parts.append(_block("F(v) = (damping and friction)", dissipative_forces(derivation), printer))
    parts += [_block("Y =", sympy.Matrix(steps.efforts), printer),
              "dynderive check runs this robot's numeric checks (and Pinocchio's, when installed)."]
    return "\n".join(parts) + "\n"


def render_floating_terminal(derivation: Derivation, digits: int | None = None) -> str:
    """Old name of ``render_terminal`` for a robot with quaternion joints (the commands'
    import; removed once they call ``render_terminal``)."""
    return render_terminal(derivation, digits)
