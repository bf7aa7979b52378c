"""The LaTeX solution sheet: quantities turned into LaTeX strings, laid out by a template."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import sympy

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from ..encode import escape_tex, tex_unit
from ..environment import LazyList, render
from .figure import sheet_figure
from .linebreak import LineBreaker
from ..numbers import Numbers, latex_decimal, sheet_digits
from ..printers import DerivationFormatter, RememberingLatexPrinter, SheetLatexPrinter
from .recursion import joint_variable, recursion_context, recursion_names

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
DISPLAY_UNITS = 64
SHEET_TEMPLATE = "sheet.tex.j2"
#: The sheet's sections, in their order; ``--sections`` chooses among them.
SECTIONS = ("generalized", "maximal", "checks")
#: Planar robots with at most this many links get the maximal-coordinates section by default:
#: beyond it the section runs to a dozen pages (a planar 3R arm: 11 of 20) that few read.
MAXIMAL_DEFAULT_LINKS = 2


def default_sections(derivation: Derivation) -> tuple[str, ...]:
    """What the robot's size makes readable: generalized coordinates and the checks always,
    maximal coordinates for planar robots of at most MAXIMAL_DEFAULT_LINKS links (the RP arm
    of the reference)."""
    robot = derivation.robot
    maximal = robot.planar and len(robot.links) <= MAXIMAL_DEFAULT_LINKS
    return tuple(s for s in SECTIONS if s != "maximal" or maximal)


def maximal_left_out(derivation: Derivation, sections: tuple[str, ...] | None) -> bool:
    """Whether the default sections (``sections`` None) leave out a maximal-coordinates
    section the robot has: the sheet then says so and how to get it (``--sections all``)."""
    return sections is None and derivation.robot.planar and "maximal" not in default_sections(derivation)


def parse_sections(text: str) -> tuple[str, ...]:
    """``--sections`` text: names from SECTIONS separated by commas, or ``all``; in the
    sheet's order. Raises ValueError naming an unknown section."""
    names = [name.strip() for name in text.split(",") if name.strip()]
    if names == ["all"]:
        return SECTIONS
    unknown = [name for name in names if name not in SECTIONS]
    if unknown or not names:
        raise ValueError(f"unknown section {unknown[0]!r}" if unknown else "no section given")
    return tuple(s for s in SECTIONS if s in names)

class Formatter(DerivationFormatter):
    """LaTeX of SymPy objects with the robot's symbol names (``qd1`` -> ``\\dot{q}_{1}``) and
    numbers as the file wrote them, to ``digits`` (``--digits``) at most; ``exact``: as SymPy
    prints them (the JSON).

    One per derivation and options (``Formatter.of``), remembering what it printed: the sheet
    prints the same quantities again (entries, matrices, the HTML's figure), and a large robot's thousands of intermediate variables
    and its maximal model cost seconds to print. A large robot's sums are printed in SymPy's
    own (canonical, deterministic) order rather than sorted, which takes half the time."""

    def __init__(self, derivation: Derivation, digits: int | None = None, exact: bool = False,
                 extra_names: dict[sympy.Symbol, str] | None = None):
        super().__init__()
        self.names = derivation.symbols.latex_names() | {
            name: rf"\mathsf{{w}}_{{{str(name)[2:]}}}" for name, _ in derivation.intermediates} | (extra_names or {})
        self.order = "none" if derivation.intermediate_form else None
        settings = {"symbol_names": self.names, "mat_delim": "[", "mat_str": "matrix", "mul_symbol": None,
                    "long_frac_ratio": 2, "order": self.order}
        # the sheet's numbers as the file wrote them (render.numbers); exact: SymPy's (the JSON)
        self.numbers = None if exact else Numbers(sheet_digits(derivation.robot, digits))
        self._printer = (RememberingLatexPrinter(settings) if self.numbers is None
                         else SheetLatexPrinter(settings, self.numbers))
        self._breaker = LineBreaker(self, typeset_width, self.order, self.numbers)

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
        if isinstance(expr, sympy.MatrixBase) or all(typeset_width(t) <= units for t in sympy.Add.make_args(expr)):
            return Display(text, [text])
        return Display(text, self._breaker.lines(expr, units))

    def matrix(self, name: str, matrix: sympy.Matrix) -> dict[str, Any]:
        """A matrix as a whole when its estimated width fits the line (``wide`` False), else as
        its non-zero entries; ``too_large`` when even those cannot be typeset."""
        rows, cols = matrix.shape
        nodes = _nodes_up_to(list(matrix), BROKEN_NODES)
        if nodes > BROKEN_NODES:
            return {"latex": "", "wide": True, "tight": False, "entries": [], "shape": [rows, cols],
                    "too_large": True, "nodes": nodes, "zeros": 0}
        large = nodes > MATRIX_NODES or any(not is_small(e, ENTRY_NODES) for e in matrix)
        whole = "" if large else self(matrix)
        entries = []
        single = rows == cols == 1 and "_" in name   # a named 1 x 1 matrix (a one-DOF loop's M_r) is its entry
        for i in range(rows):
            for j in range(cols):
                if matrix[i, j] != 0:
                    entries.append({"name": name if single else subscript(name, entry_index(i, j, rows, cols)),
                                    "latex": self.display(matrix[i, j], None)})
        width = 0 if large else matrix_width(matrix)
        wide = large or width > LINE_UNITS * TIGHT or cols > MATRIX_COLUMNS
        return {"latex": whole, "wide": wide, "tight": not wide and width > LINE_UNITS,
                "entries": entries,
                "shape": [rows, cols], "too_large": False, "nodes": nodes, "zeros": rows * cols - len(entries)}


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


