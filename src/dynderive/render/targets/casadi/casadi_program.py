"""The CasADi printer of the engine's array programs (contacts, the loops' solve): the neutral Python printer
(``codegen/array_program.py``) with CasADi's matrices (``_ca.mtimes``, ``.T``, ``_ca.vertcat``,
no batch axes) and the module's private bodies as the generated functions; the anchors' steps
always run (anchors is an input, zeros when left out)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ....derivation import Derivation
from ....model.array_program import Node, RowSpaceSolve
from ...codegen.array_program import ArrayPrinter, local
from ...encode import Code

#: Each generated function as the module's body: (text, arguments after the contact's frame).
_CALLS = {"mass_matrix": "_mass_matrix(q, p)", "generalized_forces": "_generalized_forces(q, u, p)",
          "inverse_dynamics": "_inverse_dynamics(q, qd, _ca.SX.zeros(NV), p, smoothing)",
          "effort_map": "_ca.mtimes(_effort_matrix(p), u) if NU else _ca.SX.zeros(NV)",
          "frame_transform": "_FRAME_FUNCTIONS[_index][0](q, p)",
          "frame_jacobian": "_FRAME_FUNCTIONS[_index][1](q, p)",
          "frame_jacobian_dot_qd": "_FRAME_FUNCTIONS[_index][2](q, qd, p)",
          "loop_constraints": "_loop_constraints(q, p)", "loop_jacobian": "_loop_jacobian(q, p)",
          "loop_jacobian_dot": "_loop_jacobian_dot(q, qd, p)"}


class CasadiPrinter(ArrayPrinter):
    def __init__(self) -> None:
        super().__init__("_ca", lambda step: _CALLS[step.function])

    def _rows(self, node: Node, of: Node, start: int, stop: int | None) -> str:
        return f"{self.expression(of)}[{start}:{'' if stop is None else stop}{', :' if len(node.shape) == 2 else ''}]"

    def _position(self, node: Node, pose: Node) -> str:
        return f"{self.expression(pose)}[:3, 3]"

    def _rotation(self, node: Node, pose: Node) -> str:
        return f"{self.expression(pose)}[:3, :3]"

    def _transpose(self, node: Node, matrix: Node) -> str:
        return f"{self.expression(matrix)}.T"

    def _matmul(self, node: Node, left: Node, right: Node) -> str:
        return f"_ca.mtimes({self.expression(left)}, {self.expression(right)})"

    def _stack(self, node: Node, top: Node, bottom: Node) -> str:
        return f"_ca.vertcat({self.expression(top)}, {self.expression(bottom)})"

    def statement(self, step) -> list[str]:
        if isinstance(step, RowSpaceSolve):   # CasADi's vectors are columns already; b None: zero
            b = "_ca.SX.zeros(NV)" if step.b is None else self.expression(step.b)
            rank = step.rank if step.held is None or step.rank is None else f"{step.rank} + {local(step.held)}.shape[0]"
            return [f"{local(step.x)}, {local(step.multipliers)} = _row_space_solve({local(step.mass)}, "
                    f"{local(step.jacobian)}, {b}, {self.expression(step.target)}, {rank})"]
        return super().statement(step)

    def _vee(self, node: Node, matrix: Node) -> str:
        x = self.expression(matrix)
        return "_ca.vertcat(" + ", ".join(f"({x}[{i}, {j}] - {x}[{j}, {i}]) / 2" for i, j in ((2, 1), (0, 2), (1, 0))) + ")"


def casadi_program_lines(derivation: Derivation) -> dict[str, Any]:
    """The engine's programs as lines of the CasADi module: each contact program's parts (the
    anchors' steps always, ``contact_lines``) and the loops' solve (``loop_lines``)."""
    printer = CasadiPrinter()
    loops = derivation.loop_solve
    return {"loop_lines": [] if loops is None else [Code(line) for line in printer.statements(loops.steps)],
            "contact_lines": {program.name: {"anchors": program.anchors} | {
                part: [Code(line) for line in printer.statements(
                    tuple(replace(step, anchored=False) for step in getattr(program, part)))]
                for part in ("setup", "contact", "point", "surface", "finish")}
                for program in derivation.contact_programs or ()}}
