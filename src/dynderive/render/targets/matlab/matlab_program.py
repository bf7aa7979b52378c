"""The MATLAB printer of the engine's array programs (``mechanics/contact_program.py``): each
value one MATLAB expression (``T(1:3, 1:3)' * Jf(1:3, :)``), each stacked array grown by rows,
the steps needing anchors inside ``if ~isempty(anchors)``; ``SchurSolve`` and ``RowSpaceSolve``
call the file's local ``schur_solve`` and ``row_space_solve`` (the shims, ``matlab_contacts.py``
and ``matlab_loops.py``)."""

from __future__ import annotations

from ....model.array_program import Append, Call, Let, Node, RowSpaceSolve, SchurSolve

#: Program names that MATLAB spells differently (``error`` and ``gamma`` are functions).
M_NAMES = {"error": "err", "gamma": "gam"}


def m_name(name: str) -> str:
    return M_NAMES.get(name, name)


def expression(node: Node) -> str:
    op, args = node.op, node.args
    if op == "name":
        return m_name(args[0])
    if op == "rows":
        rows = f"{args[1] + 1}:{'end' if args[2] is None else args[2]}"
        return f"{expression(args[0])}({rows}, :)" if len(node.shape) == 2 else f"{expression(args[0])}({rows})"
    if op == "position":
        return f"{expression(args[0])}(1:3, 4)"
    if op == "rotation":
        return f"{expression(args[0])}(1:3, 1:3)"
    if op == "transpose":
        return f"{expression(args[0])}'"
    if op == "matmul":
        return f"{_operand(args[0])} * {_operand(args[1])}"
    if op == "cross":
        return f"cross({expression(args[0])}, {expression(args[1])})"
    if op in ("add", "sub"):
        right = expression(args[1])
        right = f"({right})" if args[1].op in ("add", "sub") else right
        return f"{expression(args[0])} {'+' if op == 'add' else '-'} {right}"
    if op == "neg":
        return f"-{_operand(args[0])}"
    if op == "scale":
        return f"{args[0]} * {_operand(args[1])}"
    if op == "stack":
        return f"[{expression(args[0])}; {expression(args[1])}]"
    if op == "vee":
        x = expression(args[0])
        return f"[({x}(3, 2) - {x}(2, 3)) / 2; ({x}(1, 3) - {x}(3, 1)) / 2; ({x}(2, 1) - {x}(1, 2)) / 2]"
    raise ValueError(f"no MATLAB for the operation {op!r}")


def _operand(node: Node) -> str:
    text = expression(node)
    return f"({text})" if node.op in ("add", "sub", "matmul", "neg", "scale") else text


def statements(steps: tuple, package: str, n: int) -> list[str]:
    """The MATLAB lines of ``steps``; ``package`` the robot's (its functions' prefix)."""
    lines: list[str] = []
    anchored = False
    for step in steps:
        if step.anchored != anchored:
            lines.append("if ~isempty(anchors)" if step.anchored else "end")
            anchored = step.anchored
        lines += [("    " if anchored else "") + line for line in _statement(step, package, n)]
    return lines + (["end"] if anchored else [])


def _statement(step, package: str, n: int) -> list[str]:
    if isinstance(step, Call):
        function = "generalized_forces" if step.function == "effort_map" else step.function
        arguments = ("q", "u") if step.function == "effort_map" else step.arguments
        spelled = {"zeros": f"zeros({n}, 1)"}
        text = ", ".join(spelled.get(a, a) for a in arguments)
        return [f"{m_name(step.output)} = {package}.{function}({text}, p);"]
    if isinstance(step, Let):
        return [f"{m_name(step.name)} = {expression(step.value)};"]
    if isinstance(step, Append):
        name = m_name(step.stacked)
        return [f"{name} = [{name}; {expression(step.value)}];"]
    if isinstance(step, SchurSolve):
        b = "[]" if step.b is None else expression(step.b)
        return [f"[{m_name(step.x)}, {m_name(step.multipliers)}] = schur_solve({m_name(step.mass)}, "
                f"{m_name(step.jacobian)}, {b}, {expression(step.target)}, held);"]
    if isinstance(step, RowSpaceSolve):   # b None: zero; held: the contacts' rows add to a known rank
        b = f"zeros({n}, 1)" if step.b is None else expression(step.b)
        rank = "[]" if step.rank is None else step.rank if step.held is None else f"{step.rank} + size({m_name(step.held)}, 1)"
        return [f"[{m_name(step.x)}, {m_name(step.multipliers)}] = row_space_solve({m_name(step.mass)}, "
                f"{m_name(step.jacobian)}, {b}, {expression(step.target)}, {rank});"]
    raise ValueError(f"no MATLAB for the step {step!r}")
