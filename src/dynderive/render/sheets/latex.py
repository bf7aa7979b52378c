"""The LaTeX solution sheet: quantities turned into LaTeX strings (``latex_format``), laid out
by ``sheet.tex.j2``; a robot with quaternion joints gets its quasi-velocity sections
(``quasi_velocity``) in the same sheet."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import sympy

from ...derivation import Derivation
from ...model.robot import Joint
from ..encode import escape_tex
from ..environment import LazyList, render
from .centroidal import LatexNames, centroidal_context
from .figure import sheet_figure
from .latex_format import (
    INLINE_NODES,
    INLINE_UNITS,
    LINE_UNITS,
    SCALAR_NODES,
    TIGHT,
    Formatter,
    _groups,
    sheet_header,
)
from .quasi_velocity import quasi_velocity_context
from .recursion import joint_variable, recursion_context, recursion_names

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

def sheet_context(derivation: Derivation, sections: tuple[str, ...] | None = None,
                  digits: int | None = None) -> dict[str, Any]:
    """Every variable the sheet template can use (documented in docs/templates.md); only the
    ``sections`` asked for (default ``default_sections``) are derived and formatted; numbers
    to ``digits`` significant digits at most (``--digits``)."""
    fmt = Formatter.of(derivation, digits=digits)
    style = SheetStyle(derivation, fmt)
    shared = shared_context(derivation, style, sections)
    sections = shared["sections"]
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    gen = derivation.generalized_steps
    links = [{
        "index": t.index, "name": escape_tex(t.name), "mass": fmt(t.mass),
        "inertia": fmt(t.inertia), "spatial_inertia": fmt(t.spatial_inertia),
        # an inertia tensor of long decimals (CAD) is displayed, entry by entry if too wide
        "inertia_matrix": (fmt.matrix(rf"I_{{{t.index}}}", t.inertia)
                           if isinstance(t.inertia, sympy.MatrixBase)
                           and fmt.matrix_width(t.inertia) > INLINE_UNITS else None),
        "spatial_fits": fmt.matrix_width(t.spatial_inertia) <= LINE_UNITS * TIGHT,
        "jacobian": fmt.maybe(t.body_jacobian, INLINE_NODES),
        "velocity": fmt.maybe(t.body_velocity, INLINE_NODES),
        "com": fmt.maybe(t.com_position, INLINE_NODES), "angle": fmt.maybe(t.orientation, INLINE_NODES),
        # what shares a display line when it fits, else one display each, entry by entry if needed
        "pose_together": fmt.fits(t.com_position, t.body_velocity, extra=16),
        "com_matrix": fmt.matrix(rf"\left(p_{{sL_{{{t.index}}}}}\right)", t.com_position),
        "velocity_matrix": fmt.matrix(rf"\left(V^b_{{sL_{{{t.index}}}}}\right)", t.body_velocity),
        "angle_matrix": fmt.matrix(rf"\left(R_{{sL_{{{t.index}}}}}\right)", t.orientation)
        if isinstance(t.orientation, sympy.MatrixBase) else None,
        "jacobian_matrix": style.jacobian(t.index, t.body_jacobian),
        "kinetic": fmt.display(t.kinetic), "potential": fmt.display(t.potential),
    } for t in gen["links"]]
    # the default sheet shows the named recursion instead: printed only if a template reads them
    intermediates = LazyList(len(derivation.intermediates), lambda: [
        {"name": fmt(name), "latex": fmt(value)} for name, value in derivation.intermediates])
    joints = joint_rows(derivation, style)
    return sheet_header(derivation, fmt, gen["gravity"], ["Coordinate"], joints) | shared | {
        "intermediates": intermediates,
        "jacobians": [{"index": k, "matrix": style.jacobian(k, quantities[f"J_b{k}"])}
                      for k in range(1, len(robot.links) + 1)] if intermediates else [],
        "coordinates": [fmt(s) for s in table.q],
        "links": links,
        # equal generalized inertias in one display (M_1 = M_2 = ...), as the reference writes them
        # the generalized inertias as matrices while they fit the line (else diag(m_i, ..., I_i) says it)
        "inertia_groups": (_groups([(link["index"], link["spatial_inertia"]) for link in links])
                           if all(link["spatial_fits"] for link in links) else []),
        "figure": sheet_figure(derivation, fmt),
        "recursion": (recursion_context(derivation, RecursionFormatter.of(derivation, digits=digits), fmt)
                      if intermediates and "generalized" in sections else None),
    }


def joint_rows(derivation: Derivation, style: SheetStyle) -> list[dict[str, Any]]:
    """The joint table: each joint's names, its variable (its coordinate, or a <mimic> joint's
    expression) and its effort, ``style.blank`` where it has none."""
    robot, table, fmt, text = derivation.robot, derivation.symbols, style.fmt, style.text

    def several(j: Joint) -> bool:   # coordinates of its own, no quaternion (a universal joint)
        return j.kind.vector_space and j.kind.nq > 1 and j.owns

    return [{"name": text(j.name), "type": j.type, "parent": text(j.parent), "child": text(j.child),
             "variables": ([fmt(sympy.Tuple(*(sympy.Symbol(n) for n in j.kind.names(j.name)[0])))] if several(j)
                           else [fmt(joint_variable(robot, table, j)) if j.moves else style.blank]),
             "effort": (fmt(sympy.Tuple(*(sympy.Symbol(n) for n in j.effort_names))) if several(j) and j.effort
                        else fmt(sympy.Symbol(j.effort)) if j.effort else style.blank)} for j in robot.joints]


def shared_context(derivation: Derivation, style: SheetStyle,
                   sections: tuple[str, ...] | None) -> dict[str, Any]:
    """What the LaTeX sheet and the HTML page take alike from the derivation, written by
    ``style``: the ``sections`` asked for (None: ``default_sections``), whether the maximal
    coordinates are left out, the coordinates, the generalized quantities and the sections'
    content."""
    left_out = maximal_left_out(derivation, sections)
    sections = default_sections(derivation) if sections is None else sections
    table, fmt, quantities = derivation.symbols, style.fmt, derivation.quantities
    return {
        "quasi_velocity": False, "sections": list(sections), "maximal_left_out": left_out,
        "dof": len(derivation.robot.coordinates),
        "q_g": fmt(sympy.Matrix(table.q)), "qd_g": fmt(sympy.Matrix(table.qd)),
        **{key: style.scalar(quantities[key], SCALAR_NODES) for key in ("T_g", "V_g", "L_g")},
        "Y_g": fmt(quantities["Y_g"]),
        **{key: style.matrix(key, quantities[key]) for key in ("M_g", "C_g", "N_g", "EOM_g2")},
        **{key: style.matrix(key, quantities[key]) if key in quantities else None for key in ("EOM_g1", "F_g")},
        "lagrange": lagrange_context(derivation, style),
        "checks": checks_context(derivation, style) if "checks" in sections else [],
        "drives": drives_context(derivation, style),
        "maximal": (maximal_context(derivation, style)
                    if "maximal" in sections and derivation.maximal_steps is not None else None),
        "loops": loops_context(derivation, style) if derivation.robot.loops else None,
        "frames": frames_context(derivation, style) if derivation.robot.frames else None,
        "centroidal": centroidal_context(derivation, style.centroidal_names()),
    }


class RecursionFormatter(Formatter):
    """The sheet's formatter with the recursion's names (``recursion.recursion_names``: each
    line by its meaning, ``q_k``, ``s_k``, ``c_k``)."""

    def __init__(self, derivation: Derivation, digits: int | None = None):
        super().__init__(derivation, digits=digits, extra_names=recursion_names(derivation))


def lagrange_context(derivation: Derivation, style: SheetStyle) -> list[dict[str, Any]]:
    """Lagrange's equations coordinate by coordinate (where derived: small robots)."""
    steps, q, table, fmt = derivation.generalized_steps["lagrange"], derivation.quantities, derivation.symbols, style.fmt
    if not steps:   # not derived
        return []
    return [{
        "coordinate": fmt(table.q[i]), "velocity": fmt(table.qd[i]),
        **{key: style.scalar(steps[key][i], SCALAR_NODES) for key in ("dL_dqd", "ddt_dL_dqd", "dL_dq")},
        "effort": fmt(q["Y_g"][i]),
        "dissipation": style.show(q["F_g"][i]) if "F_g" in q and q["F_g"][i] != 0 else None,
        "equation": style.scalar(q["EOM_g1"][i], SCALAR_NODES),
    } for i in range(len(derivation.robot.coordinates))]


