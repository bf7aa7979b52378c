"""Dead-line pruning of straight-line programs: only the lines a result reads are printed."""

from __future__ import annotations

from collections.abc import Iterable

import sympy


def live_lines(lines: Iterable[tuple[sympy.Symbol, sympy.Basic]], needed: set[sympy.Symbol]) \
        -> list[tuple[sympy.Symbol, sympy.Basic, set[sympy.Symbol]]]:
    """The lines whose values ``needed`` reads, directly or through other lines, in order, each
    with the names it reads (found once: SymPy walks the whole tree for every
    ``free_symbols``); ``needed`` grows by every name they read."""
    kept = []
    for target, expr in reversed(list(lines)):
        if target in needed:
            names = expr.free_symbols
            kept.append((target, expr, names))
            needed |= names
    return kept[::-1]
