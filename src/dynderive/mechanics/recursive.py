"""Straight-line programs of the recursive algorithms, for the generated code.

The composite-rigid-body algorithm (M), recursive Newton-Euler (C qd + N, inverse dynamics)
and an LDL^T solve (forward dynamics) of Featherstone's *Rigid Body Dynamics Algorithms*
(2008, ch. 5-6) run once on SymPy symbols. Every intermediate value gets a name, so no
expression ever grows, and SymPy's own arithmetic drops the products with structural zeros
and ones (joint axes along z, rotations by multiples of pi/2): the result is a short list of
assignments, each a few operations, that the code template prints as Python. The same lines
run on floats (one state, with ``math``) and on NumPy arrays (a batch). Planar robots are
treated as 3-D ones moving in the plane z = 0.

>>> program = mass_matrix_program(robot, table)          # doctest: +SKIP
>>> len(program.lines), program.outputs[0]                 # doctest: +SKIP
(231, _t230)

Conventions: link frames as in the robot file (the joint frame after its motion); spatial
vectors as pairs of 3-vectors, motion ``(omega, v)`` with ``v`` the velocity of the body point
at the frame origin, force ``(n, f)`` with the moment about that origin.

Each line records what it means (``program.Meaning``, keys in ``recursion.MEANINGS``) where it is built,
for the sheet of a large robot.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import sympy

from ..model.robot import Joint, Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .drives import joint_drives
from .joints import couplings, unit
from .program import (
    Matrix3,
    Meaning,
    Program,
    Vector,
    _add,
    _cross,
    _dot,
    _rotate,
    _rotate_back,
    add_column,
    lines_read,
    part_of,
)
from .spatial import inertia_tensor, rpy_matrix


@dataclass
class _Body:
    """One link as the algorithms see it: its parent joint's transform and motion axis."""

    link: str
    parent: str
    joint: Joint
    coordinate: int | None       # index of the joint's coordinate, None for fixed joints
    revolute: bool
    axis: Vector                 # motion axis in the link frame (times a <mimic> multiplier)
    rotation: Matrix3            # link axes in the parent frame (R), with the joint's motion
    position: Vector             # link origin in the parent frame
    mass: sympy.Expr
    first_moment: Vector         # h = m c, link frame
    inertia: tuple[tuple[sympy.Expr, ...], ...]  # about the link origin, link axes
    #: a revolute joint's cosine and sine names and angle (a <mimic> joint: multiplier * q + offset)
    trig: tuple[sympy.Symbol, sympy.Symbol, sympy.Expr] | None = None

    @property
    def leads(self) -> bool:
        """Whether the joint owns its coordinate (drive terms, merged per coordinate, enter there)."""
        return self.coordinate is not None and self.joint.mimic is None


