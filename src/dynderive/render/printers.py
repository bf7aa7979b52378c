"""SymPy's LaTeX and string printers, remembering what they printed, sub-expressions included.

Printing is a pure function of the expression (and the printer's settings): the entries of
a robot's matrices share most of their pieces (``\\sin(q_1 + q_2)``, the same products of
masses and lengths), and SymPy orders and prints every one again for each entry. Each
printer here keeps the text of every sub-expression it printed, so the text is SymPy's own.
"""

from __future__ import annotations

import weakref
from typing import Any, ClassVar, Self, cast

import sympy
from sympy.printing.latex import LatexPrinter
from sympy.printing.str import StrPrinter

from ..derivation import Derivation
from .numbers import DecimalNumbers, Numbers, latex_decimal


class _Remembering:
    """Printer mixin (before the SymPy printer in the bases): the text of every sub-expression
    printed without extra arguments (a function raised to a power passes its exponent) is
    remembered, except floating-point numbers, whose text can depend on whether they are
    printed at the top (``StrPrinter``'s ``full_prec="auto"``)."""

    def __init__(self, settings: dict[str, Any]):
        super().__init__(settings)  # type: ignore[call-arg]
        self._memo: dict[sympy.Basic, str] = {}

    def _print(self, expr: Any, **kwargs: Any) -> str:
        if kwargs or not isinstance(expr, sympy.Basic) or expr.is_Float:
            return super()._print(expr, **kwargs)  # type: ignore[misc]
        known = self._memo.get(expr)
        if known is None:
            known = self._memo[expr] = super()._print(expr)  # type: ignore[misc]
        return known


class RememberingLatexPrinter(_Remembering, LatexPrinter):
    """``sympy.latex(expr, **settings)`` is ``LatexPrinter(settings).doprint(expr)``: this
    printer gives the same text, remembered."""


class RememberingStrPrinter(_Remembering, StrPrinter):
    """``sympy.sstr(expr, **settings)`` (``StrPrinter(settings).doprint(expr)``), remembered."""


class SheetLatexPrinter(DecimalNumbers, RememberingLatexPrinter):
    """The sheet's LaTeX printer: numbers as the robot file wrote them, to D digits (``render.numbers``)."""

    def __init__(self, settings: dict[str, Any], numbers: Numbers):
        super().__init__(settings)
        self.numbers = numbers

    def _decimal(self, mantissa: str, exponent: int | None) -> str:
        return latex_decimal(mantissa, exponent)


class DerivationFormatter:
    """The text of a derivation's SymPy objects (LaTeX, MathML): one formatter per derivation
    (``of``), remembering what it printed, since the sheet, the page and the JSON print the same
    quantities again. A subclass gives ``_text(expr)`` and calls ``super().__init__()``.
    Matrices are mutable, so unhashable: remembered by identity, with the object kept."""

    _shared: ClassVar[weakref.WeakKeyDictionary[Derivation, dict[tuple[Any, ...], DerivationFormatter]]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._shared = weakref.WeakKeyDictionary()   # each kind of formatter its own

    def __init__(self) -> None:
        self._printed: dict[Any, tuple[Any, Any]] = {}

    @classmethod
    def of(cls, derivation: Derivation, **options: Any) -> Self:
        """The derivation's formatter with ``options`` (those None or False left out, so
        ``of(d)`` and ``of(d, digits=None)`` are one), made on first use."""
        options = {k: v for k, v in options.items() if v is not None and v is not False}
        made = cls._shared.setdefault(derivation, {})
        key = tuple(sorted(options.items()))
        if key not in made:
            made[key] = cls(derivation, **options)   # type: ignore[call-arg]
        return cast(Self, made[key])

    def __call__(self, expr: Any) -> Any:
        key = id(expr) if isinstance(expr, sympy.MatrixBase) else expr
        known = self._printed.get(key)
        if known is not None and (known[0] is expr or not isinstance(expr, sympy.MatrixBase)):
            return known[1]
        text = self._text(expr)
        self._printed[key] = (expr, text)
        return text

    def _text(self, expr: Any) -> Any:
        raise NotImplementedError


__all__ = ["DerivationFormatter", "RememberingLatexPrinter", "RememberingStrPrinter", "SheetLatexPrinter"]
