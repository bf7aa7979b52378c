"""The HTML sheet: the LaTeX sheet's sections and quantities as one self-contained page.

Equations are MathML (``html_math``), the drawing of a planar robot inline SVG
(``html_svg``, the TikZ picture's geometry), the style an inline ``<style>``: no script,
no network, no external file. The quantities, the sections and the size rules (what is
too large to typeset) are the sheet's: the derivation's quantities, the sheet's
``default_sections`` and the LaTeX ``Formatter``'s limits. Text from the robot file reaches
the page only through the HTML environment's autoescaping.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import sympy
from markupsafe import Markup

from ...derivation import Derivation
from ..environment import render
from .figure import sheet_figure
from .html_math import (
    MathFormatter,
    body_jacobian,
    fenced,
    link_frame,
    mi,
    mrow,
    name_markup,
    page_header,
    sub,
)
from .html_recursion import html_recursion
from .html_svg import configuration_text, figure_labels, svg_figure
from .latex import LONGEST_LAMBDA, _residual_text, default_sections, maximal_left_out
from .latex_format import INLINE_NODES, SCALAR_NODES, Formatter, _groups
from .recursion import joint_variable

HTML_TEMPLATE = "html/sheet.html.j2"


def _upright(text: str) -> Markup:
    return mi(text, normal=True)


def _named(letter: str, index: str) -> Markup:
    """``M_g``, ``EOM_{g2}`` (several letters upright)."""
    return sub(_upright(letter) if len(letter) > 1 else letter, _upright(index) if not index.isdigit() else index)


def html_context(derivation: Derivation, sections: tuple[str, ...] | None = None,
                 digits: int | None = None) -> dict[str, Any]:
    """Every variable the HTML template uses; only the ``sections`` asked for (default the
    sheet's ``default_sections``); numbers to ``digits`` at most (``--digits``)."""
    left_out = maximal_left_out(derivation, sections)
    sections = default_sections(derivation) if sections is None else sections
    fmt = MathFormatter.of(derivation, digits=digits)
    robot, table, q = derivation.robot, derivation.symbols, derivation.quantities
    gen = derivation.steps["generalized"]

    def display(expr: Any, limit: int | None = SCALAR_NODES) -> Markup | None:
        return fmt(expr) if limit is None else fmt.maybe(expr, limit)

    lagrange = []
    for i in range(len(robot.coordinates) if gen["lagrange"] else 0):
        lagrange.append({
            "coordinate": fmt(table.q[i]), "velocity": fmt(table.qd[i]),
            "dL_dqd": display(gen["lagrange"]["dL_dqd"][i]),
            "ddt_dL_dqd": display(gen["lagrange"]["ddt_dL_dqd"][i]),
            "dL_dq": display(gen["lagrange"]["dL_dq"][i]),
            "dissipation": display(q["F_g"][i], None) if "F_g" in q and q["F_g"][i] != 0 else None,
            "equation": display(q["EOM_g1"][i]),
        })
    links = []
    for t in gen["links"]:
        k = t.index
        links.append({
            "index": k, "name": t.name, "mass": fmt(t.mass), "inertia": fmt(t.inertia),
            "spatial_inertia": fmt(t.spatial_inertia),
            "jacobian": fmt.maybe(t.body_jacobian, INLINE_NODES) is not None,
            # shown where the sheet shows them: both small enough to read
            "pose": all(fmt.maybe(x, INLINE_NODES) is not None for x in (t.com_position, t.body_velocity)),
            "oriented": fmt.maybe(t.orientation, INLINE_NODES) is not None,
            "com": fmt.matrix(fenced(sub("p", link_frame(k))), t.com_position, sub("p", link_frame(k))),
            "velocity": fmt.matrix(fenced(sub("V", link_frame(k), "b")), t.body_velocity, sub("V", link_frame(k), "b")),
            "angle": (fmt.maybe(t.orientation, INLINE_NODES) if robot.planar else
                      fmt.matrix(fenced(sub("R", link_frame(k))), t.orientation, sub("R", link_frame(k)))),
            "jacobian_matrix": fmt.matrix(fenced(body_jacobian(k)), t.body_jacobian, body_jacobian(k)),
            "kinetic": display(t.kinetic), "potential": display(t.potential),
            "frame": link_frame(k),
        })
    joints = [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
               "variables": [fmt(joint_variable(robot, table, j)) if j.moves else None],
               "effort": fmt(sympy.Symbol(j.effort)) if j.effort else None} for j in robot.joints]
    context = page_header(derivation, fmt, gen["gravity"], joints) | {
        "dof": len(robot.coordinates),
        "q_g": fmt(sympy.Matrix(table.q)), "qd_g": fmt(sympy.Matrix(table.qd)),
        # a large robot's equations as the recursion that computes them, as on the LaTeX sheet
        "recursion": (html_recursion(derivation, fmt.digits)
                      if derivation.intermediates and "generalized" in sections else None),
        "links": links,
        "T_g": display(q["T_g"]), "V_g": display(q["V_g"]), "L_g": display(q["L_g"]),
        "Y_g": fmt(q["Y_g"]),
        "lagrange": lagrange,
        "EOM_g1": fmt.matrix("EOM", q["EOM_g1"], _named("EOM", "g1")) if "EOM_g1" in q else None,
        "M_g": fmt.matrix("M", q["M_g"], _named("M", "g")),
        "C_g": fmt.matrix("C", q["C_g"], _named("C", "g")),
        "N_g": fmt.matrix("N", q["N_g"], _named("N", "g")),
        "F_g": fmt.matrix("F", q["F_g"], _named("F", "g")) if "F_g" in q else None,
        "EOM_g2": fmt.matrix("EOM", q["EOM_g2"], _named("EOM", "g2")),
        "inertia_groups": [{"names": [sub("\U0001d4dc", str(i)) for i in g["indices"]], "math": g["latex"]}
                           for g in _groups([(link["index"], link["spatial_inertia"]) for link in links])],
        "checks": [{"description": c.description, "passed": c.passed, "method": c.method,
                    "residual": _residual_text(c.residual)} for c in derivation.checks]
                  if "checks" in sections else [],
        "sections": list(sections),
        "maximal_left_out": left_out,
        "figure": _figure(derivation), "quasi_velocity": False,
        "drives": _drives(derivation, fmt),
        "loops": _loops(derivation, fmt) if "loops" in derivation.steps else None,
        "frames": _frames(derivation, fmt) if robot.frames else None,
        "maximal": _maximal(derivation, fmt) if "maximal" in sections and "maximal" in derivation.steps else None,
    }
    return context


