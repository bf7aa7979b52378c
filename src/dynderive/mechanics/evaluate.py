"""Evaluation of expression trees at one point with mpmath numbers, without generating code.

The consistency checks evaluate a difference of two quantities at a few random points.
``sympy.lambdify`` first finds common subexpressions and prints Python source for the whole
tree, which costs a second or more for a 4-link chain's equations, to be run four times.
Walking the tree once per point, each distinct subtree evaluated once, costs milliseconds.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import mpmath
import sympy

#: SymPy functions by their mpmath counterparts (one argument unless noted).
_FUNCTIONS: dict[type, Callable[..., Any]] = {
    sympy.sin: mpmath.sin, sympy.cos: mpmath.cos, sympy.tan: mpmath.tan, sympy.cot: mpmath.cot,
    sympy.sec: mpmath.sec, sympy.csc: mpmath.csc,
    sympy.asin: mpmath.asin, sympy.acos: mpmath.acos, sympy.atan: mpmath.atan, sympy.atan2: mpmath.atan2,
    sympy.sinh: mpmath.sinh, sympy.cosh: mpmath.cosh, sympy.tanh: mpmath.tanh,
    sympy.exp: mpmath.exp, sympy.log: mpmath.log, sympy.Abs: abs, sympy.sign: mpmath.sign,
}


class Unsupported(Exception):
    """A node ``evaluator`` cannot evaluate (the caller falls back to ``lambdify``)."""


def evaluator(exprs: Sequence[sympy.Expr], symbols: Sequence[sympy.Symbol]) -> Callable[..., list[Any]]:
    """A function of mpmath values for ``symbols`` giving the values of ``exprs`` (at the
    caller's ``mpmath.mp.dps``). Raises ``Unsupported`` at once for a tree with a node it
    cannot evaluate."""
    order: list[sympy.Basic] = []
    seen: set[sympy.Basic] = set()
    for root in exprs:   # post-order over distinct subtrees, without recursion
        stack: list[tuple[sympy.Basic, bool]] = [(sympy.sympify(root), False)]
        while stack:
            node, expanded = stack.pop()
            if node in seen:
                continue
            if expanded or not node.args:
                seen.add(node)
                order.append(node)
                continue
            stack.append((node, True))
            stack.extend((a, False) for a in node.args if a not in seen)
    for node in order:
        _kind(node)   # refuse unsupported trees before any evaluation
    roots = [sympy.sympify(e) for e in exprs]

    def evaluate(*values: Any) -> list[Any]:
        known: dict[sympy.Basic, Any] = dict(zip(symbols, values))
        for node in order:
            if node not in known:
                known[node] = _value(node, known)
        return [known[r] for r in roots]

    return evaluate


def _kind(node: sympy.Basic) -> None:
    if not (node.is_Symbol or node.is_Number or node.is_NumberSymbol or node.is_Add or node.is_Mul
            or node.is_Pow or type(node) in _FUNCTIONS or node is sympy.S.ImaginaryUnit):
        raise Unsupported(type(node).__name__)


def _value(node: sympy.Basic, known: dict[sympy.Basic, Any]) -> Any:
    if node.is_Symbol:
        raise Unsupported(f"no value for {node}")
    if node.is_Integer:
        return mpmath.mpf(int(node))
    if node.is_Rational:
        return mpmath.mpf(node.p) / node.q
    if node.is_Float:
        return mpmath.mpf(node._mpf_)
    if node.is_NumberSymbol:
        return mpmath.mpf(node.evalf(mpmath.mp.dps + 10))
    if node is sympy.S.ImaginaryUnit:
        return mpmath.mpc(0, 1)
    args = [known[a] for a in node.args]
    if node.is_Add:
        return mpmath.fsum(args)
    if node.is_Mul:
        return mpmath.fprod(args)
    if node.is_Pow:
        base, exponent = args
        if node.exp.is_Integer:
            return base ** int(node.exp)
        return mpmath.power(base, exponent)
    return _FUNCTIONS[type(node)](*args)
