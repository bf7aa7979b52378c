"""Straight-line programs of a floating-base robot (DESIGN.md section 10): the
composite-rigid-body algorithm (M), recursive Newton-Euler (inverse dynamics, gravity) and an
L^T D L solve (forward dynamics), as in ``recursive.py`` but with a free-flyer root.

The ``floating`` joint's configuration is ``[x, y, z, qx, qy, qz, qw]`` (Pinocchio's): the
joint frame's position in its parent (after the joint's ``origin``) and a unit quaternion, whose
rotation matrix is a polynomial in ``qx..qw`` (Eigen's ``Quaternion::toRotationMatrix``: no
trigonometry, no normalization). Its velocity ``[vx, vy, vz, wx, wy, wz]`` is the link frame's
linear and angular velocity in the link frame (local), so its motion subspace is the 6 x 6
identity and its joint acceleration the spatial acceleration ``qdd`` itself. A ``spherical``
joint (anywhere in the tree) is its rotational part: configuration ``[qx, qy, qz, qw]``, velocity
the local angular velocity ``[wx, wy, wz]``, motion subspace the three angular unit columns
(Pinocchio's ``JointModelSpherical``). Every other joint
is revolute, prismatic or fixed as in ``recursive.py``; a joint's coordinate is an index into
``q`` (NQ entries), its column an index into ``qd`` (NV entries). A ``<mimic>`` joint has
neither: its variable is ``multiplier * q_leader + offset``, its column its leader's with its
axis times the multiplier, and what several joints put on one column sums (``M = G^T
M_joints G``, ``tau = G^T tau_joints``), as in ``recursive.py``.

The Coriolis matrix, the derivatives of inverse dynamics and the regressor are in
``floating_derivatives.py``. Damping and Coulomb friction of the scalar joints and wrenches
at frames are not in these programs: the module computes ``F - sum J^T w`` and the forward
dynamics takes it as inputs (``recursive.friction_symbols``), as a fixed-base robot's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy

from ..errors import InputError, Problem
from ..model.robot import Joint, Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .joint_types.quaternion import quaternion_matrix as quaternion_matrix  # its home before joint types
from .joints import unit
from .program import Matrix3, Program, Vector, _add, _cross, _dot, _rotate, _rotate_back
from .recursive import _gravity, add_to_parent, body_force
from .spatial import inertia_tensor, rpy_matrix

_ZERO = sympy.Integer(0)


def not_built(robot: Robot, what: str) -> InputError:
    """The error for a part of the derivation not built yet for floating-base robots (exit
    2), at the floating joint."""
    joint = next(j for j in robot.joints if j.multi)
    line, column = robot.positions.get(f"joint:{joint.name}", (1, 1))
    return InputError(Problem(robot.source, line, column, f"{what}: not built yet for floating-base robots "
                              f"(joint '{joint.name}' is {joint.type})"))


@dataclass
class _Body:
    """One link: its parent joint's transform, and the joint's motion columns ``(index of qd,
    angular part, linear part)`` in the link frame (none for a fixed joint)."""

    link: str
    parent: str
    columns: list[tuple[int, Vector, Vector]]
    rotation: Matrix3            # link axes in the parent frame, with the joint's motion
    position: Vector             # link origin in the parent frame
    mass: sympy.Expr
    first_moment: Vector         # h = m c, link frame
    inertia: tuple[tuple[sympy.Expr, ...], ...]  # about the link origin, link axes
    #: a scalar joint's drive terms ``(multiplier, armature, stiffness, rest, variable)``, the
    #: joint's variable being ``multiplier * q_leader + offset`` (1 and ``q`` for a joint with a
    #: coordinate of its own); None: the joint declares none
    drive: tuple[sympy.Expr, ...] | None = None


@dataclass(frozen=True)
class Offsets:
    """Where each moving joint's entries start in ``q`` and in ``qd`` (by joint name)."""

    q: dict[str, int]
    v: dict[str, int]


def offsets(robot: Robot) -> Offsets:
    return Offsets(*robot.offsets())