def _figure(derivation: Derivation) -> dict[str, Any] | None:
    """The TikZ picture's geometry as SVG, and the configuration drawn."""
    latex = Formatter.of(derivation)
    figure = sheet_figure(derivation, latex)
    if figure is None:
        return None
    robot = derivation.robot
    return {"svg": svg_figure(figure, figure_labels(derivation, latex)),
            "configuration": [(name_markup(n), value) for n, value in
                              configuration_text(derivation, figure["configuration"], latex)],
            "loops": bool(robot.loops), "spatial": not robot.planar,
            "what": "" if robot.planar else "its default assembly" if robot.loops else "its zero configuration",
            "view": figure.get("view", ("", ""))}


def _drives(derivation: Derivation, fmt: MathFormatter) -> dict[str, Any] | None:
    drives = derivation.steps["generalized"]["drives"]
    if drives.empty:
        return None
    table, q = derivation.symbols, derivation.quantities

    def term(value: sympy.Expr) -> Markup | None:
        return fmt(value) if value != 0 else None

    return {
        "joints": [{"coordinate": fmt(table.q[d.coordinate]), "damping": term(d.damping),
                    "friction": term(d.friction), "stiffness": term(d.stiffness),
                    "rest": (fmt(d.rest) if d.stiffness != 0 else None), "armature": term(d.armature)}
                   for d in drives.joints],
        "kinetic": fmt(drives.kinetic) if drives.kinetic != 0 else None,
        "potential": fmt(drives.potential) if drives.potential != 0 else None,
        "armature": drives.armature != sympy.zeros(*drives.armature.shape),
        "D_g": fmt(q["D_g"]) if "D_g" in q else None,
        "coulomb": any(d.friction != 0 for d in drives.joints),
    }