class _Tree:
    """The robot's links in an order where parents come first, with their transforms."""

    def __init__(self, robot: Robot, table: SymbolTable, program: Program):
        self.robot, self.table, self.program = robot, table, program
        self.couplings = couplings(robot, table)
        depth = {link.name: len(robot.path_to(link.name)) for link in robot.links}
        order = sorted(robot.links, key=lambda link: depth[link.name])  # stable: file order per depth
        self.bodies: list[_Body] = []
        for link in order:
            joint = robot.parent_joint(link.name)
            coordinate = self.couplings[joint.name].coordinate if joint.moves else None
            self.bodies.append(self._body(link, joint, coordinate))
        self.by_link = {b.link: b for b in self.bodies}
        #: drive terms by coordinate: armature joins M[i, i] (CRBA) and Ia qdd_i the joint
        #: force (Newton-Euler), springs k (q_i - rest) the joint force
        self.drives = {d.coordinate: d for d in joint_drives(robot, table)}
        #: links welded to the world (no moving joint above them): they carry no dynamics
        self.static = {"world"} | {link.name for link in robot.links
                                   if not any(j.moves for j in robot.path_to(link.name))}

    def _body(self, link, joint: Joint, coordinate: int | None) -> _Body:
        expr, let = self.table.expr, self.program.let
        zero = sympy.Integer(0)
        if self.robot.planar:   # the plane z = 0 of a 3-D model: rotations about z only
            x, y, yaw = (expr(e) for e in joint.origin)
            z = roll = pitch = zero
        else:
            x, y, z, roll, pitch, yaw = (expr(e) for e in joint.origin)
        origin = rpy_matrix(roll, pitch, yaw)
        position = [x, y, z]
        axis: Vector = (zero,) * 3  # type: ignore[assignment]
        motion, kind = sympy.eye(3), joint_types.of(joint)   # revolute, prismatic or fixed (floating.py: others)
        revolute, trig = kind.turns, None
        if coordinate is not None:
            if self.robot.planar:   # the planar unit twist (vx, vy, omega) as a 3-D axis
                vx, vy, w = kind.planar(zero, tuple(expr(e) for e in joint.axis)).twist  # type: ignore[arg-type]
                axis = (zero, zero, w) if revolute else (vx, vy, zero)
            else:
                axis = unit(tuple(expr(e) for e in joint.axis))  # type: ignore[assignment]
            coupling = self.couplings[joint.name]
            q = coupling.variable
            if revolute and joint.mimic is None:
                cos, sin = sympy.Symbol(f"_cos{coordinate}"), sympy.Symbol(f"_sin{coordinate}")
                motion = kind.rotation([q], axis).subs({sympy.cos(q): cos, sympy.sin(q): sin})
                trig = (cos, sin, q)
            elif revolute:   # a <mimic> joint: the sine and cosine of its own variable
                cos, sin = (sympy.Symbol(f"_{f}{coordinate}_{len(self.bodies)}") for f in ("cos", "sin"))
                # by -q about the opposite axis if SymPy would pull the sign out of sin(q)
                turn, about = (-q, tuple(-a for a in axis)) if q.could_extract_minus_sign() else (q, axis)
                angle = sympy.Dummy("angle")
                motion = kind.rotation([angle], about).subs({sympy.cos(angle): cos, sympy.sin(angle): sin})
                trig = (cos, sin, turn)
            else:   # (origin axis) q
                position = [p + d for p, d in zip(position, kind.displacement(origin, [q], axis))]  # type: ignore[arg-type]
            if coupling.multiplier != 1:   # motion per unit rate of the leader's coordinate
                axis = tuple(coupling.multiplier * a for a in axis)  # type: ignore[assignment]
        rotation = origin * motion
        name = link.name
        R = tuple(tuple(let(rotation[i, j], Meaning("R", name, (i, j))) for j in range(3)) for i in range(3))
        mass = let(expr(link.mass), Meaning("m", name))
        com = [expr(e) for e in link.com]
        if self.robot.planar:   # only the inertia about z enters planar motion
            com.append(zero)
            ixx = iyy = ixy = ixz = iyz = zero
            izz = expr(link.inertia[0])
        else:
            ixx, iyy, izz, ixy, ixz, iyz = (expr(e) for e in link.inertia)
        about_com = inertia_tensor((ixx, iyy, izz, ixy, ixz, iyz))
        square = sum(c * c for c in com)
        inertia = tuple(tuple(let(about_com[i, j] + mass * ((square if i == j else 0) - com[i] * com[j]),
                                  Meaning("I", name, (i, j))) for j in range(3)) for i in range(3))
        return _Body(link.name, joint.parent, joint, coordinate, revolute, axis, R,  # type: ignore[arg-type]
                     self.program.vector(position, Meaning("p", name)), mass,
                     self.program.vector([mass * c for c in com], Meaning("h", name)), inertia, trig)

    def trig(self) -> list[tuple[sympy.Symbol, sympy.Expr]]:
        """The sines and cosines the transforms use, to compute first."""
        lines = []
        for body in self.bodies:
            if body.trig is not None:
                cos, sin, q = body.trig
                lines += [(cos, sympy.cos(q)), (sin, sympy.sin(q))]
        return lines

    def force_to_parent(self, body: _Body, n: Sequence[sympy.Expr], f: Sequence[sympy.Expr],
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

    def motion_from_parent(self, body: _Body, w: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
                           meaning: tuple[str, str] | None = None) -> tuple[Vector, Vector]:
        """A motion vector of the parent's frame seen in this link's frame (``meaning``: the
        quantities of its angular and linear parts, ``MEANINGS``)."""
        let = self.program.vector
        angular, linear = (None, None) if meaning is None else (Meaning(meaning[0], body.link), Meaning(meaning[1], body.link))
        return (let(_rotate_back(body.rotation, w), angular),
                let(_rotate_back(body.rotation, _add(v, _cross(w, body.position))), linear))


def _start(robot: Robot, table: SymbolTable) -> tuple[Program, _Tree]:
    program = Program()
    tree = _Tree(robot, table, program)
    # the bodies' constant lines were recorded while building the tree; sines and cosines
    # are inputs to them only through the rotation entries, which come later in the list
    trig = tree.trig()
    program.lines[0:0] = trig
    return program, tree


def add_to_parent(program: Program, composite: dict[str, Any], body: Any) -> None:
    """CRBA's upward step: ``body``'s composite inertia (mass, first moment, rotational inertia
    about its frame) expressed in its parent's frame and added to the parent's, as program
    lines (the fixed-base and the floating-base CRBA share it)."""
    let, vec = program.let, program.vector
    mass, h, inertia = composite[body.link]
    R, p = body.rotation, body.position
    h_r = vec(_rotate(R, h), Meaning("hc_up", body.link))
    inertia_rt = [[let(_dot(inertia[k], R[b]), Meaning("IRt", body.link, (k, b))) for b in range(3)]
                  for k in range(3)]   # I R^T
    rotated = [[_dot(R[a], [inertia_rt[k][b] for k in range(3)]) for b in range(3)] for a in range(3)]
    ph = _dot(p, h_r)
    pp = _dot(p, p)
    moved = [[rotated[a][b] + mass * ((pp if a == b else 0) - p[a] * p[b])
              + (2 * ph if a == b else 0) - h_r[a] * p[b] - p[a] * h_r[b] for b in range(3)] for a in range(3)]
    p_mass, p_h, p_inertia = composite[body.parent]
    total = [[None] * 3 for _ in range(3)]
    for a in range(3):
        for b in range(a, 3):
            total[a][b] = total[b][a] = let(p_inertia[a][b] + moved[a][b], Meaning("Ic", body.parent, (a, b)))
    composite[body.parent] = (let(p_mass + mass, Meaning("mc", body.parent)),
                              vec(_add(p_h, _add(h_r, [mass * x for x in p])), Meaning("hc", body.parent)),
                              tuple(tuple(row) for row in total))


def _composite_mass_matrix(tree: _Tree) -> list[list[sympy.Expr]]:
    """CRBA: composite inertias from the leaves up, then M_ij = S_i . (X^* I^c_j S_j)."""
    let, vec = tree.program.let, tree.program.vector
    n = len(tree.robot.coordinates)
    composite = {b.link: (b.mass, b.first_moment, b.inertia) for b in tree.bodies}
    for body in reversed(tree.bodies):
        if body.parent in tree.static:
            continue
        add_to_parent(tree.program, composite, body)
    M = [[sympy.Integer(0)] * n for _ in range(n)]
    for body in tree.bodies:
        if body.coordinate is None:
            continue
        mass, h, inertia = composite[body.link]
        a = body.axis
        j = body.coordinate
        force, moment = Meaning("Fcol", body.link, column=j), Meaning("Ncol", body.link, column=j)
        if body.revolute:
            f, nm = vec(_cross(a, h), force), vec(_rotate(inertia, a), moment)
        else:
            f, nm = vec([mass * x for x in a], force), vec(_cross(h, a), moment)
        armature = tree.drives[j].armature if j in tree.drives and body.leads else 0
        # a coordinate moving several joints (<mimic>) sums their entries: M = G^T M_joints G
        M[j][j] = let(M[j][j] + _dot(a, nm if body.revolute else f) + armature, Meaning("M", body.link, (j, j)))
        current = body
        while current.parent not in tree.static:
            nm, f = tree.force_to_parent(current, nm, f, j)
            current = tree.by_link[current.parent]
            if current.coordinate is not None:
                i = current.coordinate
                entry = _dot(current.axis, nm if current.revolute else f)   # i == j: a leader above its follower
                M[i][j] = M[j][i] = let(M[i][j] + (2 * entry if i == j else entry), Meaning("M", current.link, (i, j)))
    return M


def _advance(tree: _Tree, body: _Body, parent: tuple[Vector, Vector, Vector, Vector], qd: Sequence[sympy.Expr],
             qdd: Sequence[sympy.Expr]) -> tuple[Vector, Vector, Vector, Vector]:
    """Newton-Euler's outward step: the link's velocity and acceleration ``(w, v, alpha, a)``
    (at its frame origin, in its axes) from its parent's; a link at rest keeps only its
    frame's acceleration (gravity)."""
    vec = tree.program.vector
    zero = (sympy.Integer(0),) * 3
    if body.link in tree.static:
        return (zero, zero, zero, tree.motion_from_parent(body, zero, parent[3], ("omega", "a"))[1])  # type: ignore[return-value]
    w, v, alpha, acc = parent
    # what the lines carried from the parent mean: the link's own values where the joint adds nothing
    moves, revolute = body.coordinate is not None, body.revolute
    w, v = tree.motion_from_parent(body, w, v, ("omega_in" if moves and revolute else "omega",
                                               "v_in" if moves and not revolute else "v"))
    alpha, acc = tree.motion_from_parent(body, alpha, acc, ("alpha_in" if moves and revolute else "alpha",
                                                           "a_in" if moves else "a"))
    if body.coordinate is not None:
        rate, accel = qd[body.coordinate], qdd[body.coordinate]
        s = body.axis
        meaning = {q: Meaning(q, body.link) for q in ("omega", "v", "alpha", "a")}
        if body.revolute:   # joint motion S qd = (s qd, 0); v x S qd = (w x s, v x s) qd
            w_new = vec(_add(w, [x * rate for x in s]), meaning["omega"])
            alpha = vec(_add(alpha, [x * accel + y * rate for x, y in zip(s, _cross(w, s))]), meaning["alpha"])
            acc = vec(_add(acc, [y * rate for y in _cross(v, s)]), meaning["a"])
            w = w_new
        else:               # S qd = (0, s qd); v x S qd = (0, w x s qd)
            acc = vec(_add(acc, [x * accel + y * rate for x, y in zip(s, _cross(w, s))]), meaning["a"])
            v = vec(_add(v, [x * rate for x in s]), meaning["v"])
    return w, v, alpha, acc


def body_force(vec: Callable[..., Vector], m: sympy.Expr, h: Sequence[sympy.Expr],
               inertia: Sequence[Sequence[sympy.Expr]], w: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
               alpha: Sequence[sympy.Expr], acc: Sequence[sympy.Expr], link: str | None = None) -> tuple[Vector, Vector]:
    """The force ``(n, f)`` a link needs for its motion: ``I a + v x* (I v)`` with the spatial
    inertia of mass ``m``, first moment ``h = m c`` and ``inertia`` about the frame origin, the
    momentum ``(I w + h x v, m v + w x h)``; linear in ``(m, h, inertia)`` (the regressor).
    ``link`` (with ``vec`` a ``Program.vector``): record the lines' meanings (``k``, ``l``,
    ``N``, ``F``)."""
    def named(values: Sequence[sympy.Expr], quantity: str) -> Vector:
        return vec(values) if link is None else vec(values, Meaning(quantity, link))

    momentum_n = named(_add(_rotate(inertia, w), _cross(h, v)), "k")   # type: ignore[arg-type]
    momentum_f = named(_add([m * x for x in v], _cross(w, h)), "l")
    n = _add(_add(_rotate(inertia, alpha), _cross(h, acc)), _add(_cross(w, momentum_n), _cross(v, momentum_f)))  # type: ignore[arg-type]
    f = _add(_add([m * x for x in acc], _cross(alpha, h)), _cross(w, momentum_f))
    return named(n, "N"), named(f, "F")


def _newton_euler(tree: _Tree, qd: Sequence[sympy.Expr], qdd: Sequence[sympy.Expr],
                  gravity: Sequence[sympy.Expr]) -> list[sympy.Expr]:
    """RNEA: the generalized forces M qdd + C qd + N (gravity as an upward base acceleration)."""
    vec = tree.program.vector
    zero = (sympy.Integer(0),) * 3
    motion = {"world": (zero, zero, zero, vec([-g for g in gravity]))}   # (w, v, alpha, a)
    forces = {}
    for body in tree.bodies:
        motion[body.link] = _advance(tree, body, motion[body.parent], qd, qdd)
        if body.link in tree.static:
            continue
        w, v, alpha, acc = motion[body.link]
        forces[body.link] = body_force(vec, body.mass, body.first_moment, body.inertia, w, v, alpha, acc, body.link)
    tau: list[sympy.Expr] = [sympy.Integer(0)] * len(tree.robot.coordinates)
    for body in reversed(tree.bodies):
        if body.link in tree.static:
            continue
        n, f = forces[body.link]
        if body.coordinate is not None:
            j = body.coordinate
            drive = tree.drives.get(j) if body.leads else None
            extra = 0 if drive is None else drive.armature * qdd[j] + drive.stiffness * (tree.table.q[j] - drive.rest)
            # a coordinate moving several joints (<mimic>) sums their forces: G^T tau_joints
            tau[j] = tree.program.let(tau[j] + _dot(body.axis, n if body.revolute else f) + extra,
                                      Meaning("tau", body.link))
        if body.parent not in tree.static:
            n_p, f_p = tree.force_to_parent(body, n, f)
            parent_n, parent_f = forces[body.parent]
            forces[body.parent] = (vec(_add(parent_n, n_p), Meaning("n", body.parent)),
                                   vec(_add(parent_f, f_p), Meaning("f", body.parent)))
    return tau


def _gravity(robot: Robot, table: SymbolTable) -> list[sympy.Expr]:
    return [table.expr(e) for e in robot.gravity] + ([sympy.Integer(0)] if robot.planar else [])


def mass_matrix_program(robot: Robot, table: SymbolTable) -> Program:
    """``M(q)`` by the composite-rigid-body algorithm; outputs row by row."""
    program, tree = _start(robot, table)
    program.outputs = [e for row in _composite_mass_matrix(tree) for e in row]
    return program


def inverse_dynamics_program(robot: Robot, table: SymbolTable) -> Program:
    """``M qdd + C qd + N`` by recursive Newton-Euler."""
    program, tree = _start(robot, table)
    program.outputs = _newton_euler(tree, table.qd, table.qdd, _gravity(robot, table))
    return program


def friction_symbols(n: int) -> list[sympy.Symbol]:
    """Inputs of the forward-dynamics body for robots with damping, friction or frames: the
    forces opposing the motion from outside the body, ``F_g - J^T w``, computed by the module
    (``friction_forces``, exact or smoothed sign, and the frames' wrenches)."""
    return [sympy.Symbol(f"_friction{i}") for i in range(n)]


def forward_dynamics_program(robot: Robot, table: SymbolTable, efforts: Sequence[sympy.Expr]) -> Program:
    """``qdd`` solving ``M qdd = Y - (C qd + N) - F``: CRBA, Newton-Euler and an LDL^T solve.

    ``efforts`` is ``Y_g`` as expressions of the effort symbols; for a robot with damping,
    friction or frames, ``F - J^T w`` comes in as the inputs ``friction_symbols``. M is positive definite, so the
    factorization needs no pivoting; zeros of M (branches) stay zeros in L.
    """
    program, tree = _start(robot, table)
    let = program.let
    n = len(table.q)
    M = _composite_mass_matrix(tree)
    bias = _newton_euler(tree, table.qd, [sympy.Integer(0)] * n, _gravity(robot, table))
    friction = friction_symbols(n) if robot.dissipative or robot.frames else [0] * n
    rhs = [let(y - b - f) for y, b, f in zip(efforts, bias, friction)]
    L = [[sympy.Integer(0)] * n for _ in range(n)]
    inverse_d: list[sympy.Expr] = [sympy.Integer(0)] * n
    scaled = [[sympy.Integer(0)] * n for _ in range(n)]   # L_jk D_k
    for j in range(n):
        d = let(M[j][j] - sum((L[j][k] * scaled[j][k] for k in range(j)), sympy.Integer(0)))
        inverse_d[j] = let(1 / d)
        for i in range(j + 1, n):
            residual = M[i][j] - sum((L[i][k] * scaled[j][k] for k in range(j)), sympy.Integer(0))
            if residual != 0:
                L[i][j] = let(residual * inverse_d[j])
                scaled[i][j] = let(residual)
    y: list[sympy.Expr] = []
    for i in range(n):
        y.append(let(rhs[i] - sum((L[i][k] * y[k] for k in range(i)), sympy.Integer(0))))
    x: list[sympy.Expr] = [sympy.Integer(0)] * n
    for i in reversed(range(n)):
        x[i] = let(y[i] * inverse_d[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), sympy.Integer(0)))
    program.outputs = x
    if robot.dissipative or robot.frames:
        program.extra_inputs = friction
    return program