class FloatingTree:
    """The links of a floating-base robot, parents first, with their transforms."""

    def __init__(self, robot: Robot, table: SymbolTable):
        self.robot, self.table, self.program = robot, table, Program()
        self.offsets = offsets(robot)
        self.trig: list[tuple[sympy.Symbol, sympy.Expr]] = []
        depth = {link.name: len(robot.path_to(link.name)) for link in robot.links}
        order = sorted(robot.links, key=lambda link: depth[link.name])
        self.bodies = [self._body(link, robot.parent_joint(link.name)) for link in order]
        self.program.lines[0:0] = self.trig   # sines and cosines first

    def copy(self) -> FloatingTree:
        """The same links, with a program of the links' lines only: each program of the module
        starts from it (building the links once, not once per program; the same lines)."""
        other = object.__new__(FloatingTree)
        other.__dict__.update(self.__dict__)
        other.program = Program(lines=list(self.program.lines), _count=self.program._count,
                                _known=dict(self.program._known))
        return other

    def _value(self, text: object) -> sympy.Expr:
        return _ZERO if text is None else self.table.expr(text)

    def _body(self, link, joint: Joint) -> _Body:
        expr, let = self.table.expr, self.program.let
        x, y, z, roll, pitch, yaw = (expr(e) for e in joint.origin)
        origin = rpy_matrix(roll, pitch, yaw)
        position = sympy.Matrix([x, y, z])
        motion = sympy.eye(3)
        columns: list[tuple[int, Vector, Vector]] = []
        drive = None
        kind = joint_types.of(joint)
        if kind.nv > 1:   # floating, spherical: entries of their own (<mimic> couples scalar joints only)
            qi, vi = self.offsets.q[joint.name], self.offsets.v[joint.name]
            q = self.table.q[qi:qi + kind.nq]
            shift = kind.displacement(origin, q, ())
            position = position if shift is None else position + shift
            motion = kind.rotation(q, ())
            columns = [(vi + k, w, v) for k, (w, v) in enumerate(kind.columns(()))]
        elif joint.moves:   # a <mimic> joint: variable multiplier * q_leader + offset, column the leader's
            leader, multiplier, offset = self.robot.driver(joint)
            qi, vi = self.offsets.q[leader], self.offsets.v[leader]
            axis = unit(tuple(expr(e) for e in joint.axis))
            m = expr(multiplier)
            q = m * self.table.q[qi] + expr(offset)
            if kind.turns and joint.mimic is None:
                cos, sin = sympy.Symbol(f"_cos{vi}"), sympy.Symbol(f"_sin{vi}")
                self.trig += [(cos, sympy.cos(q)), (sin, sympy.sin(q))]
                motion = kind.rotation([q], axis).subs({sympy.cos(q): cos, sympy.sin(q): sin})
            elif kind.turns:   # the sine and cosine of the follower's own variable
                cos, sin = (sympy.Symbol(f"_{f}{vi}_{len(self.trig)}") for f in ("cos", "sin"))
                # by -q about the opposite axis if SymPy would pull the sign out of sin(q)
                turn, about = (-q, tuple(-a for a in axis)) if q.could_extract_minus_sign() else (q, axis)
                self.trig += [(cos, sympy.cos(turn)), (sin, sympy.sin(turn))]
                angle = sympy.Dummy("angle")
                motion = kind.rotation([angle], about).subs({sympy.cos(angle): cos, sympy.sin(angle): sin})
            else:   # (origin axis) q
                position = position + kind.displacement(origin, [q], axis)
            scaled = tuple(m * a for a in axis) if m != 1 else axis   # motion per unit rate of the leader
            columns = [(vi, *kind.columns(scaled)[0])]
            if joint.driven:
                drive = (m, self._value(joint.armature), self._value(joint.stiffness), self._value(joint.rest), q)
        rotation = origin * motion
        R = tuple(tuple(let(rotation[i, j]) for j in range(3)) for i in range(3))
        mass = let(expr(link.mass))
        com = [expr(e) for e in link.com]
        about_com = inertia_tensor(tuple(expr(e) for e in link.inertia))
        square = sum(c * c for c in com)
        inertia = tuple(tuple(let(about_com[i, j] + mass * ((square if i == j else 0) - com[i] * com[j]))
                              for j in range(3)) for i in range(3))
        return _Body(link.name, joint.parent, columns, R, self.program.vector(list(position)),  # type: ignore[arg-type]
                     mass, self.program.vector([mass * c for c in com]), inertia, drive)

    def force_to_parent(self, body: _Body, n: Sequence[sympy.Expr], f: Sequence[sympy.Expr]) -> tuple[Vector, Vector]:
        """A force (moment about the link origin, force) in the parent's frame."""
        vec = self.program.vector
        f_parent = vec(_rotate(body.rotation, f))
        return vec(_add(_rotate(body.rotation, n), _cross(body.position, f_parent))), f_parent

    def motion_from_parent(self, body: _Body, w: Sequence[sympy.Expr], v: Sequence[sympy.Expr]) -> tuple[Vector, Vector]:
        """A motion vector of the parent's frame seen in this link's frame."""
        vec = self.program.vector
        return vec(_rotate_back(body.rotation, w)), vec(_rotate_back(body.rotation, _add(v, _cross(w, body.position))))


