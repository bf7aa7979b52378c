"""The JSON dump of every derived quantity (DESIGN.md section 5).

``{"robot": NAME, "quantities": {NAME: {"shape": [r, c], "sympy": STR, "latex": STR}}}``.
Scalars have shape ``[1, 1]`` and a bare expression as ``sympy``; matrices print as
``Matrix([[...]])``. ``latex`` is null for entries too large to typeset. Every ``sympy`` string parses back with
``sympy.sympify(text, locals={name: sympy.Symbol(name) for name in ...})``.

Large robots (``Derivation.intermediate_form``) add ``"intermediates": {NAME: {"shape",
"sympy", "latex"}}``: the sub-expressions ``_w1, _w2, ...`` their quantities are written in,
in order, each over coordinates, parameters and earlier names (substitute them in reverse
order to expand a quantity).
"""

from __future__ import annotations

import json
from typing import Any

import sympy

from ...derivation import Derivation
from ...mechanics.tidy import is_small
from .latex import Formatter
from ..printers import RememberingStrPrinter

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
    entry: dict[str, object] = {"shape": shape, "sympy": text, "latex": latex}
    if description:
        entry["description"] = description
    return entry


def _loops_entry(derivation: Derivation) -> dict[str, Any]:
    """Size of a closed chain: constraint rows, their rank (the independent constraints), the
    coordinates kept independent and the default assembly."""
    model = derivation.steps["loops"]
    return {"constraint_rows": model.constraints.shape[0], "independent_constraints": model.rank,
            "independent_coordinates": [derivation.robot.coordinates[i] for i in model.independent],
            "assembled_configuration": model.assembled}


def render_json(derivation: Derivation) -> str:
    fmt = Formatter.of(derivation, exact=True)   # the JSON keeps SymPy's exact numbers
    printer = RememberingStrPrinter({"order": fmt.order or "lex"})
    quantities = {name: quantity_entry(value, fmt, derivation.description(name), printer)
                  for name, value in derivation.quantities.items()}
    document = {
        "robot": derivation.robot.name,
        "coordinates": list(derivation.robot.coordinates),
        "efforts": list(derivation.robot.efforts),
        "parameters": {p.name: p.value for p in derivation.robot.parameters},
        "degrees_of_freedom": derivation.mobility,
        **({"loops": _loops_entry(derivation)} if derivation.robot.loops else {}),
        "quantities": quantities,
        **({"intermediates": {str(name): quantity_entry(value, fmt, printer=printer)
                              for name, value in derivation.intermediates}}
           if derivation.intermediate_form else {}),
        "checks": [{"name": c.name, "description": c.description, "passed": c.passed,
                    "method": c.method, "residual": c.residual} for c in derivation.checks],
    }
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"
