"""What the MATLAB derivation script needs of text and expressions: free text encoded for a
``%`` comment or a single-quoted string, and SymPy expressions printed as exact Symbolic
Math Toolbox code.

Comments and strings are ``matlab_names``' (printable ASCII only in comments, no brace or
``#``: nothing can end a comment line or open a block comment).

Numbers stay exact: a rational is ``sym(p)/sym(q)``, a float its shortest decimal written as
such a rational (``9.81`` -> ``sym(981)/sym(100)``, exact, so the script's ``isAlways`` checks
are exact too), and a constant sub-expression (``sqrt(2)``, ``pi``) is built from ``sym``
integers rather than evaluated in double precision.
"""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction
from typing import Any

import sympy
from sympy.printing.octave import OctaveCodePrinter

from ...encode import Code
from .matlab_names import matlab_comment, matlab_string

#: Integers beyond this are written as digit strings (``sym('...')``): a double cannot hold them.
_EXACT_DOUBLE = 2**53


# Free text goes through the numeric package's encoders (one rule for both MATLAB outputs).
__all__ = ["matlab_code", "matlab_comment", "matlab_string"]


def _rational(numerator: int, denominator: int) -> str:
    def whole(n: int) -> str:
        return f"sym({n})" if abs(n) < _EXACT_DOUBLE else f"sym('{n}')"
    if denominator == 1:
        return whole(numerator)
    return f"({whole(numerator)}/{whole(denominator)})"


class MatlabPrinter(OctaveCodePrinter):
    """SymPy to Symbolic Math Toolbox code: exact numbers, matrices with explicit commas."""

    def __init__(self, settings: dict[str, Any] | None = None):
        super().__init__({"inline": True, **(settings or {})})
        self._exact = False

    def _print(self, expr: Any, **kwargs: Any) -> str:
        constant = (isinstance(expr, sympy.Expr) and not self._exact and expr.is_number
                    and not isinstance(expr, (sympy.Integer, sympy.Rational, sympy.Float)))
        if not constant:
            return super()._print(expr, **kwargs)
        self._exact = True
        try:
            return super()._print(expr, **kwargs)
        finally:
            self._exact = False

    def _print_Integer(self, expr: sympy.Integer) -> str:
        n = int(expr)
        if self._exact or abs(n) >= _EXACT_DOUBLE:
            return _rational(n, 1)
        return str(n)

    def _print_Rational(self, expr: sympy.Rational) -> str:
        return _rational(int(expr.p), int(expr.q))

    def _print_Float(self, expr: sympy.Float) -> str:
        value = Fraction(Decimal(repr(float(expr))))
        return _rational(value.numerator, value.denominator)

    def _print_Pi(self, expr: Any) -> str:
        return "sym(pi)"

    def _print_Exp1(self, expr: Any) -> str:
        return "exp(sym(1))"

    def _print_MatrixBase(self, expr: Any) -> str:
        rows = []
        for i in range(expr.rows):
            row = [expr[i, j] for j in range(expr.cols)]
            # a row of numbers only is written in sym numbers: Octave's symbolic package (3.0)
            # fails on [x, 0; 0, 0] (a sym row joined to a double row)
            constant = not any(sympy.sympify(e).free_symbols for e in row)
            previous, self._exact = self._exact, self._exact or constant
            try:
                rows.append(", ".join(self._print(e) for e in row))
            finally:
                self._exact = previous
        return "[" + "; ".join(rows) + "]"

    _print_Matrix = _print_DenseMatrix = _print_MutableDenseMatrix = _print_ImmutableDenseMatrix = _print_MatrixBase


_PRINTER = MatlabPrinter()


def matlab_code(expr: Any) -> Code:
    """``expr`` (a SymPy expression or matrix) as MATLAB Symbolic Math Toolbox code, always a
    ``sym`` value."""
    expr = expr if isinstance(expr, sympy.MatrixBase) else sympy.sympify(expr)
    text = _PRINTER._print_MatrixBase(expr) if isinstance(expr, sympy.MatrixBase) else _PRINTER.doprint(expr)
    # a value without symbols would be a double (``phi_1 = 0``): symbolic, so that
    # ``jacobian`` and ``diff`` take it
    scalar_number = not isinstance(expr, sympy.MatrixBase) and not expr.free_symbols and "sym(" not in text
    return Code(f"sym({text})" if scalar_number else text)