#: Residuals below this print as "below 1e-12": their digits are rounding noise (double or
#: 30-digit arithmetic) that a library version or machine may change, and the sheet must not.
RESIDUAL_FLOOR = 1e-12


def checks_context(derivation: Derivation, style: SheetStyle) -> list[dict[str, Any]]:
    return [{"description": style.text(c.description), "passed": c.passed, "method": c.method,
             "residual": "below 1e-12" if c.residual < RESIDUAL_FLOOR else f"{c.residual:.2g}"}
            for c in derivation.checks]


def frames_context(derivation: Derivation, style: SheetStyle) -> list[dict[str, Any]]:
    """Each frame's pose, Jacobian and, planar, its derivative (small robots; the names only for
    large ones, whose frame quantities the generated module computes)."""
    q, planar, fmt = derivation.quantities, derivation.robot.planar, style.fmt
    items = []
    for frame in derivation.robot.frames:
        name = frame.name
        item: dict[str, Any] = {"name": style.text(name), "link": style.text(frame.link), "symbolic": f"J_{name}" in q,
                                **style.frame_labels(name)}
        if item["symbolic"]:
            item |= {
                "position": style.frame_matrix("p", name, q[f"p_{name}"]),
                "angle": fmt(q[f"theta_{name}"][0, 0]) if planar else None,
                "rotation": None if planar else style.frame_matrix("R", name, q[f"R_{name}"]),
                "jacobian": style.frame_matrix("J", name, q[f"J_{name}"]),
                "jacobian_dot": style.frame_matrix("Jdot", name, q[f"Jdot_{name}"]) if planar else None,
            }
        items.append(item)
    return items


