"""The sheet's quantities of a small floating-base robot (issue 30), derived step by step in
quasi-velocities: Kane's (Boltzmann-Hamel's) projection of each link's Newton-Euler equations
onto its partial velocities, the columns of its body Jacobian.

The velocity ``v`` of a ``floating`` joint is the joint frame's local twist ``[v, w]`` (linear
first, DESIGN.md section 10), of a ``spherical`` joint its local angular velocity: not the
derivative of the configuration (position and unit quaternion), which is ``qdot = Q(q) v``
(``configuration_rate``). Each link's centre-of-mass twist in its own axes is ``V_i = J_i v``;
``J_i`` depends on the joints below the link's root and never on a root's pose (a local
twist is invariant under the base's motion). Then

* ``T = 1/2 sum V_i^T G_i V_i = 1/2 v^T M v`` with ``M = sum J_i^T G_i J_i``, ``G_i`` the
  spatial inertia at the centre of mass (``diag(m_i 1, I_i)``);
* ``N = - sum J_i^T (m_i R_i^T g, 0)``: gravity in link axes (``R_i`` the link's rotation
  in the world);
* ``C v = sum J_i^T (G_i Jdot_i v + (m_i w_i x v_i, w_i x I_i w_i))``, ``Jdot_i`` the time
  derivative of ``J_i`` along ``qdot = Q(q) v``;
* ``C = sum J_i^T (G_i Jdot_i + G_i (V_i x) J_i + B_i J_i)``, Pinocchio's Coriolis matrix
  (``B_i = 1/2 (V_i x* G_i - G_i V_i x + (G_i V_i) xbar*)``, covariant, so the same matrix
  as ``computeCoriolisMatrix``'s in world axes), with ``C v`` the bias above and
  ``Mdot - 2 C`` skew-symmetric.

Drives as in the module: armature on M's diagonal, springs ``k (q - rest)`` in N and V.
These are derived afresh here, not read from ``floating.py``'s programs: the tests compare
the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .floating import efforts, offsets, quaternion_matrix
from .joints import unit
from .spatial import axis_angle, inertia_tensor, rpy_matrix
from .tidy import quick_tidy

#: Most scalar (revolute, prismatic) joints of a robot whose quantities the sheet expands;
#: larger ones get the intermediate-variable form (the module's programs, line by line).
SMALL_SCALAR_JOINTS = 2
#: ... and at most this many links.
SMALL_LINKS = 4


def is_small_floating(robot: Robot) -> bool:
    """Whether the sheet expands the robot's quantities: one floating or spherical joint, at
    the world, and at most SMALL_SCALAR_JOINTS joints below it (a quaternion below another
    joint makes every entry a polynomial of high degree in it: a floating base, a spherical
    joint and an elbow take a minute and give a C of 230 000 operations)."""
    multi = [j for j in robot.joints if j.multi]
    scalar = [j for j in robot.joints if j.moves and not j.multi]
    return (len(multi) == 1 and multi[0].parent == "world" and len(scalar) <= SMALL_SCALAR_JOINTS
            and len(robot.links) <= SMALL_LINKS)


def skew(a: sympy.Matrix) -> sympy.Matrix:
    """``[a]x``: ``skew(a) * b == a x b``."""
    return sympy.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def _clean(matrix: sympy.Matrix) -> sympy.Matrix:
    return matrix.applyfunc(lambda e: quick_tidy(sympy.expand(e)))


@dataclass
class FloatingJointSheet:
    """A floating or spherical joint: its coordinates, velocities, the rotation of its
    quaternion, and ``rate`` (``qdot = rate * v``, NQ_joint x NV_joint)."""

    name: str
    type: str
    q: list[sympy.Symbol]
    v: list[sympy.Symbol]
    rotation: sympy.Matrix
    rate: sympy.Matrix


@dataclass
class LinkSheet:
    """One link: rotation and position of its frame in the world, its centre of mass in the
    world, body Jacobian of the centre of mass (link axes, rows ``(v, w)``), twist, energies."""

    index: int
    name: str
    mass: sympy.Expr
    com: sympy.Matrix
    inertia: sympy.Matrix
    rotation: sympy.Matrix
    com_position: sympy.Matrix
    jacobian: sympy.Matrix
    twist: sympy.Matrix
    gravity: sympy.Matrix          # g in link axes, R^T g
    kinetic: sympy.Expr
    potential: sympy.Expr
    jacobian_dot: sympy.Matrix = field(default_factory=lambda: sympy.zeros(0, 0))


@dataclass
class FloatingSheet:
    """Everything the small floating sheet shows (module docstring)."""

    joints: list[FloatingJointSheet]
    links: list[LinkSheet]
    rate: sympy.Matrix             # qdot = rate * v, NQ x NV
    M: sympy.Matrix
    N: sympy.Matrix
    Cv: sympy.Matrix
    C: sympy.Matrix
    T: sympy.Expr
    V: sympy.Expr
    Y: sympy.Matrix
    EOM: sympy.Matrix              # M vdot + C v + N - Y


def quaternion_rate(quaternion: list[sympy.Symbol]) -> sympy.Matrix:
    """``d quat / dt = 1/2 quat * (w, 0)`` as a 4 x 3 matrix times the local ``w``."""
    x, y, z, w = quaternion
    return sympy.Matrix([[w, -z, y], [z, w, -x], [-y, x, w], [-x, -y, -z]]) / 2


def floating_sheet(robot: Robot, table: SymbolTable) -> FloatingSheet:
    """The quantities of the module docstring, entries expanded and tidied."""
    expr = table.expr
    where = offsets(robot)
    nq, nv = len(table.q), len(table.qd)
    v = sympy.Matrix(table.qd)
    rate = sympy.zeros(nq, nv)
    joints: list[FloatingJointSheet] = []
    gravity = sympy.Matrix([expr(e) for e in robot.gravity])
    poses: dict[str, tuple[sympy.Matrix, sympy.Matrix, sympy.Matrix]] = {
        "world": (sympy.eye(3), sympy.zeros(3, 1), sympy.zeros(6, nv))}
    depth = {link.name: len(robot.path_to(link.name)) for link in robot.links}
    order = sorted(robot.links, key=lambda link: depth[link.name])
    index = {link.name: k for k, link in enumerate(robot.links, 1)}
    links: dict[str, LinkSheet] = {}
    for link in order:
        joint = robot.parent_joint(link.name)
        x, y, z, roll, pitch, yaw = (expr(e) for e in joint.origin)
        R, p = rpy_matrix(roll, pitch, yaw), sympy.Matrix([x, y, z])
        S = sympy.zeros(6, nv)
        if joint.moves:
            qi, vi = where.q[joint.name], where.v[joint.name]
        if joint.type in ("floating", "spherical"):
            start = 3 if joint.type == "floating" else 0
            quat = table.q[qi + start:qi + start + 4]
            Rq = quaternion_matrix(*quat)
            block = sympy.zeros(start + 4, start + 3)
            if start:
                p = p + R * sympy.Matrix(table.q[qi:qi + 3])
                block[:3, :3] = Rq
                S[:3, vi:vi + 3] = sympy.eye(3)
            block[start:, start:] = quaternion_rate(quat)
            S[3:, vi + start:vi + start + 3] = sympy.eye(3)
            rate[qi:qi + start + 4, vi:vi + start + 3] = block
            joints.append(FloatingJointSheet(joint.name, joint.type, table.q[qi:qi + start + 4],
                                             table.qd[vi:vi + start + 3], Rq, block))
            R = R * Rq
        elif joint.type == "revolute":
            axis = sympy.Matrix(unit(tuple(expr(e) for e in joint.axis)))
            R = R * axis_angle(tuple(axis), table.q[qi])
            S[3:, vi] = axis
            rate[qi, vi] = 1
        elif joint.type == "prismatic":
            axis = sympy.Matrix(unit(tuple(expr(e) for e in joint.axis)))
            p = p + R * axis * table.q[qi]
            S[:3, vi] = axis
            rate[qi, vi] = 1
        R_parent, p_parent, J_parent = poses[joint.parent]
        # the link origin's twist (v, w) in link axes: X(parent -> link) J_parent + S
        X = sympy.zeros(6, 6)
        X[:3, :3], X[:3, 3:], X[3:, 3:] = R.T, -R.T * skew(p), R.T
        J = _clean(X * J_parent + S)
        R_world, p_world = _clean(R_parent * R), _clean(p_parent + R_parent * p)
        poses[link.name] = (R_world, p_world, J)
        com = sympy.Matrix([expr(e) for e in link.com])
        shift = sympy.eye(6)
        shift[:3, 3:] = -skew(com)
        Jc = _clean(shift * J)
        mass, inertia = expr(link.mass), inertia_tensor(tuple(expr(e) for e in link.inertia))
        twist = _clean(Jc * v)
        g_link = _clean(R_world.T * gravity)
        kinetic = quick_tidy(sympy.expand((mass * twist[:3, 0].dot(twist[:3, 0])
                                           + (twist[3:, 0].T * inertia * twist[3:, 0])[0, 0]) / 2))
        position = _clean(p_world + R_world * com)
        links[link.name] = LinkSheet(index[link.name], link.name, mass, com, inertia, R_world, position, Jc, twist,
                                     g_link, kinetic, quick_tidy(sympy.expand(-mass * gravity.dot(position))))
    qdot = rate * v
    rates = {s: qdot[k] for k, s in enumerate(table.q)}
    M, N, Cv, C = (sympy.zeros(nv, nv), sympy.zeros(nv, 1), sympy.zeros(nv, 1), sympy.zeros(nv, nv))
    for item in links.values():
        G = sympy.diag(item.mass * sympy.eye(3), item.inertia)
        Jc = item.jacobian
        moving = sorted(Jc.free_symbols & set(table.q), key=lambda s: s.name)
        Jdot = sympy.zeros(6, nv)
        for s in moving:
            Jdot += Jc.diff(s) * rates[s]
        item.jacobian_dot = _clean(Jdot)
        lin, ang = item.twist[:3, 0], item.twist[3:, 0]
        bias = sympy.Matrix([*(item.mass * ang.cross(lin)), *ang.cross(inertia_times(item.inertia, ang))])
        M += Jc.T * G * Jc
        N -= Jc.T * sympy.Matrix([*(item.mass * item.gravity), 0, 0, 0])
        Cv += Jc.T * (G * item.jacobian_dot * v + bias)
        cross = sympy.zeros(6, 6)   # V x, (v, w) order
        cross[:3, :3], cross[:3, 3:], cross[3:, 3:] = skew(ang), skew(lin), skew(ang)
        momentum = G * item.twist
        star = sympy.zeros(6, 6)    # (G V) xbar*: m -> m x* (G V)
        star[:3, 3:], star[3:, :3], star[3:, 3:] = -skew(momentum[:3, 0]), -skew(momentum[:3, 0]), -skew(momentum[3:, 0])
        B = (-cross.T * G - G * cross + star) / 2
        C += Jc.T * (G * item.jacobian_dot + G * cross * Jc + B * Jc)
    potential = sum((item.potential for item in links.values()), sympy.Integer(0))
    for joint in (j for j in robot.joints if j.moves and not j.multi and j.driven):
        qi, vi = where.q[joint.name], where.v[joint.name]
        armature = expr(joint.armature) if joint.armature is not None else 0
        stiffness = expr(joint.stiffness) if joint.stiffness is not None else 0
        rest = expr(joint.rest) if joint.rest is not None else 0
        M[vi, vi] += armature
        N[vi] += stiffness * (table.q[qi] - rest)
        potential += stiffness * (table.q[qi] - rest) ** 2 / 2
    M, N, Cv, C = _clean(M), _clean(N), _clean(Cv), _clean(C)
    T = quick_tidy(sympy.expand((v.T * M * v)[0, 0] / 2))
    Y = sympy.Matrix(efforts(robot, table))
    EOM = _clean(M * sympy.Matrix(table.qdd) + Cv + N - Y)
    return FloatingSheet(joints, [links[link.name] for link in robot.links], rate, M, N, Cv, C, T,
                         quick_tidy(sympy.expand(potential)), Y, EOM)


def inertia_times(inertia: sympy.Matrix, w: sympy.Matrix) -> sympy.Matrix:
    return inertia * w
