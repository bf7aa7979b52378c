"""One C function body from several straight-line programs (``c.py``'s forward dynamics and
linearize): ``joined_program`` renames and links them, ``print_body`` prints each distinct
value once (two programs' sines and cosines, rotations: C compilers do not merge two calls
of ``sin``, which may set ``errno``), with guards before the stores."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sympy

from ....mechanics.tidy import fold_constants
from ...codegen.prune import live_lines


def joined_program(parts: list[tuple[Any, ...]]) -> tuple[list, list[list[sympy.Expr]], list[sympy.Symbol]]:
    """Programs ``(lines, outputs, substitutions, factors)`` as one straight-line program:
    each part's names made unique (every program numbers its own from ``_t0``), its
    substitutions applied (a dictionary, or a function of the earlier parts' outputs: an input
    replaced by an earlier output, or by zero: lines that become numbers are folded into the
    lines that read them). Returns the lines, each part's outputs, and the pivots (``1/d``
    lines) of the parts that ``factors`` M (L D L^T), for ``print_body``'s guards."""
    lines: list[tuple[sympy.Symbol, sympy.Expr]] = []
    defined: set[sympy.Symbol] = set()
    outputs, pivots = [], []
    for part_lines, part_outputs, substitutions, factors in parts:
        replace = dict(substitutions(outputs) if callable(substitutions) else substitutions)
        for target, expr in part_lines:
            expr = expr.xreplace(replace) if replace else expr
            if expr.is_Number:
                replace[target] = expr
                continue
            if target in defined:
                replace[target] = sympy.Dummy(target.name)
                target = replace[target]
            else:
                replace.pop(target, None)
            defined.add(target)
            if factors and expr.is_Pow and expr.exp == -1 and expr.base.is_Symbol:
                pivots.append(expr.base)
            lines.append((target, expr))
        outputs.append([sympy.sympify(e).xreplace(replace) if replace else sympy.sympify(e) for e in part_outputs])
    return lines, outputs, pivots


def print_body(names: Any, lines: list, stores: list[tuple[str, sympy.Expr]],
               guards: Sequence[sympy.Symbol] = ()) -> list[str]:
    """C lines of ``lines`` (those the stores and guards read), one line per distinct value
    (the same text twice, a sine of two programs, is computed once), ``return 1`` unless each
    guard is positive, then the stores."""
    needed = set().union(*(e.free_symbols for _, e in stores), set(guards))
    printer = names.printer()
    seen: dict[str, str] = {}
    text = []
    for target, expr, _ in live_lines(lines, needed):
        value = printer.doprint(fold_constants(expr, rationals=False))
        if value not in seen:
            seen[value] = f"t{len(seen)}"
            text.append(f"const double {seen[value]} = {value};")
        printer.names[target] = seen[value]
    text += [f"if (!({printer.doprint(g)} > 0.0)) return 1;" for g in guards]
    text += [f"{target} = {printer.doprint(fold_constants(expr, rationals=False))};" for target, expr in stores]
    return text