@functools.lru_cache(maxsize=1 << 16)
def typeset_width(expr: sympy.Basic) -> float:
    """Estimated width of ``expr`` typeset inline, in math glyphs: a symbol is a glyph and its
    index 0.7 a digit, a sum adds 2.2 per sign, a function its name and parentheses, a
    fraction its wider part. Rough (within about a fifth on the bundled sheets), and cheap
    (remembered: the line breaker asks for the same pieces again and again)."""
    if expr.is_Symbol:
        name = str(expr).lstrip("_")
        stem = name.rstrip("0123456789")
        index = len(name) - len(stem)
        base = stem.rstrip("d") or stem      # qd1, phid1: a dot over the coordinate's letter
        return (1.0 if base in _GREEK or len(base) == 1 else 0.9 * len(base)) + 0.7 * index
    # the sheet prints a long number as a decimal of at most 17 digits (render.numbers)
    if expr.is_Integer:
        return min(len(str(expr)), 24)
    if expr.is_Rational:
        p, q = abs(int(expr.p)), int(expr.q)
        if len(str(q)) > 3 and q == 2 ** _factor_count(q, 2) * 5 ** _factor_count(q, 5):
            # a terminating decimal, printed as one (render.numbers): its characters (at most
            # 17 digits, the point and a leading zero)
            shift = max(_factor_count(q, 2), _factor_count(q, 5))   # digits after the point
            return float(min(max(len(str(p)), shift) + 2, 19))
        return min(0.8 * max(len(str(expr.p)), len(str(expr.q))) + 0.6, 19)
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


def _fits(*values: Any, extra: float = 0.0) -> bool:
    """Whether ``values`` typeset side by side (plus ``extra`` glyphs of names and spacing)
    fit the line."""
    total = extra
    for value in values:
        total += matrix_width(value) if isinstance(value, sympy.MatrixBase) else typeset_width(sympy.sympify(value))
    return total <= LINE_UNITS


def _factor_count(n: int, prime: int) -> int:
    """How many times ``prime`` divides ``n`` (n > 0)."""
    count = 0
    while n % prime == 0:
        n //= prime
        count += 1
    return count


def matrix_width(matrix: sympy.Matrix) -> float:
    """Estimated width of ``matrix`` typeset whole: its columns' widest entries, the gaps
    between columns, the brackets and the name in front."""
    rows, cols = matrix.shape
    widest = [max(typeset_width(sympy.sympify(matrix[i, j])) for i in range(rows)) for j in range(cols)]
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


