"""What a floating-base robot's module has beyond M, N and the dynamics: the
Coriolis matrix, the derivatives of inverse dynamics on the tangent space (``linearize``)
and the regressor, as straight-line programs over ``floating.FloatingTree``.

*Coriolis matrix.* The fixed-base route (Christoffel symbols of ``dM/dq``) needs ``qd`` to
be the derivative of ``q``; a free flyer's velocity is a local twist, so its Christoffel
symbols would take the structure constants of SE(3) as well. The program follows Pinocchio's
``computeCoriolisMatrix`` instead (the same C, compared to 1e-9):
``C = sum_k J_k^T (I_k Jdot_k + B_k J_k)`` over the links ``k``, with
``B_k = 1/2 (v_k x* I_k - I_k v_k x + (I_k v_k) xbar*)`` (``f xbar* m = m x* f``); then
``C qd`` is the bias ``C qd + N - N`` and ``Mdot - 2 C`` is skew-symmetric. As Pinocchio,
in world axes (about the world origin): a joint's column ``S_j`` and its rate ``v_j x S_j``
(``v_j`` the velocity of joint j's link) are then the same in every link's Jacobian below
it, so ``C_ij = S_i^T (I^c_k (v_j x S_j) + B^c_k S_j)`` with ``k`` the deeper link of the
two joints and ``I^c``, ``B^c`` summed from the leaves up: one pose, inertia and ``B`` per
link, no frame change per column.

*Derivatives.* Newton-Euler differentiated line by line (``recursive._carry``, each line's
partial derivatives kept across the passes) along each velocity direction: a scalar joint's
coordinate, and for the floating joint the configuration's tangent of ``integrate(q, e_k h)`` at h = 0 (``dp = R e_lin``,
``dquat = 1/2 quat * (e_ang, 0)``; a spherical joint's quaternion likewise), Pinocchio's
convention in ``computeABADerivatives``.

*Regressor.* ``recursive``/``regressor.py``'s construction: each joint's axis carried down
into the frames of the links below it, dotted with each link's force per unit parameter
(Pinocchio's order, about the link frame's origin); then per driven scalar joint its
damping ``b`` (column ``qd_i``), Coulomb friction ``fc`` (``sign(qd_i)``, an input of the
body as in ``regressor.py``), armature and stiffness (``regressor.DRIVE_KINDS``' order).
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .floating import (
    FloatingTree,
    _times,
    efforts,
    ltdl_solve,
    mass_matrix,
    motions,
    newton_euler,
    potential,
)
from .program import Matrix3, Program, Vector, _add, _cross, _dot, _rotate
from .recursive import _forward, _partial, body_force, friction_symbols
from .regressor import _ENTRY, DRIVE_KINDS, SPATIAL_KINDS, Parameter, _unit_parameters, sign_symbols
from .spatial import inertia_tensor

_ZERO = sympy.Integer(0)
_HALF = sympy.Rational(1, 2)
Motion = tuple[Vector, Vector]
Inertia = tuple[sympy.Expr, Vector, Matrix3]   # (m, h, I about the origin)


def _motion_cross(a: Motion, b: Motion) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``a x b`` of motion vectors ``(w, v)``."""
    return _cross(a[0], b[0]), _add(_cross(a[0], b[1]), _cross(a[1], b[0]))


