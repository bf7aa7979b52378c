"""Straight-line programs of the recursive algorithms, for the generated code, over the one
tree of every robot class (``tree.py``).

The composite-rigid-body algorithm (M), recursive Newton-Euler (C qd + N, inverse dynamics)
and an L^T D L solve (forward dynamics) of Featherstone's *Rigid Body Dynamics Algorithms*
(2008, ch. 5-6) run once on SymPy symbols. Every intermediate value gets a name, so no
expression ever grows, and SymPy's own arithmetic drops the products with structural zeros
and ones (joint axes along z, rotations by multiples of pi/2): the result is a short list of
assignments, each a few operations, that the code template prints as Python. The same lines
run on floats (one state, with ``math``) and on NumPy arrays (a batch).

>>> program = mass_matrix_program(robot, table)          # doctest: +SKIP
>>> len(program.lines), program.outputs[0]                 # doctest: +SKIP
(231, _t230)

Each joint adds its motion columns ``S = (s_w, s_v)`` (``tree.Body.columns``); a column with
a zero part (a revolute or a prismatic joint's) costs only its other part, so scalar joints
get the specialized recursions of a fixed-base robot. The Coriolis matrix of a robot without
quaternions is the Christoffel symbols of ``dM/dq`` (``GeneralizedProgram``, shared with the
sheet); a quaternion's velocity is a local twist, and its robot's C is Pinocchio's
(``coriolis.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
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
    _times,
    lines_read,
    part_of,
)
from .tree import ZERO, Body, Tree, gravity


def moved_inertia(program: Program, mass: sympy.Expr, h: Vector, inertia: Matrix3, R: Matrix3, p: Vector,
                  link: str | None = None) -> tuple[Vector, list[list[sympy.Expr]]]:
    """A spatial inertia (``mass``, first moment ``h``, ``inertia`` about its frame's origin) of
    a frame at rotation ``R`` and origin ``p`` in an outer frame, in the outer frame: ``R h``
    (as lines; the caller adds ``mass p``) and the inertia about the outer origin (entries not
    named). ``link``: record the lines' meanings (``hc_up``, ``IRt``)."""
    h_r = program.vector(_rotate(R, h), None if link is None else Meaning("hc_up", link))
    inertia_rt = [[program.let(_dot(inertia[k], R[b]), None if link is None else Meaning("IRt", link, (k, b)))
                   for b in range(3)] for k in range(3)]   # I R^T
    ph, pp = _dot(p, h_r), _dot(p, p)
    return h_r, [[_dot(R[a], [inertia_rt[k][b] for k in range(3)]) + mass * ((pp if a == b else 0) - p[a] * p[b])
                  + (2 * ph if a == b else 0) - h_r[a] * p[b] - p[a] * h_r[b] for b in range(3)] for a in range(3)]


def add_to_parent(program: Program, composite: dict[str, Any], body: Any) -> None:
    """CRBA's upward step: ``body``'s composite inertia (mass, first moment, rotational inertia
    about its frame) expressed in its parent's frame and added to the parent's, as program lines."""
    let, vec = program.let, program.vector
    mass, h, inertia = composite[body.link]
    p = body.position
    h_r, moved = moved_inertia(program, mass, h, inertia, body.rotation, p, body.link)
    p_mass, p_h, p_inertia = composite[body.parent]
    total = program.symmetric([[p_inertia[a][b] + moved[a][b] for b in range(3)] for a in range(3)],
                              Meaning("Ic", body.parent))
    composite[body.parent] = (let(p_mass + mass, Meaning("mc", body.parent)),
                              vec(_add(p_h, _add(h_r, [mass * x for x in p])), Meaning("hc", body.parent)),
                              total)


def _pair(s: tuple[Vector, Vector], n: Sequence[sympy.Expr], f: Sequence[sympy.Expr]) -> sympy.Expr:
    """A motion column and a force: ``s_w . n + s_v . f``."""
    return _dot(s[0], n) + _dot(s[1], f)


def _composite_mass_matrix(tree: Tree) -> list[list[sympy.Expr]]:
    """CRBA: composite inertias from the leaves up, then M_ij = S_i . (X^* I^c_j S_j)."""
    let, vec = tree.program.let, tree.program.vector
    n = tree.size
    composite = {b.link: (b.mass, b.first_moment, b.inertia) for b in tree.bodies}
    for body in reversed(tree.bodies):
        if body.parent not in tree.static:
            add_to_parent(tree.program, composite, body)
    M = [[ZERO] * n for _ in range(n)]
    for body in tree.bodies:
        mass, h, inertia = composite[body.link]
        for j, sw, sv in body.columns:
            # the composite body's momentum per unit rate of column j: (I sw + h x sv, m sv + sw x h)
            f = vec(_add(_times(sv, mass), _cross(sw, h)), Meaning("Fcol", body.link, column=j))
            nm = vec(_add(_rotate(inertia, sw), _cross(h, sv)), Meaning("Ncol", body.link, column=j))   # type: ignore[arg-type]
            armature = tree.drives[j].armature if j in tree.drives and body.leads else 0
            # a coordinate moving several joints (<mimic>) sums their entries: M = G^T M_joints G
            for i, tw, tv in body.columns:
                if i < j:
                    M[i][j] = M[j][i] = let(M[i][j] + _pair((tw, tv), nm, f), Meaning("M", body.link, (i, j)))
            M[j][j] = let(M[j][j] + _pair((sw, sv), nm, f) + armature, Meaning("M", body.link, (j, j)))
            current = body
            while current.parent not in tree.static:
                nm, f = tree.force_to_parent(current, nm, f, j)
                current = tree.by_link[current.parent]
                for i, tw, tv in current.columns:
                    entry = _pair((tw, tv), nm, f)   # i == j: a leader above its follower
                    M[i][j] = M[j][i] = let(M[i][j] + (2 * entry if i == j else entry),
                                            Meaning("M", current.link, (i, j)))
    return M


def _advance(tree: Tree, body: Body, parent: tuple[Vector, Vector, Vector, Vector], qd: Sequence[sympy.Expr],
             qdd: Sequence[sympy.Expr]) -> tuple[Vector, Vector, Vector, Vector]:
    """Newton-Euler's outward step: the link's velocity and acceleration ``(w, v, alpha, a)``
    (at its frame origin, in its axes) from its parent's; a link at rest keeps only its
    frame's acceleration (gravity). Per column ``S = (s_w, s_v)``: ``w += s_w qd``,
    ``v += s_v qd``, ``alpha += s_w qdd + (w x s_w) qd``, ``a += s_v qdd + (w x s_v + v x s_w) qd``;
    a column that changes with the joint's coordinates adds its rate times ``qd`` (``c_J``)."""
    vec = tree.program.vector
    zero = (ZERO,) * 3
    if body.link in tree.static:
        return (zero, zero, zero, tree.motion_from_parent(body, zero, parent[3], ("omega", "a"))[1])  # type: ignore[return-value]
    w, v, alpha, acc = parent
    # what the lines carried from the parent mean: the link's own values where the joint adds nothing
    turns, slides = body.turns, body.slides
    w, v = tree.motion_from_parent(body, w, v, ("omega_in" if turns else "omega", "v_in" if slides else "v"))
    alpha, acc = tree.motion_from_parent(body, alpha, acc, ("alpha_in" if turns else "alpha",
                                                           "a_in" if body.columns else "a"))
    if body.columns:
        dw, dv, dalpha, dacc = [ZERO] * 3, [ZERO] * 3, [ZERO] * 3, [ZERO] * 3
        for j, sw, sv in body.columns:
            rate, accel = qd[j], qdd[j]
            dw = _add(dw, [x * rate for x in sw])
            dv = _add(dv, [x * rate for x in sv])
            dalpha = _add(dalpha, [x * accel + y * rate for x, y in zip(sw, _cross(w, sw))])
            dacc = _add(dacc, [x * accel + y * rate for x, y in zip(sv, _add(_cross(w, sv), _cross(v, sw)))])
        for j, rw, rv in body.rates:   # columns that turn with the joint's own coordinates: c_J
            dalpha = _add(dalpha, [x * qd[j] for x in rw])
            dacc = _add(dacc, [x * qd[j] for x in rv])
        if turns:
            w = vec(_add(w, dw), Meaning("omega", body.link))
            alpha = vec(_add(alpha, dalpha), Meaning("alpha", body.link))
        acc = vec(_add(acc, dacc), Meaning("a", body.link))
        if slides:
            v = vec(_add(v, dv), Meaning("v", body.link))
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


def _newton_euler(tree: Tree, qd: Sequence[sympy.Expr], qdd: Sequence[sympy.Expr]) -> list[sympy.Expr]:
    """RNEA: the generalized forces M qdd + C qd + N (gravity as an upward base acceleration)."""
    vec = tree.program.vector
    lift = vec([-g for g in gravity(tree.robot, tree.table)])
    zero = (ZERO,) * 3
    motion = {"world": (zero, zero, zero, lift)}
    forces = {}
    for body in tree.bodies:
        motion[body.link] = _advance(tree, body, motion[body.parent], qd, qdd)   # type: ignore[assignment]
        if body.link not in tree.static:
            forces[body.link] = body_force(vec, body.mass, body.first_moment, body.inertia,
                                           *motion[body.link], body.link)
    tau: list[sympy.Expr] = [ZERO] * tree.size
    for body in reversed(tree.bodies):
        if body.link in tree.static:
            continue
        n, f = forces[body.link]
        for j, sw, sv in body.columns:
            drive = tree.drives.get(j) if body.leads else None
            extra = 0 if drive is None else drive.armature * qdd[j] + drive.stiffness * (tree.coordinate[j] - drive.rest)
            # a coordinate moving several joints (<mimic>) sums their forces: G^T tau_joints
            tau[j] = tree.program.let(tau[j] + _pair((sw, sv), n, f) + extra, Meaning("tau", body.link))
        if body.parent not in tree.static:
            n_p, f_p = tree.force_to_parent(body, n, f)
            parent_n, parent_f = forces[body.parent]
            forces[body.parent] = (vec(_add(parent_n, n_p), Meaning("n", body.parent)),
                                   vec(_add(parent_f, f_p), Meaning("f", body.parent)))
    return tau


def mass_matrix_program(robot: Robot, table: SymbolTable) -> Program:
    """``M(q)`` by the composite-rigid-body algorithm; outputs row by row."""
    tree = Tree(robot, table)
    tree.program.outputs = [e for row in _composite_mass_matrix(tree) for e in row]
    return tree.program


def inverse_dynamics_program(robot: Robot, table: SymbolTable, tree: Tree | None = None) -> Program:
    """``M qdd + C qd + N`` by recursive Newton-Euler (on ``tree``'s program, if given)."""
    tree = tree or Tree(robot, table)
    tree.program.outputs = _newton_euler(tree, table.qd, table.qdd)
    return tree.program


def friction_symbols(n: int) -> list[sympy.Symbol]:
    """Inputs of the forward-dynamics body for robots with damping, friction or frames: the
    forces opposing the motion from outside the body, ``F_g - J^T w``, computed by the module
    (``friction_forces``, exact or smoothed sign, and the frames' wrenches)."""
    return [sympy.Symbol(f"_friction{i}") for i in range(n)]


def ltdl_solve(let, M: list[list[sympy.Expr]], rhs: Sequence[sympy.Expr]) -> list[sympy.Expr]:   # noqa: ANN001
    """``x`` solving ``M x = rhs`` by ``M = L^T D L`` (Featherstone's LTDL, 2008, sec. 6.3):
    eliminating from the last column to the first, a tree's M (nonzero only between a joint and
    its ancestors, parents before children) fills in nothing, where L D L^T from the first
    column (a floating base, coupled to every joint; any joint with two branches below) would
    fill in. M is positive definite: no pivoting. Structural zeros stay zeros. The updates of a
    row sum unnamed until the row is eliminated (one line per entry of L, as many as an
    L D L^T's: the UR5's forward dynamics 331 lines and 1210 operations against 343 and 1268,
    the Panda's 482 and 2344 against 483 and 2409)."""
    n = len(rhs)
    H = [list(row) for row in M]
    for k in reversed(range(n)):
        inverse = let(1 / let(H[k][k]))   # the pivot named: the C target checks it is positive
        H[k][k] = inverse
        below = [i for i in reversed(range(k)) if H[k][i] != 0]
        row = {i: let(H[k][i]) for i in below}   # the updates of the rows above sum unnamed until read
        for i in below:   # from the nearest ancestor up
            a = let(row[i] * inverse)
            for j in below:
                if j <= i:
                    H[i][j] = H[j][i] = H[i][j] - a * row[j]
            H[k][i] = a
    y = list(rhs)   # L^T y = rhs: from the last entry
    for k in reversed(range(n)):
        y[k] = let(y[k])
        for i in range(k):
            if H[k][i] != 0:
                y[i] = y[i] - H[k][i] * y[k]
    x: list[sympy.Expr] = [ZERO] * n   # D^-1 y, then L x = D^-1 y from the first entry
    for k in range(n):
        x[k] = let(y[k] * H[k][k] - sum((H[k][j] * x[j] for j in range(k) if H[k][j] != 0), ZERO))
    return x


def forward_dynamics_program(robot: Robot, table: SymbolTable, efforts: Sequence[sympy.Expr],
                             tree: Tree | None = None) -> Program:
    """``qdd`` solving ``M qdd = Y - (C qd + N) - F``: CRBA, Newton-Euler and a solve (``ltdl_solve``).

    ``efforts`` is ``Y`` as expressions of the effort symbols; for a robot with damping,
    friction or frames, ``F - J^T w`` comes in as the inputs ``friction_symbols``.
    """
    tree = tree or Tree(robot, table)
    program, let, n = tree.program, tree.program.let, tree.size
    M = _composite_mass_matrix(tree)
    bias = _newton_euler(tree, table.qd, [ZERO] * n)
    friction = friction_symbols(n) if robot.dissipative or robot.frames else [0] * n
    rhs = [let(y - b - f) for y, b, f in zip(efforts, bias, friction)]
    program.outputs = ltdl_solve(let, M, rhs)
    if robot.dissipative or robot.frames:
        program.extra_inputs = friction   # type: ignore[assignment]
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
           lines: Sequence[tuple[sympy.Symbol, sympy.Expr, set[sympy.Symbol]]],
           partials: dict[tuple[sympy.Expr, sympy.Symbol], sympy.Expr] | None = None) -> None:
    """One forward pass: the tangent of each of ``lines`` (name, expression, its names) that
    has one joins ``tangent`` under a new name of ``program``. ``partials``: each line's
    partial derivatives kept across passes that differentiate the same lines (only the
    tangents they multiply differ)."""
    for name, expr, symbols in lines:
        d = _forward(expr, tangent, trig, symbols, partials)
        if d != 0:
            tangent[name] = program.let(d)