def _partial(expr: sympy.Expr, symbol: sympy.Symbol) -> sympy.Expr:
    """``d expr / d symbol`` for a program line: sums, products and integer powers of names
    and numbers, by the sum and product rules (SymPy's general ``diff`` costs several times
    as much per line, and the Coriolis passes differentiate n times every line of the CRBA);
    anything else by ``diff``."""
    zero = sympy.S.Zero
    if expr.is_Symbol:
        return sympy.S.One if expr == symbol else zero
    if expr.is_Number:
        return zero
    if expr.is_Add:
        return sympy.Add(*(_partial(a, symbol) for a in expr.args))
    if expr.is_Mul:
        args = expr.args
        terms = []
        for i, factor in enumerate(args):
            d = _partial(factor, symbol)
            rest = args[:i] + args[i + 1:]
            if d is sympy.S.One and (len(rest) > 2 or not (rest[0].is_Number and rest[-1].is_Add)):
                # the other factors of a product, in SymPy's order, are a product already (but
                # for a number times a sum, which SymPy distributes)
                terms.append(rest[0] if len(rest) == 1 else sympy.Mul._from_args(rest, True))
            elif d is not zero:
                terms.append(sympy.Mul(*args[:i], d, *args[i + 1:]))
        return sympy.Add(*terms)
    if expr.is_Pow and expr.exp.is_Integer:
        d = _partial(expr.base, symbol)
        return zero if d is zero else expr.exp * expr.base ** (expr.exp - 1) * d
    return sympy.diff(expr, symbol)


