"""The C printer of the engine's array programs (``mechanics/contact_program.py``,
``mechanics/loop_solve.py``): a generated function's call (``call_line``); a value printed element
by element, its rows unrolled (at most 6) or looped (NV, or the contacts' rows ``count``) and its
columns looped; a product over NV entries (``J qd``) is summed into a local
first, and a compound operand of a 3 x 3 product into a local array, so nothing is computed twice.

``names`` maps a program's array to its C text: a local array, an argument, or ``A`` (the
anchor's) -- a local is never named like a function of ``<math.h>`` (``gamma``, ``-Wshadow``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from ....derivation import Derivation
from ....model.array_program import HELD, Call, Node

#: Program names that C spells differently (a <math.h> function, the anchors' pointer, the
#: multipliers of the stacked loop and contact rows: the Schur shim's own local is ``lam``).
C_NAMES = {"gamma": "gam", "anchor": "A", "lam": "multipliers"}

#: The largest number of rows printed one by one (a frame's 6); more are a loop.
UNROLLED = 6


def c_name(name: str) -> str:
    return C_NAMES.get(name, name)


def flat_index(row: int | str, columns: int | None, column: int | str | None) -> str:
    """``row * columns + column`` as C (row-major), folded where both are numbers."""
    if columns is None:
        return str(row)
    if isinstance(row, int) and isinstance(column, int):
        return str(row * columns + column)
    start = row * columns if isinstance(row, int) else f"({row}) * {columns}" if " " in row else f"{row} * {columns}"
    return f"{start} + {column}" if start != 0 else str(column)


def _shifted(row: int | str, start: int) -> int | str:
    if isinstance(row, int):
        return row + start
    return f"{row} + {start}" if start else row


class Elements:
    """Prints the elements of one statement's value; ``lines`` collects the locals it needs
    first (sums over NV entries, compound operands of 3 x 3 products)."""

    def __init__(self, n: int, fresh: Iterator[int]):
        self.n, self.lines = n, []
        self._made: dict[tuple, str] = {}
        self._fresh = fresh

    def element(self, node: Node, row: int | str, column: int | str | None = None) -> str:
        op, args = node.op, node.args
        if op == "name":
            columns = node.shape[1] if len(node.shape) == 2 else None
            if node.shape[0] == HELD and columns is None:
                return f"{c_name(args[0])}[{row}]"
            return f"{c_name(args[0])}[{flat_index(row, columns, column)}]"
        if op == "rows":
            return self.element(args[0], _shifted(row, args[1]), column)
        if op == "position":
            return self.element(args[0], row, 3)
        if op == "rotation":
            return self.element(args[0], row, column)
        if op == "transpose":
            return self.element(args[0], column, row)
        if op in ("add", "sub"):
            sign = " + " if op == "add" else " - "
            return f"{self._operand(args[0], row, column)}{sign}{self._operand(args[1], row, column)}"
        if op == "neg":
            return f"-{self._operand(args[0], row, column)}"
        if op == "scale":
            return f"{args[0]}*{self._operand(args[1], row, column)}"
        if op == "stack":
            top = args[0].shape[0]
            if isinstance(row, int):
                return self.element(args[0], row, column) if row < top else self.element(args[1], row - top, column)
            raise ValueError("a stack's rows are printed one by one")
        if op == "cross":
            a, b = args
            i, j = (row + 1) % 3, (row + 2) % 3
            return f"({self.element(a, i)}*{self.element(b, j)} - {self.element(a, j)}*{self.element(b, i)})"
        if op == "vee":
            i, j = ((2, 1), (0, 2), (1, 0))[row]
            return f"({self.element(args[0], i, j)} - {self.element(args[0], j, i)}) / 2"
        if op == "matmul":
            return self._product(node, row, column)
        raise ValueError(f"no C for the operation {op!r}")

    def _operand(self, node: Node, row: int | str, column: int | str | None) -> str:
        text = self.element(node, row, column)
        return f"({text})" if node.op in ("add", "sub") else text

    def _product(self, node: Node, row: int | str, column: int | str | None) -> str:
        left, right = node.args
        inner = left.shape[1]
        if inner > 3:   # a sum over NV entries: a local, summed in order from 0
            key = (id(node), row, column)
            if key not in self._made:
                name = self._made[key] = f"dot{next(self._fresh)}"
                term = f"{self.element(left, row, 'j')}*{self.element(right, 'j', column)}"
                self.lines += [f"double {name} = 0.0;", f"for (int j = 0; j < {inner}; ++j) {name} += {term};"]
            return self._made[key]
        if right.op not in ("name", "rows", "position", "rotation", "transpose"):
            right = self._local(right)
        return " + ".join(f"{self.element(left, row, k)}*{self.element(right, k, column)}" for k in range(inner))

    def _local(self, node: Node) -> Node:
        """A compound vector of 3 as a local array, computed once."""
        key = (id(node),)
        if key not in self._made:
            name = self._made[key] = f"t{next(self._fresh)}"
            self.lines += [f"double {name}[{node.shape[0]}];",
                           *(f"{name}[{i}] = {self.element(node, i)};" for i in range(node.shape[0]))]
        return Node("name", (self._made[key],), node.shape)


def assignment(target: Callable[[int | str, int | str | None], str], value: Node, n: int,
               fresh: Iterator[int], rows: str = "count") -> list[str]:
    """``target(row, column)`` (C text of an element) set to ``value``: rows unrolled up to 6
    (else looped over ``i`` up to their number, or over ``r`` up to ``rows``), columns looped
    over ``j``; ``fresh`` numbers the locals of the whole function."""
    matrix, size = len(value.shape) == 2, value.shape[0]
    if value.op == "stack" and size == HELD:   # fixed rows (the loops'), then the contacts' count
        top, bottom = value.args
        start = top.shape[0]
        return [*assignment(target, top, n, fresh, rows),
                *assignment(lambda i, j: target(_shifted(i, start), j), bottom, n, fresh, rows)]
    elements = Elements(n, fresh)
    if size == HELD or size > UNROLLED:
        index, bound = ("r", rows) if size == HELD else ("i", str(size))
        column = "j" if matrix else None
        text = elements.element(value, index, column)
        body = [*elements.lines, f"{target(index, column)} = {text};"]
        if matrix:
            body = [f"for (int j = 0; j < {value.shape[1]}; ++j) {{", *(f"    {line}" for line in body), "}"]
        return [f"for (int {index} = 0; {index} < {bound}; ++{index}) {{", *(f"    {line}" for line in body), "}"]
    if not matrix:
        values = [elements.element(value, i) for i in range(size)]
        return [*elements.lines, *(f"{target(i, None)} = {text};" for i, text in enumerate(values))]
    values = [elements.element(value, i, "j") for i in range(size)]
    body = [*elements.lines, *(f"{target(i, 'j')} = {text};" for i, text in enumerate(values))]
    return [f"for (int j = 0; j < {value.shape[1]}; ++j) {{", *(f"    {line}" for line in body), "}"]


def call_line(derivation: Derivation, step: Call, n: int) -> list[str]:
    """A generated function's call; ``effort_map`` (a floating base's efforts at their columns)
    written out."""
    robot = derivation.robot
    if step.function == "effort_map":
        columns = robot.effort_columns()
        return [f"for (int i = 0; i < {n}; ++i) {step.output}[i] = 0.0;",
                *(["if (u) {", *(f"    {step.output}[{c}] = u[{k}];" for k, c in enumerate(columns)), "}"]
                  if columns else ["(void)u;"])]
    spelled = {"u": "u ? u : zeros", "frame": "f"}
    arguments = ", ".join(spelled.get(a, c_name(a)) for a in step.arguments)
    return [f"{robot.name}_{step.function}({arguments}, p, {c_name(step.output)});"]