def _forward(expr: sympy.Expr, tangent: dict[sympy.Symbol, sympy.Expr], trig: dict[sympy.Expr, sympy.Symbol],
             symbols: set[sympy.Symbol] | None = None,
             partials: dict[tuple[sympy.Expr, sympy.Symbol], sympy.Expr] | None = None) -> sympy.Expr:
    """The tangent of ``expr`` (forward mode): ``sum_s d expr/d s * tangent[s]`` over its names
    (``symbols``, if known) that have one; sines and cosines of coordinates in terms of the
    program's trig lines (``trig``). ``partials``: the partial derivatives already taken."""
    expr = sympy.sympify(expr)
    moving = sorted((s for s in (expr.free_symbols if symbols is None else symbols) if s in tangent),
                    key=lambda s: s.name)
    if not moving:
        return sympy.Integer(0)
    if expr.is_Function:   # a sine or cosine of a coordinate: in terms of the trig lines
        return sympy.Add(*(sympy.diff(expr, s) * tangent[s] for s in moving)).xreplace(trig)
    partials = {} if partials is None else partials
    terms = []
    for s in moving:
        if (expr, s) not in partials:
            partials[expr, s] = _partial(expr, s)
        terms.append(partials[expr, s] if tangent[s] is sympy.S.One else partials[expr, s] * tangent[s])
    return sympy.Add(*terms)


