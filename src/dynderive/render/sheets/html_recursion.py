"""A large robot's HTML page as the recursion a reader can follow: the LaTeX sheet's
``recursion.tex.j2`` (``render/recursion.py``) in MathML. The lines, their grouping, the
kinematic data and the names' meanings are ``recursion.recursion_parts`` and
``recursion.named_lines``; here each name is a MathML fragment (``\\omega_{3x}`` is an omega
with the subscript 3x, a bar an accent over it), shown by ``templates/html/recursion.html.j2``.
"""

from __future__ import annotations

import re
from typing import Any

import sympy
from markupsafe import Markup

from ...derivation import Derivation
from .html_math import MathFormatter, Name, accent, mi, mn, mo, mrow, sub
from .recursion import kinematic_table, name_fields, recursion_names, recursion_parts

#: MathML of each quantity (``recursion.NAMES``, ``mechanics.sheet_recursion.MEANINGS``): the letter,
#: a dot over it, a bar over that, the superscript and the subscript (``{i}`` the link's index,
#: ``{j}`` the column's, ``{k}`` the coordinate's, ``{c}`` the component).
MATH_NAMES: dict[str, tuple[str, bool, bool, str, str]] = {
    "R": ("R", False, False, "", "{i},{c}"), "p": ("p", False, False, "", "{i}{c}"),
    "m": ("m", False, False, "", "{i}"), "h": ("h", False, False, "", "{i}{c}"),
    "I": ("I", False, False, "", "{i},{c}"),
    "omega_in": ("\u03c9", False, True, "", "{i}{c}"), "v_in": ("v", False, True, "", "{i}{c}"),
    "alpha_in": ("\u03c9", True, True, "", "{i}{c}"), "a_in": ("a", False, True, "", "{i}{c}"),
    "omega": ("\u03c9", False, False, "", "{i}{c}"), "v": ("v", False, False, "", "{i}{c}"),
    "alpha": ("\u03c9", True, False, "", "{i}{c}"), "a": ("a", False, False, "", "{i}{c}"),
    "k": ("k", False, False, "", "{i}{c}"), "l": ("\u2113", False, False, "", "{i}{c}"),
    "F": ("F", False, False, "", "{i}{c}"), "N": ("N", False, False, "", "{i}{c}"),
    "f_up": ("f", False, True, "", "{i}{c}"), "n_up": ("n", False, True, "", "{i}{c}"),
    "f": ("f", False, False, "", "{i}{c}"), "n": ("n", False, False, "", "{i}{c}"),
    "tau": ("\u03c4", False, False, "", "{k}"), "mc": ("m", False, False, "c", "{i}"),
    "hc": ("h", False, False, "c", "{i}{c}"), "Ic": ("I", False, False, "c", "{i},{c}"),
    "hc_up": ("h", False, True, "c", "{i}{c}"), "IRt": ("U", False, False, "", "{i},{c}"),
    "Fcol": ("f", False, False, "({j})", "{i}{c}"), "Ncol": ("n", False, False, "({j})", "{i}{c}"),
    "M": ("M", False, False, "", "{c}"),
}
#: Between values shown side by side (the LaTeX sheet's ``,\quad``).
SEPARATOR = Markup('<mo>,</mo><mspace width="1em"></mspace>')


def _tokens(text: str) -> Markup:
    """An index's text (``3x``, ``6,xx``, ``(7)``) as MathML: digits numbers, letters
    identifiers, the rest operators."""
    parts = [mn(t) if t.isdigit() else mi(t) if t.isalpha() else mo(t) for t in re.findall(r"\d+|.", text)]
    return parts[0] if len(parts) == 1 else mrow(*parts)


def meaning_markup(quantity: str, fields: dict[str, Any], primes: int = 0) -> Markup:
    """The MathML name of a line meaning ``quantity`` (``recursion.name_fields``), primed."""
    letter, dot, bar, sup, script = MATH_NAMES[quantity]
    base = mi(letter)
    if dot:
        base = accent(base, "\u02d9")
    if bar:
        base = accent(base, "\u00af")
    name = sub(base, _tokens(script.format(**fields)), _tokens(sup.format(**fields)) if sup else None)
    if primes:
        name = Markup(f"<msup>{name}<mo>{chr(0x2032) * primes}</mo></msup>")
    # as SymPy's printer writes it (non-ASCII as character references): the same bytes in a
    # line's name and among values shown as they are
    return Markup(str(name).encode("ascii", "xmlcharrefreplace").decode())


def recursion_math_names(derivation: Derivation) -> dict[sympy.Symbol, Name | Markup]:
    """MathML names of the recursion's program (``recursion.recursion_names`` in MathML)."""
    return recursion_names(derivation, lambda letter, dots, k: (letter, "", dots, k), meaning_markup)


class RecursionMathFormatter(MathFormatter):
    """The page's formatter with the recursion's names (``recursion_math_names``)."""

    def __init__(self, derivation: Derivation, digits: int | None = None):
        super().__init__(derivation, digits=digits, extra_names=recursion_math_names(derivation))


def html_recursion(derivation: Derivation, digits: int | None = None) -> dict[str, Any]:
    """What ``html/recursion.html.j2`` shows: the LaTeX ``recursion.recursion_context`` in
    MathML, names as written (escaped by the template); a block's lines are each a ``name``
    and its ``math`` (``name`` None for values shown as they are, side by side in ``math``)."""
    robot, r, table = derivation.robot, derivation.recursion, derivation.symbols
    fmt, plain = RecursionMathFormatter.of(derivation, digits=digits), MathFormatter.of(derivation, digits=digits)
    parts = recursion_parts(derivation, fmt.width)
    index, n = parts["link_index"], len(robot.coordinates)

    def alias(item: dict[str, Any]) -> Markup:
        name = meaning_markup(item["meaning"].quantity, name_fields(item["meaning"], index, robot, n))
        return Markup(f"{name}<mo>=</mo>{fmt(item['value'])}")

    def line(item: dict[str, Any]) -> dict[str, Any]:
        if item["symbol"] is not None:
            return {"name": fmt(item["symbol"]), "math": fmt(item["value"])}
        return {"name": None, "math": SEPARATOR.join(alias(a) for a in item["aliases"])}

    def html(blocks: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{"link": b["link"], "index": b["index"], "lines": [line(item) for item in b["lines"]],
                 "rotation": None if b["rotation"] is None else
                 Markup(f"{sub('R', mn(b['index']))}<mo>=</mo>{fmt(b['rotation'])}")} for b in blocks]

    def vector(values: list[sympy.Expr]) -> Markup:
        return mrow(mo("("), *[Markup(f"{plain(v)}<mo>,</mo>") for v in values[:-1]], plain(values[-1]), mo(")"))

    shown = {key: html(parts[key]) for key in ("forward", "backward", "composite", "columns")}
    return {
        "links": kinematic_table(parts["links"], robot.planar, plain, vector, str, None),
        "coordinates": [{"index": k, "name": plain(q)} for k, q in enumerate(table.q, 1)],
        **shown,
        "tau": fmt(sympy.Matrix(r.tau).T),
        "M_g": fmt.matrix("M", sympy.Matrix(n, n, [e for row in r.mass_matrix for e in row]), sub("M", mi("g", normal=True))),
        "lines": sum(len(b["lines"]) for blocks in shown.values() for b in blocks),
    }
