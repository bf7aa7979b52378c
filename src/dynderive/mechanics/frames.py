"""Named frames fixed on links: pose, world-frame geometric Jacobian and ``Jdot qd``.

Two routes, as for the dynamics. ``frame_quantities`` derives the symbolic quantities of
DESIGN.md section 4 (``p_<f>``, ``R_<f>`` or planar ``theta_<f>``, ``J_<f>``, ``Jdot_<f>``)
for the sheet and the JSON by composing the joint transforms along the frame's path.
``frame_programs`` writes straight-line programs for the generated module (every robot size):
the links' world poses carried down the tree (``recursive._Tree``), the Jacobian's columns
from the joint axes, and ``Jdot qd`` as the program's forward derivative along ``qd``.

Conventions: the Jacobian maps ``qd`` to the frame's twist in world axes, rows linear (the
velocity of the frame's origin) then angular: planar ``(vx, vy, omega)``, 3-D ``(v, omega)``:
Pinocchio's ``LOCAL_WORLD_ALIGNED``. ``Jdot qd`` is then the frame's classical acceleration
at ``qdd = 0``.

>>> quantities = frame_quantities(robot, table)   # doctest: +SKIP
>>> quantities["J_tool"].shape                     # doctest: +SKIP
(3, 2)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import sympy

from ..model.naming import frame_quantity_names
from ..model.robot import Frame, Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .joint_variables import couplings, scalar_motions
from .program import Program, Vector, _add, _cross, _rotate
from .recursive import _carry, _forward
from .rotations import rpy_matrix
from .spatial import Transform
from .tidy import tidy
from .tree import Tree

#: What the symbolic quantities of a frame are, for the sheet, the terminal and JSON consumers.
FRAME_DESCRIPTIONS = {
    "p": "position of frame {name} in the world",
    "R": "orientation of frame {name} (world axes of its x, y, z)",
    "theta": "angle of frame {name} in the world",
    "J": "world-frame geometric Jacobian of frame {name} (rows: linear, then angular)",
    "Jdot": "time derivative of J_{name} (Jdot qd: the frame's acceleration at qdd = 0)",
}


def describe(key: str) -> str | None:
    """The description of a frame quantity ``p_tool`` etc., or None for other names."""
    kind, _, name = key.partition("_")
    template = FRAME_DESCRIPTIONS.get(kind)
    return template.format(name=name) if template and name else None


def frame_quantities(robot: Robot, table: SymbolTable) -> dict[str, sympy.Matrix]:
    """Symbolic pose, Jacobian and its time derivative of every frame, tidied entry by entry,
    by the names ``naming.frame_quantity_names`` gives."""
    quantities: dict[str, sympy.Matrix] = {}
    q, qd = sympy.Matrix(table.q), table.qd
    pose = _planar_pose if robot.planar else _spatial_pose
    for frame in robot.frames:
        orientation, position, angular = pose(robot, table, frame)
        jacobian = sympy.Matrix.vstack(position.jacobian(q), angular).applyfunc(tidy)
        rate = sum((jacobian.diff(qk) * rk for qk, rk in zip(table.q, qd)), sympy.zeros(*jacobian.shape))
        quantities.update(zip(frame_quantity_names(frame.name, robot.planar),
                              (position.applyfunc(tidy), orientation.applyfunc(tidy), jacobian, rate.applyfunc(tidy))))
    return quantities


def _planar_pose(robot: Robot, table: SymbolTable,
                 frame: Frame) -> tuple[sympy.Matrix, sympy.Matrix, sympy.Matrix]:
    """World angle (a 1 x 1 matrix) and position of a planar frame, and the angular row of its
    Jacobian."""
    index = {name: i for i, name in enumerate(robot.coordinates)}
    angle: sympy.Expr = sympy.Integer(0)
    x: sympy.Expr = sympy.Integer(0)
    y: sympy.Expr = sympy.Integer(0)
    angular = sympy.zeros(1, len(table.q))

    def shift(dx: sympy.Expr, dy: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr]:
        c, s = sympy.cos(angle), sympy.sin(angle)
        return x + c * dx - s * dy, y + s * dx + c * dy

    for joint in robot.path_to(frame.link):
        ox, oy, otheta = (table.expr(e) for e in joint.origin)
        x, y = shift(ox, oy)
        angle = angle + otheta
        if joint.moves:   # the joint type's motion in the plane: a shift in the joint frame, then a turn
            coordinate = index[joint.name]
            motion = joint_types.of(joint).planar(table.q[coordinate], tuple(table.expr(e) for e in joint.axis))
            x, y = shift(*motion.shift)
            angle = angle + motion.angle
            if motion.twist[2] != 0:
                angular[0, coordinate] = motion.twist[2]
    fx, fy, ftheta = (table.expr(e) for e in frame.origin)
    x, y = shift(fx, fy)
    return sympy.Matrix([[angle + ftheta]]), sympy.Matrix([x, y]), angular


def _spatial_pose(robot: Robot, table: SymbolTable, frame: Frame) -> tuple[sympy.Matrix, sympy.Matrix, sympy.Matrix]:
    """World rotation and position of a 3-D frame, and the angular rows of its Jacobian (the
    revolute joints' axes in world axes)."""
    coupling = couplings(robot, table)
    pose = Transform.identity()
    angular = sympy.zeros(3, len(table.q))
    for joint in robot.path_to(frame.link):
        x, y, z, roll, pitch, yaw = (table.expr(e) for e in joint.origin)
        pose = pose * Transform(rpy_matrix(roll, pitch, yaw), sympy.Matrix([x, y, z]))
        if not joint.moves:
            continue
        for motion in scalar_motions(robot, table, joint, coupling):   # one per coordinate it moves with
            c, kind, axis, geometry = motion.coupling, motion.kind, motion.axis, motion.geometry
            (w, _), = kind.columns([c.variable], axis, geometry)
            if any(e != 0 for e in w):   # a turn's angular column: its axis, which its own turn keeps
                column = (pose.R * sympy.Matrix(w) * c.multiplier).applyfunc(tidy)
                present = angular[:, c.coordinate]
                angular[:, c.coordinate] = column if present.is_zero_matrix else (present + column).applyfunc(tidy)
            shift = kind.displacement(sympy.eye(3), [c.variable], axis, geometry)
            pose = pose * Transform(kind.rotation([c.variable], axis, geometry),
                                    sympy.zeros(3, 1) if shift is None else shift)
    x, y, z, roll, pitch, yaw = (table.expr(e) for e in frame.origin)
    pose = pose * Transform(rpy_matrix(roll, pitch, yaw), sympy.Matrix([x, y, z]))
    return pose.R, pose.p, angular


class FramePrograms(NamedTuple):
    """Straight-line programs of one frame: ``transform`` (homogeneous matrix, row by row:
    4 x 4, planar 3 x 3), ``jacobian`` (6 x NV, planar 3 x n, row by row) and
    ``jacobian_dot_qd`` (6, planar 3); a tuple ``(name, transform, jacobian,
    jacobian_dot_qd)`` as well."""

    name: str
    transform: Program
    jacobian: Program
    jacobian_dot_qd: Program


def frame_programs(robot: Robot, table: SymbolTable) -> list[FramePrograms]:
    """The programs of every frame, in the file's order; one program shared by all, so the
    links' world poses are computed once per robot. ``Jdot qd`` is the forward derivative of
    the Jacobian along the motion (each configuration entry's rate: ``qd_k`` for a scalar
    joint, a quaternion's from ``Tree.tangent_seeds``) times ``qd``."""
    if not robot.frames:
        return []
    tree = Tree(robot, table)
    program = tree.program
    poses = tree.world_poses()
    n = tree.size
    built = []
    for frame in robot.frames:
        offset, shift = tree.placement(frame.origin)
        rotation, position = tree.compose(poses[frame.link], offset.tolist(), shift)
        columns = _jacobian_columns(tree, poses, frame.link, position)
        if robot.planar:
            transform = [rotation[0][0], rotation[0][1], position[0], rotation[1][0], rotation[1][1], position[1],
                         0, 0, 1]
            rows = [[columns[j][0][0] for j in range(n)], [columns[j][0][1] for j in range(n)],
                    [columns[j][1][2] for j in range(n)]]
        else:
            transform = [*rotation[0], position[0], *rotation[1], position[1], *rotation[2], position[2], 0, 0, 0, 1]
            rows = [[columns[j][part][axis] for j in range(n)] for part in range(2) for axis in range(3)]
        built.append((frame.name, transform, [[program.let(e) for e in row] for row in rows]))
    rates = along_motion(tree)   # one forward pass for every frame
    results = []
    for name, transform, jacobian in built:
        jdot_qd = rates(jacobian)
        results.append(FramePrograms(name, _part(program, transform), _part(program, [e for row in jacobian for e in row]),
                                     _part(program, jdot_qd)))
    return results


def along_motion(tree: Tree) -> Callable[[Sequence[Sequence[sympy.Expr]]], list[sympy.Expr]]:
    """One forward pass over ``tree``'s program along the motion: each line's tangent, each
    configuration entry's rate ``qd_k`` for a scalar joint, a quaternion's from
    ``Tree.tangent_seeds``. Returns ``rates``: rows of the program's values -> each row's
    tangent times ``qd`` (``Jdot qd`` of a Jacobian's rows), as lines of the program."""
    program, qd = tree.program, tree.table.qd
    trig = {expr: name for name, expr in tree.trig}
    tangent: dict[sympy.Symbol, sympy.Expr] = {}
    for seed, rate in zip(tree.tangent_seeds(), qd):
        for symbol, value in seed.items():
            tangent[symbol] = tangent.get(symbol, 0) + (rate if value is sympy.S.One else program.let(value * rate))
    tangent = {s: program.let(t) for s, t in tangent.items()}
    _carry(program, tangent, trig, [(name, expr, expr.free_symbols) for name, expr in program.lines])

    def rates(rows: Sequence[Sequence[sympy.Expr]]) -> list[sympy.Expr]:
        return [program.let(sum((_forward(e, tangent, trig) * rate for e, rate in zip(row, qd)), sympy.Integer(0)))
                for row in rows]

    return rates


def _part(program: Program, outputs: Sequence[sympy.Expr]) -> Program:
    return Program(lines=list(program.lines), outputs=[sympy.sympify(e) for e in outputs])


Pose = tuple[tuple[Vector, Vector, Vector], Vector]


def _jacobian_columns(tree: Tree, poses: dict[str, Pose], link: str,
                      position: Vector) -> list[tuple[Vector, Vector]]:
    """``(linear, angular)`` world-axes columns of a point fixed on ``link`` at world
    ``position``: a joint column ``(s_w, s_v)`` gives ``(R s_v + w x (p - o), w = R s_w)``
    (a revolute joint ``(z x (p - o), z)``, a prismatic one ``(z, 0)``), with ``R``, ``o``
    its link's world pose; joints off the path give zeros."""
    let = tree.program.let
    zero = sympy.Integer(0)
    columns: list[tuple[Vector, Vector]] = [((zero,) * 3, (zero,) * 3)] * tree.size   # type: ignore[list-item]
    path = {j.name for j in tree.robot.path_to(link)}
    added: set[int] = set()
    for body in tree.bodies:
        if not body.columns or body.joint.name not in path:
            continue
        R, origin = poses[body.link]
        lever = None
        for j, sw, sv in body.columns:
            w = tuple(let(e) for e in _rotate(R, sw))
            if any(e != 0 for e in w) and lever is None:
                lever = tuple(let(a - b) for a, b in zip(position, origin))
            v = _rotate(R, sv) if lever is None else _add(_rotate(R, sv), _cross(w, lever))
            column = (tuple(let(e) for e in v), w)
            if j in added:   # a <mimic> joint on the path of its leader: the sum
                column = tuple(tuple(let(a + b) for a, b in zip(*pair)) for pair in zip(columns[j], column))
            added.add(j)
            columns[j] = column   # type: ignore[assignment]
    return columns