def _carry(program: Program, tangent: dict[sympy.Symbol, sympy.Expr], trig: dict[sympy.Expr, sympy.Symbol],
           lines: Sequence[tuple[sympy.Symbol, sympy.Expr, set[sympy.Symbol]]]) -> None:
    """One forward pass: the tangent of each of ``lines`` (name, expression, its names) that
    has one joins ``tangent`` under a new name of ``program``."""
    for name, expr, symbols in lines:
        d = _forward(expr, tangent, trig, symbols)
        if d != 0:
            tangent[name] = program.let(d)


def _forward(expr: sympy.Expr, tangent: dict[sympy.Symbol, sympy.Expr], trig: dict[sympy.Expr, sympy.Symbol],
             symbols: set[sympy.Symbol] | None = None) -> sympy.Expr:
    """The tangent of ``expr`` (forward mode): ``sum_s d expr/d s * tangent[s]`` over its names
    (``symbols``, if known) that have one; sines and cosines of coordinates in terms of the
    program's trig lines (``trig``)."""
    expr = sympy.sympify(expr)
    moving = sorted((s for s in (expr.free_symbols if symbols is None else symbols) if s in tangent),
                    key=lambda s: s.name)
    if not moving:
        return sympy.Integer(0)
    if expr.is_Function:   # a sine or cosine of a coordinate: in terms of the trig lines
        return sympy.Add(*(sympy.diff(expr, s) * tangent[s] for s in moving)).xreplace(trig)
    return sympy.Add(*(_partial(expr, s) if tangent[s] is sympy.S.One else _partial(expr, s) * tangent[s]
                       for s in moving))