def _loops(derivation: Derivation, fmt: MathFormatter) -> dict[str, Any]:
    q, model, table = derivation.quantities, derivation.steps["loops"], derivation.symbols
    labels = {"R_g": _named("R", "g"), "M_r": _named("M", "r"), "C_r": _named("C", "r"), "N_r": _named("N", "r"),
              "Y_r": sub("\u03a5", _upright("r"))}
    reduced = {key: fmt.matrix(key.split("_")[0] if key != "Y_r" else "\u03a5", q[key], label) if key in q else None
               for key, label in labels.items()}
    return {
        "joints": [lp.name for lp in derivation.robot.loops],
        "count": q["a_g"].shape[0], "rank": model.rank, "mobility": model.mobility,
        "rows": [f"{name}: {what}" for name, what in model.rows],
        "a_g": fmt.matrix("a", q["a_g"], mrow(_named("a", "g"), fenced(_named("q", "g")))),
        "A_g": fmt.matrix("A", q["A_g"], _named("A", "g")),
        "Adot_g": fmt.matrix(_dot("A"), q["Adot_g"], sub(_dot("A"), _upright("g"))),
        "multipliers": fmt(q["lambda_g"]),
        "independent": fmt(sympy.Matrix([table.q[i] for i in model.independent])),
        "dependent": fmt(sympy.Matrix([table.q[i] for i in model.dependent])),
        "assembled": fmt(sympy.Matrix([sympy.Float(x, 4) for x in model.assembled])) if model.assembled else None,
        "notes": [n.split(": note: ", 1)[-1] for n in model.notes],
        **reduced,
    }


def _dot(letter: str) -> Markup:
    from .html_math import accent

    return accent(letter, "\u02d9")


def _frames(derivation: Derivation, fmt: MathFormatter) -> list[dict[str, Any]]:
    q, planar = derivation.quantities, derivation.robot.planar
    items = []
    for frame in derivation.robot.frames:
        name = frame.name
        label = _upright(name)
        item: dict[str, Any] = {"name": name, "link": frame.link, "symbolic": f"J_{name}" in q}
        if item["symbolic"]:
            item |= {
                "position": fmt.matrix(sub("p", label), q[f"p_{name}"]),
                "angle": fmt(q[f"theta_{name}"][0, 0]) if planar else None,
                "theta": sub("\u03b8", label),
                "rotation": None if planar else fmt.matrix(sub("R", label), q[f"R_{name}"]),
                "jacobian": fmt.matrix(sub("J", label), q[f"J_{name}"]),
                "jacobian_dot": fmt.matrix(sub(_dot("J"), label), q[f"Jdot_{name}"]) if planar else None,
            }
        items.append(item)
    return items


