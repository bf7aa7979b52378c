"""The JSON dump of every derived quantity (DESIGN.md section 5).

``{"robot": NAME, "quantities": {NAME: {"shape": [r, c], "sympy": STR, "latex": STR}}}``.
Scalars have shape ``[1, 1]`` and a bare expression as ``sympy``; matrices print as
``Matrix([[...]])``. ``latex`` is null for entries too large to typeset. Every ``sympy`` string parses back with
``sympy.sympify(text, locals={name: sympy.Symbol(name) for name in ...})``.

Large robots (``Derivation.intermediate_form``) add ``"intermediates": {NAME: {"shape",
"sympy", "latex"}}``: the sub-expressions ``_w1, _w2, ...`` their quantities are written in,
in order, each over coordinates, parameters and earlier names (substitute them in reverse
order to expand a quantity).

A robot with quaternion joints (a floating base, spherical joints) gets the same layout and
names where they apply, in quasi-velocities.

``NQ`` and ``NV``, ``coordinates`` (NQ names), ``velocities`` and ``accelerations`` (NV names)
join the fixed-base keys. A small robot's ``quantities`` (``mechanics/quasi_velocity.py``):
``T_g``, ``V_g``, ``Y_g``, ``M_g``, ``C_g`` (Pinocchio's Coriolis matrix), ``N_g`` (gravity
and springs: not ``dV/dq``, the velocities being quasi-velocities), ``EOM_g2``
(``M vdot + C v + N - Y``), ``Q_g`` (``qdot = Q_g v``), the body Jacobians ``J_b1, ...`` and
the centre of mass's ``m_total``, ``p_G``, ``J_G``, ``A_G`` (``mechanics/centroidal_steps.py``:
world axes, per quasi-velocity; a fixed-base 3-D robot has them among its quantities too).
A large robot's (the sheet's intermediate-variable form) ``M_g``, ``N_g`` and ``EOM_g2`` over
``intermediates`` ``_w1, _w2, ...``, the lines of the module's programs. No Lagrange's
equations (``EOM_g1``, ``L_g``) and no checks: the quaternion is not a generalized coordinate
of Lagrange's path (``dynderive check`` runs the module's checks).
"""

from __future__ import annotations

import json
from typing import Any

import sympy

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from ...model.naming import CENTROIDAL_QUANTITIES
from ..printers import RememberingStrPrinter
from .latex_format import Formatter
from .quasi_velocity import _names_of, dissipative_forces, listing

#: Quantities larger than this (tree nodes per entry, on average) get ``"latex": null``: their
#: LaTeX would run to pages per entry and costs most of the JSON's time (30 s for the UR5's C_g).
LATEX_NODES = 2000


def _text(expr: sympy.Expr, printer: RememberingStrPrinter) -> str:
    """``sstr`` with terms in ``printer``'s order (lexicographic; a large robot's: SymPy's own
    order, like its LaTeX); entries too large to typeset get the plain printing of ``_plain``
    (a 7-DOF arm's C_g: minutes with ``sstr``, seconds so)."""
    return printer.doprint(expr) if is_small(expr, LATEX_NODES) else _plain(expr)


def _plain(expr: sympy.Expr) -> str:
    """SymPy's own (canonical, deterministic) argument order, every sum inside a product or
    power in parentheses, every number that is negative or a fraction in parentheses: no
    precedence rules to apply, so it prints fast; ``sympify`` reads it back to ``expr``."""
    memo: dict[int, str] = {}

    def text(e: sympy.Basic) -> str:
        key = id(e)
        if key in memo:
            return memo[key]
        if e.is_Symbol:
            out = e.name
        elif e.is_Integer:
            out = str(e.p) if e.p >= 0 else f"({e.p})"
        elif e.is_Rational:
            out = f"({e.p}/{e.q})"
        elif e.is_Number:
            out = f"({sympy.sstr(e)})"
        elif e.is_Add:
            out = " + ".join(text(a) for a in e.args)
        elif e.is_Mul:
            out = "*".join(f"({text(a)})" if a.is_Add else text(a) for a in e.args)
        elif e.is_Pow:
            base, exp = e.args
            out = f"({text(base)})**{text(exp)}" if not (base.is_Symbol or base.is_Function) else f"{text(base)}**{text(exp)}"
        elif e.is_Function:
            out = f"{type(e).__name__}({', '.join(text(a) for a in e.args)})"
        else:
            out = sympy.sstr(e)
        memo[key] = out
        return out

    return text(expr)


def quantity_entry(value: object, fmt: Formatter, description: str = "",
                   printer: RememberingStrPrinter | None = None) -> dict[str, object]:
    printer = printer or RememberingStrPrinter({"order": fmt.order or "lex"})
    if isinstance(value, sympy.MatrixBase):
        shape = [int(value.shape[0]), int(value.shape[1])]
        text = "Matrix([" + ", ".join(
            "[" + ", ".join(_text(value[i, j], printer) for j in range(value.shape[1])) + "]"
            for i in range(value.shape[0])) + "])"
    else:
        shape = [1, 1]
        text = _text(value, printer)
    # LaTeX of very large quantities (3-D arms' C_g) takes minutes and nobody reads it.
    latex = fmt.maybe(value, LATEX_NODES)
    described = {"description": description} if description else {}
    return {"shape": shape, "sympy": text, "latex": latex} | described


