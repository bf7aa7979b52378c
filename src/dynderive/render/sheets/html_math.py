"""MathML for the HTML sheet: SymPy's presentation printer with the sheet's symbol names.

The LaTeX sheet names ``qd1`` as ``\\dot{q}_{1}`` and ``m_link`` as ``m_{\\mathrm{link}}``
(``model.naming.latex_name``); here the same names are MathML elements (a dot accent over
the letter, the index as a subscript). The printer's output is Markup (MathML fragments
without the ``<math>`` element), so the HTML environment's autoescaping leaves it as it is;
every text it holds went through the XML writer, which escapes ``<``, ``&`` and quotes.
"""

from __future__ import annotations

import re
from typing import Any
from xml.dom import minidom

import sympy
from markupsafe import Markup, escape
from sympy.printing.mathml import MathMLPresentationPrinter
from sympy.printing.pretty.pretty_symbology import greek_unicode

from ...derivation import Derivation
from ...model.naming import GREEK, split_index
from ..numbers import DecimalNumbers, Numbers, sheet_digits
from ..printers import DerivationFormatter
from .latex_format import (
    Formatter,
    coordinate_entries,
    entry_index,
    matrix_layout,
    opening,
    shown_digits,
)

#: A name: (letters, mathvariant or "", dots over it, subscript text or "").
Name = tuple[str, str, int, str]

_DOTS = {1: "\u02d9", 2: "\u00a8"}


def name_of(name: str, dots: int = 0) -> Name:
    """What ``latex_name`` typesets, as a ``Name``: ``q1`` -> q with subscript 1; ``phi2`` ->
    the Greek letter; ``m_link`` -> m with the upright subscript ``link``."""
    head, _, rest = name.partition("_")
    if not head:
        head, rest = name, ""
    stem, digits = (head, "") if rest else split_index(head)
    sub = digits or rest
    letters = greek_unicode.get(stem, stem) if stem in GREEK else stem
    return letters, "", dots, sub


def name_element(dom: minidom.Document, name: Name) -> minidom.Element:
    """The MathML element of ``name`` in ``dom``."""
    letters, variant, dots, sub = name
    base = _element(dom, "mi", letters)
    if variant:
        base.setAttribute("mathvariant", variant)
    if dots:
        over = dom.createElement("mover")
        over.setAttribute("accent", "true")
        over.appendChild(base)
        over.appendChild(_element(dom, "mo", _DOTS[dots]))
        base = over
    if not sub:
        return base
    script = dom.createElement("msub")
    script.appendChild(base)
    if sub.isdigit():
        script.appendChild(_element(dom, "mn", sub))
    else:
        index = _element(dom, "mi", sub)
        index.setAttribute("mathvariant", "normal")
        script.appendChild(index)
    return script


def _element(dom: minidom.Document, tag: str, text: str) -> minidom.Element:
    element = dom.createElement(tag)
    element.appendChild(dom.createTextNode(text))
    return element


_DOM = minidom.Document()


def name_markup(name: Name) -> Markup:
    """``name`` as a MathML fragment."""
    return Markup(name_element(_DOM, name).toxml())


# Small builders of MathML fragments for the sheet's labels (M_g, J^b_{sL_1}, ...): text is
# escaped, fragments (Markup) are kept.

def mi(text: str, normal: bool = False) -> Markup:
    variant = ' mathvariant="normal"' if normal else ""
    return Markup(f"<mi{variant}>{escape(text)}</mi>")


def mn(text: str | int) -> Markup:
    return Markup(f"<mn>{escape(str(text))}</mn>")


def mo(text: str) -> Markup:
    return Markup(f"<mo>{escape(text)}</mo>")


def mrow(*parts: Any) -> Markup:
    return Markup("<mrow>" + "".join(str(_atom(p)) for p in parts) + "</mrow>")


def sub(base: Any, index: Any, sup: Any = None) -> Markup:
    """``base`` with a subscript (and a superscript)."""
    if sup is None:
        return Markup(f"<msub>{_atom(base)}{_atom(index)}</msub>")
    return Markup(f"<msubsup>{_atom(base)}{_atom(index)}{_atom(sup)}</msubsup>")


def accent(base: Any, mark: str) -> Markup:
    """``base`` with an accent above: ``\u02d9`` (dot), ``~`` (tilde)."""
    return Markup(f'<mover accent="true">{_atom(base)}<mo>{escape(mark)}</mo></mover>')