def sheet_context(derivation: Derivation, sections: tuple[str, ...] | None = None,
                  digits: int | None = None) -> dict[str, Any]:
    """Every variable the sheet template can use (documented in docs/templates.md); only the
    ``sections`` asked for (default ``default_sections``) are derived and formatted; numbers
    to ``digits`` significant digits at most (``--digits``)."""
    left_out = maximal_left_out(derivation, sections)
    sections = default_sections(derivation) if sections is None else sections
    fmt = Formatter.of(derivation, digits=digits)
    robot, table, q = derivation.robot, derivation.symbols, derivation.quantities
    gen = derivation.steps["generalized"]
    coordinate_latex = [fmt(s) for s in table.q]
    lagrange = []
    for i in range(len(robot.coordinates) if gen["lagrange"] else 0):
        lagrange.append({
            "coordinate": coordinate_latex[i], "velocity": fmt(table.qd[i]),
            "dL_dqd": fmt.display(gen["lagrange"]["dL_dqd"][i]),
            "ddt_dL_dqd": fmt.display(gen["lagrange"]["ddt_dL_dqd"][i]),
            "dL_dq": fmt.display(gen["lagrange"]["dL_dq"][i]),
            "effort": fmt(q["Y_g"][i]),
            "dissipation": fmt.display(q["F_g"][i], None) if "F_g" in q and q["F_g"][i] != 0 else None,
            "equation": fmt.display(q["EOM_g1"][i]),
        })
    links = []
    for t in gen["links"]:
        links.append({
            "index": t.index, "name": escape_tex(t.name), "mass": fmt(t.mass),
            "inertia": fmt(t.inertia), "spatial_inertia": fmt(t.spatial_inertia),
            # an inertia tensor of long decimals (CAD) is displayed, entry by entry if too wide
            "inertia_matrix": (fmt.matrix(rf"I_{{{t.index}}}", t.inertia)
                               if isinstance(t.inertia, sympy.MatrixBase) and matrix_width(t.inertia) > INLINE_UNITS
                               else None),
            "spatial_fits": matrix_width(t.spatial_inertia) <= LINE_UNITS * TIGHT,
            "jacobian": fmt.maybe(t.body_jacobian, INLINE_NODES),
            "velocity": fmt.maybe(t.body_velocity, INLINE_NODES),
            "com": fmt.maybe(t.com_position, INLINE_NODES), "angle": fmt.maybe(t.orientation, INLINE_NODES),
            # what shares a display line when it fits, else one display each, entry by entry if needed
            "pose_together": _fits(t.com_position, t.body_velocity, extra=16),
            "com_matrix": fmt.matrix(rf"\left(p_{{sL_{{{t.index}}}}}\right)", t.com_position),
            "velocity_matrix": fmt.matrix(rf"\left(V^b_{{sL_{{{t.index}}}}}\right)", t.body_velocity),
            "angle_matrix": fmt.matrix(rf"\left(R_{{sL_{{{t.index}}}}}\right)", t.orientation)
            if isinstance(t.orientation, sympy.MatrixBase) else None,
            "jacobian_matrix": fmt.matrix(rf"\left(J^b_{{sL_{{{t.index}}}}}\right)", t.body_jacobian),
            "kinetic": fmt.display(t.kinetic), "potential": fmt.display(t.potential),
        })
    parameters = [{
        "symbol": fmt(table.parameters[p.name]),
        "value": "" if p.value is None else parameter_value(p.value, fmt.numbers),
        "unit": tex_unit(p.unit), "description": escape_tex(p.description),
    } for p in robot.parameters]
    joints = [{
        "name": escape_tex(j.name), "type": j.type, "parent": escape_tex(j.parent),
        "child": escape_tex(j.child),
        "coordinate": fmt(joint_variable(robot, table, j)) if j.moves else "",
        "effort": fmt(sympy.Symbol(j.effort)) if j.effort else "",
    } for j in robot.joints]
    # the default sheet shows the named recursion instead: printed only if a template reads them
    intermediates = LazyList(len(derivation.intermediates), lambda: [
        {"name": fmt(name), "latex": fmt(value)} for name, value in derivation.intermediates])
    context = {
        "intermediates": intermediates,
        "jacobians": [{"index": k, "matrix": fmt.matrix(rf"\left(J^b_{{sL_{{{k}}}}}\right)", q[f"J_b{k}"])}
                      for k in range(1, len(robot.links) + 1)] if intermediates else [],
        "generator": f"dynderive {_version()}",
        "source": escape_tex(Path(robot.source).name),
        "robot": {"name": escape_tex(robot.name), "title": escape_tex(robot.title),
                  "planar": robot.planar, "parameters": parameters, "joints": joints,
                  "gravity": fmt(gen["gravity"])},
        "dof": len(robot.coordinates),
        "coordinates": coordinate_latex,
        "q_g": fmt(sympy.Matrix(table.q)),
        "qd_g": fmt(sympy.Matrix(table.qd)),
        "links": links,
        "T_g": fmt.display(q["T_g"]), "V_g": fmt.display(q["V_g"]),
        "L_g": fmt.display(q["L_g"]),
        "Y_g": fmt(q["Y_g"]),
        "lagrange": lagrange,
        "EOM_g1": fmt.matrix("EOM", q["EOM_g1"]) if "EOM_g1" in q else None,
        "M_g": fmt.matrix("M", q["M_g"]),
        "C_g": fmt.matrix("C", q["C_g"]),
        "N_g": fmt.matrix("N", q["N_g"]),
        "EOM_g2": fmt.matrix("EOM", q["EOM_g2"]),
        "checks": [{"description": escape_tex(c.description), "passed": c.passed,
                    "method": c.method, "residual": _residual_text(c.residual)} for c in derivation.checks]
                  if "checks" in sections else [],
        "sections": list(sections),
        "maximal_left_out": left_out,
        # equal generalized inertias in one display (M_1 = M_2 = ...), as the reference writes them
        # the generalized inertias as matrices while they fit the line (else diag(m_i, ..., I_i) says it)
        "inertia_groups": (_groups([(link["index"], link["spatial_inertia"]) for link in links])
                           if all(link["spatial_fits"] for link in links) else []),
        "figure": sheet_figure(derivation, fmt),
        "drives": drives_context(derivation, fmt),
        "F_g": fmt.matrix("F", q["F_g"]) if "F_g" in q else None,
        "maximal": maximal_context(derivation, fmt) if "maximal" in sections and "maximal" in derivation.steps else None,
        "loops": loops_context(derivation, fmt) if "loops" in derivation.steps else None,
        "frames": frames_context(derivation, fmt) if robot.frames else None,
        "recursion": _recursion(derivation, digits) if intermediates and "generalized" in sections else None,
    }
    return context