def _loops_entry(derivation: Derivation) -> dict[str, Any]:
    """Size of a closed chain: constraint rows, their rank (the independent constraints), the
    coordinates kept independent and the default assembly."""
    if derivation.robot.floating:   # rows on the tree's twists: their rank is the module's, per state
        rows = derivation.loop_programs.rows
        return {"constraint_rows": len(rows), "rows": [list(row) for row in rows]}
    model = derivation.loop_model
    return {"constraint_rows": model.constraints.shape[0], "independent_constraints": model.rank,
            "independent_coordinates": [derivation.robot.coordinates[i] for i in model.independent],
            "assembled_configuration": model.assembled}


DESCRIPTIONS = {
    "T_g": "kinetic energy 1/2 v^T M v",
    "V_g": "potential energy (gravity and springs)",
    "Y_g": "applied generalized forces (each effort at its velocity column)",
    "M_g": "mass matrix in the velocity coordinates v (NV x NV)",
    "C_g": "Coriolis matrix (Pinocchio's computeCoriolisMatrix; Mdot - 2 C skew-symmetric)",
    "N_g": "generalized gravity and spring forces (NV)",
    "EOM_g2": "equations of motion M vdot + C v + N + F - Y (= 0)",
    "F_g": "dissipative forces b v + fc sign(v) of the joints' damping and Coulomb friction (NV)",
    "Q_g": "configuration rate: qdot = Q_g v (NQ x NV)",
}


def render_json(derivation: Derivation) -> str:
    """The dump of every quantity; a robot with quaternion joints: its quasi-velocity
    quantities (``_quasi_velocity``)."""
    robot = derivation.robot
    if robot.floating:
        head, quantities, intermediates, degrees = _quasi_velocity(derivation)
        if robot.loops:   # the loops' rank (so the mobility) is found per state by the generated module
            degrees = None
        checks: list[dict[str, Any]] = []
    else:
        fmt = Formatter.of(derivation, exact=True)   # the JSON keeps SymPy's exact numbers
        printer = RememberingStrPrinter({"order": fmt.order or "lex"})
        head = {"coordinates": list(robot.coordinates)}
        quantities = {name: quantity_entry(value, fmt, derivation.description(name), printer)
                      for name, value in derivation.quantities.items()}
        intermediates = ({str(name): quantity_entry(value, fmt, printer=printer) for name, value in derivation.intermediates}
                         if derivation.intermediate_form else {})
        degrees = derivation.mobility
        checks = [{"name": c.name, "description": c.description, "passed": c.passed,
                   "method": c.method, "residual": c.residual} for c in derivation.checks]
    document = {
        "robot": robot.name,
        **head,
        "efforts": list(robot.efforts),
        "parameters": {p.name: p.value for p in robot.parameters},
        "degrees_of_freedom": degrees,
        **({"loops": _loops_entry(derivation)} if robot.loops else {}),
        "quantities": quantities,
        **({"intermediates": intermediates} if intermediates else {}),
        "checks": checks,
    }
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"


def _quasi_velocity(derivation: Derivation) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any], int]:
    """A robot with quaternion joints: the dump's head (``floating``, ``NQ``, ``NV``, the names,
    the joints), quantities, intermediates and degrees of freedom."""
    robot, table = derivation.robot, derivation.symbols
    steps, groups, outputs = listing(derivation)
    fmt = Formatter.of(derivation, exact=True, lines=_names_of(groups))
    printer = RememberingStrPrinter({"order": fmt.order or "lex"})
    nv = len(table.qd)
    if (sheet := steps.sheet) is not None:
        values: dict[str, object] = {"T_g": sheet.T, "V_g": sheet.V, "Y_g": sheet.Y, "M_g": sheet.M, "C_g": sheet.C,
                                     "N_g": sheet.N, "EOM_g2": sheet.EOM, "Q_g": sheet.rate}
        values |= {f"J_b{link.index}": link.jacobian for link in sheet.links}
    else:
        Y = sympy.Matrix(steps.efforts)
        values = {"Y_g": Y, "M_g": sympy.Matrix(nv, nv, outputs["M"]), "N_g": sympy.Matrix(outputs["N"]),
                  "EOM_g2": sympy.Matrix(outputs["tau"]) + dissipative_forces(derivation) - Y}
    if robot.dissipative:
        values["F_g"] = dissipative_forces(derivation)
    if (centroidal := derivation.centroidal_steps) is not None:
        values |= centroidal.quantities()

    def description(name: str) -> str:
        if name in CENTROIDAL_QUANTITIES:
            return derivation.description(name)
        if name.startswith("J_b"):
            link = robot.links[int(name[3:]) - 1].name
            return (f"body Jacobian of link {name[3:]} ({link}): the twist (v, omega) of its centre of mass in "
                    "the link's own axes per velocity coordinate")
        return DESCRIPTIONS[name]

    where_q, where_v = robot.offsets()
    head = {
        "floating": True,
        "NQ": len(table.q),
        "NV": nv,
        "coordinates": [str(s) for s in table.q],
        "velocities": [str(s) for s in table.qd],
        "accelerations": [str(s) for s in table.qdd],
        "joints": {j.name: ({"type": j.type, "q": where_q[j.name], "v": where_v[j.name]} if j.owns else
                            {"type": j.type, "mimic": dict(zip(("joint", "multiplier", "offset"), robot.driver(j)))})
                   for j in robot.joints if j.moves},
    }
    quantities = {name: quantity_entry(value, fmt, description(name), printer) for name, value in values.items()}
    intermediates = {str(name): quantity_entry(value, fmt, printer=printer) for _, lines in groups for name, value in lines}
    return head, quantities, intermediates, nv