@dataclass
class _Passes:
    """The forward passes of ``_coriolis``: per coordinate k, the tangent (d/dq_k) of every
    line of the first ``lines`` lines that has one, by name."""

    tangents: list[dict[sympy.Symbol, sympy.Expr]]
    lines: int
    trig: dict[sympy.Expr, sympy.Symbol]


def _coriolis(tree: Tree, M: list[list[sympy.Expr]]) -> tuple[list[sympy.Expr], list[list[list[sympy.Expr]]], _Passes]:
    """The Christoffel-symbol Coriolis matrix ``C(q, qd)`` of the CRBA's ``M``, row by row,
    with ``dM/dq_k`` (``[k][i][j]``) and the passes that gave it.

    ``dM/dq_k`` comes from differentiating the program line by line (forward mode: each
    line's tangent from its own small expression), then
    ``C_ij = 1/2 sum_k (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) qd_k``, the same C as C_g.
    """
    program, table = tree.program, tree.table
    n = len(table.q)
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    trig = {expr: name for name, expr in program.lines[:len(tree.trig)]}
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


def _potential(tree: Tree) -> sympy.Expr:
    """``V(q)``: gravity's potential ``-sum (m_i g.p_i + g.R_i h_i)`` of every link, with gravity
    carried into each link frame (``g_i = R^T g_parent``) and ``s_i = g.p_i`` (link origin)
    accumulated along the tree, plus the joints' springs ``k (q - rest)**2 / 2``."""
    let, vec = tree.program.let, tree.program.vector
    frames: dict[str, tuple[Vector, sympy.Expr]] = {"world": (vec(gravity(tree.robot, tree.table)), ZERO)}
    total = sympy.Integer(0)
    for body in tree.bodies:
        g_parent, s_parent = frames[body.parent]
        g = vec(_rotate_back(body.rotation, g_parent))
        s = let(s_parent + _dot(g_parent, body.position))
        frames[body.link] = (g, s)
        total += body.mass * s + _dot(g, body.first_moment)
    springs = [d.stiffness * (tree.coordinate[d.coordinate] - d.rest) ** 2 / 2 for d in tree.drives.values()]
    return let(-total + sum(springs, sympy.Integer(0)))


