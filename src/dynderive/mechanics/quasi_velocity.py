"""The sheet's quantities of a small robot with quaternion joints (a floating base, a spherical
joint), derived step by step in quasi-velocities: Kane's (Boltzmann-Hamel's) projection of each
link's Newton-Euler equations onto its partial velocities, the columns of its body Jacobian.

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

Drives as in the module: armature on M's diagonal, springs ``k (q - rest)`` in N and V,
damping and Coulomb friction ``F = b v + fc sign(v)`` in the equations of motion.
These are derived afresh here, not read from the recursive programs (``recursive.py``): the tests compare
the two.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import sympy

from ..model.robot import Joint, Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .drives import dissipative_force, joint_drives
from .joint_types.quaternion import quaternion_matrix
from .joint_variables import unit
from .polynomial import expand
from .program import _cross
from .rotations import rpy_matrix
from .spatial import inertia_tensor
from .tidy import fold_constants
from .tree import efforts, offsets

#: Most scalar (revolute, prismatic) joints of a robot whose quantities the sheet expands;
#: larger ones get the intermediate-variable form (the module's programs, line by line).
SMALL_SCALAR_JOINTS = 2
#: ... and at most this many links.
SMALL_LINKS = 4


def is_step_by_step(robot: Robot) -> bool:
    """Whether the sheet expands the robot's quantities: one floating or spherical joint, at
    the world, and at most SMALL_SCALAR_JOINTS joints below it (a quaternion below another
    joint makes every entry a polynomial of high degree in it: a floating base, a spherical
    joint and an elbow take a minute and give a C of 230 000 operations). A robot with
    ``<mimic>`` joints gets the programs' form (the steps here give each joint a coordinate)."""
    multi = [j for j in robot.joints if j.multi]
    scalar = [j for j in robot.joints if j.moves and not j.multi]
    return (not robot.mimics and len(multi) == 1 and multi[0].parent == "world" and len(scalar) <= SMALL_SCALAR_JOINTS
            and len(robot.links) <= SMALL_LINKS)


@dataclass
class QuasiVelocitySteps:
    """What the sheets' quasi-velocity sections and the JSON show
    (``Derivation.quasi_velocity_steps``): a small robot's step-by-step quantities (None for a
    large one, shown as the module's programs), the applied forces Y, and each floating or
    spherical joint's rotation matrix and configuration rate."""

    sheet: QuasiVelocitySheet | None
    efforts: list[sympy.Expr]
    rotations: dict[str, tuple[sympy.Matrix, sympy.Matrix]]


def quasi_velocity_steps(robot: Robot, table: SymbolTable) -> QuasiVelocitySteps:
    where_q = robot.offsets()[0]
    rotations = {}
    for joint in (j for j in robot.joints if j.multi):
        start = where_q[joint.name] + joint_types.of(joint).quaternion_start  # type: ignore[operator]
        quaternion = table.q[start:start + 4]
        rotations[joint.name] = (quaternion_matrix(*quaternion), quaternion_rate(quaternion))
    sheet = quasi_velocity_sheet(robot, table) if is_step_by_step(robot) else None
    return QuasiVelocitySteps(sheet, efforts(robot, table), rotations)


def skew(a: sympy.Matrix) -> sympy.Matrix:
    """``[a]x``: ``skew(a) * b == a x b``."""
    return sympy.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


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
    jacobian_dot: sympy.Matrix     # d J / dt along qdot = Q(q) v


@dataclass
class QuasiVelocitySheet:
    """Everything the quasi-velocity sections of a small robot show (module docstring)."""

    links: list[LinkSheet]
    rate: sympy.Matrix             # qdot = rate * v, NQ x NV
    M: sympy.Matrix
    N: sympy.Matrix
    Cv: sympy.Matrix
    C: sympy.Matrix
    T: sympy.Expr
    V: sympy.Expr
    Y: sympy.Matrix
    EOM: sympy.Matrix              # M vdot + C v + N + F - Y (F: damping and Coulomb friction)


def quaternion_rate(quaternion: list[sympy.Symbol]) -> sympy.Matrix:
    """``d quat / dt = 1/2 quat * (w, 0)`` as a 4 x 3 matrix times the local ``w``."""
    x, y, z, w = quaternion
    return sympy.Matrix([[w, -z, y], [z, w, -x], [-y, x, w], [-x, -y, -z]]) / 2


#: With a double among the robot's numbers, a term whose coefficient is below this fraction of
#: its entry's largest is rounding noise (terms that cancel exactly in exact arithmetic).
NOISE = 1e-14


