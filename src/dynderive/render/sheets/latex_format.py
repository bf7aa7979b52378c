"""The sheet's LaTeX of SymPy objects: the ``Formatter`` (the robot's symbol names, numbers as
the file wrote them, matrices whole or entry by entry) and the width estimates that choose how
an expression is set (``typeset_width``, ``matrix_width``, ``subscript``)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import sympy

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from ...model.naming import latex_name
from ...model.written import written_digits
from ..encode import escape_tex, tex_unit
from ..numbers import Numbers, latex_decimal, sheet_digits
from ..printers import DerivationFormatter, RememberingLatexPrinter, SheetLatexPrinter
from .linebreak import LineBreaker

#: Largest entry (tree nodes) the sheet typesets; larger ones are named but not printed.
ENTRY_NODES = 400
#: Largest scalar (tree nodes) typeset in a breqn display; beyond it breqn overflows.
SCALAR_NODES = 500
#: Largest entry of a matrix typeset inline on one line (positions, Jacobians, rotations).
INLINE_NODES = 120
#: Widest (estimated math glyphs) a matrix set inline in a sentence may be (a link's inertia).
INLINE_UNITS = 40
#: Largest matrix (tree nodes in all) the sheet typesets whole or entry by entry as built.
MATRIX_NODES = 6000
#: Largest matrix (tree nodes in all) the sheet typesets at all: one with more nodes than
#: MATRIX_NODES, or an entry over ENTRY_NODES, is set entry by entry, each broken over lines.
BROKEN_NODES = 12000
#: The text width in units of a math glyph of the sheet's 11pt type (16.6 cm, about 5.5 pt a
#: glyph): a matrix whose estimated width (``typeset_width``) exceeds it is typeset entry by entry.
LINE_UNITS = 80
#: A matrix up to this factor wider than the line is set in small type with narrow columns.
TIGHT = 1.15
#: Most columns a matrix typeset whole may have: the preamble's ``MaxMatrixCols`` (amsmath
#: stops at more, "Extra alignment tab"); a wider one is typeset entry by entry.
MATRIX_COLUMNS = 20
#: Estimated width (math glyphs) of one line of a displayed expression: the line less room for
#: the name in front, the continuation lines' indent and the estimate's error (about a fifth).
DISPLAY_UNITS = 74


#: Estimated width (math glyphs) of an entry's name and "=" (``(J^b_{sL_2})_{11} =``), and of
#: the ``,\qquad`` between entries set side by side (``packed``).
ENTRY_NAME_UNITS = 9.0
ENTRY_GAP_UNITS = 4.0


#: Coordinate and velocity LaTeX of a floating joint's entries (DESIGN.md section 10 order).
FREE_FLYER_Q = ("x", "y", "z", "q_{x}", "q_{y}", "q_{z}", "q_{w}")
FREE_FLYER_V = ("v_{x}", "v_{y}", "v_{z}", "\\omega_{x}", "\\omega_{y}", "\\omega_{z}")


def _tagged(name: str, tag: str) -> str:
    """``q_{x}`` -> ``q_{x,tag}``, ``x`` -> ``x_{tag}`` (no tag: unchanged)."""
    if not tag:
        return name
    return name[:-1] + "," + tag + "}" if name.endswith("}") else f"{name}_{{{tag}}}"


def _dotted(name: str) -> str:
    head, _, tail = name.partition("_")
    return "\\dot{" + head + "}" + ("_" + tail if tail else "")


def coordinate_entries(derivation: Derivation) -> list[tuple[sympy.Symbol, str | None, str, int]]:
    """Every coordinate, velocity and acceleration as ``(symbol, text, name, dots)``: a floating
    or spherical joint's entry has its ``FREE_FLYER_Q``/``FREE_FLYER_V`` text and, as ``name``, the
    joint's name when it must be tagged (the robot has several such joints, or another symbol
    would read the same; else ""); a scalar joint's has ``text`` None and its joint's name. The
    LaTeX sheet and the HTML page each spell these (``coordinate_names``,
    ``html_math.coordinate_math_names``)."""
    robot, table = derivation.robot, derivation.symbols
    where_q, where_v = robot.offsets()
    multi = [j for j in robot.joints if j.multi]
    others = {latex_name(str(s)) for s in [*table.parameters.values(), *table.efforts.values()]}
    others |= {latex_name(name) for j in robot.joints if j.owns and not j.multi for name in j.kind.names(j.name)[0]}
    plain = set(FREE_FLYER_Q) | set(FREE_FLYER_V)
    entries: list[tuple[sympy.Symbol, str | None, str, int]] = []
    for joint in multi:
        tag = "" if len(multi) == 1 and not plain & others else joint.name
        skipped = 3 - (joint.kind.quaternion_start or 0)   # a ball joint has no position
        qs, vs = FREE_FLYER_Q[skipped:], FREE_FLYER_V[skipped:]
        qi, vi = where_q[joint.name], where_v[joint.name]
        entries += [(table.q[qi + k], text, tag, 0) for k, text in enumerate(qs)]
        for k, text in enumerate(vs):
            entries += [(table.qd[vi + k], text, tag, 0), (table.qdd[vi + k], text, tag, 1)]
    for joint in (j for j in robot.joints if j.owns and not j.multi):
        qi, vi = where_q[joint.name], where_v[joint.name]
        for k, name in enumerate(joint.kind.names(joint.name)[0]):   # a universal joint's two
            entries += [(table.q[qi + k], None, name, 0), (table.qd[vi + k], None, name, 1),
                        (table.qdd[vi + k], None, name, 2)]
    return entries


def coordinate_names(derivation: Derivation) -> dict[sympy.Symbol, str]:
    """LaTeX of every coordinate, velocity and acceleration (``coordinate_entries``): a floating
    joint's ``x, y, z, q_x, q_y, q_z, q_w`` and ``v_x .. omega_z`` (tagged ``q_{x,\\mathrm{name}}``),
    a spherical joint's quaternion and ``omega``, a scalar joint's as on the fixed-base sheet."""
    return {symbol: latex_name(name, dots) if text is None
            else _tagged(_dotted(text) if dots else text, "\\mathrm{" + escape_tex(name) + "}" if name else "")
            for symbol, text, name, dots in coordinate_entries(derivation)}


class Formatter(DerivationFormatter):
    """LaTeX of SymPy objects with the robot's symbol names (``qd1`` -> ``\\dot{q}_{1}``) and
    numbers as the file wrote them, to ``digits`` (``--digits``) at most; ``exact``: as SymPy
    prints them (the JSON).

    One per derivation and options (``Formatter.of``), remembering what it printed: the sheet
    prints the same quantities again (entries, matrices, the HTML's figure), and a large robot's thousands of intermediate variables
    and its maximal model cost seconds to print. A large robot's sums are printed in SymPy's
    own (canonical, deterministic) order rather than sorted, which takes half the time."""

    def __init__(self, derivation: Derivation, digits: int | None = None, exact: bool = False,
                 extra_names: dict[sympy.Symbol, str] | None = None, lines: tuple[tuple[sympy.Symbol, str], ...] = ()):
        super().__init__()
        if derivation.robot.floating:
            # quaternion joints: their entries' names (``coordinate_names``) and, for
            # a large robot, its programs' ``lines`` (symbol -> LaTeX); never the intermediates
            names, self.order = coordinate_names(derivation) | dict(lines), "none" if lines else None
        else:
            names = {name: rf"\mathsf{{w}}_{{{str(name)[2:]}}}" for name, _ in derivation.intermediates}
            self.order = "none" if derivation.intermediate_form else None
        self.names = derivation.symbols.latex_names() | names | (extra_names or {})
        settings = {"symbol_names": self.names, "mat_delim": "[", "mat_str": "matrix", "mul_symbol": None,
                    "long_frac_ratio": 2, "order": self.order}
        # the sheet's numbers as the file wrote them (render.numbers); exact: SymPy's (the JSON)
        self.numbers = None if exact else Numbers(sheet_digits(derivation.robot, digits))
        self._printer = (RememberingLatexPrinter(settings) if self.numbers is None
                         else SheetLatexPrinter(settings, self.numbers))
        self._breaker = LineBreaker(self, self.width, self.order, self.numbers)

    def width(self, expr: sympy.Basic) -> float:
        """``typeset_width`` of ``expr`` at this sheet's precision."""
        return typeset_width(expr, shown_digits(self.numbers))

    def matrix_width(self, matrix: sympy.Matrix) -> float:
        """``matrix_width`` of ``matrix`` at this sheet's precision."""
        return matrix_width(matrix, shown_digits(self.numbers))

    def fits(self, *values: Any, extra: float = 0.0) -> bool:
        """``fits`` at this sheet's precision."""
        return fits(*values, extra=extra, digits=shown_digits(self.numbers))

    def _text(self, expr: Any) -> str:
        if isinstance(expr, sympy.MatrixBase):
            # SymPy's own matrix LaTeX (mat_str "matrix", delimiter "["), from the entries'
            # LaTeX: the sheet prints each entry of a matrix too, and the JSON every matrix
            return r"\left[\begin{matrix}" + r"\\".join(
                " & ".join(self(e) for e in expr.row(i)) for i in range(expr.rows)) + r"\end{matrix}\right]"
        return self._printer.doprint(expr)

    def maybe(self, expr: Any, limit: int = ENTRY_NODES) -> str | None:
        """LaTeX of ``expr``, or None when it is too large to read (or to typeset)."""
        entries = list(expr) if isinstance(expr, sympy.MatrixBase) else [expr]
        if not is_small(sympy.Tuple(*entries), limit * max(1, len(entries))):
            return None
        return self(expr)

    def display(self, expr: Any, limit: int | None = SCALAR_NODES, units: float = DISPLAY_UNITS) -> Display | None:
        """LaTeX of ``expr`` with the lines it is displayed on (``Display``, lines of at most
        ``units`` glyphs), or None when it is larger than ``limit`` nodes (no limit: None)."""
        text = self(expr) if limit is None else self.maybe(expr, limit)
        if text is None:
            return None
        # breqn breaks a sum between its terms by itself; the breaker takes over where a term
        # is wider than the line (a long product, a fraction, a sum in parentheses)
        if isinstance(expr, sympy.MatrixBase) or all(self.width(t) <= units for t in sympy.Add.make_args(expr)):
            return Display(text, [text])
        return Display(text, self._breaker.lines(expr, units))

    def matrix(self, name: str, matrix: sympy.Matrix) -> dict[str, Any]:
        """A matrix as a whole when its estimated width fits the line (``wide`` False), else as
        its non-zero entries; ``too_large`` when even those cannot be typeset (``matrix_layout``)."""
        layout, places, large = matrix_layout(matrix, shown_digits(self.numbers))
        rows, cols = matrix.shape
        whole = "" if large else self(matrix)
        single = rows == cols == 1 and "_" in name   # a named 1 x 1 matrix (a one-DOF loop's M_r) is its entry
        entries = [{"name": name if single else subscript(name, entry_index(i, j, rows, cols)),
                    "latex": self.display(matrix[i, j], None)} for i, j in places]
        widths = [self.width(matrix[i, j]) + ENTRY_NAME_UNITS for i, j in places]
        return {"latex": whole, **layout, "entries": entries, "rows": packed(entries, widths)}


def packed(entries: list[dict[str, Any]], widths: list[float]) -> list[list[dict[str, Any]]]:
    """The entries of a matrix set entry by entry, as display lines: consecutive one-line
    entries side by side while their estimated widths (``widths``, names included) fit a line,
    a broken one alone. A wide matrix of short entries (a CAD robot's Jacobian) then takes a
    few lines instead of a display each."""
    rows: list[list[dict[str, Any]]] = []
    used = DISPLAY_UNITS + 1.0
    for entry, width in zip(entries, widths):
        alone = len(getattr(entry["latex"], "lines", ())) > 1
        if alone or not rows or len(rows[-1][0]["latex"].lines) > 1 or used + ENTRY_GAP_UNITS + width > DISPLAY_UNITS:
            rows.append([entry])
            used = width
        else:
            rows[-1].append(entry)
            used += ENTRY_GAP_UNITS + width
    return rows


def matrix_layout(matrix: sympy.Matrix, digits: int = 17) -> tuple[dict[str, Any], list[tuple[int, int]], bool]:
    """How both sheets set ``matrix`` (the LaTeX ``Formatter.matrix``, the page's
    ``MathFormatter.matrix``; widths at ``digits``, ``shown_digits``): its ``wide``, ``tight``, ``shape``, ``too_large``, ``nodes`` and
    ``zeros``; the places of its non-zero entries (none when ``too_large``); and whether it is
    too large to typeset whole (it is then ``wide``)."""
    rows, cols = matrix.shape
    nodes = _nodes_up_to(list(matrix), BROKEN_NODES)
    layout = {"wide": True, "tight": False, "shape": [rows, cols], "too_large": nodes > BROKEN_NODES,
              "nodes": nodes, "zeros": 0}
    if layout["too_large"]:
        return layout, [], True
    large = nodes > MATRIX_NODES or any(not is_small(e, ENTRY_NODES) for e in matrix)
    places = [(i, j) for i in range(rows) for j in range(cols) if matrix[i, j] != 0]
    width = 0 if large else matrix_width(matrix, digits)
    wide = large or width > LINE_UNITS * TIGHT or cols > MATRIX_COLUMNS
    layout |= {"wide": wide, "tight": not wide and width > LINE_UNITS, "zeros": rows * cols - len(places)}
    return layout, places, large


def entry_index(i: int, j: int, rows: int, cols: int) -> str:
    """The subscript of entry (i, j), 0-based, of a ``rows`` x ``cols`` matrix: ``i+1`` for a
    column, ``i+1`` and ``j+1`` side by side (``12``), or apart (``1,12``) when either can
    have two digits and ``112`` would be ambiguous."""
    if cols == 1:
        return f"{i + 1}"
    return f"{i + 1},{j + 1}" if max(rows, cols) > 9 else f"{i + 1}{j + 1}"


def _tokens(tex: str) -> list[str]:
    """Top-level tokens of LaTeX math: a control word or symbol, a braced group, a character."""
    tokens, k = [], 0
    while k < len(tex):
        if tex[k] == "\\":
            end = k + 2 if k + 1 < len(tex) and not tex[k + 1].isalpha() else k + 1
            while end < len(tex) and tex[end].isalpha() and tex[k + 1].isalpha():
                end += 1
        elif tex[k] == "{":
            depth, end = 0, k
            while end < len(tex):
                depth += {"{": 1, "}": -1}.get(tex[end], 0)
                end += 2 if tex[end] == "\\" else 1
                if depth == 0:
                    break
        else:
            end = k + 1
        tokens.append(tex[k:end])
        k = end
    return tokens


def subscript(name: str, index: str) -> str:
    """``name`` with the subscript ``index``: ``M`` -> ``M_{11}``; a name whose last atom
    already has a subscript gets ``index`` added to it, ``J^b_7`` -> ``J^b_{7,11}`` (TeX
    refuses a second one: "Double subscript"); ``\\left(R\\right)`` -> ``\\left(R\\right)_{11}``."""
    tokens = _tokens(name)
    target = None   # position of the last atom's subscript argument
    k = 0
    while k < len(tokens):
        token = tokens[k]
        if token in ("_", "^") and k + 1 < len(tokens):
            if token == "_":
                target = k + 1
            k += 2
            continue
        if token == "\\left":   # \left ... \right<delimiter> is one atom, a fresh nucleus
            depth = 0
            while k < len(tokens):
                depth += {"\\left": 1, "\\right": -1}.get(tokens[k], 0)
                k += 1
                if depth == 0:
                    break
            k += 1   # the closing delimiter
            target = None
            continue
        target = None
        k += 1
    if target is None:
        return f"{name}_{{{index}}}"
    inner = tokens[target][1:-1] if tokens[target].startswith("{") else tokens[target]
    return "".join(tokens[:target]) + f"{{{inner},{index}}}" + "".join(tokens[target + 1:])


class Display(str):
    """An expression's LaTeX (the string itself) and ``lines``: that LaTeX broken into display
    lines of at most ``DISPLAY_UNITS`` estimated glyphs at sums and products (``render.linebreak``)
    when one of its terms is wider than that, else one line. The sheet sets several lines in
    ``align*``, one in breqn's ``dmath*``, which breaks a sum of terms that fit by itself."""

    lines: list[str]

    def __new__(cls, text: str, lines: list[str]) -> Display:
        self = super().__new__(cls, text)
        self.lines = lines
        return self


def shown_digits(numbers: Numbers | None) -> int:
    """The significant digits ``typeset_width`` measures a sheet's decimals at: its formatter's
    (None: SymPy's exact numbers, as wide as they are: 17). An argument, not a setting: the
    formatters are shared, so a width must never depend on which sheet was made last."""
    return numbers.digits if numbers is not None else 17


def typeset_width(expr: sympy.Basic, digits: int = 17) -> float:
    """Estimated width of ``expr`` typeset inline, in math glyphs: a symbol is a glyph and its
    index 0.7 a digit, a sum adds 2.2 per sign, a function its name and parentheses, a
    fraction its wider part, a long number its decimal at the sheet's precision. Rough (within
    about a fifth on the bundled sheets), and cheap (remembered: the line breaker asks for the
    same pieces again and again)."""
    return _typeset_width(expr, digits)


@functools.lru_cache(maxsize=1 << 16)
def _typeset_width(expr: sympy.Basic, digits: int) -> float:
    def typeset_width(part: sympy.Basic) -> float:   # the parts, at the same precision
        return _typeset_width(part, digits)

    if expr.is_Symbol:
        name = str(expr).lstrip("_")
        stem = name.rstrip("0123456789")
        index = len(name) - len(stem)
        base = stem.rstrip("d") or stem      # qd1, phid1: a dot over the coordinate's letter
        return (1.0 if base in _GREEK or len(base) == 1 else 0.9 * len(base)) + 0.7 * index
    # the sheet prints a long number as a decimal of at most ``digits`` digits (render.numbers)
    if expr.is_Integer:
        size = len(str(abs(int(expr))))
        return float(size if size <= max(digits, 3) else min(size, digits + 5))   # 1.23457 \cdot 10^{8}
    if expr.is_Rational:
        numerator, denominator = abs(int(expr.p)), int(expr.q)
        if len(str(denominator)) > 3 and denominator == 2 ** _factor_count(denominator, 2) * 5 ** _factor_count(denominator, 5):
            # a terminating decimal, printed as one (render.numbers): its characters (at most
            # ``digits`` digits, the point and a leading zero)
            shift = max(_factor_count(denominator, 2), _factor_count(denominator, 5))   # digits after the point
            return float(min(max(len(str(numerator)), shift) + 2, 19, digits + 3))
        return min(0.8 * max(len(str(expr.p)), len(str(expr.q))) + 0.6, 19, digits + 3)
    if expr.is_Number:
        return len(sympy.sstr(expr))
    if expr.is_Add:
        return sum(typeset_width(a) for a in expr.args) + 2.2 * (len(expr.args) - 1)
    if expr.is_Mul:
        coefficient, rest = expr.as_coeff_Mul()
        factors = sympy.Mul.make_args(rest)
        width = 1.5 if coefficient.is_negative else 0.0
        coefficient = abs(coefficient)
        if coefficient.is_Rational and coefficient.q != 1:   # \frac{p a b}{q} f(x): the wider of p a b and q
            above = [f for f in factors if not f.is_Function]
            beside = [f for f in factors if f.is_Function]
            numerator = sum(typeset_width(f) + (2.0 if f.is_Add else 0.0) for f in above) + len(str(coefficient.p)) * (
                coefficient.p != 1 or not above)
            width += max(numerator, 0.8 * len(str(coefficient.q))) + 0.6 + sum(typeset_width(f) for f in beside)
            return width
        if coefficient != 1:
            width += len(sympy.sstr(coefficient))
        return width + sum(typeset_width(f) + (2.0 if f.is_Add else 0.0) for f in factors) + 0.3 * (len(factors) - 1)
    if expr.is_Pow:
        base, exponent = expr.args
        if exponent == sympy.S.Half:
            return typeset_width(base) + 1.5
        if exponent.is_negative:   # a fraction: its wider part
            return max(1.0, typeset_width(base ** -exponent)) + 0.6
        return typeset_width(base) + (2.0 if base.is_Add else 0.0) + 0.7 * typeset_width(exponent)
    if expr.is_Function:
        return len(type(expr).__name__) + 1.5 + sum(typeset_width(a) for a in expr.args)
    return len(sympy.sstr(expr))


_GREEK = {"alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa", "lambda",
          "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi", "omega"}


def _groups(items: list[tuple[int, str]]) -> list[dict[str, Any]]:
    """``(index, latex)`` pairs grouped by equal LaTeX, in order of first appearance."""
    groups: dict[str, list[int]] = {}
    for index, latex in items:
        groups.setdefault(latex, []).append(index)
    return [{"indices": indices, "latex": latex} for latex, indices in groups.items()]


def fits(*values: Any, extra: float = 0.0, digits: int = 17) -> bool:
    """Whether ``values`` typeset side by side (plus ``extra`` glyphs of names and spacing)
    fit the line (decimals of ``digits`` digits)."""
    total = extra
    for value in values:
        total += (matrix_width(value, digits) if isinstance(value, sympy.MatrixBase)
                  else typeset_width(sympy.sympify(value), digits))
    return total <= LINE_UNITS


def _factor_count(n: int, prime: int) -> int:
    """How many times ``prime`` divides ``n`` (n > 0)."""
    count = 0
    while n % prime == 0:
        n //= prime
        count += 1
    return count


def matrix_width(matrix: sympy.Matrix, digits: int = 17) -> float:
    """Estimated width of ``matrix`` typeset whole: its columns' widest entries, the gaps
    between columns, the brackets and the name in front."""
    rows, cols = matrix.shape
    widest = [max(typeset_width(sympy.sympify(matrix[i, j]), digits) for i in range(rows)) for j in range(cols)]
    return sum(widest) + 2.0 * (cols - 1) + 6.0


def _nodes_up_to(exprs: list[Any], limit: int) -> int:
    """Tree nodes of ``exprs``, counting no further than just past ``limit``."""
    count = 0
    for expr in exprs:
        for _ in sympy.preorder_traversal(expr):
            count += 1
            if count > limit:
                return count
    return count



def parameter_value(value: float, numbers: Numbers | None) -> str:
    """A parameter's default in the sheet's table (text mode): as written, to D digits."""
    if numbers is None:
        return f"{value:g}"
    mantissa, exponent = numbers.value_parts(value)
    return mantissa if exponent is None else f"${latex_decimal(mantissa, exponent)}$"


def sheet_header(derivation: Derivation, fmt: Formatter, gravity: sympy.Matrix, joint_columns: list[str],
                 joints: list[dict[str, Any]]) -> dict[str, Any]:
    """What every sheet opens with (``opening``), and its joint table (``joints``: each with
    ``variables``, one per entry of ``joint_columns``)."""
    opened = opening(derivation, fmt, gravity, joints, escape_tex,
                     lambda value: parameter_value(value, fmt.numbers), tex_unit)
    return opened | {"joint_columns": joint_columns}


def opening(derivation: Derivation, fmt: Any, gravity: sympy.Matrix, joints: list[dict[str, Any]], text: Any,
            value: Any, unit: Any) -> dict[str, Any]:
    """What the sheet and the page open with: who made it from which file, the robot's name,
    title, gravity, ``joints`` and parameter table; free text written by ``text``, a
    parameter's default by ``value``, its unit by ``unit``."""
    from ..._version import __version__

    robot, table = derivation.robot, derivation.symbols
    parameters = [{"symbol": fmt(table.parameters[p.name]),
                   "value": "" if p.value is None else value(p.value),
                   "unit": unit(p.unit), "description": text(p.description)} for p in robot.parameters]
    numbers = getattr(fmt, "numbers", None)
    written = written_digits(robot)
    return {
        "generator": f"dynderive {__version__}",
        "source": text(Path(robot.source).name),
        # the file wrote more digits than the sheet shows (a CAD file's 17): said once, at the top
        "precision": {"digits": numbers.digits, "written": written}
        if numbers is not None and written > numbers.digits else None,
        "robot": {"name": text(robot.name), "title": text(robot.title), "planar": robot.planar,
                  "parameters": parameters, "joints": joints, "gravity": fmt(gravity)},
    }