def _force_cross(m: Motion, f: Sequence[Sequence[sympy.Expr]]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``m x* f`` of a motion ``(w, v)`` and a force ``(n, f)``."""
    return _add(_cross(m[0], f[0]), _cross(m[1], f[1])), _cross(m[0], f[1])


def _world_inertia(let, vec, body, R: Matrix3, p: Vector) -> Inertia:  # noqa: ANN001
    """The link's spatial inertia ``(m, h, I)`` about the world origin in world axes (the
    link frame at rotation ``R``, origin ``p``)."""
    h_r = vec(_rotate(R, body.first_moment))
    inertia_rt = [[let(_dot(body.inertia[k], R[b])) for b in range(3)] for k in range(3)]   # I R^T
    ph, pp, mass = _dot(p, h_r), _dot(p, p), body.mass
    inertia = [[None] * 3 for _ in range(3)]
    for a in range(3):
        for b in range(a, 3):
            inertia[a][b] = inertia[b][a] = let(
                _dot(R[a], [inertia_rt[k][b] for k in range(3)]) + mass * ((pp if a == b else 0) - p[a] * p[b])
                + (2 * ph if a == b else 0) - h_r[a] * p[b] - p[a] * h_r[b])
    return mass, vec(_add(h_r, _times(p, mass))), tuple(tuple(row) for row in inertia)  # type: ignore[return-value]


def _apply(inertia: Inertia, m: Motion) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """A spatial inertia ``(m, h, I)`` times a motion ``(w, v)``: ``(I w + h x v, m v + w x h)``."""
    mass, h, J = inertia
    return _add(_rotate(J, m[0]), _cross(h, m[1])), _add(_times(m[1], mass), _cross(m[0], h))


def _pair(m: Sequence[sympy.Expr], f: Sequence[sympy.Expr]) -> sympy.Expr:
    """A motion and a force (six entries each, angular part first): ``w . n + v . f``."""
    return sum((a * b for a, b in zip(m, f)), _ZERO)


def coriolis_matrix(tree: FloatingTree) -> list[list[sympy.Expr]]:
    """Pinocchio's Coriolis matrix ``C(q, qd)`` (module docstring), n x n, in world axes as
    ``computeCoriolisMatrix`` builds it: with every quantity about the world origin, a joint's
    column ``S_j`` and its rate ``v_j x S_j`` are the same for every link below it, so
    ``C_ij = S_i^T (I^c_k (v_j x S_j) + B^c_k S_j)`` with ``k`` the deeper of the two joints'
    links and ``I^c``, ``B^c`` summed over the links below ``k`` (no frame changes)."""
    let, vec = tree.program.let, tree.program.vector
    n = tree.robot.velocity_count
    qd = tree.table.qd
    one = sympy.Integer(1)
    identity: Matrix3 = ((one, _ZERO, _ZERO), (_ZERO, one, _ZERO), (_ZERO, _ZERO, one))
    zero: Vector = (_ZERO, _ZERO, _ZERO)
    poses: dict[str, tuple[Matrix3, Vector]] = {"world": (identity, zero)}
    velocity: dict[str, Motion] = {"world": (zero, zero)}
    # (link, j): (link, S_j, v_j x S_j), world axes; keyed by link too, as a <mimic> joint shares
    # its leader's column j, and its entries join the leader's (C = G^T C_joints G)
    columns: dict[tuple[str, int], tuple[str, Motion, Motion]] = {}
    composite: dict[str, Inertia] = {}
    B: dict[str, list[list[sympy.Expr]]] = {}
    units = [tuple(tuple(one if 3 * part + k == r else _ZERO for k in range(3)) for part in range(2)) for r in range(6)]
    for body in tree.bodies:   # parents first
        R_p, p_p = poses[body.parent]
        R = tuple(tuple(let(_dot(R_p[a], [body.rotation[k][b] for k in range(3)])) for b in range(3)) for a in range(3))
        p = vec(_add(p_p, _rotate(R_p, body.position)))
        poses[body.link] = (R, p)   # type: ignore[assignment]
        own = []
        for j, sw, sv in body.columns:
            w = vec(_rotate(R, sw))   # type: ignore[arg-type]
            own.append((j, (w, vec(_add(_rotate(R, sv), _cross(p, w))))))   # type: ignore[arg-type]
        w, v = velocity[body.parent]
        if own:
            w = vec([w[k] + sum((s[0][k] * qd[j] for j, s in own), _ZERO) for k in range(3)])
            v = vec([v[k] + sum((s[1][k] * qd[j] for j, s in own), _ZERO) for k in range(3)])
        velocity[body.link] = (w, v)
        for j, s in own:
            columns[body.link, j] = (body.link, s, tuple(vec(x) for x in _motion_cross((w, v), s)))  # type: ignore[assignment]
        inertia = _world_inertia(let, vec, body, R, p)   # type: ignore[arg-type]
        composite[body.link] = inertia
        momentum = tuple(vec(x) for x in _apply(inertia, (w, v)))
        B_columns = []   # B e_r = (v x* I e_r - I (v x e_r) + e_r x* I v) / 2
        for e in units:
            first = _force_cross((w, v), _apply(inertia, e))
            second = _apply(inertia, _motion_cross((w, v), e))
            third = _force_cross(e, momentum)
            B_columns.append([let(_HALF * (a - b + c)) for part in zip(first, second, third)
                              for a, b, c in zip(*part)])
        B[body.link] = [[B_columns[c][r] for c in range(6)] for r in range(6)]
    for body in reversed(tree.bodies):   # composites from the leaves up
        if body.parent == "world":
            continue
        mass, h, J = composite[body.link]
        p_mass, p_h, p_J = composite[body.parent]
        total = [[None] * 3 for _ in range(3)]
        for a in range(3):
            for b in range(a, 3):
                total[a][b] = total[b][a] = let(p_J[a][b] + J[a][b])
        composite[body.parent] = (let(p_mass + mass), vec(_add(p_h, h)), tuple(tuple(row) for row in total))  # type: ignore[assignment]
        B[body.parent] = [[let(x + y) for x, y in zip(row_p, row)] for row_p, row in zip(B[body.parent], B[body.link])]
    by_link = {b.link: b for b in tree.bodies}
    C = [[_ZERO] * n for _ in range(n)]
    rows: dict[tuple[str, int], tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]] = {}   # (S_i^T B^c, I^c S_i)
    for key, (link, s, ds) in columns.items():
        j = key[1]
        flat = (*s[0], *s[1])
        spin = _apply(composite[link], ds)
        turn = [sum((B[link][r][c] * flat[c] for c in range(6)), _ZERO) for r in range(6)]
        force = vec([a + b for a, b in zip((*spin[0], *spin[1]), turn)])   # I^c_k dS_j + B^c_k S_j
        rows[key] = (vec([sum((flat[r] * B[link][r][c] for r in range(6)), _ZERO) for c in range(6)]),
                     vec([x for part in _apply(composite[link], s) for x in part]))
        current = by_link[link]
        while True:   # rows of joint j's link and of the joints above it
            for i, _, _ in current.columns:
                t = columns[current.link, i][1]
                C[i][j] = let(C[i][j] + _pair((*t[0], *t[1]), force))
            if current.parent == "world":
                break
            current = by_link[current.parent]
    for key, (link, _, _) in columns.items():   # the joints strictly above joint i's link
        i = key[1]
        current = by_link[link]
        while current.parent != "world":
            current = by_link[current.parent]
            for j, _, _ in current.columns:
                t, dt = columns[current.link, j][1], columns[current.link, j][2]
                C[i][j] = let(C[i][j] + _pair((*t[0], *t[1]), rows[key][0]) + _pair((*dt[0], *dt[1]), rows[key][1]))
    return C


def _tangent_seeds(tree: FloatingTree) -> list[dict[sympy.Symbol, sympy.Expr]]:
    """Per velocity column, the tangent of the configuration along it, its joint type's
    ``tangent_seed``: ``q_i = 1`` for a scalar joint; for a floating or spherical joint, that
    of ``integrate(q, e_k h)`` at h = 0."""
    let, table, where = tree.program.let, tree.table, tree.offsets
    seeds: list[dict[sympy.Symbol, sympy.Expr]] = [{} for _ in range(tree.robot.velocity_count)]
    for joint in (j for j in tree.robot.joints if j.owns):   # a <mimic> joint moves with its leader's
        kind = joint_types.of(joint)
        qi, vi = where.q[joint.name], where.v[joint.name]
        seeds[vi:vi + kind.nv] = kind.tangent_seed(table.q[qi:qi + kind.nq], let)
    return seeds


def _carry_shared(program: Program, tangent: dict[sympy.Symbol, sympy.Expr], trig: dict[sympy.Expr, sympy.Symbol],
                  lines: Sequence[tuple[sympy.Symbol, sympy.Expr, set[sympy.Symbol]]],
                  partials: dict[tuple[sympy.Symbol, sympy.Symbol], sympy.Expr]) -> None:
    """``recursive._carry`` (the same lines) with each line's partial derivatives kept in
    ``partials`` across the passes: the 2 n passes of the linearization differentiate the same
    lines by the same names, and only the tangents they multiply differ."""
    one = sympy.S.One
    for name, expr, symbols in lines:
        moving = sorted((s for s in symbols if s in tangent), key=lambda s: s.name)
        if not moving:
            continue
        if expr.is_Function:
            d = _forward(expr, tangent, trig, symbols)
        else:
            terms = []
            for s in moving:
                partial = partials.get((name, s))
                if partial is None:
                    partial = partials[name, s] = _partial(expr, s)
                terms.append(partial if tangent[s] is one else partial * tangent[s])
            d = sympy.Add(*terms)
        if d != 0:
            tangent[name] = program.let(d)


def inverse_dynamics_derivatives(tree: FloatingTree) -> Program:
    """``dtau/dq`` (along ``integrate``, n x n) then ``dtau/dqd``, row by row, in ``tree``'s program."""
    robot, table = tree.robot, tree.table
    tau = newton_euler(tree, table.qd, table.qdd)
    program = tree.program
    trig = {expr: name for name, expr in tree.trig}
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    seeds = _tangent_seeds(tree) + [{rate: sympy.Integer(1)} for rate in table.qd]
    by_variable = []
    partials: dict[tuple[sympy.Symbol, sympy.Symbol], sympy.Expr] = {}
    for seed in seeds:
        tangent = dict(seed)
        _carry_shared(program, tangent, trig, lines, partials)
        by_variable.append([program.let(_forward(t, tangent, trig)) for t in tau])
    n = robot.velocity_count
    program.outputs = [by_variable[k][i] for i in range(n) for k in range(n)]
    program.outputs += [by_variable[n + k][i] for i in range(n) for k in range(n)]
    return program


