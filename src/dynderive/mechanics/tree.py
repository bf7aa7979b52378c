"""The one tree the recursive algorithms run on (``recursive.py``, ``regressor.py``,
``frames.py``, ``coriolis.py``), for every robot class: fixed or floating base, revolute,
prismatic, fixed, spherical and floating joints, ``<mimic>`` followers, planar robots.

Each link is a ``Body``: its parent joint's transform (``rotation``, ``position``: the joint's
``origin`` then its motion) and the joint's motion ``columns`` ``(index of qd, angular part,
linear part)`` in the link frame, from the joint type (``joint_types``). A scalar joint has one
column, a spherical joint three, a floating joint six (the link's local twist, Pinocchio's
``JointModelFreeFlyer``). A ``<mimic>`` joint has no entry of its own: its variable is
``multiplier * q_leader + offset``, its column its leader's with the axis times the multiplier,
and what several joints put on one column sums (``M = G^T M_joints G``, ``tau = G^T tau_joints``).
A planar robot is a 3-D one moving in the plane z = 0 (rotations about z only).

Conventions: link frames as in the robot file (the joint frame after its motion); spatial
vectors as pairs of 3-vectors, motion ``(omega, v)`` with ``v`` the velocity of the body point
at the frame origin, force ``(n, f)`` with the moment about that origin. Each line records what
it means (``program.Meaning``, keys in ``sheet_recursion.MEANINGS``) where it is built, for the sheet
of a large robot.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import sympy

from ..errors import InputError, Problem
from ..model.robot import Joint, Link, Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .drives import JointDrive, joint_drives
from .joint_variables import unit
from .program import Matrix3, Meaning, Program, Vector, _add, _cross, _rotate, _rotate_back
from .rotations import rpy_matrix
from .spatial import inertia_tensor

ZERO = sympy.Integer(0)
Column = tuple[int, Vector, Vector]


@dataclass
class Body:
    """One link as the algorithms see it: its parent joint's transform and motion columns."""

    link: str
    parent: str
    joint: Joint
    columns: list[Column]        # (index of qd, angular, linear), link frame; none for a fixed joint
    rotation: Matrix3            # link axes in the parent frame (R), with the joint's motion
    position: Vector             # link origin in the parent frame
    mass: sympy.Expr
    first_moment: Vector         # h = m c, link frame
    inertia: tuple[tuple[sympy.Expr, ...], ...]  # about the link origin, link axes
    #: a revolute joint's cosine and sine names and angle (a <mimic> joint: multiplier * q + offset)
    trig: tuple[sympy.Symbol, sympy.Symbol, sympy.Expr] | None = None
    #: per column whose direction changes with the joint's own coordinates (a universal or
    #: 3-D planar joint's), its rate in the link frame: (index of qd, angular, linear)
    rates: list[Column] = field(default_factory=list)

    @property
    def leads(self) -> bool:
        """Whether the joint owns its entries (drive terms, merged per column, enter there)."""
        return bool(self.columns) and self.joint.mimic is None

    @property
    def turns(self) -> bool:
        """Whether some column rotates the link (a revolute, spherical or floating joint)."""
        return any(any(x != 0 for x in w) for _, w, _ in self.columns)

    @property
    def slides(self) -> bool:
        """Whether some column translates the link (a prismatic or floating joint)."""
        return any(any(x != 0 for x in v) for _, _, v in self.columns)


@dataclass(frozen=True)
class Offsets:
    """Where each moving joint's entries start in ``q`` and in ``qd`` (by joint name)."""

    q: dict[str, int]
    v: dict[str, int]


def offsets(robot: Robot) -> Offsets:
    return Offsets(*robot.offsets())


def not_built(robot: Robot, what: str) -> InputError:
    """The error for a part of the derivation not built for robots with a quaternion in their
    configuration (exit 2), at the first such joint."""
    joint = next(j for j in robot.joints if j.multi)
    line, column = robot.positions.get(f"joint:{joint.name}", (1, 1))
    return InputError(Problem(robot.source, line, column, f"{what}: not built yet for floating-base robots "
                              f"(joint '{joint.name}' is {joint.type})"))