@dataclass
class _Passes:
    """The forward passes of ``_coriolis``: per coordinate k, the tangent (d/dq_k) of every
    line of the first ``lines`` lines that has one, by name."""

    tangents: list[dict[sympy.Symbol, sympy.Expr]]
    lines: int
    trig: dict[sympy.Expr, sympy.Symbol]


def _coriolis(tree: _Tree, M: list[list[sympy.Expr]]) -> tuple[list[sympy.Expr], list[list[list[sympy.Expr]]], _Passes]:
    """The Christoffel-symbol Coriolis matrix ``C(q, qd)`` of the CRBA's ``M``, row by row,
    with ``dM/dq_k`` (``[k][i][j]``) and the passes that gave it.

    ``dM/dq_k`` comes from differentiating the program line by line (forward mode: each
    line's tangent from its own small expression), then
    ``C_ij = 1/2 sum_k (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) qd_k``, the same C as C_g.
    """
    program, table = tree.program, tree.table
    n = len(table.q)
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    trig = {expr: name for name, expr in program.lines[:len(tree.trig())]}
    dM = []
    tangents = []
    for k in range(n):
        tangent: dict[sympy.Symbol, sympy.Expr] = {table.q[k]: sympy.Integer(1)}
        _carry(program, tangent, trig, lines)
        dM.append([[program.let(_forward(M[i][j], tangent, trig)) for j in range(n)] for i in range(n)])
        tangents.append(tangent)
    half = sympy.Rational(1, 2)
    qd = table.qd
    C = [program.let(half * sum((qd[k] * (dM[k][i][j] + dM[j][i][k] - dM[i][j][k]) for k in range(n)),
                                sympy.Integer(0)))
         for i in range(n) for j in range(n)]
    return C, dM, _Passes(tangents, len(lines), trig)