def _atom(part: Any) -> Markup:
    """Markup as it is; other text as an identifier (a digit string as a number)."""
    if isinstance(part, Markup):
        return part
    text = str(part)
    return mn(text) if text.isdigit() else mi(text)


def link_frame(index: int) -> Markup:
    """``sL_i``: the centre-of-mass frame of link ``i`` seen from the world frame."""
    return mrow(mi("s"), sub("L", str(index)))


def body_jacobian(index: int) -> Markup:
    """``J^b_{sL_i}``."""
    return sub("J", link_frame(index), "b")


def fenced(body: Markup) -> Markup:
    return mrow(mo("("), body, mo(")"))


class _Printer(DecimalNumbers, MathMLPresentationPrinter):
    """The presentation printer with the robot's names for its symbols and the sheet's
    numbers (``render.numbers``), remembering the elements it printed (cloned on reuse: a DOM
    node has one parent)."""

    def __init__(self, settings: dict[str, Any], names: dict[sympy.Symbol, Name | Markup], numbers: Numbers):
        super().__init__(settings)
        self._names = names
        self.numbers = numbers
        self._memo: dict[sympy.Basic, minidom.Element] = {}

    def _decimal(self, mantissa: str, exponent: int | None) -> minidom.Element:
        number = _element(self.dom, "mn", mantissa.replace("-", "\u2212"))
        if exponent is None:
            return number
        row, power = self.dom.createElement("mrow"), self.dom.createElement("msup")
        power.appendChild(_element(self.dom, "mn", "10"))
        power.appendChild(_element(self.dom, "mn", str(exponent).replace("-", "\u2212")))
        for part in (number, _element(self.dom, "mo", "\u00b7"), power):
            row.appendChild(part)
        return row

    def _print(self, expr: Any, **kwargs: Any) -> Any:
        if kwargs or not isinstance(expr, sympy.Basic) or isinstance(expr, sympy.MatrixBase):
            return super()._print(expr, **kwargs)
        known = self._memo.get(expr)
        if known is None:
            known = self._memo[expr] = super()._print(expr)
        return known.cloneNode(True)

    def _print_Symbol(self, sym: sympy.Symbol, style: str = "plain") -> Any:
        # a symbol made after the formatter (the maximal model's multipliers, derived on first
        # use) is named as the table would have named it: the page must not depend on the
        # order in which the derivation's stages ran
        name = self._names.get(sym) or name_of(str(sym))
        if isinstance(name, Markup):   # a ready fragment (the recursion's names)
            return minidom.parseString(name).documentElement
        return name_element(self.dom, name)


def _coordinate(text: str, tag: str, dots: int = 0) -> Markup:
    """A floating joint's entry (``FREE_FLYER_Q``/``FREE_FLYER_V`` text: ``q_{x}``, ``\\omega_{z}``)
    in MathML: the letter (dotted), its subscript, the joint's name upright after a comma when tagged."""
    letter, _, index = text.partition("_")
    letter, index = greek_unicode.get(letter.lstrip("\\"), letter), index.strip("{}")
    base = accent(mi(letter), "\u02d9") if dots else mi(letter)
    parts = [mi(index)] if index else []
    if tag:
        parts += [mo(","), mi(tag, normal=True)] if parts else [mi(tag, normal=True)]
    if not parts:
        return base
    return sub(base, parts[0] if len(parts) == 1 else mrow(*parts))


def coordinate_math_names(derivation: Derivation) -> dict[sympy.Symbol, Name | Markup]:
    """MathML names of every coordinate, velocity and acceleration, those of the LaTeX sheet
    (``latex_format.coordinate_entries``)."""
    return {symbol: name_of(name, dots) if text is None else _coordinate(text, name, dots)
            for symbol, text, name, dots in coordinate_entries(derivation)}


