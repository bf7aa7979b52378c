"""Closed loops as constraints on the one tree: straight-line programs of the loop residual
``a(q)``, its Jacobian ``A`` on the velocity space and the drift ``Adot qd``, for robots with a
quaternion in ``q`` (a floating base, spherical joints), whose symbolic route (``loops.py``,
Lagrange's equations on the coordinates) does not apply.

A loop is then what a contact is: rows on the twists of frames, here two frames fixed on the
tree (the loop frame on the parent link and the one on the child) instead of one frame and the
world. The rows say what ``loops.py`` says (DESIGN.md section 13):

* every type but prismatic: the gap ``p_c - p_p`` between the frame origins, world axes (3);
  its Jacobian the difference of the frames' linear rows (Pinocchio ``LOCAL_WORLD_ALIGNED``);
* revolute: and the parent's axis ``a = R_p axis`` stays normal to the child's normals
  ``b_k = R_c n_k`` (2): rows ``a . b_k``, Jacobian ``(a x b_k)^T (J_w,p - J_w,c)``;
* prismatic: no relative rotation, ``vee(R_rel - R_rel^T)`` with ``R_rel = R_p^T R_c`` (3),
  Jacobian ``(tr(R_rel) I - R_rel) R_p^T (J_w,c - J_w,p)``; no offset across the axis,
  ``n_k . R_p^T (p_c - p_p)`` (2), Jacobian ``(R_p n_k)^T (J_v,c - J_v,p + [p_c - p_p]x J_w,p)``.

``Adot qd`` is the Jacobian rows' forward derivative along the motion (``frames.along_motion``,
a quaternion's rate from the joint type), so ``A qdd + Adot qd`` is the rows' acceleration.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import sympy

from ..model.joint_kinds import joint_kind
from ..model.robot import LoopJoint, Robot
from ..model.symbols import SymbolTable
from .frames import _jacobian_columns, _part, along_motion
from .joint_variables import unit
from .loops import _normals
from .program import Program, Vector, _cross
from .recursive import _carry, _forward
from .tree import Tree

ZERO = sympy.Integer(0)


class LoopPrograms(NamedTuple):
    """The loops' programs over one tree: ``constraints`` (k), ``jacobian`` (k x NV, row by row)
    and ``jacobian_dot_qd`` (k); ``rows`` says what each row is, ``(loop joint, description)``."""

    constraints: Program
    jacobian: Program
    jacobian_dot_qd: Program
    rows: list[tuple[str, str]]


def _dot(a: Sequence[sympy.Expr], b: Sequence[sympy.Expr]) -> sympy.Expr:
    return sum((x * y for x, y in zip(a, b)), ZERO)


def _transpose(R: Sequence[Sequence[sympy.Expr]]) -> list[list[sympy.Expr]]:
    return [[R[j][i] for j in range(3)] for i in range(3)]


def _times(R: Sequence[Sequence[sympy.Expr]], v: Sequence[sympy.Expr]) -> list[sympy.Expr]:
    return [_dot(row, v) for row in R]


def open_tree_note(robot: Robot, programs: LoopPrograms) -> str:
    """The note of a robot whose loops are closed by the generated module only, at its first loop."""
    first = robot.loops[0].name
    where = robot.positions.get(f"loop:{first}", robot.positions.get("loops", (1, 1)))
    return (f"{robot.source}:{where[0]}:{where[1]}: note: the {len(programs.rows)} loop constraint rows are "
            "closed by the generated modules' forward_dynamics; the sheets show the open tree's equations")


class LoopLinearization(NamedTuple):
    """What ``linearize`` of a robot with quaternions in q and closed loops needs beyond
    Newton-Euler's derivatives, on the tangent space (along ``Tree.tangent_seeds``, as
    ``inverse_dynamics_derivatives``): ``force`` = d(A^T lambda)/dq at fixed ``multipliers``
    (NV x NV), ``acceleration`` = d(A qdd + Adot qd)/dq at fixed qdd (k x NV) and ``rate`` =
    d(Adot qd)/dqd (k x NV), each row by row."""

    multipliers: list[sympy.Symbol]
    force: Program
    acceleration: Program
    rate: Program


def loop_programs(robot: Robot, table: SymbolTable) -> LoopPrograms:
    """The programs of every loop joint's rows, in the file's order (3-D robots)."""
    tree, residuals, jacobian, drift, rows = _built(robot, table)
    program = tree.program
    return LoopPrograms(_part(program, residuals), _part(program, [e for row in jacobian for e in row]),
                        _part(program, drift), rows)


def loop_linearization_programs(robot: Robot, table: SymbolTable) -> LoopLinearization:
    """The loops' terms of ``linearize`` (``LoopLinearization``): the rows' program, then one
    forward pass over it per velocity column (the configuration's tangent along it, then each
    velocity), as ``linearization.inverse_dynamics_derivatives_program`` differentiates
    Newton-Euler's."""
    tree, _, jacobian, drift, _ = _built(robot, table)
    program, n, k = tree.program, tree.size, len(jacobian)
    multipliers = [sympy.Symbol(f"lambda_g{i}") for i in range(1, k + 1)]
    force = [sum((jacobian[r][c] * multipliers[r] for r in range(k)), ZERO) for c in range(n)]        # A^T lambda
    acceleration = [sum((e * a for e, a in zip(jacobian[r], table.qdd)), ZERO) + drift[r] for r in range(k)]
    trig = {expr: name for name, expr in tree.trig}
    seeds = tree.tangent_seeds()
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    partials: dict[tuple[sympy.Expr, sympy.Symbol], sympy.Expr] = {}
    by_coordinate, by_rate = [], []
    for seed in seeds:
        tangent = dict(seed)
        _carry(program, tangent, trig, lines, partials)
        by_coordinate.append(([program.let(_forward(e, tangent, trig)) for e in force],
                              [program.let(_forward(e, tangent, trig)) for e in acceleration]))
    for rate in table.qd:
        tangent = {rate: sympy.Integer(1)}
        _carry(program, tangent, trig, lines, partials)
        by_rate.append([program.let(_forward(e, tangent, trig)) for e in drift])
    return LoopLinearization(
        multipliers,
        _part(program, [by_coordinate[c][0][i] for i in range(n) for c in range(n)]),
        _part(program, [by_coordinate[c][1][r] for r in range(k) for c in range(n)]),
        _part(program, [by_rate[c][r] for r in range(k) for c in range(n)]))


