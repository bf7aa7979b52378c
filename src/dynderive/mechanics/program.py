"""A straight-line program (``name = expression`` assignments in order) and the 3-vector
algebra the recursive algorithms write their lines with.

``Program.let`` names every value that costs something to repeat, once: the same value
computed twice gets one name, so lines never grow. Every target's printer (NumPy today) reads
``lines`` and ``outputs``; ``lines_read`` prunes a program to what some outputs need.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import sympy

from .tidy import operation_count

Vector = tuple[sympy.Expr, sympy.Expr, sympy.Expr]
Matrix3 = tuple[Vector, Vector, Vector]


class Meaning(NamedTuple):
    """What a program line computes, recorded where the recursion builds it (the sheet names
    the line by it): ``quantity`` a key of ``sheet_recursion.MEANINGS`` (``omega``: the link's
    angular velocity), ``link`` the link's name, ``index`` the component (0-2, or row and
    column), ``column`` the mass matrix's column ``j`` for CRBA's force columns, else -1."""

    quantity: str
    link: str
    index: tuple[int, ...] = ()
    column: int = -1


@dataclass
class Program:
    """Assignments ``name = expression`` in order; ``outputs`` are expressions of the names."""

    lines: list[tuple[sympy.Symbol, sympy.Expr]] = field(default_factory=list)
    outputs: list[sympy.Expr] = field(default_factory=list)
    #: Symbols the body takes besides q, qd, qdd and u (forward dynamics of a robot with
    #: damping or friction: the dissipative forces, computed outside the body).
    extra_inputs: list[sympy.Symbol] = field(default_factory=list)
    #: What the lines mean (``Meaning``), by name, where the recursion recorded it.
    labels: dict[sympy.Symbol, Meaning] = field(default_factory=dict)
    #: Every value given a meaning, in order: ``(meaning, value)``, the value a line's name
    #: or, where it costs nothing to repeat (``q_1``, ``0``), the value itself.
    records: list[tuple[Meaning, sympy.Expr]] = field(default_factory=list)
    _count: int = 0
    _known: dict[sympy.Expr, sympy.Symbol] = field(default_factory=dict)

    def let(self, expr: sympy.Expr, meaning: Meaning | None = None) -> sympy.Expr:
        """``expr`` itself if it costs nothing to repeat (a number, a name, minus a name),
        else a new name bound to it, with ``meaning`` recorded for a new line (a value
        computed before keeps its first meaning)."""
        value = self._let(expr, meaning)
        if meaning is not None:
            self.records.append((meaning, value))
        return value

    def _let(self, expr: sympy.Expr, meaning: Meaning | None) -> sympy.Expr:
        expr = _numeric_constants(sympy.sympify(expr))
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1
                            and expr.args[1].is_Atom):
            return expr
        if expr in self._known:       # the same value computed twice: one name
            return self._known[expr]
        name = sympy.Symbol(f"_t{self._count}")
        self._count += 1
        self._known[expr] = name
        self.lines.append((name, expr))
        if meaning is not None:
            self.labels[name] = meaning
        return name

    def vector(self, values: Sequence[sympy.Expr], meaning: Meaning | None = None) -> Vector:
        """Each component ``let``; ``meaning`` (without index) gives component k index (k,)."""
        named = [self.let(v, meaning and meaning._replace(index=(k,))) for k, v in enumerate(values)]
        return tuple(named)  # type: ignore[return-value]

    def symmetric(self, entries: Sequence[Sequence[sympy.Expr]], meaning: Meaning | None = None) -> Matrix3:
        """A symmetric 3 x 3 matrix: the upper triangle of ``entries`` ``let`` row by row;
        ``meaning`` (without index) gives entry (a, b) index (a, b)."""
        rows: list[list[sympy.Expr]] = [[sympy.S.Zero] * 3 for _ in range(3)]
        for a in range(3):
            for b in range(a, 3):
                rows[a][b] = rows[b][a] = self.let(entries[a][b], meaning and meaning._replace(index=(a, b)))
        return tuple(tuple(row) for row in rows)  # type: ignore[return-value]

    @property
    def operations(self) -> int:
        """Arithmetic operations and function calls of the program."""
        return sum(operation_count(e) for _, e in self.lines) + sum(operation_count(e) for e in self.outputs)


def lines_read(values: Sequence[object], definitions: dict[sympy.Symbol, sympy.Expr]) -> set[sympy.Symbol]:
    """The names among ``definitions`` that ``values`` read, directly or through other names:
    the lines a straight-line program needs to compute them."""
    needed: set[sympy.Symbol] = set()
    pending = [s for value in values for s in sympy.sympify(value).free_symbols if s in definitions]
    while pending:
        symbol = pending.pop()
        if symbol not in needed:
            needed.add(symbol)
            pending += [s for s in definitions[symbol].free_symbols if s in definitions and s not in needed]
    return needed


def _numeric_constants(expr: sympy.Expr) -> sympy.Expr:
    """Irrational constants (``sqrt(2)/2``, ``cos(0.147)``) as 20-digit floats, so that the
    printed lines call ``sin`` and ``cos`` of coordinates only; rationals stay exact."""
    if expr.is_Atom:
        return expr
    if not expr.free_symbols and isinstance(expr, sympy.Expr):   # not a branch's (value, condition)
        return expr if expr.is_Rational else sympy.Float(expr.evalf(20), 20)
    args = [_numeric_constants(a) for a in expr.args]
    return expr.func(*args) if any(a is not b for a, b in zip(args, expr.args)) else expr


def _dot(a: Sequence[sympy.Expr], b: Sequence[sympy.Expr]) -> sympy.Expr:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Sequence[sympy.Expr], b: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _add(a: Sequence[sympy.Expr], b: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    return tuple(x + y for x, y in zip(a, b))


def motion_cross(a: Sequence[Sequence[sympy.Expr]],
                 b: Sequence[Sequence[sympy.Expr]]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``a x b`` of motion vectors ``(angular, linear)``."""
    return _cross(a[0], b[0]), _add(_cross(a[0], b[1]), _cross(a[1], b[0]))


def _times(vector: Sequence[sympy.Expr], scalar: sympy.Expr) -> tuple[sympy.Expr, ...]:
    return tuple(x * scalar for x in vector)


def _rotate(R: Matrix3, v: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    return tuple(_dot(row, v) for row in R)


def _rotate_back(R: Matrix3, v: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
    """``R^T v``."""
    return tuple(R[0][k] * v[0] + R[1][k] * v[1] + R[2][k] * v[2] for k in range(3))


def part_of(lines: Sequence[tuple[sympy.Symbol, sympy.Expr]], outputs: Sequence[sympy.Expr]) -> Program:
    """The program of ``outputs``: the ``lines`` they read, renamed in their order. A shared
    program grows with what a run asks for first (the sheet's body Jacobians, V's gradient of
    the checks), and SymPy orders a sum's terms by their names: without the renaming a
    module's bytes would depend on which other outputs its run writes."""
    needed = lines_read(outputs, dict(lines))
    kept = [(name, expr) for name, expr in lines if name in needed]
    names = {name: sympy.Symbol(f"_t{k}") for k, (name, _) in enumerate(kept)}
    return Program(lines=[(names[name], expr.xreplace(names)) for name, expr in kept],
                   outputs=[sympy.sympify(e).xreplace(names) for e in outputs])