def _times(vector: Sequence[sympy.Expr], scalar: sympy.Expr) -> tuple[sympy.Expr, ...]:
    return tuple(x * scalar for x in vector)


def mass_matrix(tree: FloatingTree) -> list[list[sympy.Expr]]:
    """CRBA: composite inertias from the leaves up, then ``M_ij = S_i . (X^* I^c_j S_j)``."""
    let, vec = tree.program.let, tree.program.vector
    n = tree.robot.velocity_count
    composite = {b.link: (b.mass, b.first_moment, b.inertia) for b in tree.bodies}
    by_link = {b.link: b for b in tree.bodies}
    for body in reversed(tree.bodies):
        if body.parent == "world":
            continue
        add_to_parent(tree.program, composite, body)
    M = [[_ZERO] * n for _ in range(n)]
    for body in tree.bodies:
        mass, h, inertia = composite[body.link]
        for j, sw, sv in body.columns:
            # the composite body's momentum per unit rate of column j: (I sw + h x sv, m sv + sw x h)
            nm = vec(_add(_rotate(inertia, sw), _cross(h, sv)))   # type: ignore[arg-type]
            f = vec(_add(_times(sv, mass), _cross(sw, h)))
            armature = body.drive[0] ** 2 * body.drive[1] if body.drive is not None else 0
            for i, tw, tv in body.columns:
                if i <= j:   # a coordinate moving several joints (<mimic>) sums their entries: G^T M_joints G
                    M[i][j] = M[j][i] = let(M[i][j] + _dot(tw, nm) + _dot(tv, f) + (armature if i == j else 0))
            current = body
            while current.parent != "world":
                nm, f = tree.force_to_parent(current, nm, f)
                current = by_link[current.parent]
                for i, tw, tv in current.columns:
                    entry = _dot(tw, nm) + _dot(tv, f)   # i == j: a leader above its follower
                    M[i][j] = M[j][i] = let(M[i][j] + (2 * entry if i == j else entry))
    return M


def motions(tree: FloatingTree, qd: Sequence[sympy.Expr], qdd: Sequence[sympy.Expr],
            gravity: bool = True) -> dict[str, tuple[Vector, Vector, Vector, Vector]]:
    """Newton-Euler's outward pass: each link's ``(w, v, alpha, a)`` in its own frame, by link
    name (gravity as an upward acceleration of the world, unless ``gravity`` is false)."""
    vec = tree.program.vector
    zero = (_ZERO,) * 3
    lift = vec([-g for g in _gravity(tree.robot, tree.table)]) if gravity else zero
    motion = {"world": (zero, zero, zero, lift)}
    for body in tree.bodies:
        w, v, alpha, acc = motion[body.parent]
        w, v = tree.motion_from_parent(body, w, v)
        alpha, acc = tree.motion_from_parent(body, alpha, acc)
        if body.columns:   # joint velocity S qd = (wj, vj); a = X a_p + S qdd + (X v_p) x S qd
            wj = [sum((sw[k] * qd[j] for j, sw, _ in body.columns), _ZERO) for k in range(3)]
            vj = [sum((sv[k] * qd[j] for j, _, sv in body.columns), _ZERO) for k in range(3)]
            aw = [sum((sw[k] * qdd[j] for j, sw, _ in body.columns), _ZERO) for k in range(3)]
            av = [sum((sv[k] * qdd[j] for j, _, sv in body.columns), _ZERO) for k in range(3)]
            alpha = vec(_add(alpha, _add(aw, _cross(w, wj))))
            acc = vec(_add(acc, _add(av, _add(_cross(w, vj), _cross(v, wj)))))
            w, v = vec(_add(w, wj)), vec(_add(v, vj))
        motion[body.link] = (w, v, alpha, acc)
    return motion