def _built(robot: Robot, table: SymbolTable) -> tuple[Tree, list[sympy.Expr], list[list[sympy.Expr]],
                                                      list[sympy.Expr], list[tuple[str, str]]]:
    """The tree and its program's lines of the loops' residuals, Jacobian rows (k x NV) and drift
    (Adot qd), and what each row is."""
    tree = Tree(robot, table)
    let = tree.program.let
    poses = tree.world_poses()
    n = tree.size

    def end(link: str, origin: Sequence[object]) -> tuple[list[list[sympy.Expr]], Vector, list[list[sympy.Expr]]]:
        """World rotation and origin of a loop frame, and its Jacobian's rows (v, then w)."""
        offset, shift = tree.placement(origin)
        R, p = tree.compose(poses[link], offset.tolist(), shift)
        if link == "world":
            return [list(r) for r in R], p, [[ZERO] * n for _ in range(6)]
        columns = _jacobian_columns(tree, poses, link, p)
        return [list(r) for r in R], p, [[columns[j][part][axis] for j in range(n)] for part in range(2) for axis in range(3)]

    residuals: list[sympy.Expr] = []
    jacobian: list[list[sympy.Expr]] = []
    rows: list[tuple[str, str]] = []
    for loop in robot.loops:
        for description, value, row in _rows(loop, end(loop.parent, loop.origin), end(loop.child, loop.child_origin),
                                             table, n):
            residuals.append(let(value))
            jacobian.append([let(e) for e in row])
            rows.append((loop.name, description))
    drift = along_motion(tree)(jacobian)   # after every Jacobian line: one pass covers them all
    return tree, residuals, jacobian, drift, rows


def _rows(loop: LoopJoint, parent: tuple[list[list[sympy.Expr]], Vector, list[list[sympy.Expr]]],
          child: tuple[list[list[sympy.Expr]], Vector, list[list[sympy.Expr]]], table: SymbolTable,
          n: int) -> list[tuple[str, str, list[sympy.Expr]]]:
    """``(description, residual, Jacobian row)`` of each row of ``loop`` from its two frames."""
    (R_p, p_p, J_p), (R_c, p_c, J_c) = parent, child
    gap = [c - p for c, p in zip(p_c, p_p)]
    linear = [[J_c[i][j] - J_p[i][j] for j in range(n)] for i in range(3)]          # d gap / dt
    angular = [[J_c[3 + i][j] - J_p[3 + i][j] for j in range(n)] for i in range(3)]  # w_c - w_p
    out: list[tuple[str, str, list[sympy.Expr]]] = []
    translation, rotation = joint_kind(loop.type).frees or ("all", "all")
    if translation == "none":
        out += [(f"{axis} of the gap between the loop frames", gap[i], linear[i]) for i, axis in enumerate("xyz")]
    if rotation == "all":
        return out
    axis = unit(tuple(table.expr(e) for e in loop.axis))
    normals = [list(b) for b in _normals(axis)]   # type: ignore[arg-type]
    if rotation == "axis":
        a = _times(R_p, axis)
        for k, b in enumerate(normals):
            b_world = _times(R_c, b)
            lever = _cross(a, b_world)
            row = [-_dot(lever, [angular[i][j] for i in range(3)]) for j in range(n)]
            out.append((f"axis alignment ({('first', 'second')[k]} normal)", _dot(a, b_world), row))
        return out
    R_pt = _transpose(R_p)
    relative = [[_dot(R_pt[i], [R_c[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]
    trace = relative[0][0] + relative[1][1] + relative[2][2]
    spin = [[_dot(R_pt[i], [angular[k][j] for k in range(3)]) for j in range(n)] for i in range(3)]  # R_p^T (w_c - w_p)
    for name, (k, j), r in zip("xyz", ((2, 1), (0, 2), (1, 0)), range(3)):
        row = [(trace * spin[r][c] - _dot(relative[r], [spin[i][c] for i in range(3)])) for c in range(n)]
        out.append((f"relative rotation about {name}", relative[k][j] - relative[j][k], row))
    offset = [c - p for c, p in zip(p_c, p_p)]
    for k, b in enumerate(normals):
        b_world = _times(R_p, b)
        # d/dt R_p^T gap = R_p^T (v_c - v_p + gap x w_p)
        row = [_dot(b_world, [linear[i][c] + _cross(offset, [J_p[3 + m][c] for m in range(3)])[i] for i in range(3)])
               for c in range(n)]
        out.append((f"offset across the sliding axis ({('first', 'second')[k]} normal)",
                    _dot(b_world, offset), row))
    return out