class RecursionFormatter(Formatter):
    """The sheet's formatter with the recursion's names (``recursion.recursion_names``: each
    line by its meaning, ``q_k``, ``s_k``, ``c_k``)."""

    def __init__(self, derivation: Derivation, digits: int | None = None):
        super().__init__(derivation, digits=digits, extra_names=recursion_names(derivation))


def _recursion(derivation: Derivation, digits: int | None) -> dict[str, Any]:
    return recursion_context(derivation, RecursionFormatter.of(derivation, digits=digits),
                             Formatter.of(derivation, digits=digits), typeset_width)


def frames_context(derivation: Derivation, fmt: Formatter) -> list[dict[str, Any]]:
    """Each frame's pose, Jacobian and its derivative (small robots; the names only for large
    ones, whose frame quantities the generated module computes)."""
    q, planar = derivation.quantities, derivation.robot.planar
    items = []
    for frame in derivation.robot.frames:
        name = frame.name
        symbolic = f"J_{name}" in q
        label = r"\mathrm{" + escape_tex(name) + "}"
        item: dict[str, Any] = {"name": escape_tex(name), "link": escape_tex(frame.link), "label": label,
                                "symbolic": symbolic}
        if symbolic:
            item |= {
                "position": fmt.matrix("p", q[f"p_{name}"]),
                "angle": fmt(q[f"theta_{name}"][0, 0]) if planar else None,
                "rotation": None if planar else fmt.matrix("R", q[f"R_{name}"]),
                "jacobian": fmt.matrix("J", q[f"J_{name}"]),
                "jacobian_dot": fmt.matrix(r"\dot J", q[f"Jdot_{name}"]),
            }
        items.append(item)
    return items