def _body_jacobians(tree: Tree) -> dict[str, sympy.Matrix]:
    """Each link's body Jacobian: the twist of its COM frame (axes of the link frame) per
    joint rate, rows ``(v, omega)`` (planar ``(vx, vy, omega)``), as ``J_b`` of the
    kinematics. Columns are carried from parent to child like Newton-Euler's velocities."""
    vec, n = tree.program.vector, tree.size
    columns: dict[str, dict[int, tuple[Vector, Vector]]] = {"world": {}}
    jacobians = {}
    for body in tree.bodies:
        own = columns[body.link] = tree.carry_columns(body, columns[body.parent])
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
    and JSON of a large robot, and ``module_programs.build_programs`` prints the lines each quantity reads as
    the generated module's bodies: one program for both, so the module's bytes do not depend
    on which other outputs a run writes."""

    def __init__(self, robot: Robot, table: SymbolTable, report: Callable[[str], None] = lambda stage: None):
        tree = Tree(robot, table)
        program = tree.program
        self.program, self._tree = program, tree
        n = len(table.q)
        report(f"program: mass matrix (composite rigid bodies, {n} coordinates)")
        self.mass_matrix = _composite_mass_matrix(tree)
        report("program: " + coriolis_note(n, len(program.lines)))
        self.coriolis, self.mass_matrix_derivatives, self._passes = _coriolis(tree, self.mass_matrix)
        report("program: gravity vector and potential energy")
        zeros = [sympy.Integer(0)] * n
        self.gravity = _newton_euler(tree, zeros, zeros)
        self.potential = _potential(tree)
        self.trig = tree.trig

    @cached_property
    def potential_gradient(self) -> list[sympy.Expr]:
        """``dV/dq_k`` for every k (Lagrange's route to the gravity terms, where ``gravity``
        is Newton-Euler's): the Coriolis passes carried on over the lines V reads."""
        needed = lines_read([self.potential], dict(self.program.lines))
        later = [(name, e, e.free_symbols) for name, e in self.program.lines[self._passes.lines:] if name in needed]
        gradient = []
        for passed in self._passes.tangents:
            tangent = dict(passed)
            _carry(self.program, tangent, self._passes.trig, later)
            gradient.append(self.program.let(_forward(self.potential, tangent, self._passes.trig)))
        return gradient

    @cached_property
    def jacobians(self) -> dict[str, sympy.Matrix]:
        """Each link's body Jacobian (``_body_jacobians``), by link name, computed on first use
        with lines appended after those of M, C, N and V."""
        return _body_jacobians(self._tree)

    def part(self, outputs: Sequence[sympy.Expr]) -> Program:
        """A program computing ``outputs``, whatever joined this one first (``part_of``)."""
        return part_of(self.program.lines, outputs)