class SheetStyle:
    """How the LaTeX sheet writes the sections the HTML page shares with it (drives, closed
    loops, maximal coordinates: ``drives_context``, ``loops_context``, ``maximal_context``
    build their content); ``html.PageStyle`` writes them in MathML."""

    text = staticmethod(escape_tex)
    blank: Any = ""      # a drive term a joint has not
    unknown: Any = "?"   # an assembly not found
    #: the sheet's names of the sections' matrices
    NAMES = {"M_g": "M", "C_g": "C", "N_g": "N", "F_g": "F", "EOM_g1": "EOM", "EOM_g2": "EOM", "a_g": "a",
             "A_g": "A", "Adot_g": "\\dot{A}", "R_g": "R_g", "M_r": "M_r", "C_r": "C_r", "N_r": "N_r",
             "Y_r": "\\Upsilon_r", "a_m": "a", "A_m": "A", "Adot_m": "\\dot{A}", "Y_m": "\\Upsilon", "M_m": "M",
             "C_m": "C", "N_m": "N", "EOM_m1": "\\mathrm{EOM}", "EOM_m2": "\\mathrm{EOM}", "h": "h", "H": "H",
             "F_m": "F", "Hdot": "\\dot{H}", "M_tilde": "\\tilde{M}", "C_tilde": "\\tilde{C}", "N_tilde": "\\tilde{N}",
             "Y_tilde": "\\tilde{\\Upsilon}", "F_tilde": "\\tilde{F}", "EOM_g3": "\\mathrm{EOM}"}

    def __init__(self, derivation: Derivation, fmt: Any):
        self.fmt, self.latex = fmt, fmt   # latex: the LaTeX formatter, whose lengths decide what is shown

    def centroidal_names(self) -> LatexNames:
        """How the section on the centre of mass names its matrices (``centroidal``)."""
        return LatexNames(self.fmt)

    def matrix(self, key: str, value: sympy.Matrix) -> dict[str, Any]:
        return self.fmt.matrix(self.NAMES[key], value)

    def jacobian(self, k: int, value: sympy.Matrix) -> dict[str, Any]:
        return self.fmt.matrix(rf"\left(J^b_{{sL_{{{k}}}}}\right)", value)

    def frame_labels(self, name: str) -> dict[str, Any]:
        """A frame's name as the template writes it beside its matrices' letters."""
        return {"label": r"\mathrm{" + escape_tex(name) + "}"}

    def frame_matrix(self, letter: str, name: str, value: sympy.Matrix) -> dict[str, Any]:
        """A frame's matrix (``letter`` p, R, J or Jdot; the template adds the frame's label)."""
        return self.fmt.matrix(r"\dot J" if letter == "Jdot" else letter, value)

    def show(self, value: sympy.Expr) -> Any:
        """An equation's side, however large."""
        return self.fmt.display(value, None)

    def scalar(self, value: sympy.Expr, limit: int = SCALAR_NODES) -> Any:
        """A scalar shown while it has at most ``limit`` nodes."""
        return self.fmt.display(value, limit)


