"""What a floating-base robot's module has beyond M, N and the dynamics (issue 30): the
Coriolis matrix, the derivatives of inverse dynamics on the tangent space (``linearize``)
and the regressor, as straight-line programs over ``floating.FloatingTree``.

*Coriolis matrix.* The fixed-base route (Christoffel symbols of ``dM/dq``) needs ``qd`` to
be the derivative of ``q``; a free flyer's velocity is a local twist, so its Christoffel
symbols would take the structure constants of SE(3) as well. The program follows Pinocchio's
``computeCoriolisMatrix`` instead (the same C, compared to 1e-9):
``C = sum_k J_k^T (I_k Jdot_k + B_k J_k)`` over the links ``k``, with ``J_k`` the link's
Jacobian in its own frame, ``Jdot_k``'s column of joint ``j`` the motion vector
``v_j x S_j`` (``v_j`` the velocity of joint j's link) carried into link k's frame, and
``B_k = 1/2 (v_k x* I_k - I_k v_k x + (I_k v_k) xbar*)`` (``f xbar* m = m x* f``); then
``C qd`` is the bias ``C qd + N - N`` and ``Mdot - 2 C`` is skew-symmetric.
``C_ij = S_i . sum_{k below i and j} F_jk``, ``F_jk = I_k Jdot_k e_j + B_k J_k e_j``: per
column j the forces ``F_jk`` of the links below joint j, summed from the leaves up.

*Derivatives.* Newton-Euler differentiated line by line (``recursive._carry``) along each
velocity direction: a scalar joint's coordinate, and for the floating joint the
configuration's tangent of ``integrate(q, e_k h)`` at h = 0 (``dp = R e_lin``,
``dquat = 1/2 quat * (e_ang, 0)``), Pinocchio's convention in ``computeABADerivatives``.

*Regressor.* ``recursive``/``regressor.py``'s construction: each joint's axis carried down
into the frames of the links below it, dotted with each link's force per unit parameter
(Pinocchio's order, about the link frame's origin); then armature and stiffness per driven
joint. Damping and friction are not in a floating-base robot's dynamics, nor here.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .floating import (
    FloatingTree,
    _times,
    efforts,
    ltdl_solve,
    mass_matrix,
    motions,
    newton_euler,
    potential,
    quaternion_matrix,
)
from .program import Program, Vector, _add, _cross, _dot, _rotate
from .recursive import _carry, _forward, body_force
from .regressor import _ENTRY, SPATIAL_KINDS, Parameter, _unit_parameters
from .spatial import inertia_tensor

_ZERO = sympy.Integer(0)
_HALF = sympy.Rational(1, 2)
Motion = tuple[Vector, Vector]


def _motion_cross(a: Motion, b: Motion) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``a x b`` of motion vectors ``(w, v)``."""
    return _cross(a[0], b[0]), _add(_cross(a[0], b[1]), _cross(a[1], b[0]))