def floating_parameter_vector(robot: Robot, table: SymbolTable) -> list[Parameter]:
    """``pi``: per link (file order) its ten standard parameters in Pinocchio's order, about
    the link frame's origin; then damping, friction, armature and stiffness per driven scalar
    joint (nonzero ones, ``regressor.DRIVE_KINDS``' order, as a fixed-base robot's)."""
    entries = []
    for link in robot.links:
        mass = table.expr(link.mass)
        com = [table.expr(e) for e in link.com]
        about_com = inertia_tensor(tuple(table.expr(e) for e in link.inertia))
        square = sum((c * c for c in com), _ZERO)
        values = {"m": mass, "mcx": mass * com[0], "mcy": mass * com[1], "mcz": mass * com[2]}
        for kind, (a, b) in _ENTRY.items():
            values[kind] = about_com[a, b] + mass * ((square if a == b else 0) - com[a] * com[b])
        entries += [Parameter(f"{kind}_{link.name}", kind, link.name, values[kind]) for kind in SPATIAL_KINDS]
    for joint in (j for j in robot.joints if j.moves and not j.multi and j.driven):
        for kind in DRIVE_KINDS:
            text = getattr(joint, kind)
            if text is not None and table.expr(text) != 0:
                entries.append(Parameter(f"{kind}_{joint.name}", kind, joint.name, table.expr(text)))
    return entries