def drives_context(derivation: Derivation, fmt: Formatter) -> dict[str, Any] | None:
    """The joints' drive terms and where each enters Lagrange's equations (None: no drives)."""
    drives = derivation.steps["generalized"]["drives"]
    if drives.empty:
        return None
    table, q = derivation.symbols, derivation.quantities

    def term(value: sympy.Expr) -> str:
        return fmt(value) if value != 0 else ""

    return {
        "joints": [{"coordinate": fmt(table.q[d.coordinate]), "damping": term(d.damping),
                    "friction": term(d.friction), "stiffness": term(d.stiffness),
                    "rest": term(d.rest) if d.stiffness != 0 else "", "armature": term(d.armature)}
                   for d in drives.joints],
        "kinetic": fmt.display(drives.kinetic, None) if drives.kinetic != 0 else None,
        "potential": fmt.display(drives.potential, None) if drives.potential != 0 else None,
        "armature": drives.armature != sympy.zeros(*drives.armature.shape),
        "D_g": fmt.display(q["D_g"], None) if "D_g" in q else None,
        "coulomb": any(d.friction != 0 for d in drives.joints),
    }


def loops_context(derivation: Derivation, fmt: Formatter) -> dict[str, Any]:
    """The closed-loop section: constraints, multiplier form, reduced form (where derived)."""
    q, model, table = derivation.quantities, derivation.steps["loops"], derivation.symbols
    names = {"R_g": "R_g", "M_r": "M_r", "C_r": "C_r", "N_r": "N_r", "Y_r": "\\Upsilon_r"}
    reduced = {key: fmt.matrix(name, q[key]) if key in q else None for key, name in names.items()}
    return {
        "joints": [escape_tex(lp.name) for lp in derivation.robot.loops],
        "count": q["a_g"].shape[0], "rank": model.rank, "mobility": model.mobility,
        "rows": [f"{escape_tex(name)}: {escape_tex(what)}" for name, what in model.rows],
        "a_g": fmt.matrix("a", q["a_g"]), "A_g": fmt.matrix("A", q["A_g"]),
        "Adot_g": fmt.matrix("\\dot{A}", q["Adot_g"]),
        "multipliers": fmt(q["lambda_g"]),
        "independent": fmt(sympy.Matrix([table.q[i] for i in model.independent])),
        "dependent": fmt(sympy.Matrix([table.q[i] for i in model.dependent])),
        "assembled": fmt(sympy.Matrix([sympy.Float(x, 4) for x in model.assembled])) if model.assembled else "?",
        "notes": [escape_tex(n.split(": note: ", 1)[-1]) for n in model.notes],
        **reduced,
    }


#: Longest LaTeX of one lambda entry that the sheet still prints.
LONGEST_LAMBDA = 1800