def _force_cross(m: Motion, f: Sequence[Sequence[sympy.Expr]]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``m x* f`` of a motion ``(w, v)`` and a force ``(n, f)``."""
    return _add(_cross(m[0], f[0]), _cross(m[1], f[1])), _cross(m[0], f[1])


def _inertia_times(body, m: Sequence[Sequence[sympy.Expr]]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:  # noqa: ANN001
    """The link's spatial inertia times a motion vector: ``(I w + h x v, m v + w x h)``."""
    return (_add(_rotate(body.inertia, m[0]), _cross(body.first_moment, m[1])),
            _add(_times(m[1], body.mass), _cross(m[0], body.first_moment)))


def coriolis_matrix(tree: FloatingTree) -> list[list[sympy.Expr]]:
    """Pinocchio's Coriolis matrix ``C(q, qd)`` (module docstring), n x n."""
    let, vec = tree.program.let, tree.program.vector
    n = tree.robot.velocity_count
    velocity = {link: (w, v) for link, (w, v, _, _) in motions(tree, tree.table.qd, [_ZERO] * n).items()}
    momentum = {b.link: tuple(vec(x) for x in _inertia_times(b, velocity[b.link])) for b in tree.bodies}
    by_link = {b.link: b for b in tree.bodies}
    C = [[_ZERO] * n for _ in range(n)]
    for body in tree.bodies:
        for j, sw, sv in body.columns:
            column: Motion = (sw, sv)
            carried = {body.link: (column, tuple(vec(x) for x in _motion_cross(velocity[body.link], column)))}
            below = [body]
            for other in tree.bodies:   # parents first: the links below joint j, the column in their frames
                if other.parent in carried and other.link not in carried:
                    s, ds = carried[other.parent]
                    carried[other.link] = (tree.motion_from_parent(other, *s), tree.motion_from_parent(other, *ds))
                    below.append(other)
            forces = {}
            for link in below:
                s, ds = carried[link.link]
                v = velocity[link.link]
                half_ds = [[d - x / 2 for d, x in zip(part, cross)]   # I (dS - v x S / 2) + (v x* I S + S x* I v) / 2
                           for part, cross in zip(ds, _motion_cross(v, s))]
                first = _inertia_times(link, half_ds)
                second = _force_cross(v, _inertia_times(link, s))
                third = _force_cross(s, momentum[link.link])
                forces[link.link] = tuple(vec([a + _HALF * (b + c) for a, b, c in zip(*parts)])
                                          for parts in zip(first, second, third))
            for link in reversed(below[1:]):   # from the leaves up to joint j's link
                n_p, f_p = tree.force_to_parent(link, *forces[link.link])
                parent_n, parent_f = forces[link.parent]
                forces[link.parent] = (vec(_add(parent_n, n_p)), vec(_add(parent_f, f_p)))
            for link in below:
                for i, tw, tv in link.columns:
                    C[i][j] = let(_dot(tw, forces[link.link][0]) + _dot(tv, forces[link.link][1]))
            current, force = body, forces[body.link]
            while current.parent != "world":   # the joints above j
                force = tree.force_to_parent(current, *force)
                current = by_link[current.parent]
                for i, tw, tv in current.columns:
                    C[i][j] = let(_dot(tw, force[0]) + _dot(tv, force[1]))
    return C


def _tangent_seeds(tree: FloatingTree) -> list[dict[sympy.Symbol, sympy.Expr]]:
    """Per velocity column, the tangent of the configuration along it: ``q_i = 1`` for a
    scalar joint; for the floating joint, that of ``integrate(q, e_k h)`` at h = 0."""
    let, table, where = tree.program.let, tree.table, tree.offsets
    seeds: list[dict[sympy.Symbol, sympy.Expr]] = [{} for _ in range(tree.robot.velocity_count)]
    for joint in (j for j in tree.robot.joints if j.moves):
        qi, vi = where.q[joint.name], where.v[joint.name]
        if joint.type != "floating":
            seeds[vi] = {table.q[qi]: sympy.Integer(1)}
            continue
        q = table.q[qi:qi + 7]
        R = quaternion_matrix(*q[3:])
        u, s = q[3:6], q[6]
        for k in range(3):
            seeds[vi + k] = {q[r]: let(R[r, k]) for r in range(3)}
            axis = [sympy.Integer(int(r == k)) for r in range(3)]
            spin = _add([s * a for a in axis], _cross(u, axis))   # 1/2 quat * (axis, 0)
            seeds[vi + 3 + k] = {**{q[3 + r]: let(_HALF * spin[r]) for r in range(3)}, q[6]: let(-_HALF * u[k])}
    return seeds


def inverse_dynamics_derivatives(robot: Robot, table: SymbolTable) -> Program:
    """``dtau/dq`` (along ``integrate``, n x n) then ``dtau/dqd``, row by row."""
    tree = FloatingTree(robot, table)
    tau = newton_euler(tree, table.qd, table.qdd)
    program = tree.program
    trig = {expr: name for name, expr in tree.trig}
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    seeds = _tangent_seeds(tree) + [{rate: sympy.Integer(1)} for rate in table.qd]
    by_variable = []
    for seed in seeds:
        tangent = dict(seed)
        _carry(program, tangent, trig, lines)
        by_variable.append([program.let(_forward(t, tangent, trig)) for t in tau])
    n = robot.velocity_count
    program.outputs = [by_variable[k][i] for i in range(n) for k in range(n)]
    program.outputs += [by_variable[n + k][i] for i in range(n) for k in range(n)]
    return program


def floating_parameter_vector(robot: Robot, table: SymbolTable) -> list[Parameter]:
    """``pi``: per link (file order) its ten standard parameters in Pinocchio's order, about
    the link frame's origin; then armature and stiffness per driven joint (nonzero ones)."""
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
    for joint in (j for j in robot.joints if j.moves and j.type != "floating" and j.driven):
        for kind in ("armature", "stiffness"):
            text = getattr(joint, kind)
            if text is not None and table.expr(text) != 0:
                entries.append(Parameter(f"{kind}_{joint.name}", kind, joint.name, table.expr(text)))
    return entries


def regressor(robot: Robot, table: SymbolTable) -> Program:
    """``Y(q, qd, qdd)`` with ``Y pi = inverse_dynamics``, row by row (NV rows)."""
    tree = FloatingTree(robot, table)
    program, vec = tree.program, tree.program.vector
    n = robot.velocity_count
    parameters = floating_parameter_vector(robot, table)
    column = {p.name: i for i, p in enumerate(parameters)}
    Y = [[_ZERO] * len(parameters) for _ in range(n)]
    motion = motions(tree, table.qd, table.qdd)
    axes: dict[str, dict[int, Motion]] = {"world": {}}
    for body in tree.bodies:
        own = {j: tree.motion_from_parent(body, w, v) for j, (w, v) in axes[body.parent].items()}
        own.update({j: (sw, sv) for j, sw, sv in body.columns})
        axes[body.link] = own
        for kind in SPATIAL_KINDS:
            n_k, f_k = body_force(vec, *_unit_parameters(kind), *motion[body.link])
            for j, (s_w, s_v) in sorted(own.items()):
                Y[j][column[f"{kind}_{body.link}"]] = program.let(_dot(s_w, n_k) + _dot(s_v, f_k))
    for joint in (j for j in robot.joints if j.moves and j.type != "floating"):
        i = tree.offsets.v[joint.name]
        if f"armature_{joint.name}" in column:
            Y[i][column[f"armature_{joint.name}"]] = table.qdd[i]
        if f"stiffness_{joint.name}" in column:
            Y[i][column[f"stiffness_{joint.name}"]] = program.let(tree.drives[i][3] - tree.drives[i][2])
    program.outputs = [e for row in Y for e in row]
    return program


def floating_programs(robot: Robot, table: SymbolTable) -> dict[str, Program]:
    """The programs of a floating-base robot's module, by name: ``mass_matrix`` (row by row),
    ``gravity``, ``potential``, ``inverse_dynamics``, ``forward_dynamics`` (``floating.py``'s
    recursions), ``coriolis``, ``inverse_dynamics_derivatives`` and ``regressor`` (this module's)."""
    programs = {}
    zeros = [_ZERO] * robot.velocity_count
    tree = FloatingTree(robot, table)
    tree.program.outputs = [e for row in mass_matrix(tree) for e in row]
    programs["mass_matrix"] = tree.program
    tree = FloatingTree(robot, table)
    tree.program.outputs = newton_euler(tree, zeros, zeros)
    programs["gravity"] = tree.program
    tree = FloatingTree(robot, table)
    tree.program.outputs = [potential(tree)]
    programs["potential"] = tree.program
    tree = FloatingTree(robot, table)
    tree.program.outputs = newton_euler(tree, table.qd, table.qdd)
    programs["inverse_dynamics"] = tree.program
    tree = FloatingTree(robot, table)
    M = mass_matrix(tree)
    bias = newton_euler(tree, table.qd, zeros)
    rhs = [tree.program.let(y - b) for y, b in zip(efforts(robot, table), bias)]
    tree.program.outputs = ltdl_solve(tree.program.let, M, rhs)
    programs["forward_dynamics"] = tree.program
    tree = FloatingTree(robot, table)
    tree.program.outputs = [e for row in coriolis_matrix(tree) for e in row]
    programs["coriolis"] = tree.program
    programs["inverse_dynamics_derivatives"] = inverse_dynamics_derivatives(robot, table)
    programs["regressor"] = regressor(robot, table)
    return programs