def regressor(tree: FloatingTree) -> Program:
    """``Y(q, qd, qdd)`` with ``Y pi = inverse_dynamics``, row by row (NV rows), in ``tree``'s program."""
    robot, table = tree.robot, tree.table
    program, vec = tree.program, tree.program.vector
    n = robot.velocity_count
    parameters = floating_parameter_vector(robot, table)
    column = {p.name: i for i, p in enumerate(parameters)}
    Y = [[_ZERO] * len(parameters) for _ in range(n)]
    motion = motions(tree, table.qd, table.qdd)
    # each joint column carried down, by (depth of its link, column): a <mimic> joint's sums into
    # its leader's row (G^T Y_joints)
    depth = {b.link: k for k, b in enumerate(tree.bodies)}
    axes: dict[str, dict[tuple[int, int], Motion]] = {"world": {}}
    for body in tree.bodies:
        own = {key: tree.motion_from_parent(body, w, v) for key, (w, v) in axes[body.parent].items()}
        own.update({(depth[body.link], j): (sw, sv) for j, sw, sv in body.columns})
        axes[body.link] = own
        for kind in SPATIAL_KINDS:
            n_k, f_k = body_force(vec, *_unit_parameters(kind), *motion[body.link])
            for (_, j), (s_w, s_v) in sorted(own.items(), key=lambda item: (item[0][1], item[0][0])):
                c = column[f"{kind}_{body.link}"]
                Y[j][c] = program.let(Y[j][c] + _dot(s_w, n_k) + _dot(s_v, f_k))
    signs = sign_symbols(n)
    joint_of = {j.child: j for j in robot.joints}
    for body in tree.bodies:   # a follower's terms on its leader's column: m^2 b qd, |m| fc sign(qd), m^2 Ia qdd
        if body.drive is None:
            continue
        m, _, _, rest, variable = body.drive
        name, [(i, _, _)] = joint_of[body.link].name, body.columns
        if f"damping_{name}" in column:
            Y[i][column[f"damping_{name}"]] = m * m * table.qd[i]
        if f"friction_{name}" in column:
            Y[i][column[f"friction_{name}"]] = abs(m) * signs[i]
        if f"armature_{name}" in column:
            Y[i][column[f"armature_{name}"]] = m * m * table.qdd[i]
        if f"stiffness_{name}" in column:
            Y[i][column[f"stiffness_{name}"]] = program.let(m * (variable - rest))
    program.outputs = [e for row in Y for e in row]
    if any(p.kind == "friction" for p in parameters):
        program.extra_inputs = signs
    return program