def newton_euler(tree: FloatingTree, qd: Sequence[sympy.Expr], qdd: Sequence[sympy.Expr]) -> list[sympy.Expr]:
    """RNEA: ``M qdd + C qd + N`` (gravity as an upward acceleration of the world)."""
    vec = tree.program.vector
    motion = motions(tree, qd, qdd)
    forces = {b.link: body_force(vec, b.mass, b.first_moment, b.inertia, *motion[b.link]) for b in tree.bodies}
    tau: list[sympy.Expr] = [_ZERO] * tree.robot.velocity_count
    for body in reversed(tree.bodies):
        n, f = forces[body.link]
        for j, sw, sv in body.columns:   # a <mimic> joint's force joins its leader's: G^T tau_joints
            m, armature, stiffness, rest, q = body.drive if body.drive is not None else (0, 0, 0, 0, 0)
            tau[j] = tree.program.let(tau[j] + _dot(sw, n) + _dot(sv, f) + m * m * armature * qdd[j]
                                      + m * stiffness * (q - rest))
        if body.parent != "world":
            n_p, f_p = tree.force_to_parent(body, n, f)
            parent_n, parent_f = forces[body.parent]
            forces[body.parent] = (vec(_add(parent_n, n_p)), vec(_add(parent_f, f_p)))
    return tau


def potential(tree: FloatingTree) -> sympy.Expr:
    """``V(q)``: gravity's potential ``-sum (m_i g.p_i + g.R_i h_i)`` with gravity carried into
    each link frame and ``g.p`` accumulated along the tree, plus the springs ``k (q - rest)**2 / 2``."""
    let, vec = tree.program.let, tree.program.vector
    frames: dict[str, tuple[Vector, sympy.Expr]] = {"world": (vec(_gravity(tree.robot, tree.table)), _ZERO)}
    total = _ZERO
    for body in tree.bodies:
        g_parent, s_parent = frames[body.parent]
        g, s = vec(_rotate_back(body.rotation, g_parent)), let(s_parent + _dot(g_parent, body.position))
        frames[body.link] = (g, s)
        total += body.mass * s + _dot(g, body.first_moment)
    springs = [b.drive[2] * (b.drive[4] - b.drive[3]) ** 2 / 2 for b in tree.bodies if b.drive is not None]
    return let(-total + sum(springs, _ZERO))


def efforts(robot: Robot, table: SymbolTable) -> list[sympy.Expr]:
    """``Y``: each effort symbol at its column of ``qd``, zero elsewhere (an actuated floating
    joint's six, the wrench on its child in its frame; a spherical joint's three)."""
    Y: list[sympy.Expr] = [_ZERO] * robot.velocity_count
    for name, column in zip(robot.efforts, robot.effort_columns()):
        Y[column] = table.efforts[name]
    return Y


def ltdl_solve(let, M: list[list[sympy.Expr]], rhs: Sequence[sympy.Expr]) -> list[sympy.Expr]:   # noqa: ANN001
    """``x`` solving ``M x = rhs`` by ``M = L^T D L`` (Featherstone's LTDL, 2008, sec. 6.3):
    eliminating from the last column to the first, a tree's M (nonzero only between a joint and
    its ancestors, parents before children) fills in nothing, where L D L^T from the first
    column (the floating base, coupled to every joint) would fill in all of it. M is positive
    definite: no pivoting. Structural zeros stay zeros."""
    n = len(rhs)
    H = [list(row) for row in M]
    for k in reversed(range(n)):
        inverse = let(1 / H[k][k])
        H[k][k] = inverse
        below = [i for i in reversed(range(k)) if H[k][i] != 0]
        for i in below:   # from the nearest ancestor up: H[k][j], j <= i, not yet replaced by L
            a = let(H[k][i] * inverse)
            for j in below:
                if j <= i:
                    H[i][j] = let(H[i][j] - a * H[k][j])
                    H[j][i] = H[i][j]
            H[k][i] = a
    y = list(rhs)   # L^T y = rhs: from the last entry
    for k in reversed(range(n)):
        y[k] = let(y[k])
        for i in range(k):
            if H[k][i] != 0:
                y[i] = y[i] - H[k][i] * y[k]
    x: list[sympy.Expr] = [_ZERO] * n   # D^-1 y, then L x = D^-1 y from the first entry
    for k in range(n):
        x[k] = let(y[k] * H[k][k] - sum((H[k][j] * x[j] for j in range(k) if H[k][j] != 0), _ZERO))
    return x


