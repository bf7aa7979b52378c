"""The functions the Python targets print (NumPy, JAX, CasADi): array arguments (``Argument``),
explicit expressions evaluated entry by entry (``ExpressionFunction``), and straight-line
bodies whose values reuse local names once dead (``ProgramFunction``), printed by
``printer.py``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy
from sympy.printing.numpy import NumPyPrinter

from ...mechanics.tidy import fold_constants, operation_count
from ..encode import Code
from .cse import common_subexpressions
from .fold import folded
from .printer import _CALL, BODY_FUNCTIONS, _ProgramPrinter
from .prune import live_lines


@dataclass
class Argument:
    """An array argument: its name and the symbols it carries along its last axis."""

    name: str
    symbols: list[sympy.Symbol]
    doc: str

    def __post_init__(self) -> None:
        self.doc = Code(self.doc)   # built from validated identifiers only


@dataclass
class ExpressionFunction:
    """A generated function whose result is one SymPy matrix, evaluated entry by entry."""

    name: str
    doc: str
    arguments: list[Argument]
    shape: tuple[int, ...]
    unpack: list[tuple[str, str, int]]   # (symbol, argument, index)
    lines: list[tuple[str, str]]          # CSE temporaries
    entries: list[tuple[str, str]]        # (index text, expression)

    @property
    def shape_text(self) -> str:
        return repr(tuple(self.shape))


@dataclass
class ProgramFunction:
    """A straight-line body (see ``recursive.py``) printed with reused local names."""

    name: str
    doc: str
    arguments: list[Argument]
    lines: list[tuple[str, str]]
    outputs: list[str]
    operations: int
    #: Names of the functions the body calls (its parameters after the argument rows).
    functions: tuple[str, ...] = ()
    #: Whether it takes the robot's parameters (keyword arguments; the configuration maps do not).
    keywords: bool = True


def program_function(name: str, doc: str, arguments: list[Argument], program: Any) -> ProgramFunction:
    """Print ``program``, giving each value a local name that is reused once the value is dead.

    Reuse keeps the live arrays few (a batch chunk stays in cache); the same body then runs
    on floats for one state.
    """
    output_names = [sympy.sympify(e).free_symbols for e in program.outputs]
    body = live_lines(program.lines, set().union(*output_names))   # drop values nothing reads
    last_use: dict[sympy.Symbol, int] = {}
    for position, (_, _, names) in enumerate(body):
        for symbol in names:
            last_use[symbol] = position
    end = len(body)
    for names in output_names:
        for symbol in names:
            last_use[symbol] = end
    targets = {target for target, _, _ in body}
    slot: dict[sympy.Symbol, str] = {}
    printer = _ProgramPrinter(slot)
    free: list[str] = []
    count = 0
    lines = []
    for position, (target, expr, names) in enumerate(body):
        text = Code(printer(folded(expr)))
        for symbol in sorted(names & targets, key=lambda s: s.name):
            if last_use[symbol] == position:
                free.append(slot[symbol])
        if free:
            slot[target] = free.pop()
        else:
            slot[target] = f"_r{count}"
            count += 1
        lines.append((slot[target], text))
    outputs = [Code(printer(folded(e))) for e in program.outputs]
    operations = sum(operation_count(e) for _, e, _ in body) + operation_count(sympy.Matrix(program.outputs))
    used = {m.group(1) for text in [*(t for _, t in lines), *outputs] for m in _CALL.finditer(text)}
    functions = tuple(f for f in BODY_FUNCTIONS if f in used)
    return ProgramFunction(name, Code(doc), arguments, lines, outputs, operations, functions)


def expression_function(name: str, doc: str, arguments: list[Argument], value: Any,
                        printer: NumPyPrinter, parameters: set[sympy.Symbol],
                        matrix_result: bool = False) -> ExpressionFunction:
    """Eliminate common subexpressions of ``value`` and print it as NumPy code.

    A column matrix becomes a vector ``(..., n)`` unless ``matrix_result`` keeps it ``(..., n, 1)``.
    """
    matrix = value if isinstance(value, sympy.MatrixBase) else sympy.Matrix([[value]])
    scalar = not isinstance(value, sympy.MatrixBase)
    column = not scalar and matrix.shape[1] == 1 and not matrix_result
    cells = [(i, j) for i in range(matrix.shape[0]) for j in range(matrix.shape[1])
             if matrix[i, j] != 0]
    exprs = [fold_constants(matrix[i, j]) for i, j in cells]
    temporaries, reduced = common_subexpressions(exprs, "_t")
    used = set().union(*(e.free_symbols for e in reduced), *(e.free_symbols for _, e in temporaries)) if exprs else set()
    unpack = []
    for arg in arguments:
        for index, symbol in enumerate(arg.symbols):
            if symbol in used:
                unpack.append((str(symbol), arg.name, index))
    lines = [(str(t), Code(printer.doprint(e))) for t, e in temporaries]
    entries = []
    for (i, j), expr in zip(cells, reduced):
        index = "" if scalar else (f"{i}" if column else f"{i}, {j}")
        entries.append((index, Code(printer.doprint(expr))))
    shape = () if scalar else ((matrix.shape[0],) if column else tuple(matrix.shape))
    return ExpressionFunction(name, Code(doc), arguments, shape, unpack, lines, entries)


def flat_entries(function: ExpressionFunction) -> list[tuple[int, str]]:
    """The entries of an expression function by their flat (row-major) index (a module that fills
    its results from a flat list, as the JAX module does)."""
    columns = function.shape[1] if len(function.shape) == 2 else 1
    flat = []
    for index, expr in function.entries:
        parts = [int(p) for p in index.split(",")] if index else [0]
        flat.append((parts[0] * columns + parts[1] if len(parts) == 2 else parts[0], expr))
    return flat
