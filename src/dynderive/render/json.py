"""The JSON dump of every derived quantity (DESIGN.md section 5).

``{"robot": NAME, "quantities": {NAME: {"shape": [r, c], "sympy": STR, "latex": STR}}}``.
Scalars have shape ``[1, 1]`` and a bare expression as ``sympy``; matrices print as
``Matrix([[...]])``. ``latex`` is null for entries too large to typeset. Every ``sympy`` string parses back with
``sympy.sympify(text, locals={name: sympy.Symbol(name) for name in ...})``.
"""

from __future__ import annotations

import json

import sympy

from ..derivation import DESCRIPTIONS, Derivation
from ..tidy import is_small
from .latex import Formatter

#: Quantities larger than this (tree nodes per entry, on average) get ``"latex": null``: their
#: LaTeX would run to pages per entry and costs most of the JSON's time (30 s for the UR5's C_g).
LATEX_NODES = 2000


def _text(expr: sympy.Expr) -> str:
    """``sstr`` with terms in lexicographic order; entries too large to typeset keep SymPy's own
    (canonical, deterministic) argument order instead, which prints 2-3x faster (a 7-DOF
    arm's C_g: minutes otherwise)."""
    return sympy.sstr(expr, order="lex" if is_small(expr, LATEX_NODES) else "none")


def quantity_entry(value: object, fmt: Formatter, description: str = "") -> dict[str, object]:
    if isinstance(value, sympy.MatrixBase):
        shape = [int(value.shape[0]), int(value.shape[1])]
        text = "Matrix([" + ", ".join(
            "[" + ", ".join(_text(value[i, j]) for j in range(value.shape[1])) + "]"
            for i in range(value.shape[0])) + "])"
    else:
        shape = [1, 1]
        text = _text(value)
    # LaTeX of very large quantities (3-D arms' C_g) takes minutes and nobody reads it.
    latex = fmt.maybe(value, LATEX_NODES)
    entry: dict[str, object] = {"shape": shape, "sympy": text, "latex": latex}
    if description:
        entry["description"] = description
    return entry


def render_json(derivation: Derivation) -> str:
    fmt = Formatter(derivation)
    quantities = {name: quantity_entry(value, fmt, DESCRIPTIONS.get(name, ""))
                  for name, value in derivation.quantities.items()}
    document = {
        "robot": derivation.robot.name,
        "coordinates": list(derivation.robot.coordinates),
        "efforts": list(derivation.robot.efforts),
        "parameters": {p.name: p.value for p in derivation.robot.parameters},
        "quantities": quantities,
        "checks": [{"name": c.name, "description": c.description, "passed": c.passed,
                    "method": c.method, "residual": c.residual} for c in derivation.checks],
    }
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"