def maximal_context(derivation: Derivation, fmt: Formatter) -> dict[str, Any]:
    q, steps, table = derivation.quantities, derivation.steps["maximal"], derivation.symbols
    lagrange = []
    for i, coordinate in enumerate(table.qm):
        lagrange.append({
            "coordinate": fmt(coordinate), "velocity": fmt(table.qmd[i]),
            "dL_dqd": fmt.display(steps["lagrange"]["dL_dqd"][i], None),
            "ddt_dL_dqd": fmt.display(steps["lagrange"]["ddt_dL_dqd"][i], None),
            "dL_dq": fmt.display(steps["lagrange"]["dL_dq"][i], None),
            # the three derivatives share a display line when they fit side by side, else the
            # first two (short: momenta and their rates) when they do
            "together": _fits(*(steps["lagrange"][k][i] for k in ("dL_dqd", "ddt_dL_dqd", "dL_dq")), extra=24),
            "pair": _fits(*(steps["lagrange"][k][i] for k in ("dL_dqd", "ddt_dL_dqd")), extra=16),
            "equation": fmt.display(q["EOM_m1"][i], None),
        })
    lambda_entries = None
    if "lambdaVec" in q and max(len(fmt(e)) for e in q["lambdaVec"]) <= LONGEST_LAMBDA:
        # the LaTeX first: breaking entries too long to show into lines cost seconds
        lambda_entries = [fmt.display(e, None) for e in q["lambdaVec"]]
    return {
        "q_m": fmt(q["q_m"]), "qd_m": fmt(sympy.Matrix(table.qmd)),
        "lambda": fmt(sympy.Matrix(table.multipliers)),
        "constraint_count": q["a_m"].shape[0],
        "constraints_from_file": steps["constraint_origin"] == "override",
        "a_m": fmt.matrix("a", q["a_m"]), "A_m": fmt.matrix("A", q["A_m"]),
        "Adot_m": fmt.matrix("\\dot{A}", q["Adot_m"]),
        "T_m": fmt.display(q["T_m"], None), "V_m": fmt.display(q["V_m"], None), "L_m": fmt.display(q["L_m"], None),
        "Y_m": fmt.matrix("\\Upsilon", q["Y_m"]),
        "lagrange": lagrange,
        "jacobians": [fmt.matrix(rf"\left(J^b_{{sL_{{{k}}}}}\right)", j) for k, j in enumerate(steps["jacobians"], 1)],
        "M_m": fmt.matrix("M", q["M_m"]), "C_m": fmt.matrix("C", q["C_m"]),
        "N_m": fmt.matrix("N", q["N_m"]), "EOM_m2": fmt.matrix("\\mathrm{EOM}", q["EOM_m2"]),
        "EOM_m1": fmt.matrix("\\mathrm{EOM}", q["EOM_m1"]),
        "lambda_symbolic": "lambdaVec" in q, "lambda_entries": lambda_entries,
        "h": fmt.matrix("h", q["h"]), "H": fmt.matrix("H", q["H"]),
        **(_change_of_basis(q, steps, fmt) if "EOM_g3" in q else {"EOM_g3": None}),
        "F_m": fmt.matrix("F", q["F_m"]) if "F_m" in q else None,
        "D_m": fmt.display(q["D_m"]) if "D_m" in q else None,
        "drives": not derivation.steps["generalized"]["drives"].empty,
    }


def _change_of_basis(q: Any, steps: dict[str, Any], fmt: Formatter) -> dict[str, Any]:
    """The maximal model mapped through H (small robots: ``EOM_g3``)."""
    return {
        "Hdot": fmt.matrix("\\dot{H}", steps["Hdot"]),
        "M_tilde": fmt.matrix("\\tilde{M}", steps["M_tilde"]),
        "C_tilde": fmt.matrix("\\tilde{C}", steps["C_tilde"]),
        "N_tilde": fmt.matrix("\\tilde{N}", steps["N_tilde"]),
        "Y_tilde": fmt.matrix("\\tilde{\\Upsilon}", steps["Y_tilde"]),
        "EOM_g3": fmt.matrix("\\mathrm{EOM}", q["EOM_g3"]),
        "F_tilde": fmt.matrix("\\tilde{F}", steps["F_tilde"]) if "F_m" in q else None,
    }


def _version() -> str:
    from ..._version import __version__

    return __version__


def render_latex(derivation: Derivation, template_dir: str | Path | None = None,
                 sections: tuple[str, ...] | None = None, digits: int | None = None) -> str:
    """The sheet of ``sections`` (default: ``default_sections``), numbers to ``digits``
    significant digits at most (default: as the robot file wrote them)."""
    return render("latex", SHEET_TEMPLATE, sheet_context(derivation, sections, digits), template_dir)


def parameter_value(value: float, numbers: Numbers | None) -> str:
    """A parameter's default in the sheet's table (text mode): as written, to D digits."""
    if numbers is None:
        return f"{value:g}"
    mantissa, exponent = numbers.value_parts(value)
    return mantissa if exponent is None else f"${latex_decimal(mantissa, exponent)}$"


#: Residuals below this print as "below 1e-12": their digits are rounding noise (double or
#: 30-digit arithmetic) that a library version or machine may change, and the sheet must not.
RESIDUAL_FLOOR = 1e-12


def _residual_text(residual: float) -> str:
    return "below 1e-12" if residual < RESIDUAL_FLOOR else f"{residual:.2g}"
