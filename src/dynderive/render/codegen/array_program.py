"""The Python printer of the engine's array programs (``mechanics/contact_program.py``) over an
array namespace ``xp`` with leading batch axes (NumPy, JAX): ``x[..., 0:3, :]``, ``A @ B``,
``_matvec(A, x)``; a target with other arrays (CasADi) overrides the operations that differ.

Program locals are printed with a leading ``_`` (a robot's parameter may be named ``M`` or
``tau``); the function's inputs and ``restitution`` keep their names. ``call`` spells a
generated function's call (each target its own); the steps needing anchors go inside
``if _anchor is not None:`` (a contact's) or ``if anchors is not None:`` (the finish)."""

from __future__ import annotations

from collections.abc import Callable

from ...model.array_program import HELD, Append, Call, Let, Node, RowSpaceSolve, SchurSolve

#: Names a program reads that are the function's own (not locals).
ARGUMENTS = ("q", "qd", "u", "qd_minus", "restitution", "alpha", "beta")


def local(name: str) -> str:
    return name if name in ARGUMENTS else f"_{name}"


class ArrayPrinter:
    """Python text of ``Node`` trees and program steps for an ``xp`` namespace."""

    def __init__(self, xp: str, call: Callable[[Call], str]):
        self.xp, self.call = xp, call

    def expression(self, node: Node) -> str:
        return getattr(self, f"_{node.op}")(node, *node.args)

    def _name(self, node: Node, name: str) -> str:
        return local(name)

    def _rows(self, node: Node, of: Node, start: int, stop: int | None) -> str:
        return f"{self.expression(of)}[..., {start}:{'' if stop is None else stop}{', :' if len(node.shape) == 2 else ''}]"

    def _position(self, node: Node, pose: Node) -> str:
        return f"{self.expression(pose)}[..., :3, 3]"

    def _rotation(self, node: Node, pose: Node) -> str:
        return f"{self.expression(pose)}[..., :3, :3]"

    def _transpose(self, node: Node, matrix: Node) -> str:
        return f"{self.xp}.swapaxes({self.expression(matrix)}, -1, -2)"

    def _matmul(self, node: Node, left: Node, right: Node) -> str:
        if len(right.shape) == 1:
            return f"_matvec({self.expression(left)}, {self.expression(right)})"
        return f"{self._operand(left)} @ {self._operand(right)}"

    def _cross(self, node: Node, a: Node, b: Node) -> str:
        return f"{self.xp}.cross({self.expression(a)}, {self.expression(b)})"

    def _add(self, node: Node, a: Node, b: Node) -> str:
        return f"{self.expression(a)} + {self._operand(b)}"

    def _sub(self, node: Node, a: Node, b: Node) -> str:
        return f"{self.expression(a)} - {self._operand(b)}"

    def _neg(self, node: Node, a: Node) -> str:
        return f"-{self._operand(a)}"

    def _scale(self, node: Node, scalar: str, a: Node) -> str:
        return f"{local(scalar)} * {self._operand(a)}"

    def _stack(self, node: Node, top: Node, bottom: Node) -> str:
        axis = -2 if len(node.shape) == 2 else -1
        if node.shape[0] == HELD:   # the loops' rows over the contacts': batches broadcast (the module's _stacked)
            return f"_stacked([{self.expression(top)}, {self.expression(bottom)}], {axis})"
        return f"{self.xp}.concatenate([{self.expression(top)}, {self.expression(bottom)}], axis={axis})"

    def _vee(self, node: Node, matrix: Node) -> str:
        x = self.expression(matrix)
        parts = ", ".join(f"({x}[..., {i}, {j}] - {x}[..., {j}, {i}]) / 2" for i, j in ((2, 1), (0, 2), (1, 0)))
        return f"{self.xp}.stack([{parts}], axis=-1)"

    def _operand(self, node: Node) -> str:
        text = self.expression(node)
        return f"({text})" if node.op in ("add", "sub", "neg", "scale") or (node.op == "matmul" and
                                                                              len(node.args[1].shape) == 2) else text

    def _column(self, node: Node) -> str:
        """A vector as a matrix of one column."""
        return f"{self._operand(node) if node.op != 'name' else self.expression(node)}[..., None]"

    def statements(self, steps: tuple, anchors: str = "_anchor") -> list[str]:
        """The lines of ``steps``; those needing anchors under ``if <anchors> is not None:``."""
        lines: list[str] = []
        anchored = False
        for step in steps:
            if step.anchored != anchored:
                anchored = step.anchored
                if anchored:
                    lines.append(f"if {anchors} is not None:")
            lines += [("    " if anchored else "") + line for line in self.statement(step)]
        return lines

    def statement(self, step) -> list[str]:
        if isinstance(step, Call):
            return [f"{local(step.output)} = {self.call(step)}"]
        if isinstance(step, Let):
            return [f"{local(step.name)} = {self.expression(step.value)}"]
        if isinstance(step, Append):
            return [f"{local(step.stacked)}.append({self.expression(step.value)})"]
        if isinstance(step, SchurSolve):
            b = "None" if step.b is None else self.expression(step.b)
            return [f"{local(step.x)}, {local(step.multipliers)} = _schur_solve({local(step.mass)}, "
                    f"{local(step.jacobian)}, {b}, {self.expression(step.target)}, _held)"]
        if isinstance(step, RowSpaceSolve):   # the shim solves for columns: a vector is one
            x, multipliers = local(step.x), local(step.multipliers)
            b = f"{self.xp}.zeros_like({local(step.mass)}[..., :1])" if step.b is None else self._column(step.b)
            rank = step.rank if step.held is None or step.rank is None else f"{step.rank} + {local(step.held)}.shape[-2]"
            return [f"{x}, {multipliers} = _row_space_solve({local(step.mass)}, {local(step.jacobian)}, "
                    f"{b}, {self._column(step.target)}, {rank})",
                    f"{x}, {multipliers} = {x}[..., 0], {multipliers}[..., 0]"]
        raise ValueError(f"no Python for the step {step!r}")