def coriolis_note(n: int, lines: int) -> str:
    """Progress line of the Coriolis stage, the longest for large robots: n forward passes over
    the CRBA's lines, about 0.3 ms per line and pass on the 2-core reference machine (measured:
    generic 20-DOF 3-D chain, 20 passes over about 2000 lines, 13.5 s; 30-DOF planar chain,
    30 x 1870, 16.4 s), so it grows like n^3."""
    estimate = n * lines * 0.0003
    note = f", estimated {estimate:.0f} s" if estimate >= 5 else ""
    return f"Coriolis matrix ({n} forward derivatives of {lines} lines{note})"


def _potential(tree: _Tree) -> sympy.Expr:
    """``V(q)``: gravity's potential ``-sum (m_i g.p_i + g.R_i h_i)`` of every link, with gravity
    carried into each link frame (``g_i = R^T g_parent``) and ``s_i = g.p_i`` (link origin)
    accumulated along the tree, plus the joints' springs ``k (q - rest)**2 / 2``."""
    let, vec = tree.program.let, tree.program.vector
    gravity = _gravity(tree.robot, tree.table)
    frames: dict[str, tuple[Vector, sympy.Expr]] = {"world": (vec(gravity), sympy.Integer(0))}
    total = sympy.Integer(0)
    for body in tree.bodies:
        g_parent, s_parent = frames[body.parent]
        g = vec(_rotate_back(body.rotation, g_parent))
        s = let(s_parent + _dot(g_parent, body.position))
        frames[body.link] = (g, s)
        total += body.mass * s + _dot(g, body.first_moment)
    springs = [d.stiffness * (tree.table.q[d.coordinate] - d.rest) ** 2 / 2 for d in tree.drives.values()]
    return let(-total + sum(springs, sympy.Integer(0)))