class MathFormatter(DerivationFormatter):
    """The LaTeX ``Formatter`` in MathML: the same names, numbers and size rules (``maybe``,
    ``matrix``: the same limits, so the page shows what the sheet shows)."""

    def __init__(self, derivation: Derivation, digits: int | None = None,
                 extra_names: dict[sympy.Symbol, Name | Markup] | None = None, lines: tuple[sympy.Symbol, ...] = ()):
        super().__init__()
        self.digits = digits   # --digits, for the LaTeX formatter's decisions the page repeats
        self.numbers = Numbers(sheet_digits(derivation.robot, digits))
        table = derivation.symbols
        names: dict[sympy.Symbol, Name | Markup] = {s: name_of(str(s)) for s in table.all_symbols()}
        if derivation.robot.floating:
            # quaternion joints: their entries' names (``coordinate_math_names``) and, for a large
            # robot, its programs' ``lines`` named ``w_k`` in sans-serif; never the intermediates
            names |= coordinate_math_names(derivation)
            names |= {name: ("w", "sans-serif", 0, str(name)[2:]) for name in lines}
            order = "none" if lines else None
        else:
            for coords, rates, accels in ((table.q, table.qd, table.qdd), (table.qm, table.qmd, table.qmdd)):
                for c, r, a in zip(coords, rates, accels):
                    names[r] = name_of(str(c), 1)
                    names[a] = name_of(str(c), 2)
            for name, _ in derivation.intermediates:
                names[name] = ("w", "sans-serif", 0, str(name)[2:])
            order = "none" if derivation.intermediate_form else None
        self.names = names | (extra_names or {})
        self._printer = _Printer({"order": order, "mat_delim": "["}, self.names, self.numbers)

    def _text(self, expr: Any) -> Markup:
        text = self._printer.doprint(sympy.sympify(expr))
        # the invisible times as a character reference (XML knows no named entities), the
        # minus as the minus sign (SymPy writes the hyphen)
        return Markup(text.replace("&InvisibleTimes;", "&#x2062;").replace("<mo>-</mo>", "<mo>&#x2212;</mo>"))

    #: MathML of an expression, or None when the sheet finds it too large
    maybe = Formatter.maybe

    #: the LaTeX sheet's width estimates, at the page's precision (the same decisions)
    width, matrix_width, fits = Formatter.width, Formatter.matrix_width, Formatter.fits

    def matrix(self, base: Markup | str, matrix: sympy.Matrix, label: Markup | str | None = None) -> dict[str, Any]:
        """A matrix shown whole, or entry by entry (``wide``: as the sheet's too wide a
        matrix, named ``base`` with the entry's index), or ``too_large`` (the sheet's limits:
        ``matrix_layout``). ``label``: its name in front (default ``base``)."""
        layout, places, large = matrix_layout(matrix, shown_digits(self.numbers))
        rows, cols = matrix.shape
        shown = _atom(label if label is not None else base)
        single = rows == cols == 1 and label is not None   # a named 1 x 1 matrix (M_r) is its entry
        entries = [{"name": shown if single else sub(base, entry_index(i, j, rows, cols).replace(",", "\u2009")),
                    "math": self(matrix[i, j])} for i, j in places]
        return {"label": shown, "math": None if large else self(matrix), **layout, "entries": entries}


def html_unit(unit: str) -> Markup:
    """A unit with powers raised, as the sheet's ``tex_unit``: ``m/s^2`` -> m/s<sup>2</sup>,
    ``kg*m**2`` -> kg m<sup>2</sup>; the rest escaped."""
    parts = re.split(r"\^\(?([+-]?\d+(?:\.\d+)?)\)?", unit.replace("**", "^"))
    return Markup("").join(Markup("<sup>{}</sup>").format(part.replace("-", "\u2212")) if index % 2
                           else escape(part.replace("*", "\u2009")) for index, part in enumerate(parts))


def value_markup(value: float, fmt: MathFormatter) -> Markup:
    """A parameter's default in the page's table: as written, to the page's digits."""
    mantissa, exponent = fmt.numbers.value_parts(value)
    if exponent is None:
        return Markup(escape(mantissa))
    return Markup("{}\u00d710<sup>{}</sup>").format(mantissa, str(exponent).replace("-", "\u2212"))


def page_header(derivation: Derivation, fmt: MathFormatter, gravity: sympy.Matrix,
                joints: list[dict[str, Any]]) -> dict[str, Any]:
    """What every page opens with (the LaTeX sheet's ``opening``); names and free text as
    written (the environment escapes them)."""
    return opening(derivation, fmt, gravity, joints, lambda text: text or "",
                   lambda value: value_markup(value, fmt), lambda unit: html_unit(unit or ""))
