"""The HTML page's quasi-velocity content, what ``render_html`` gives a robot with quaternion
joints: the LaTeX sheet's quasi-velocity sections (``quasi_velocity``: a small robot's
equations step by step in quasi-velocities, a large one's as the module's programs line by
line) as one self-contained page, rendered as the other robots' page is (``html``): MathML
from the same SymPy quantities (``html_math``), the sheet's names for the quaternion joints'
entries (``x, y, z, q_x .. q_w``, ``v_x .. omega_z``), the programs' lines named ``w_k``, text
from the robot file escaped by the HTML environment. No drawing: the 3-D kinematic diagram
(``figure_3d``) is not drawn for such a robot, as on the LaTeX sheet.
"""

from __future__ import annotations

from typing import Any

import sympy
from markupsafe import Markup

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from .html_math import (
    MathFormatter,
    _atom,
    accent,
    mi,
    mn,
    mo,
    mrow,
    page_header,
    sub,
)
from .latex_format import entry_index
from .quasi_velocity import (
    ENTRY_LIMIT,
    dissipative_forces,
    multi_joint,
    program_listing,
)


def _matrix(fmt: MathFormatter, letter: Any, index: int | None, matrix: sympy.Matrix,
            label: Markup | None = None) -> dict[str, Any]:
    """``MathFormatter.matrix`` of ``letter`` (with the link's ``index``, entries named as the
    LaTeX sheet's: ``I_{1,23}``), ``label`` in front of the whole matrix (default the name),
    with the entries the LaTeX sheet leaves out (over ``quasi_velocity.ENTRY_LIMIT`` nodes) left
    out here too: their ``math`` None (the page says they are too long and in the JSON dump)."""
    name = _atom(letter) if index is None else sub(letter, str(index))
    fits = [is_small(e, ENTRY_LIMIT) for e in matrix if e != 0]   # row by row, as the entries
    shown = fmt.matrix(name, matrix.applyfunc(lambda e: e if is_small(e, ENTRY_LIMIT) else sympy.Integer(1)),
                       label if label is not None else name)
    rows, cols = matrix.shape
    places = [(i, j) for i in range(rows) for j in range(cols) if matrix[i, j] != 0]
    for entry, (i, j) in zip(shown["entries"], places):
        at = mn(entry_index(i, j, rows, cols).replace(",", "\u2009"))
        entry["name"] = sub(letter, at if index is None else mrow(str(index), mo(","), at))
    if not all(fits) and not shown["too_large"]:
        shown["wide"], shown["math"] = True, None
        for entry, small in zip(shown["entries"], fits):
            if not small:
                entry["math"] = None
    return shown


def quasi_velocity_html_context(derivation: Derivation, digits: int | None = None) -> dict[str, Any]:
    """Every variable ``html/sheet.html.j2`` uses for a robot with quaternion joints: the LaTeX
    sheet's (``quasi_velocity.quasi_velocity_context``) in MathML; names and free text as written
    (the environment escapes them)."""
    robot, table = derivation.robot, derivation.symbols
    steps = derivation.quasi_velocity_steps
    small = steps.sheet is not None
    groups, outputs = ([], {}) if small else program_listing(derivation)
    lines = tuple(name for _, group in groups for name, _ in group)
    fmt = MathFormatter.of(derivation, digits=digits, lines=lines)
    where_q, where_v = robot.offsets()

    def listed(symbols: list[sympy.Symbol]) -> Markup | None:
        return Markup("<mo>,</mo>").join(fmt(s) for s in symbols) if symbols else None

    joints = []
    for j in robot.joints:
        size = {"floating": (7, 6), "spherical": (4, 3)}.get(j.type, (1, 1)) if j.moves else (0, 0)
        qi, vi = where_q.get(j.name, 0), where_v.get(j.name, 0)
        joints.append({"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                       "variables": [listed(table.q[qi:qi + size[0]]), listed(table.qd[vi:vi + size[1]])],
                       "effort": listed([table.efforts[n] for n in j.effort_names])})
    gravity = sympy.Matrix([table.expr(e) for e in robot.gravity])
    context = page_header(derivation, fmt, gravity, joints) | {
        "nq": len(table.q), "nv": len(table.qd), "small": small,
        "q": fmt(sympy.Matrix(table.q)), "v": fmt(sympy.Matrix(table.qd)), "vdot": fmt(sympy.Matrix(table.qdd)),
        "floating_base": robot.floating_base,
        "multi": [multi_joint(j, fmt, table, where_q, where_v, steps.rotations[j.name], str, None)
                  for j in robot.joints if j.multi],
        "Y": fmt(sympy.Matrix(steps.efforts)),
        "F": fmt(dissipative_forces(derivation)) if robot.dissipative else None,
        "actuated_multi": any(j.multi and j.effort for j in robot.joints),
        "figure": None, "quasi_velocity": True,
    }
    if small:
        context |= _small_context(steps.sheet, fmt)
    else:
        context |= _large_context(groups, outputs, fmt, len(table.qd))
    return context


