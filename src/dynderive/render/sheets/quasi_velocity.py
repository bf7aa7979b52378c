"""The sheet's quasi-velocity sections, what a robot with quaternion joints (a floating base,
spherical joints) gets in ``sheet.tex.j2`` (``sections/quasi_velocity.tex.j2``): a small
robot's equations derived step by step in quasi-velocities (``mechanics/quasi_velocity.py``),
a large one's as the intermediate-variable form of its module's programs (Newton-Euler and
composite rigid bodies, line by line). The names of the quaternion joints' entries, the
program listing and the dissipative forces serve the HTML page, the JSON dump and the
terminal too."""

from __future__ import annotations

from typing import Any

import sympy

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from ..encode import escape_tex
from .centroidal import LatexNames, centroidal_context
from .latex_format import Formatter, sheet_header
from .recursion import COLUMN_UNITS


def program_listing(derivation: Derivation) -> tuple[list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]],
                                                     dict[str, list[sympy.Expr]]]:
    """A large robot's intermediate-variable form: the lines the module's programs share
    (the links' transforms), then those of Newton-Euler (``tau``), then those of the
    composite rigid bodies (``M``), each line renamed ``_wk`` in one sequence; and the
    outputs over those names (``tau`` = M vdot + C v + N, ``M`` row by row, ``N``)."""
    programs = derivation.programs
    parts = {"tau": programs["inverse_dynamics"], "M": programs["mass_matrix"], "N": programs["gravity"]}
    shared = 0
    first, second = parts["tau"].lines, parts["M"].lines
    while shared < min(len(first), len(second)) and first[shared] == second[shared]:
        shared += 1
    count = 0
    groups: list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]] = []
    outputs: dict[str, list[sympy.Expr]] = {}
    renamed_shared: dict[sympy.Symbol, sympy.Symbol] = {}
    for key, program in parts.items():
        renames = dict(renamed_shared)
        lines = []
        for k, (name, value) in enumerate(program.lines):
            if k < shared and name in renamed_shared:
                continue
            count += 1
            renames[name] = sympy.Symbol(f"_w{count}")
            lines.append((renames[name], value.xreplace(renames)))
        if not renamed_shared:   # the first program: its first lines are the shared ones
            renamed_shared = {name: renames[name] for name, _ in program.lines[:shared]}
            groups.append(("shared", lines[:shared]))
            lines = lines[shared:]
        groups.append((key, lines))
        outputs[key] = [e.xreplace(renames) for e in program.outputs]
    return groups, outputs


def _names_of(groups: list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]]) -> tuple[tuple[sympy.Symbol, str], ...]:
    return tuple((name, f"\\mathsf{{w}}_{{{str(name)[2:]}}}") for _, lines in groups for name, _ in lines)


def listing(derivation: Derivation) -> tuple[Any, list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]],
                                             dict[str, list[sympy.Expr]]]:
    """The robot's quasi-velocity steps and, for a large robot (no step-by-step ``sheet``), its
    ``program_listing`` (empty for a small one): what every format shows."""
    steps = derivation.quasi_velocity_steps
    groups, outputs = ([], {}) if steps.sheet is not None else program_listing(derivation)
    return steps, groups, outputs


#: Largest entry (tree nodes, then LaTeX characters: about a page) sheet
#: typesets: breqn cannot break a display over pages; a longer one is in the JSON dump.
ENTRY_LIMIT = 1500
LATEX_LIMIT = 5000