def efforts(robot: Robot, table: SymbolTable) -> list[sympy.Expr]:
    """``Y``: each effort symbol at its column of ``qd``, zero elsewhere (an actuated floating
    joint's six, the wrench on its child in its frame; a spherical joint's three)."""
    Y: list[sympy.Expr] = [ZERO] * robot.velocity_count
    for name, column in zip(robot.efforts, robot.effort_columns()):
        Y[column] = table.efforts[name]
    return Y


def origin_inertia(robot: Robot, table: SymbolTable, link: Link,
                   mass: sympy.Expr) -> tuple[list[sympy.Expr], list[list[sympy.Expr]]]:
    """A link's centre of mass ``c`` (a planar robot's with z = 0) and its inertia about the
    link origin, ``I_C + mass (|c|^2 1 - c c^T)`` (only the inertia about z enters planar motion)."""
    com = [table.expr(e) for e in link.com]
    if robot.planar:
        com.append(ZERO)
        moments = (ZERO, ZERO, table.expr(link.inertia[0]), ZERO, ZERO, ZERO)
    else:
        moments = tuple(table.expr(e) for e in link.inertia)
    about_com, square = inertia_tensor(moments), sum(c * c for c in com)
    return com, [[about_com[i, j] + mass * ((square if i == j else 0) - com[i] * com[j]) for j in range(3)]
                 for i in range(3)]


def gravity(robot: Robot, table: SymbolTable) -> list[sympy.Expr]:
    """The world's gravity as a 3-vector (a planar robot's with z = 0)."""
    return [table.expr(e) for e in robot.gravity] + ([ZERO] if robot.planar else [])


