"""The MATLAB/Octave target's printing (``matlab.py``, ``matlab_loops.py``): SymPy's
``OctaveCodePrinter`` with numbers as exact double literals of 17 significant digits, integer
powers as products and ``~`` for negation (``MatlabPrinter``), the project's fast line printer
with the same numbers and powers (``FastMatlabPrinter``), one function file's parts
(``MFunction``), the names of symbols (``q(1)``, ``p.m``), and the bodies shared by the open
tree's and the loops' functions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy
from sympy.printing.octave import OctaveCodePrinter

from ....derivation import Derivation
from ....mechanics.tidy import fold_constants
from ... import api
from ...codegen.c_syntax import DoublePrinting, FastCPrinter, expression_body, program_body
from ...codegen.c_syntax import Names as CNames
from ...encode import Code
from .matlab_names import matlab_comment


class MatlabPrinter(DoublePrinting, OctaveCodePrinter):
    """``OctaveCodePrinter`` with ``DoublePrinting``'s symbols, numbers and powers, and
    MATLAB's ``~`` (not Octave's ``!``) for negation."""

    language = "MATLAB"
    _operators = {"and": "&&", "or": "||", "not": "~"}

    def __init__(self, names: dict[sympy.Symbol, str]):
        super().__init__({"strict": True, "inline": True})
        self.names = names

    def _print_Not(self, expr: sympy.Basic) -> str:
        return f"~({self._print(expr.args[0])})"

    def _print_Relational(self, expr: sympy.Basic) -> str:
        operator = {"==": "==", "!=": "~=", "<": "<", "<=": "<=", ">": ">", ">=": ">="}[expr.rel_op]
        return f"({self._part(expr.lhs)} {operator} {self._part(expr.rhs)})"

    def _choice(self, condition: str, value: str, otherwise: str) -> str:
        """A branch (``Piecewise``): the local function ``IF_ELSE`` of the file, which returns
        one of its arguments (arithmetic on the condition would turn 0 * Inf into NaN)."""
        return f"if_else({condition}, {value}, {otherwise})"


class FastMatlabPrinter(FastCPrinter):
    """``MatlabPrinter``'s text for program lines, fast: ``c.FastCPrinter`` (sums, products,
    integer powers, numbers, names, sines and cosines by the project's line printer; MATLAB's
    scalar expressions are C's), with ``MatlabPrinter`` for any other node."""

    general_printer = MatlabPrinter


@dataclass
class MFunction:
    """One function file: ``function outputs = name(arguments)``, its help text (the first
    line is MATLAB's H1 line), its body, and local functions after it (same fields)."""

    name: str
    outputs: str
    arguments: list[str]
    help: list[str]
    body: list[str] = field(default_factory=list)
    local: list[MFunction] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.help = [matlab_comment(line) for line in self.help]
        self.body = [Code(line) for line in self.body]
        self.signature = Code(f"function {self.outputs} = {self.name}({', '.join(self.arguments)})"
                              if self.outputs else f"function {self.name}({', '.join(self.arguments)})")


class Names(CNames):
    """The MATLAB text of each symbol: ``q(i)``, ``p.m``, and locals of one function (``extra``:
    more, or all of them without a derivation)."""

    parameter, entry, first, declaration = "p.{}", "{}({})", 1, ""
    fast_printer = FastMatlabPrinter


def help_line(derivation: Derivation, name: str, *notes: str) -> str:
    """The first help line of the API function ``name``: its summary from the API table with
    MATLAB's dimensions (``3 x 1``), then ``notes``."""
    return " ".join([f"{name.upper()}  {api.described(name, api.sizes(derivation), '{n} x 1')}.", *notes])


def matrix_targets(out: str, rows: int, columns: int) -> list[str]:
    """``out(i, j)`` for row-major entries."""
    return [f"{out}({i + 1}, {j + 1})" for i in range(rows) for j in range(columns)]


def vector_targets(out: str, size: int) -> list[str]:
    return [f"{out}({i + 1})" for i in range(size)]


