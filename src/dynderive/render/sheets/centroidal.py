"""The sheets' section "Centre of mass and centroidal momentum" (3-D robots): for a small
robot the steps of ``mechanics/centroidal_steps.py`` (each moving link's centre of mass and
its Jacobians, ``p_G``, ``J_G``, ``A_G`` column by column), for a large one the names of the
generated functions that compute them. The LaTeX sheet (``LatexNames``) and the HTML page
(``HtmlNames``) show the same content, each in its own notation."""

from __future__ import annotations

from typing import Any

import sympy

from ...derivation import Derivation
from ..encode import escape_tex
from .html_math import accent, mi, mo, mrow, sub


class LatexNames:
    """The section's matrices in LaTeX: ``label`` is the symbol the template writes before
    ``=``, and the name of the entries when the matrix is set entry by entry."""

    text = staticmethod(escape_tex)

    def __init__(self, fmt: Any):
        self.fmt = fmt

    def label(self, kind: str, index: Any, barred: bool) -> str:
        bar = (lambda s: rf"\bar{{{s}}}") if barred else (lambda s: s)
        letters = {"p": bar("p"), "Jv": bar("J") + r"_{v,", "Jw": bar("J") + r"_{\omega,",
                   "p_G": bar("p") + "_{G}", "J_G": bar("J") + "_{G}", "R_B": "R_{B}", "p_B": "p_{B}"}
        if kind == "p":
            return letters["p"] + f"_{{{index}}}"
        if kind in ("Jv", "Jw"):
            return letters[kind] + f"{index}}}"
        if kind == "A_G":
            return rf"\left({bar('A')}_{{G}}\right)_{{\omega,{index}}}"
        return letters[kind]

    def matrix(self, kind: str, index: Any, barred: bool, value: sympy.Matrix) -> dict[str, Any]:
        label = self.label(kind, index, barred)
        return self.fmt.matrix(label, value) | {"symbol": label}

    def scalar(self, value: sympy.Expr) -> Any:
        return self.fmt(value)


class HtmlNames(LatexNames):
    """The same matrices in MathML: ``label`` the name in front, ``symbol`` too."""

    text = staticmethod(str)

    def label(self, kind: str, index: Any, barred: bool) -> Any:
        bar = (lambda s: accent(s, "\u00af")) if barred else (lambda s: mi(s))
        if kind == "p":
            return sub(bar("p"), str(index))
        if kind in ("Jv", "Jw"):
            return sub(bar("J"), mrow(mi("v" if kind == "Jv" else "\u03c9"), mo(","), str(index)))
        if kind == "A_G":
            return sub(mrow(mo("("), sub(bar("A"), "G"), mo(")")), mrow(mi("\u03c9"), mo(","), str(index)))
        if kind in ("R_B", "p_B"):
            return sub(kind[0], "B")
        return sub(bar(kind[0]), "G")

    def matrix(self, kind: str, index: Any, barred: bool, value: sympy.Matrix) -> dict[str, Any]:
        label = self.label(kind, index, barred)
        return self.fmt.matrix(label, value, label) | {"symbol": label}


def centroidal_context(derivation: Derivation, names: LatexNames) -> dict[str, Any] | None:
    """The section's content (None: a planar robot, which has none). ``symbolic`` False: a
    robot too large for the steps (the generated functions compute them)."""
    robot = derivation.robot
    if robot.planar:
        return None
    steps = derivation.centroidal_steps
    if steps is None:
        return {"symbolic": False, "loops": bool(robot.loops)}
    barred = steps.base is not None
    velocities = derivation.symbols.qd
    return {
        "symbolic": True,
        "mass": names.scalar(steps.mass),
        "links": [{"index": part.index, "name": names.text(part.name), "mass": names.scalar(part.mass),
                   "position": names.matrix("p", part.index, barred, part.position),
                   "linear": names.matrix("Jv", part.index, barred, part.linear),
                   "angular": names.matrix("Jw", part.index, barred, part.angular)} for part in steps.links],
        "com": names.matrix("p_G", None, barred, steps.com),
        "jacobian": names.matrix("J_G", None, barred, steps.jacobian),
        "columns": [{"index": k, "velocity": names.scalar(velocities[k - 1]),
                     "matrix": names.matrix("A_G", k, barred, steps.matrix[3:, k - 1])}
                    for k in range(1, steps.matrix.cols + 1)],
        "base": ({"rotation": names.matrix("R_B", None, False, steps.base[0]),
                  "position": names.matrix("p_B", None, False, steps.base[1])} if barred else None),
    }