class _Ring:
    """Exact (or, with a double among the robot's numbers, floating-point) polynomial
    arithmetic over the robot's symbols, ``sin q_k`` and ``cos q_k`` as variables: SymPy's
    ``expand`` of the sheet's products of 6 x 6 matrices takes minutes with CAD numbers,
    sparse polynomials a second. Matrices are lists of rows."""

    def __init__(self, table: SymbolTable, revolute: list[sympy.Symbol], values: list[sympy.Basic]):
        self.trig = {f(q): sympy.Symbol(f"_{f.__name__}_{q}")
                     for q in revolute for f in (sympy.sin, sympy.cos)}
        self.back = {v: k for k, v in self.trig.items()}
        found = set().union(*(sympy.sympify(value).xreplace(self.trig).free_symbols for value in values),
                            table.q, table.qd, table.qdd)
        sines = [self.trig[sympy.sin(q)] for q in revolute]
        cosines = [self.trig[sympy.cos(q)] for q in revolute]
        rest = sorted(found - set(sines) - set(cosines), key=lambda s: s.name)
        floats = any(a.is_Float for value in values for a in sympy.sympify(value).atoms(sympy.Number))
        self.domain = (sympy.RR if floats else sympy.QQ)[tuple(sines + cosines + rest)]
        self.circles = [self.domain.from_sympy(a ** 2 + b ** 2 - 1) for a, b in zip(sines, cosines)]
        self.derivatives = {q: (self.domain.from_sympy(self.trig[sympy.sin(q)]), self.domain.from_sympy(self.trig[sympy.cos(q)]))
                            for q in revolute}

    def of(self, matrix: sympy.Matrix) -> list[list]:
        return [[self.domain.from_sympy(sympy.sympify(matrix[i, j]).xreplace(self.trig)) for j in range(matrix.cols)]
                for i in range(matrix.rows)]

    def expr(self, element, scale: float | None = None) -> sympy.Expr:   # noqa: ANN001
        """SymPy's expression of ``element``; with doubles, its terms below NOISE times
        ``scale`` (default: its own largest coefficient) dropped as rounding noise."""
        for circle in self.circles:   # sin^2 -> 1 - cos^2
            element = element.rem(circle)
        if self.domain.domain == sympy.RR and element:
            largest = scale if scale is not None else _largest(element)
            element = element.ring({m: c for m, c in element.items() if abs(float(c)) > NOISE * largest})
        value = self.domain.to_sympy(element).xreplace(self.back)
        return value.xreplace({f: _number(f) for f in value.atoms(sympy.Float)})

    def matrix(self, rows: list[list]) -> sympy.Matrix:
        """The matrix, noise measured against its largest coefficient (an entry that is zero in
        exact arithmetic comes out as noise alone)."""
        scale = max((_largest(e) for row in rows for e in row if e), default=0.0)
        return sympy.Matrix([[self.expr(e, scale) for e in row] for row in rows])

    def diff(self, element, symbol: sympy.Symbol):   # noqa: ANN001
        """d element / d symbol, a revolute coordinate through its sine and cosine."""
        if symbol in self.derivatives:
            sin, cos = self.derivatives[symbol]
            return element.diff(sin) * cos - element.diff(cos) * sin
        return element.diff(self.domain.from_sympy(symbol))


def _largest(element) -> float:   # noqa: ANN001
    return max(abs(float(c)) for c in element.values())


def _number(value: sympy.Float) -> sympy.Number:
    """A double that is an integer or a fraction of a small power of two, exactly."""
    exact = sympy.Rational(float(value))
    return exact if exact.q <= 64 else value


def _mul(A: list[list], B: list[list], zero) -> list[list]:   # noqa: ANN001
    return [[sum((A[i][k] * B[k][j] for k in range(len(B))), zero) for j in range(len(B[0]))] for i in range(len(A))]


def _add(*matrices: list[list]) -> list[list]:
    return [[sum(entries[1:], entries[0]) for entries in zip(*rows)] for rows in zip(*matrices)]


def _scale(A: list[list], factor) -> list[list]:   # noqa: ANN001
    return [[e * factor for e in row] for row in A]


def _t(A: list[list]) -> list[list]:
    return [list(column) for column in zip(*A)]


