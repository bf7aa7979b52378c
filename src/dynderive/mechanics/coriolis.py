"""Pinocchio's Coriolis matrix ``C(q, qd)`` as a straight-line program over the tree
(``tree.py``), for robots whose velocity is not the derivative of their configuration.

The Christoffel route (``recursive.GeneralizedProgram``, from ``dM/dq``) needs ``qd`` to be
the derivative of ``q``; a floating joint's velocity is a local twist (a spherical joint's a
local angular velocity), so its Christoffel symbols would take the structure constants of
SE(3) as well. The program follows Pinocchio's ``computeCoriolisMatrix`` instead:
``C = sum_k J_k^T (I_k Jdot_k + B_k J_k)`` over the links ``k``, with
``B_k = 1/2 (v_k x* I_k - I_k v_k x + (I_k v_k) xbar*)`` (``f xbar* m = m x* f``); then
``C qd`` is the bias ``C qd + N - N`` and ``Mdot - 2 C`` is skew-symmetric. As Pinocchio,
in world axes (about the world origin): a joint's column ``S_j`` and its rate ``v_j x S_j``
(``v_j`` the velocity of joint j's link) are then the same in every link's Jacobian below
it, so ``C_ij = S_i^T (I^c_k (v_j x S_j) + B^c_k S_j)`` with ``k`` the deeper link of the
two joints and ``I^c``, ``B^c`` summed from the leaves up: one pose, inertia and ``B`` per
link, no frame change per column.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy

from .program import Matrix3, Vector, _add, _cross, _rotate, _times, motion_cross
from .recursive import moved_inertia
from .tree import Tree

_ZERO = sympy.Integer(0)
_HALF = sympy.Rational(1, 2)
Motion = tuple[Vector, Vector]
Inertia = tuple[sympy.Expr, Vector, Matrix3]   # (m, h, I about the origin)


def _force_cross(m: Motion, f: Sequence[Sequence[sympy.Expr]]) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """``m x* f`` of a motion ``(w, v)`` and a force ``(n, f)``."""
    return _add(_cross(m[0], f[0]), _cross(m[1], f[1])), _cross(m[0], f[1])


def _apply(inertia: Inertia, m: Motion) -> tuple[tuple[sympy.Expr, ...], tuple[sympy.Expr, ...]]:
    """A spatial inertia ``(m, h, I)`` times a motion ``(w, v)``: ``(I w + h x v, m v + w x h)``."""
    mass, h, J = inertia
    return _add(_rotate(J, m[0]), _cross(h, m[1])), _add(_times(m[1], mass), _cross(m[0], h))


def _pair(m: Sequence[sympy.Expr], f: Sequence[sympy.Expr]) -> sympy.Expr:
    """A motion and a force (six entries each, angular part first): ``w . n + v . f``."""
    return sum((a * b for a, b in zip(m, f)), _ZERO)


def coriolis_matrix(tree: Tree) -> list[list[sympy.Expr]]:
    """Pinocchio's Coriolis matrix ``C(q, qd)``, n x n, in world axes as ``computeCoriolisMatrix``
    builds it: ``C_ij = S_i^T (I^c_k (v_j x S_j) + B^c_k S_j)`` (module docstring)."""
    let, vec = tree.program.let, tree.program.vector
    n = tree.size
    qd = tree.table.qd
    one = sympy.Integer(1)
    zero: Vector = (_ZERO, _ZERO, _ZERO)
    poses = tree.world_poses()
    velocity: dict[str, Motion] = {"world": (zero, zero)}
    # (link, j): (link, S_j, v_j x S_j), world axes; keyed by link too, as a <mimic> joint shares
    # its leader's column j, and its entries join the leader's (C = G^T C_joints G)
    columns: dict[tuple[str, int], tuple[str, Motion, Motion]] = {}
    composite: dict[str, Inertia] = {}
    B: dict[str, list[list[sympy.Expr]]] = {}
    units = [tuple(tuple(one if 3 * part + k == r else _ZERO for k in range(3)) for part in range(2)) for r in range(6)]
    for body in tree.bodies:   # parents first
        R, p = poses[body.link]
        own = []
        for j, sw, sv in body.columns:
            w = vec(_rotate(R, sw))   # type: ignore[arg-type]
            own.append((j, (w, vec(_add(_rotate(R, sv), _cross(p, w))))))   # type: ignore[arg-type]
        w, v = velocity[body.parent]
        if own:
            w = vec([w[k] + sum((s[0][k] * qd[j] for j, s in own), _ZERO) for k in range(3)])
            v = vec([v[k] + sum((s[1][k] * qd[j] for j, s in own), _ZERO) for k in range(3)])
        velocity[body.link] = (w, v)
        changing = {}   # a column that changes with the joint's coordinates: its rate, world axes
        for j, rw, rv in body.rates:
            turn = _rotate(R, rw)
            changing[j] = (turn, _add(_rotate(R, rv), _cross(p, turn)))
        for j, s in own:
            rate = motion_cross((w, v), s)
            if j in changing:
                rate = (_add(rate[0], changing[j][0]), _add(rate[1], changing[j][1]))
            columns[body.link, j] = (body.link, s, tuple(vec(x) for x in rate))  # type: ignore[assignment]
        # the link's spatial inertia (m, h, I) about the world origin, in world axes
        h_r, moved = moved_inertia(tree.program, body.mass, body.first_moment, body.inertia, R, p)
        about_origin = tree.program.symmetric(moved)
        inertia = composite[body.link] = (body.mass, vec(_add(h_r, _times(p, body.mass))), about_origin)
        momentum = tuple(vec(x) for x in _apply(inertia, (w, v)))
        B_columns = []   # B e_r = (v x* I e_r - I (v x e_r) + e_r x* I v) / 2
        for e in units:
            first = _force_cross((w, v), _apply(inertia, e))
            second = _apply(inertia, motion_cross((w, v), e))
            third = _force_cross(e, momentum)
            B_columns.append([let(_HALF * (a - b + c)) for part in zip(first, second, third)
                              for a, b, c in zip(*part)])
        B[body.link] = [[B_columns[c][r] for c in range(6)] for r in range(6)]
    for body in reversed(tree.bodies):   # composites from the leaves up
        if body.parent == "world":
            continue
        mass, h, J = composite[body.link]
        p_mass, p_h, p_J = composite[body.parent]
        total = tree.program.symmetric([[p_J[a][b] + J[a][b] for b in range(3)] for a in range(3)])
        composite[body.parent] = (let(p_mass + mass), vec(_add(p_h, h)), total)
        B[body.parent] = [[let(x + y) for x, y in zip(row_p, row)] for row_p, row in zip(B[body.parent], B[body.link])]
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
        current = tree.by_link[link]
        while True:   # rows of joint j's link and of the joints above it
            for i, _, _ in current.columns:
                t = columns[current.link, i][1]
                C[i][j] = let(C[i][j] + _pair((*t[0], *t[1]), force))
            if current.parent == "world":
                break
            current = tree.by_link[current.parent]
    for key, (link, _, _) in columns.items():   # the joints strictly above joint i's link
        i = key[1]
        current = tree.by_link[link]
        while current.parent != "world":
            current = tree.by_link[current.parent]
            for j, _, _ in current.columns:
                t, dt = columns[current.link, j][1], columns[current.link, j][2]
                C[i][j] = let(C[i][j] + _pair((*t[0], *t[1]), rows[key][0]) + _pair((*dt[0], *dt[1]), rows[key][1]))
    return C