class Tree:
    """The robot's links in an order where parents come first, with their transforms, in a
    program of their own lines (sines and cosines first)."""

    def __init__(self, robot: Robot, table: SymbolTable):
        self.robot, self.table, self.program = robot, table, Program()
        self.offsets = offsets(robot)
        self.size = robot.velocity_count
        depth = {link.name: len(robot.path_to(link.name)) for link in robot.links}
        order = sorted(robot.links, key=lambda link: depth[link.name])  # stable: file order per depth
        self.bodies: list[Body] = []
        for link in order:
            self.bodies.append(self._body(link, robot.parent_joint(link.name)))
        self.by_link = {b.link: b for b in self.bodies}
        #: drive terms by column: armature joins M[i, i] (CRBA) and Ia qdd_i the joint force
        #: (Newton-Euler), springs k (q_i - rest) the joint force
        self.drives: dict[int, JointDrive] = {d.coordinate: d for d in joint_drives(robot, table)}
        #: each vector-space column's coordinate in q (a universal joint's two)
        self.coordinate = {self.offsets.v[j.name] + k: table.q[self.offsets.q[j.name] + k]
                           for j in robot.joints if j.owns and not j.multi for k in range(j.sizes[1])}
        #: links welded to the world (no moving joint above them): they carry no dynamics
        self.static = {"world"} | {link.name for link in robot.links
                                   if not any(j.moves for j in robot.path_to(link.name))}
        self.trig = [line for b in self.bodies if b.trig is not None
                     for line in ((b.trig[0], sympy.cos(b.trig[2])), (b.trig[1], sympy.sin(b.trig[2])))]
        # the bodies' constant lines were recorded while building the tree; sines and cosines
        # are inputs to them only through the rotation entries, which come later in the list
        self.program.lines[0:0] = self.trig

    def copy(self) -> Tree:
        """The same links, with a program of the links' lines only: each program of the module
        starts from it (building the links once, not once per program; the same lines)."""
        other = object.__new__(Tree)
        other.__dict__.update(self.__dict__)
        p = self.program
        other.program = Program(lines=list(p.lines), _count=p._count, _known=dict(p._known),
                                labels=dict(p.labels), records=list(p.records))
        return other

    def _body(self, link, joint: Joint) -> Body:   # noqa: ANN001
        expr, let, planar = self.table.expr, self.program.let, self.robot.planar
        origin, position = self.placement(joint.origin)
        motion, kind = sympy.eye(3), joint_types.of(joint)
        columns: list[Column] = []
        trig = None
        geometry = joint_types.geometry_of(joint, expr)
        rates: list[Column] = []
        if kind.nq > 1:   # entries of their own (<mimic> couples one-coordinate joints only)
            qi, vi = self.offsets.q[joint.name], self.offsets.v[joint.name]
            q = self.table.q[qi:qi + kind.nq]
            axis = unit(tuple(expr(e) for e in joint.axis)) if joint.kind.takes_axis else ()
            shift = kind.displacement(origin, q, axis, geometry)
            position = position if shift is None else [p + d for p, d in zip(position, shift)]
            motion = kind.rotation(q, axis, geometry)
            columns = [(vi + k, w, v) for k, (w, v) in enumerate(kind.columns(q, axis, geometry))]
            changing = kind.column_rates(q, self.table.qd[vi:vi + kind.nv], axis, geometry)
            rates = [] if changing is None else [(vi + k, w, v) for k, (w, v) in enumerate(changing)]
        elif joint.moves:   # variable multiplier * q_leader + offset (1 and 0 for a leader), column the leader's
            leader, multiplier, offset = self.robot.driver(joint)
            coordinate = self.offsets.v[leader]
            m = expr(multiplier)
            q = m * self.table.q[self.offsets.q[leader]] + expr(offset)
            if planar:   # the planar unit twist (vx, vy, omega) as a 3-D axis
                vx, vy, w = kind.planar(ZERO, tuple(expr(e) for e in joint.axis)).twist  # type: ignore[arg-type]
                axis = (ZERO, ZERO, w) if kind.turns else (vx, vy, ZERO)
            else:
                axis = unit(tuple(expr(e) for e in joint.axis))
            if kind.turns:   # sine and cosine names: a <mimic> joint's of its own variable
                suffix = "" if joint.mimic is None else f"_{len(self.bodies)}"
                cos, sin = (sympy.Symbol(f"_{f}{coordinate}{suffix}") for f in ("cos", "sin"))
                # by -q about the opposite axis if SymPy would pull the sign out of sin(q)
                turn, about = (-q, tuple(-a for a in axis)) if q.could_extract_minus_sign() else (q, axis)
                angle = sympy.Dummy("angle")
                motion = kind.rotation([angle], about, geometry).subs({sympy.cos(angle): cos, sympy.sin(angle): sin})
                trig = (cos, sin, turn)
            shift = kind.displacement(origin, [q], axis, geometry)   # a prismatic joint's (origin axis) q
            position = position if shift is None else [p + d for p, d in zip(position, shift)]
            scaled = tuple(m * a for a in axis) if m != 1 else axis   # motion per unit rate of the leader
            columns = [(coordinate, *kind.columns([q], scaled, geometry)[0])]
        rotation = origin * motion
        name = link.name
        R = tuple(tuple(let(rotation[i, j], Meaning("R", name, (i, j))) for j in range(3)) for i in range(3))
        mass = let(expr(link.mass), Meaning("m", name))
        com, about_origin = origin_inertia(self.robot, self.table, link, mass)
        inertia = tuple(tuple(let(e, Meaning("I", name, (i, j))) for j, e in enumerate(row))
                        for i, row in enumerate(about_origin))
        return Body(link.name, joint.parent, joint, columns, R,  # type: ignore[arg-type]
                    self.program.vector(position, Meaning("p", name)), mass,
                    self.program.vector([mass * c for c in com], Meaning("h", name)), inertia, trig,
                    rates)  # type: ignore[arg-type]

    def placement(self, values: Sequence[object]) -> tuple[sympy.Matrix, list[sympy.Expr]]:
        """A joint's or a frame's ``origin`` (planar: x, y, yaw; the plane z = 0 of a 3-D model,
        rotations about z only) as its rotation and position in its link's frame."""
        entries = [self.table.expr(e) for e in values]
        if self.robot.planar:
            entries = [entries[0], entries[1], ZERO, ZERO, ZERO, entries[2]]
        return rpy_matrix(*entries[3:]), entries[:3]

    def compose(self, outer: tuple[Matrix3, Vector], rotation: Sequence[Sequence[sympy.Expr]],
                position: Sequence[sympy.Expr]) -> tuple[Matrix3, Vector]:
        """The pose ``(R, p)`` of a frame at ``rotation``, ``position`` in a frame at pose
        ``outer`` (lines of this tree's program)."""
        let, (R_outer, p_outer) = self.program.let, outer
        R = tuple(tuple(let(sum((R_outer[i][k] * rotation[k][j] for k in range(3)), ZERO)) for j in range(3))
                  for i in range(3))
        return R, tuple(let(e) for e in _add(p_outer, _rotate(R_outer, position)))   # type: ignore[return-value]

    def force_to_parent(self, body: Body, n: Sequence[sympy.Expr], f: Sequence[sympy.Expr],
                        column: int = -1) -> tuple[Vector, Vector]:
        """A force (moment about the link origin, force) in the parent's frame: the joint's
        force (``f_up``, ``n_up``), or CRBA's ``column`` at the parent (``Fcol``, ``Ncol``)."""
        let = self.program.vector
        if column < 0:
            force, moment = Meaning("f_up", body.link), Meaning("n_up", body.link)
        else:
            force, moment = Meaning("Fcol", body.parent, column=column), Meaning("Ncol", body.parent, column=column)
        f_parent = let(_rotate(body.rotation, f), force)
        n_parent = let(_add(_rotate(body.rotation, n), _cross(body.position, f_parent)), moment)
        return n_parent, f_parent

    def motion_from_parent(self, body: Body, w: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
                           meaning: tuple[str, str] | None = None) -> tuple[Vector, Vector]:
        """A motion vector of the parent's frame seen in this link's frame (``meaning``: the
        quantities of its angular and linear parts, ``MEANINGS``)."""
        let = self.program.vector
        angular, linear = (None, None) if meaning is None else (Meaning(meaning[0], body.link), Meaning(meaning[1], body.link))
        return (let(_rotate_back(body.rotation, w), angular),
                let(_rotate_back(body.rotation, _add(v, _cross(w, body.position))), linear))

    def carry_columns(self, body: Body, above: dict[int, tuple[Vector, Vector]]) -> dict[int, tuple[Vector, Vector]]:
        """The motion columns ``(w, v)`` of the joints above ``body`` (``above``, by column of
        ``qd``, in its parent's frame) in its frame, with its own joint's: a <mimic> joint's
        summed into its leader's column (lines of this tree's program)."""
        vec = self.program.vector
        own = {j: self.motion_from_parent(body, w, v) for j, (w, v) in above.items()}
        for j, sw, sv in body.columns:
            own[j] = (sw, sv) if j not in own else (vec(_add(own[j][0], sw)), vec(_add(own[j][1], sv)))
        return own

    def world_poses(self) -> dict[str, tuple[Matrix3, Vector]]:
        """Each link frame's world rotation and origin, carried from parent to child (lines of
        this tree's program)."""
        one = sympy.Integer(1)
        identity = ((one, ZERO, ZERO), (ZERO, one, ZERO), (ZERO, ZERO, one))
        poses: dict[str, tuple[Matrix3, Vector]] = {"world": (identity, (ZERO, ZERO, ZERO))}  # type: ignore[dict-item]
        for body in self.bodies:
            poses[body.link] = self.compose(poses[body.parent], body.rotation, body.position)
        return poses

    def tangent_seeds(self) -> list[dict[sympy.Symbol, sympy.Expr]]:
        """Per velocity column, the tangent of the configuration along it, its joint type's
        ``tangent_seed``: ``q_i = 1`` for a scalar joint; for a floating or spherical joint,
        that of ``integrate(q, e_k h)`` at h = 0 (lines of this tree's program)."""
        seeds: list[dict[sympy.Symbol, sympy.Expr]] = [{} for _ in range(self.size)]
        for joint in (j for j in self.robot.joints if j.owns):   # a <mimic> joint moves with its leader's
            kind = joint_types.of(joint)
            qi, vi = self.offsets.q[joint.name], self.offsets.v[joint.name]
            seeds[vi:vi + kind.nv] = kind.tangent_seed(self.table.q[qi:qi + kind.nq], self.program.let)
        return seeds
