"""The HTML page's quasi-velocity content, what ``render_html`` gives a robot with quaternion
joints: the LaTeX sheet's quasi-velocity sections (``quasi_velocity``: the same content and
names) written in MathML by ``HtmlStyle``. No drawing, as on the LaTeX sheet.
"""

from __future__ import annotations

import math
from typing import Any

import sympy
from markupsafe import Markup

from ...derivation import Derivation
from .centroidal import HtmlNames
from .html_math import MathFormatter, _atom, accent, mi, mn, mo, mrow, page_header, sub
from .latex_format import entry_index
from .quasi_velocity import ENTRY_LIMIT, LatexStyle, quasi_velocity_context

_TWIST = mi("\U0001d4b1")   # script V: a link's twist


class HtmlStyle(LatexStyle):
    """The quasi-velocity content in MathML; names and free text as written (the environment
    escapes them)."""

    dash = "\u2013"
    absent = None
    text_key, longest = "math", math.inf   # no limit on the MathML of an entry
    name = staticmethod(str)

    def formatter(self, derivation: Derivation, digits: int | None, groups: list[Any]) -> MathFormatter:
        return MathFormatter.of(derivation, digits=digits, lines=tuple(n for _, group in groups for n, _ in group))

    def opening(self, derivation: Derivation, fmt: Any, gravity: sympy.Matrix, joints: list[Any]) -> dict[str, Any]:
        return page_header(derivation, fmt, gravity, joints)

    def listed(self, fmt: Any, symbols: list[sympy.Symbol]) -> Markup | None:
        return Markup("<mo>,</mo>").join(fmt(s) for s in symbols) if symbols else None

    def shown(self, fmt: Any, key: str, index: int | None, matrix: sympy.Matrix) -> dict[str, Any]:
        """``MathFormatter.matrix`` named as the LaTeX sheet's (entries ``I_{1,23}``), a label in
        front of the twist."""
        letter, label = self._letter(key, index), None
        if key == "gravity":
            index = None
        if key == "twist":
            label = mrow(sub(_TWIST, index), mo("="), sub("J", index), mi("v"))
        name = _atom(letter) if index is None else sub(letter, str(index))
        shown = fmt.matrix(name, matrix, label if label is not None else name)
        rows, cols = matrix.shape
        places = [(i, j) for i in range(rows) for j in range(cols) if matrix[i, j] != 0]
        for entry, (i, j) in zip(shown["entries"], places):
            at = mn(entry_index(i, j, rows, cols).replace(",", "\u2009"))
            entry["name"] = sub(letter, at if index is None else mrow(str(index), mo(","), at))
        return shown

    @staticmethod
    def _letter(key: str, index: int | None) -> Any:
        if key == "gravity":
            return mrow(mo("("), Markup(f"<msubsup><mi>R</mi><mn>{index}</mn><mi>T</mi></msubsup>"),
                        Markup('<mover><mi>g</mi><mo>&#x2192;</mo></mover>'), mo(")"))
        return {"inertia": "I", "rotation": "R", "position": "p", "jacobian": "J", "jacobian_dot": accent("J", "\u02d9"),
                "twist": _TWIST, "rate": "Q", "Cv": mrow(mo("("), mi("C"), mi("v"), mo(")")),
                "EOM": mi("EOM", normal=True)}.get(key, key)

    def scalar(self, fmt: Any, expr: sympy.Expr) -> Any:
        return fmt.maybe(expr, ENTRY_LIMIT)

    def centroidal_names(self, fmt: Any) -> HtmlNames:
        return HtmlNames(fmt)

    def line(self, fmt: Any, name: sympy.Symbol, value: sympy.Expr) -> dict[str, Any]:
        return {"name": fmt(name), "math": fmt(value)}

    def output(self, fmt: Any, key: str, value: sympy.Expr, row: int, column: int | None = None) -> Any:
        at = str(row) if column is None else mrow(str(row), mo(","), str(column))
        return {"name": sub("\u03c4" if key == "tau" else key, at), "math": fmt(value)}


def quasi_velocity_html_context(derivation: Derivation, digits: int | None = None) -> dict[str, Any]:
    """Every variable ``html/sheet.html.j2`` uses for a robot with quaternion joints: the LaTeX
    sheet's (``quasi_velocity.quasi_velocity_context``) in MathML."""
    return quasi_velocity_context(derivation, digits, HtmlStyle())