def quasi_velocity_sheet(robot: Robot, table: SymbolTable) -> QuasiVelocitySheet:
    """The quantities of the module docstring, entries expanded (polynomials in the
    coordinates, velocities, sines and cosines and the robot's symbols)."""
    expr = table.expr
    where = offsets(robot)
    nq, nv = len(table.q), len(table.qd)
    rate = sympy.zeros(nq, nv)
    gravity = sympy.Matrix([expr(e) for e in robot.gravity])
    depth = {link.name: len(robot.path_to(link.name)) for link in robot.links}
    order = sorted(robot.links, key=lambda link: depth[link.name])
    index = {link.name: k for k, link in enumerate(robot.links, 1)}
    pieces = {}   # link: (R, p, S) of its joint, mass, com, inertia (SymPy)
    for link in order:
        joint = robot.parent_joint(link.name)
        x, y, z, roll, pitch, yaw = (expr(e) for e in joint.origin)
        # constant transforms and axes with their irrational numbers (cos(0.3), a normalized axis's
        # square roots) as doubles: exact, they would multiply out into every entry below
        R, p = fold_constants(rpy_matrix(roll, pitch, yaw)), fold_constants(sympy.Matrix([x, y, z]))
        S = sympy.zeros(6, nv)
        if joint.moves:
            qi, vi = where.q[joint.name], where.v[joint.name]
        kind = joint_types.of(joint)
        if kind.quaternion_start is not None:   # floating (position, then quaternion), spherical
            start = kind.quaternion_start
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
            R = R * Rq
        elif kind.moves:   # vector-space coordinates: its type's turn and shift, its columns
            axis = tuple(fold_constants(sympy.Matrix(unit(tuple(expr(e) for e in joint.axis)))))
            geometry = joint_types.geometry_of(joint, expr)
            entries = table.q[qi:qi + kind.nq]
            shift = kind.displacement(R, entries, axis, geometry)   # (R axis) q for a prismatic joint
            p = p if shift is None else p + shift
            R = R * kind.rotation(entries, axis, geometry)
            for k, (w, v) in enumerate(kind.columns(entries, axis, geometry)):
                S[3:, vi + k], S[:3, vi + k] = sympy.Matrix(w), sympy.Matrix(v)
                rate[qi + k, vi + k] = 1
        com = sympy.Matrix([expr(e) for e in link.com])
        pieces[link.name] = (R, p, S, expr(link.mass), com, inertia_tensor(tuple(expr(e) for e in link.inertia)))
    revolute = [table.q[where.q[j.name] + k] for j in robot.joints if j.kind.vector_space and j.owns
                for k, turn in enumerate(_turns(j, expr)) if turn]   # the angles inside sines and cosines
    ring = _Ring(table, revolute, [*gravity, *(e for piece in pieces.values() for part in piece
                                               for e in (part if isinstance(part, sympy.MatrixBase) else [part]))])
    K = ring.domain
    zero, one = K.zero, K.one
    v = ring.of(sympy.Matrix(table.qd))
    g = ring.of(gravity)
    identity = [[one if i == j else zero for j in range(3)] for i in range(3)]
    poses = {"world": (identity, [[zero]] * 3, [[zero] * nv for _ in range(6)])}
    rates = {s: ring.of(sympy.Matrix([e]))[0][0] for s, e in zip(table.q, rate * sympy.Matrix(table.qd))}
    links: dict[str, LinkSheet] = {}
    M, C = [[zero] * nv for _ in range(nv)], [[zero] * nv for _ in range(nv)]
    N, Cv = [[zero] for _ in range(nv)], [[zero] for _ in range(nv)]
    half = K.convert(sympy.Rational(1, 2))
    for link in order:
        joint = robot.parent_joint(link.name)
        R_s, p_s, S_s, mass_s, com_s, inertia_s = pieces[link.name]
        R, p, S = ring.of(R_s), ring.of(p_s), ring.of(S_s)
        mass, com, inertia = ring.of(sympy.Matrix([mass_s]))[0][0], ring.of(com_s), ring.of(inertia_s)
        R_parent, p_parent, J_parent = poses[joint.parent]
        Rt = _t(R)
        # the link origin's twist (v, w) in link axes: X J_parent + S
        X = _blocks(zero, Rt, _mul(Rt, _scale(ring.of(skew(p_s)), -one), zero), None, Rt)
        J = _add(_mul(X, J_parent, zero), S)
        R_world = _mul(R_parent, R, zero)
        p_world = _add(p_parent, _mul(R_parent, p, zero))
        poses[link.name] = (R_world, p_world, J)
        Jc = _mul(_blocks(zero, identity, ring.of(-skew(com_s)), None, identity), J, zero)
        twist = _mul(Jc, v, zero)
        g_link = _mul(_t(R_world), g, zero)
        lin, ang = [row[0] for row in twist[:3]], [row[0] for row in twist[3:]]
        I_w = [row[0] for row in _mul(inertia, [[a] for a in ang], zero)]
        spin = sum((a * b for a, b in zip(ang, I_w)), zero)
        kinetic = (mass * sum((a * a for a in lin), zero) + spin) * half
        position = _add(p_world, _mul(R_world, com, zero))
        potential = -mass * sum((a[0] * b[0] for a, b in zip(g, position)), zero)
        masses = [[mass if i == j else zero for j in range(3)] for i in range(3)]
        G = _blocks(zero, masses, None, None, inertia)
        Jdot = [[zero] * nv for _ in range(6)]
        for s in table.q:
            if s in rates and rates[s] != zero:
                Jdot = _add(Jdot, [[ring.diff(e, s) * rates[s] for e in row] for row in Jc])
        shown = [ring.matrix(m) for m in (R_world, position, Jc, twist, g_link)]
        links[link.name] = LinkSheet(index[link.name], link.name, mass_s, com_s, inertia_s, *shown,
                                     ring.expr(kinetic), ring.expr(potential), ring.matrix(Jdot))
        JcT = _t(Jc)
        bias = [[mass * e] for e in _cross(ang, lin)] + [[e] for e in _cross(ang, I_w)]
        M = _add(M, _mul(JcT, _mul(G, Jc, zero), zero))
        N = _add(N, _mul(JcT, [[-mass * row[0]] for row in g_link] + [[zero]] * 3, zero))
        Cv = _add(Cv, _mul(JcT, _add(_mul(G, _mul(Jdot, v, zero), zero), bias), zero))
        momentum = [row[0] for row in _mul(G, twist, zero)]
        wx = _skew3(ang, zero)
        cross = _blocks(zero, wx, _skew3(lin, zero), None, wx)   # V x, (v, w) order
        px, Lx = _skew3([-e for e in momentum[:3]], zero), _skew3([-e for e in momentum[3:]], zero)
        star = _blocks(zero, None, px, px, Lx)    # (G V) xbar*: m -> m x* (G V)
        B = _scale(_add(_scale(_mul(_t(cross), G, zero), -one), _scale(_mul(G, cross, zero), -one), star), half)
        C = _add(C, _mul(JcT, _add(_mul(G, Jdot, zero), _mul(_mul(G, cross, zero), Jc, zero), _mul(B, Jc, zero)), zero))
    potential_s = sum((item.potential for item in links.values()), sympy.Integer(0))
    M_s, N_s = ring.matrix(M), ring.matrix(N)
    F = sympy.zeros(len(table.qd), 1)   # damping and Coulomb friction of the scalar joints
    coordinate = {where.v[j.name] + k: table.q[where.q[j.name] + k] for j in robot.joints if j.moves and not j.multi
                  for k in range(max(j.sizes[1], 1))}
    for drive in joint_drives(robot, table):
        vi, spring = drive.coordinate, coordinate[drive.coordinate] - drive.rest
        M_s[vi, vi] += drive.armature
        N_s[vi] = expand(N_s[vi] + drive.stiffness * spring)
        potential_s += drive.stiffness * spring ** 2 / 2
        F[vi] = dissipative_force(drive.damping, drive.friction, table.qd[vi])
    v_s = sympy.Matrix(table.qd)
    T = expand((v_s.T * M_s * v_s)[0, 0] / 2)
    Y = sympy.Matrix(efforts(robot, table))
    Cv_s = ring.matrix(Cv)
    EOM = (M_s * sympy.Matrix(table.qdd) + Cv_s + N_s + F - Y).applyfunc(expand)
    return QuasiVelocitySheet([links[link.name] for link in robot.links], rate, M_s, N_s, Cv_s, ring.matrix(C), T,
                              expand(potential_s), Y, EOM)


def _turns(joint: Joint, expr: Callable[[object], sympy.Expr]) -> list[bool]:
    """Per coordinate of a vector-space joint, whether it is an angle (a sine and cosine's)."""
    axis = unit(tuple(expr(e) for e in joint.axis)) if joint.kind.takes_axis else ()
    segments = joint_types.of(joint).segments(axis, joint_types.geometry_of(joint, expr))
    return [segment.kind.turns for segment in segments]


def _skew3(a: list, zero) -> list[list]:   # noqa: ANN001
    return [[zero, -a[2], a[1]], [a[2], zero, -a[0]], [-a[1], a[0], zero]]


def _blocks(zero, top_left, top_right, bottom_left, bottom_right) -> list[list]:   # noqa: ANN001
    """The 6 x 6 matrix of four 3 x 3 blocks (None: a zero block)."""
    rows = [[zero] * 6 for _ in range(6)]
    corners = {(0, 0): top_left, (0, 3): top_right, (3, 0): bottom_left, (3, 3): bottom_right}
    for (r, c), block in corners.items():
        if block is not None:
            for i in range(3):
                rows[r + i][c:c + 3] = block[i]
    return rows