def _body_jacobians(tree: _Tree) -> dict[str, sympy.Matrix]:
    """Each link's body Jacobian: the twist of its COM frame (axes of the link frame) per
    joint rate, rows ``(v, omega)`` (planar ``(vx, vy, omega)``), as ``J_b`` of the
    kinematics. Columns are carried from parent to child like Newton-Euler's velocities."""
    vec, n = tree.program.vector, len(tree.robot.coordinates)
    zero = (sympy.Integer(0),) * 3
    columns: dict[str, dict[int, tuple[Vector, Vector]]] = {"world": {}}
    jacobians = {}
    for body in tree.bodies:
        own = {j: tree.motion_from_parent(body, w, v) for j, (w, v) in columns[body.parent].items()}
        if body.coordinate is not None:
            own[body.coordinate] = add_column(vec, own.get(body.coordinate),
                                              (body.axis, zero) if body.revolute else (zero, body.axis))
        columns[body.link] = own
        com = [tree.table.expr(e) for e in tree.robot.link(body.link).com] + ([sympy.Integer(0)] if tree.robot.planar else [])
        rows = 3 if tree.robot.planar else 6
        jacobian = sympy.zeros(rows, n)
        for j, (w, v) in own.items():
            v_com = vec(_add(v, _cross(w, com)))
            column = [v_com[0], v_com[1], w[2]] if tree.robot.planar else [*v_com, *w]
            for r, value in enumerate(column):
                jacobian[r, j] = value
        jacobians[body.link] = jacobian
    return jacobians


