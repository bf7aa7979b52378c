"""Common subexpressions of explicit expressions, eliminated the one way every target does."""

from __future__ import annotations

from collections.abc import Sequence

import sympy


def common_subexpressions(exprs: Sequence[sympy.Basic], prefix: str) -> tuple[list, list]:
    """(temporaries, reduced expressions) of ``sympy.cse`` in canonical order, the temporaries
    named ``<prefix>0, <prefix>1, ...``: the same input always prints the same text."""
    return sympy.cse(exprs, symbols=sympy.numbered_symbols(prefix), order="canonical")