def _matmul(let, A: Sequence[Sequence[sympy.Expr]], B: Sequence[Sequence[sympy.Expr]]) -> Matrix3:  # noqa: ANN001
    return tuple(tuple(let(sum((A[i][k] * B[k][j] for k in range(3)), _ZERO)) for j in range(3))  # type: ignore[return-value]
                 for i in range(3))


def frame_programs(robot: Robot, table: SymbolTable) -> dict[str, tuple[Program, Program, Program]]:
    """Each frame's pose (homogeneous, row by row), world-aligned Jacobian (rows ``(v, w)``:
    the velocity of the frame's origin and the angular velocity in world axes, per velocity
    column, Pinocchio's LOCAL_WORLD_ALIGNED) and ``Jdot qd`` (the origin's classical
    acceleration and the angular acceleration at qdd = 0, world axes), by frame name; one
    program shared by all."""
    if not robot.frames:
        return {}
    tree = FloatingTree(robot, table)
    let, vec, expr = tree.program.let, tree.program.vector, table.expr
    by_link = {b.link: b for b in tree.bodies}
    one = sympy.Integer(1)
    poses: dict[str, tuple[Matrix3, Vector]] = {
        "world": (((one, _ZERO, _ZERO), (_ZERO, one, _ZERO), (_ZERO, _ZERO, one)), (_ZERO, _ZERO, _ZERO))}
    for body in tree.bodies:   # parents first
        R, p = poses[body.parent]
        poses[body.link] = (_matmul(let, R, body.rotation), vec(_add(p, _rotate(R, body.position))))
    n = robot.velocity_count
    moving = motions(tree, table.qd, [_ZERO] * n, gravity=False)
    built: dict[str, tuple[list[sympy.Expr], list[sympy.Expr], list[sympy.Expr]]] = {}
    for frame in robot.frames:
        x, y, z, roll, pitch, yaw = (expr(e) for e in frame.origin)
        R_link, p_link = poses[frame.link]
        offset = rpy_matrix(roll, pitch, yaw)
        rotation = _matmul(let, R_link, tuple(tuple(offset[i, j] for j in range(3)) for i in range(3)))
        position = vec(_add(p_link, _rotate(R_link, (x, y, z))))
        rows: list[list[sympy.Expr]] = [[_ZERO] * n for _ in range(6)]
        link = frame.link
        while link != "world":
            body = by_link[link]
            R, p = poses[link]
            lever = vec([a - b for a, b in zip(position, p)])
            for j, sw, sv in body.columns:
                w = vec(_rotate(R, sw))
                v = vec(_add(_rotate(R, sv), _cross(w, lever)))
                for r, value in enumerate((*v, *w)):   # a <mimic> joint's column joins its leader's
                    rows[r][j] = rows[r][j] + value
            link = body.parent
        transform = [*rotation[0], position[0], *rotation[1], position[1], *rotation[2], position[2],
                     _ZERO, _ZERO, _ZERO, one]
        w, v, alpha, acc = moving[frame.link]   # at qdd = 0, no gravity; r: the frame's origin in link axes
        velocity = vec(_add(v, _cross(w, (x, y, z))))
        classical = vec(_add(_add(acc, _cross(alpha, (x, y, z))), _cross(w, velocity)))
        bias = [*_rotate(R_link, classical), *_rotate(R_link, alpha)]
        built[frame.name] = (transform, [e for row in rows for e in row], [let(e) for e in bias])
    return {name: tuple(Program(lines=list(tree.program.lines), outputs=list(outputs)) for outputs in programs)
            for name, programs in built.items()}