def _maximal(derivation: Derivation, fmt: MathFormatter) -> dict[str, Any]:
    q, steps, table = derivation.quantities, derivation.steps["maximal"], derivation.symbols
    lagrange = [{"coordinate": fmt(c), "velocity": fmt(table.qmd[i]),
                 "dL_dqd": fmt(steps["lagrange"]["dL_dqd"][i]), "ddt_dL_dqd": fmt(steps["lagrange"]["ddt_dL_dqd"][i]),
                 "dL_dq": fmt(steps["lagrange"]["dL_dq"][i]), "equation": fmt(q["EOM_m1"][i])}
                for i, c in enumerate(table.qm)]
    lambda_entries = None
    latex = Formatter.of(derivation, digits=fmt.digits)
    if "lambdaVec" in q and max(len(latex(e)) for e in q["lambdaVec"]) <= LONGEST_LAMBDA:
        lambda_entries = [fmt(e) for e in q["lambdaVec"]]
    tilde = {}
    if "EOM_g3" in q:
        marks = {"M_tilde": "M", "C_tilde": "C", "N_tilde": "N", "Y_tilde": "\u03a5"}
        tilde = {key: fmt.matrix(_tilde(letter), steps[key]) for key, letter in marks.items()}
        tilde["F_tilde"] = fmt.matrix(_tilde("F"), steps["F_tilde"]) if "F_m" in q else None
        tilde["Hdot"] = fmt.matrix(_dot("H"), steps["Hdot"])
        tilde["EOM_g3"] = fmt.matrix("EOM", q["EOM_g3"], _named("EOM", "g3"))
    else:
        tilde["EOM_g3"] = None
    return {
        "q_m": fmt(q["q_m"]), "qd_m": fmt(sympy.Matrix(table.qmd)), "lambda": fmt(sympy.Matrix(table.multipliers)),
        "constraint_count": q["a_m"].shape[0], "constraints_from_file": steps["constraint_origin"] == "override",
        "a_m": fmt.matrix("a", q["a_m"], mrow(_named("a", "m"), fenced(_named("q", "m")))),
        "A_m": fmt.matrix("A", q["A_m"], _named("A", "m")),
        "Adot_m": fmt.matrix(_dot("A"), q["Adot_m"], sub(_dot("A"), _upright("m"))),
        "T_m": fmt(q["T_m"]), "V_m": fmt(q["V_m"]), "L_m": fmt(q["L_m"]),
        "Y_m": fmt.matrix("\u03a5", q["Y_m"], sub("\u03a5", _upright("m"))),
        "lagrange": lagrange,
        "jacobians": [fmt.matrix(fenced(body_jacobian(k)), j, body_jacobian(k)) for k, j in enumerate(steps["jacobians"], 1)],
        "M_m": fmt.matrix("M", q["M_m"], _named("M", "m")), "C_m": fmt.matrix("C", q["C_m"], _named("C", "m")),
        "N_m": fmt.matrix("N", q["N_m"], _named("N", "m")),
        "EOM_m1": fmt.matrix("EOM", q["EOM_m1"], _named("EOM", "m1")),
        "EOM_m2": fmt.matrix("EOM", q["EOM_m2"], _named("EOM", "m2")),
        "lambda_symbolic": "lambdaVec" in q, "lambda_entries": lambda_entries,
        "h": fmt.matrix("h", q["h"], mrow(mi("h"), fenced(_named("q", "g")))),
        "H": fmt.matrix("H", q["H"], mrow(mi("H"), fenced(_named("q", "g")))),
        "F_m": fmt.matrix("F", q["F_m"], _named("F", "m")) if "F_m" in q else None,
        "D_m": fmt.maybe(q["D_m"]) if "D_m" in q else None,
        "drives": not derivation.steps["generalized"]["drives"].empty,
        **tilde,
    }


def _tilde(letter: str) -> Markup:
    from .html_math import accent

    return accent(letter, "~")


def render_html(derivation: Derivation, template_dir: str | Path | None = None,
                sections: tuple[str, ...] | None = None, digits: int | None = None) -> str:
    """The HTML sheet of ``sections`` (default: the LaTeX sheet's ``default_sections``), numbers
    to ``digits`` significant digits at most (default: as the robot file wrote them). A robot
    with quaternion joints gets the quasi-velocity page (``html_quasi_velocity``)."""
    if derivation.robot.floating:
        from .html_quasi_velocity import quasi_velocity_html_context

        return render("html", HTML_TEMPLATE, quasi_velocity_html_context(derivation, digits), template_dir)
    return render("html", HTML_TEMPLATE, html_context(derivation, sections, digits), template_dir)