class GeneralizedProgram:
    """One straight-line program for a robot's generalized quantities: M (CRBA), C (its
    Christoffel symbols), N (Newton-Euler at rest) and V, sharing every intermediate; the body
    Jacobians join it on first use. ``mechanics/structured.py`` names its lines for the sheet
    and JSON of a large robot, and ``programs.build_programs`` prints the lines each quantity reads as
    the generated module's bodies: one program for both, so the module's bytes do not depend
    on which other outputs a run writes."""

    def __init__(self, robot: Robot, table: SymbolTable, report: Callable[[str], None] = lambda stage: None):
        program, tree = _start(robot, table)
        self.program, self._tree = program, tree
        n = len(table.q)
        report(f"program: mass matrix (composite rigid bodies, {n} coordinates)")
        self.mass_matrix = _composite_mass_matrix(tree)
        report("program: " + coriolis_note(n, len(program.lines)))
        self.coriolis, self.mass_matrix_derivatives, self._passes = _coriolis(tree, self.mass_matrix)
        report("program: gravity vector and potential energy")
        zeros = [sympy.Integer(0)] * n
        self.gravity = _newton_euler(tree, zeros, zeros, _gravity(robot, table))
        self.potential = _potential(tree)
        self.trig = tree.trig()
        self._jacobians: dict[str, sympy.Matrix] | None = None
        self._potential_gradient: list[sympy.Expr] | None = None

    @property
    def potential_gradient(self) -> list[sympy.Expr]:
        """``dV/dq_k`` for every k (Lagrange's route to the gravity terms, where ``gravity``
        is Newton-Euler's): the Coriolis passes carried on over the lines V reads."""
        if self._potential_gradient is None:
            self._potential_gradient = self._gradient(self.potential)
        return self._potential_gradient

    def _gradient(self, expr: sympy.Expr) -> list[sympy.Expr]:
        needed = lines_read([expr], dict(self.program.lines))
        later = [(name, e, e.free_symbols) for name, e in self.program.lines[self._passes.lines:] if name in needed]
        gradient = []
        for passed in self._passes.tangents:
            tangent = dict(passed)
            _carry(self.program, tangent, self._passes.trig, later)
            gradient.append(self.program.let(_forward(expr, tangent, self._passes.trig)))
        return gradient

    @property
    def jacobians(self) -> dict[str, sympy.Matrix]:
        """Each link's body Jacobian (``_body_jacobians``), by link name, computed on first use
        with lines appended after those of M, C, N and V."""
        if self._jacobians is None:
            self._jacobians = _body_jacobians(self._tree)
        return self._jacobians

    def part(self, outputs: Sequence[sympy.Expr]) -> Program:
        """A program computing ``outputs``, whatever joined this one first (``part_of``)."""
        return part_of(self.program.lines, outputs)