def _small_context(sheet: Any, fmt: MathFormatter) -> dict[str, Any]:
    cal_v = mi("\U0001d4b1")   # script V: a link's twist
    links = []
    for item in sheet.links:
        k = item.index
        gravity = mrow(mo("("), Markup(f"<msubsup><mi>R</mi><mn>{k}</mn><mi>T</mi></msubsup>"),
                       Markup('<mover><mi>g</mi><mo>&#x2192;</mo></mover>'), mo(")"))
        links.append({
            "index": item.index, "name": item.name, "mass": fmt(item.mass), "com": fmt(item.com),
            "inertia": _matrix(fmt, "I", k, item.inertia),
            "rotation": _matrix(fmt, "R", k, item.rotation),
            "position": _matrix(fmt, "p", k, item.com_position),
            "jacobian": _matrix(fmt, "J", k, item.jacobian),
            "jacobian_dot": _matrix(fmt, accent("J", "\u02d9"), k, item.jacobian_dot)
            if item.jacobian_dot != sympy.zeros(*item.jacobian_dot.shape) else None,
            "twist": _matrix(fmt, cal_v, k, item.twist, mrow(sub(cal_v, k), mo("="), sub("J", k), mi("v"))),
            "gravity": _matrix(fmt, gravity, None, item.gravity),
            "kinetic": fmt.maybe(item.kinetic, ENTRY_LIMIT), "potential": fmt.maybe(item.potential, ENTRY_LIMIT),
        })
    return {
        "links": links, "single": len(sheet.links) == 1,
        "rate": _matrix(fmt, "Q", None, sheet.rate),
        "T": fmt.maybe(sheet.T, ENTRY_LIMIT), "V": fmt.maybe(sheet.V, ENTRY_LIMIT),
        "M": _matrix(fmt, "M", None, sheet.M), "N": _matrix(fmt, "N", None, sheet.N),
        "Cv": _matrix(fmt, mrow(mo("("), mi("C"), mi("v"), mo(")")), None, sheet.Cv),
        "C": _matrix(fmt, "C", None, sheet.C), "EOM": _matrix(fmt, mi("EOM", normal=True), None, sheet.EOM),
    }


def _large_context(groups: list[tuple[str, list[tuple[sympy.Symbol, sympy.Expr]]]], outputs: dict[str, list[sympy.Expr]],
                   fmt: MathFormatter, nv: int) -> dict[str, Any]:
    titles = {"shared": "The links' transforms and inertias", "tau": "Newton\u2013Euler",
              "M": "Composite rigid bodies", "N": "Gravity (Newton\u2013Euler at rest)"}
    return {
        "groups": [{"title": titles[key], "key": key, "lines": [{"name": fmt(n), "math": fmt(v)} for n, v in lines]}
                   for key, lines in groups],
        "line_count": sum(len(lines) for _, lines in groups),
        "tau": [{"name": sub("\u03c4", str(i + 1)), "math": fmt(e)} for i, e in enumerate(outputs["tau"])],
        "N": [{"name": sub("N", str(i + 1)), "math": fmt(e)} for i, e in enumerate(outputs["N"])],
        "M": [{"name": sub("M", mrow(str(i + 1), mo(","), str(j + 1))), "math": fmt(outputs["M"][i * nv + j])}
              for i in range(nv) for j in range(i, nv) if outputs["M"][i * nv + j] != 0],
    }