class LatexStyle:
    """How the LaTeX sheet writes the quasi-velocity content that ``quasi_velocity_context``
    builds (which sections, matrices and lines, in which order); the HTML page's style
    (``html_quasi_velocity.HtmlStyle``) writes the same content in MathML."""

    dash = "--"
    absent: Any = ""
    #: the key of a matrix's and its entries' text, and the longest entry text shown
    text_key, longest = "latex", LATEX_LIMIT
    name = staticmethod(escape_tex)
    #: the names of a link's (``{k}`` its index) and the robot's matrices
    NAMES = {"inertia": "I_{{{k}}}", "rotation": "R_{{{k}}}", "position": "p_{{{k}}}", "jacobian": "J_{{{k}}}",
             "jacobian_dot": "\\dot J_{{{k}}}", "twist": "\\mathcal{{V}}_{{{k}}}",
             "gravity": "\\left(R_{{{k}}}^T \\vec g\\right)", "rate": "Q", "M": "M", "N": "N",
             "Cv": "\\left(C v\\right)", "C": "C", "EOM": "\\mathrm{{EOM}}"}

    def formatter(self, derivation: Derivation, digits: int | None, groups: list[Any]) -> Formatter:
        return Formatter.of(derivation, digits=digits, lines=_names_of(groups))

    def header(self, derivation: Derivation, fmt: Any, gravity: sympy.Matrix) -> dict[str, Any]:
        """The header with the joint table: each joint's coordinates and velocities (a
        ``<mimic>`` joint's follow its leader's coordinate)."""
        robot, table = derivation.robot, derivation.symbols
        where_q, where_v = robot.offsets()
        joints = []
        for j in robot.joints:
            variables = [self.listed(fmt, []), self.listed(fmt, [])]
            if j.owns:
                size = j.sizes   # a universal joint's two, a floating joint's seven and six
                variables = [self.listed(fmt, table.q[where_q[j.name]:where_q[j.name] + size[0]]),
                             self.listed(fmt, table.qd[where_v[j.name]:where_v[j.name] + size[1]])]
            elif j.moves:
                leader, multiplier, offset = robot.driver(j)
                m = table.expr(multiplier)
                variables = [fmt(m * table.q[where_q[leader]] + table.expr(offset)), fmt(m * table.qd[where_v[leader]])]
            joints.append({"name": self.name(j.name), "type": j.type, "parent": self.name(j.parent),
                           "child": self.name(j.child), "variables": variables,
                           "effort": self.listed(fmt, [table.efforts[n] for n in j.effort_names])})
        return self.opening(derivation, fmt, gravity, joints)

    def opening(self, derivation: Derivation, fmt: Any, gravity: sympy.Matrix, joints: list[Any]) -> dict[str, Any]:
        return sheet_header(derivation, fmt, gravity, ["Coordinates", "Velocities"], joints)

    def listed(self, fmt: Any, symbols: list[sympy.Symbol]) -> Any:
        return ", ".join(fmt(s) for s in symbols)

    def matrix(self, fmt: Any, key: str, index: int | None, matrix: sympy.Matrix) -> dict[str, Any]:
        """The matrix ``key`` (of link ``index``) as ``shown``, with the entries over ENTRY_LIMIT
        nodes or ``longest`` characters left out: their text None (the template says they are
        too long and in the JSON dump)."""
        fits = [is_small(e, ENTRY_LIMIT) for e in matrix if e != 0]   # row by row, as the entries
        shown = self.shown(fmt, key, index,
                           matrix.applyfunc(lambda e: e if is_small(e, ENTRY_LIMIT) else sympy.Integer(1)))
        long = [not small or len(entry[self.text_key]) > self.longest
                for small, entry in zip(fits, shown["entries"])]
        if any(long):
            shown["wide"], shown[self.text_key] = True, self.absent
            for entry, too_long in zip(shown["entries"], long):
                if too_long:
                    entry[self.text_key] = None
        return shown

    def shown(self, fmt: Any, key: str, index: int | None, matrix: sympy.Matrix) -> dict[str, Any]:
        return fmt.matrix(self.NAMES[key].format(k=index), matrix)

    def scalar(self, fmt: Any, expr: sympy.Expr) -> Any:
        return fmt.display(expr)

    def centroidal_names(self, fmt: Any) -> LatexNames:
        """How the section on the centre of mass names its matrices (``centroidal``)."""
        return LatexNames(fmt)

    def line(self, fmt: Any, name: sympy.Symbol, value: sympy.Expr) -> dict[str, Any]:
        return {"name": fmt(name), "parts": fmt.display(value, None, COLUMN_UNITS).lines}

    def output(self, fmt: Any, key: str, value: sympy.Expr, row: int, column: int | None = None) -> Any:
        """An entry of ``tau``, ``N`` (its LaTeX) or ``M`` (with its row and column)."""
        if column is None:
            return fmt(value)
        return {"row": row, "column": column, "latex": fmt(value)}


def quasi_velocity_context(derivation: Derivation, digits: int | None = None, style: Any = None) -> dict[str, Any]:
    """Every variable ``sheet.tex.j2`` uses for a robot with quaternion joints
    (docs/reference/outputs.md), written by ``style`` (default ``LatexStyle``; the HTML page
    passes its own)."""
    style = style or LatexStyle()
    robot, table = derivation.robot, derivation.symbols
    steps, groups, outputs = listing(derivation)
    small = steps.sheet is not None
    fmt = style.formatter(derivation, digits, groups)
    where_q, where_v = robot.offsets()
    gravity = sympy.Matrix([table.expr(e) for e in robot.gravity])
    context = style.header(derivation, fmt, gravity) | {
        "quasi_velocity": True, "maximal_left_out": False,
        "nq": len(table.q), "nv": len(table.qd), "small": small,
        "q": fmt(sympy.Matrix(table.q)), "v": fmt(sympy.Matrix(table.qd)), "vdot": fmt(sympy.Matrix(table.qdd)),
        # what its quaternion joints are, in words; whether it is one free body (Euler's equations)
        "quaternion_joints": "with a floating base" if robot.floating_base else "with floating or spherical joints",
        "free_body": robot.floating_base and len(robot.links) == 1,
        "multi": [multi_joint(j, fmt, table, where_q, where_v, steps.rotations[j.name], style) for j in robot.joints
                  if j.multi],
        "Y": fmt(sympy.Matrix(steps.efforts)),
        "actuated_multi": any(j.multi and j.effort for j in robot.joints),
        "intermediates": bool(groups), "figure": None,
        "F": fmt(dissipative_forces(derivation)) if robot.dissipative else None,
    }
    context["centroidal"] = centroidal_context(derivation, style.centroidal_names(fmt))
    if small:
        context |= _small_context(steps.sheet, fmt, style)
    else:
        context |= _large_context(groups, outputs, fmt, len(table.qd), style)
    return context