def drives_context(derivation: Derivation, style: SheetStyle) -> dict[str, Any] | None:
    """The joints' drive terms and where each enters Lagrange's equations (None: no drives)."""
    drives = derivation.generalized_steps["drives"]
    if drives.empty:
        return None
    table, q, fmt = derivation.symbols, derivation.quantities, style.fmt

    def term(value: sympy.Expr) -> Any:
        return fmt(value) if value != 0 else style.blank

    return {
        "joints": [{"coordinate": fmt(table.q[d.coordinate]), "damping": term(d.damping),
                    "friction": term(d.friction), "stiffness": term(d.stiffness),
                    "rest": fmt(d.rest) if d.stiffness != 0 else style.blank, "armature": term(d.armature)}
                   for d in drives.joints],
        "kinetic": style.show(drives.kinetic) if drives.kinetic != 0 else None,
        "potential": style.show(drives.potential) if drives.potential != 0 else None,
        "armature": drives.armature != sympy.zeros(*drives.armature.shape),
        "D_g": style.show(q["D_g"]) if "D_g" in q else None,
        "coulomb": any(d.friction != 0 for d in drives.joints),
    }


def loops_context(derivation: Derivation, style: SheetStyle) -> dict[str, Any]:
    """The closed-loop section: constraints, multiplier form, reduced form (where derived)."""
    q, model, table, fmt, text = derivation.quantities, derivation.loop_model, derivation.symbols, style.fmt, style.text
    return {
        "joints": [text(lp.name) for lp in derivation.robot.loops],
        "count": q["a_g"].shape[0], "rank": model.rank, "mobility": model.mobility,
        "rows": [f"{text(name)}: {text(what)}" for name, what in model.rows],
        "multipliers": fmt(q["lambda_g"]),
        "independent": fmt(sympy.Matrix([table.q[i] for i in model.independent])),
        "dependent": fmt(sympy.Matrix([table.q[i] for i in model.dependent])),
        "assembled": (fmt(sympy.Matrix([sympy.Float(x, 4) for x in model.assembled])) if model.assembled
                      else style.unknown),
        "notes": [text(n.split(": note: ", 1)[-1]) for n in model.notes],
        **{key: style.matrix(key, q[key]) if key in q else None
           for key in ("a_g", "A_g", "Adot_g", "R_g", "M_r", "C_r", "N_r", "Y_r")},
    }


#: Longest LaTeX of one lambda entry that the sheet still prints.
LONGEST_LAMBDA = 1800