def prologue(derivation: Derivation, vectors: list[str], count: int, optional: dict[str, str] | None = None) -> list[str]:
    """Column vectors of the arguments ``vectors``; ``p`` (argument number ``count``) the
    defaults when absent or empty; other optional arguments by ``optional``."""
    name = derivation.robot.name
    lines = [f"{v} = {v}(:);" for v in vectors if v not in (optional or {})]
    for position, (argument, default) in enumerate((optional or {}).items(), start=count - len(optional or {})):
        lines += [f"if nargin < {position} || isempty({argument})", f"    {argument} = {default};", "end",
                  f"{argument} = {argument}(:);"]
    return lines + [f"if nargin < {count} || isempty(p)", f"    p = {name}.parameters();", "end"]


#: ``s``: sign(qd), or tanh(qd / friction_smoothing) when that is positive (the NumPy module's).
DIRECTION_LINES = ["if p.friction_smoothing > 0", "    s = tanh(qd / p.friction_smoothing);", "else",
                   "    s = sign(qd);", "end"]


def friction_slope(derivation: Derivation, names: Names, target: str, offset: int | None = None,
                   sign: str = "-") -> list[str]:
    """``target(i, offset + i) -= dF_i/dqd_i`` (``offset`` n by default; ``sign`` "+" adds it):
    b + fc (1 - tanh(qd/eps)^2)/eps (0 for the exact sign)."""
    if not derivation.robot.dissipative:
        return []
    n, printer, lines = len(derivation.symbols.qd), names.printer(), []
    offset = n if offset is None else offset
    for drive in derivation.joint_drives:
        i = drive.coordinate
        entry = f"{target}({i + 1}, {offset + i + 1})"
        if drive.damping != 0:
            lines.append(f"{entry} = {entry} {sign} ({printer.doprint(fold_constants(drive.damping))});")
        if drive.friction != 0:
            fc = printer.doprint(fold_constants(drive.friction))
            lines += ["if p.friction_smoothing > 0",
                      f"    {entry} = {entry} {sign} ({fc})*(1.0 - tanh(qd({i + 1}) / p.friction_smoothing)"
                      f"*tanh(qd({i + 1}) / p.friction_smoothing)) / p.friction_smoothing;", "end"]
    return lines


def input_matrix_lines(derivation: Derivation, names: Names, target: str, rows: int, offset: int) -> list[str]:
    """``target(i, offset + k) = dY_i/du_k`` (the efforts' generalized forces; with quaternions
    each effort is 1 at its velocity column)."""
    table = derivation.symbols
    if not table.efforts:
        return []
    if len(table.q) != len(table.qd):
        return [f"{target}({c + 1}, {offset + k + 1}) = 1;" for k, c in enumerate(derivation.robot.effort_columns())]
    nu = len(table.efforts)
    return expression_body(names, list(derivation.effort_jacobian), [f"{target}({i + 1}, {offset + k + 1})"
                                                 for i in range(rows) for k in range(nu)])


def linearize_rhs(derivation: Derivation, names: Names, qdd: str) -> list[str]:
    """``R = [-dtau/dq, -dtau/dqd - dF/dqd, dY/du]`` (n x 2n+nu) at accelerations ``qdd``."""
    table = derivation.symbols
    n, nu = len(table.qd), len(table.efforts)
    local = names.extended({s: f"{qdd}({i + 1})" for i, s in enumerate(table.qdd)})
    lines = [f"D = zeros({2 * n * n}, 1);",
             *program_body(local, derivation.programs["inverse_dynamics_derivatives"], vector_targets("D", 2 * n * n)),
             f"R = zeros({n}, {2 * n + nu});",
             f"R(:, 1:{n}) = -reshape(D(1:{n * n}), {n}, {n})';",
             f"R(:, {n + 1}:{2 * n}) = -reshape(D({n * n + 1}:{2 * n * n}), {n}, {n})';"]
    return lines + friction_slope(derivation, names, "R") + input_matrix_lines(derivation, names, "R", n, 2 * n)