def dissipative_forces(derivation: Derivation) -> sympy.Matrix:
    """``F = b v + fc sign(v)``, NV x 1: the damping and Coulomb friction of the scalar joints
    (``Derivation.joint_drives``, by velocity column), as the module's ``friction_forces``."""
    qd = derivation.symbols.qd
    F = sympy.zeros(len(qd), 1)
    for drive in derivation.joint_drives:
        F[drive.coordinate] = drive.damping * qd[drive.coordinate] + drive.friction * sympy.sign(qd[drive.coordinate])
    return F


def multi_joint(joint: Any, fmt: Any, table: Any, where_q: dict[str, int], where_v: dict[str, int],
                rotation: tuple[sympy.Matrix, sympy.Matrix], style: Any) -> dict[str, Any]:
    """A floating or spherical joint: its quaternion's rotation matrix and configuration rate,
    formatted by ``fmt`` with ``style``'s ``name`` and ``absent`` (a spherical joint has no position)."""
    start = joint.kind.quaternion_start or 0
    qi, vi = where_q[joint.name], where_v[joint.name]
    quat = table.q[qi + start:qi + start + 4]
    return {"name": style.name(joint.name), "type": joint.type,
            "quaternion": fmt(sympy.Matrix(quat)),
            "position": fmt(sympy.Matrix(table.q[qi:qi + 3])) if start else style.absent,
            "linear": fmt(sympy.Matrix(table.qd[vi:vi + 3])) if start else style.absent,
            "angular": fmt(sympy.Matrix(table.qd[vi + start:vi + start + 3])),
            "rotation": fmt(rotation[0]), "rate": fmt(rotation[1])}


def _small_context(sheet: Any, fmt: Any, style: Any) -> dict[str, Any]:
    links = [{
        "index": item.index, "name": style.name(item.name), "mass": fmt(item.mass), "com": fmt(item.com),
        **{key: style.matrix(fmt, key, item.index, getattr(item, field)) for key, field in (
            ("inertia", "inertia"), ("rotation", "rotation"), ("position", "com_position"),
            ("jacobian", "jacobian"), ("twist", "twist"), ("gravity", "gravity"))},
        "jacobian_dot": style.matrix(fmt, "jacobian_dot", item.index, item.jacobian_dot)
        if item.jacobian_dot != sympy.zeros(*item.jacobian_dot.shape) else None,
        "kinetic": style.scalar(fmt, item.kinetic), "potential": style.scalar(fmt, item.potential),
    } for item in sheet.links]
    return {
        "links": links, "single": len(sheet.links) == 1,
        "rate": style.matrix(fmt, "rate", None, sheet.rate),
        "T": style.scalar(fmt, sheet.T), "V": style.scalar(fmt, sheet.V),
        **{key: style.matrix(fmt, key, None, getattr(sheet, key)) for key in ("M", "N", "Cv", "C", "EOM")},
    }


def _large_context(groups: list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]], outputs: dict[str, list[sympy.Expr]],
                   fmt: Any, nv: int, style: Any) -> dict[str, Any]:
    titles = {"shared": "The links' transforms and inertias", "tau": "Newton--Euler",
              "M": "Composite rigid bodies", "N": "Gravity (Newton--Euler at rest)"}
    return {
        "groups": [{"title": titles[key].replace("--", style.dash), "key": key,
                    "lines": [style.line(fmt, n, v) for n, v in lines]} for key, lines in groups],
        "line_count": sum(len(lines) for _, lines in groups),
        "tau": [style.output(fmt, "tau", e, i) for i, e in enumerate(outputs["tau"], 1)],
        "N": [style.output(fmt, "N", e, i) for i, e in enumerate(outputs["N"], 1)],
        "M": [style.output(fmt, "M", outputs["M"][i * nv + j], i + 1, j + 1)
              for i in range(nv) for j in range(i, nv) if outputs["M"][i * nv + j] != 0],
    }