def maximal_context(derivation: Derivation, style: SheetStyle) -> dict[str, Any]:
    """The maximal-coordinates section; the change of basis to the generalized coordinates
    (``EOM_g3``) for small robots."""
    steps, table, fmt = derivation.maximal_steps, derivation.symbols, style.fmt
    assert steps is not None, "maximal coordinates: planar robots only"
    quantities = derivation.quantities
    derivatives = ("dL_dqd", "ddt_dL_dqd", "dL_dq")
    lagrange = [{
        "coordinate": fmt(coordinate), "velocity": fmt(table.qmd[i]),
        **{key: style.show(steps["lagrange"][key][i]) for key in derivatives},
        # the three derivatives share a display line when they fit side by side, else the
        # first two (short: momenta and their rates) when they do
        "together": fmt.fits(*(steps["lagrange"][k][i] for k in derivatives), extra=24),
        "pair": fmt.fits(*(steps["lagrange"][k][i] for k in derivatives[:2]), extra=16),
        "equation": style.show(quantities["EOM_m1"][i]),
    } for i, coordinate in enumerate(table.qm)]
    lambda_entries = None
    if "lambdaVec" in quantities and max(len(style.latex(e)) for e in quantities["lambdaVec"]) <= LONGEST_LAMBDA:
        # the LaTeX first: breaking entries too long to show into lines cost seconds
        lambda_entries = [style.show(e) for e in quantities["lambdaVec"]]
    tilde: tuple[Literal["Hdot", "M_tilde", "C_tilde", "N_tilde", "Y_tilde"], ...] = (
        ("Hdot", "M_tilde", "C_tilde", "N_tilde", "Y_tilde") if "EOM_g3" in quantities else ())
    return {
        "q_m": fmt(quantities["q_m"]), "qd_m": fmt(sympy.Matrix(table.qmd)),
        "lambda": fmt(sympy.Matrix(table.multipliers)),
        "constraint_count": quantities["a_m"].shape[0],
        "constraints_from_file": steps["constraint_origin"] == "override",
        **{key: style.matrix(key, quantities[key]) for key in ("a_m", "A_m", "Adot_m")},
        "T_m": style.show(quantities["T_m"]), "V_m": style.show(quantities["V_m"]), "L_m": style.show(quantities["L_m"]),
        "Y_m": style.matrix("Y_m", quantities["Y_m"]),
        "lagrange": lagrange,
        "jacobians": [style.jacobian(k, j) for k, j in enumerate(steps["jacobians"], 1)],
        **{key: style.matrix(key, quantities[key]) for key in ("M_m", "C_m", "N_m", "EOM_m2", "EOM_m1")},
        "lambda_symbolic": "lambdaVec" in quantities, "lambda_entries": lambda_entries,
        "h": style.matrix("h", quantities["h"]), "H": style.matrix("H", quantities["H"]),
        **{key: style.matrix(key, steps[key]) for key in tilde},
        "EOM_g3": style.matrix("EOM_g3", quantities["EOM_g3"]) if tilde else None,
        "F_tilde": style.matrix("F_tilde", steps["F_tilde"]) if tilde and "F_m" in quantities else None,
        "F_m": style.matrix("F_m", quantities["F_m"]) if "F_m" in quantities else None,
        "D_m": style.scalar(quantities["D_m"]) if "D_m" in quantities else None,
        "drives": not derivation.generalized_steps["drives"].empty,
    }


def render_latex(derivation: Derivation, template_dir: str | Path | None = None,
                 sections: tuple[str, ...] | None = None, digits: int | None = None) -> str:
    """The sheet of ``sections`` (default: ``default_sections``), numbers to ``digits``
    significant digits (default: as the robot file wrote them, at most 6). A robot with
    quaternion joints gets the quasi-velocity sections (``quasi_velocity``) instead."""
    context = (quasi_velocity_context(derivation, digits) if derivation.robot.floating
               else sheet_context(derivation, sections, digits))
    return render("latex", SHEET_TEMPLATE, context, template_dir)
