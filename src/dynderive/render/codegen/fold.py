"""Constant folding of a program line before it is printed."""

from __future__ import annotations

import sympy

from ...mechanics.tidy import fold_constants


def folded(expr: sympy.Basic) -> sympy.Basic:
    """``expr`` with its constant subexpressions folded to floats (``tidy.fold_constants``); a
    branch (``Piecewise``: the configuration maps' lines, numbers and names only) as it is."""
    return expr if expr.has(sympy.Piecewise) else fold_constants(expr, rationals=False)