def floating_programs(robot: Robot, table: SymbolTable) -> dict[str, Program]:
    """The programs of a floating-base robot's module, by name: ``mass_matrix`` (row by row),
    ``gravity``, ``potential``, ``inverse_dynamics``, ``forward_dynamics`` (``floating.py``'s
    recursions), ``coriolis``, ``inverse_dynamics_derivatives`` and ``regressor`` (this module's)."""
    programs = {}
    zeros = [_ZERO] * robot.velocity_count
    base = FloatingTree(robot, table)
    tree = base.copy()
    tree.program.outputs = [e for row in mass_matrix(tree) for e in row]
    programs["mass_matrix"] = tree.program
    tree = base.copy()
    tree.program.outputs = newton_euler(tree, zeros, zeros)
    programs["gravity"] = tree.program
    tree = base.copy()
    tree.program.outputs = [potential(tree)]
    programs["potential"] = tree.program
    tree = base.copy()
    tree.program.outputs = newton_euler(tree, table.qd, table.qdd)
    programs["inverse_dynamics"] = tree.program
    tree = base.copy()
    M = mass_matrix(tree)
    bias = newton_euler(tree, table.qd, zeros)
    # damping, friction, frames: F - J^T w comes in as inputs (recursive.forward_dynamics_program's)
    opposing = friction_symbols(len(zeros)) if robot.dissipative or robot.frames else zeros
    rhs = [tree.program.let(y - b - f) for y, b, f in zip(efforts(robot, table), bias, opposing)]
    tree.program.outputs = ltdl_solve(tree.program.let, M, rhs)
    if robot.dissipative or robot.frames:
        tree.program.extra_inputs = list(opposing)
    programs["forward_dynamics"] = tree.program
    tree = base.copy()
    tree.program.outputs = [e for row in coriolis_matrix(tree) for e in row]
    programs["coriolis"] = tree.program
    programs["inverse_dynamics_derivatives"] = inverse_dynamics_derivatives(base.copy())
    programs["regressor"] = regressor(base.copy())
    return programs
