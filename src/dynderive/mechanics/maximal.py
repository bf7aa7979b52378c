"""Equations of motion in maximal coordinates (Problem 2 of the reference).

Each link's centre-of-mass frame has its own pose ``(x_k, y_k, phi_k)``; the joints become
holonomic constraints ``a(q_m) = 0`` with multipliers ``lambda``. The change of basis
``q_m = h(q_g)``, ``H = Dh`` maps the model back to generalized coordinates, which proves
both models equal (``EOM_g3 == EOM_g1``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NotRequired, TypedDict

import sympy

from ..model.joint_kinds import joint_kind
from ..model.robot import Joint, LoopJoint, Robot
from ..model.symbols import SymbolTable
from .drives import dissipative_force
from .exact_fast import matmul
from .joint_variables import unit
from .lagrange import (
    christoffel_coriolis,
    constraint_jacobian_dot,
    gravity_vector,
    jacobian,
    lagrange_steps,
    mass_matrix_from_jacobians,
)
from .planar import PlanarLinkKinematics, rotated
from .tidy import quick_tidy, tidy, tidy_matrix

#: Above this many operations in A M^-1 A^T, lambda is not solved symbolically (the
#: generated code always solves it numerically).
LAMBDA_SYMBOLIC_LIMIT = 200
#: Systems with more constraints than this keep lambda numeric only.
LAMBDA_SYMBOLIC_ROWS = 4


def _cross(a: sympy.Matrix | tuple, b: sympy.Matrix | tuple) -> sympy.Expr:
    return a[0] * b[1] - a[1] * b[0]


class _Bodies:
    """Pose symbols of each link's COM frame, and the world as a fixed body."""

    def __init__(self, robot: Robot, table: SymbolTable):
        self.robot, self.table = robot, table
        self.index = {link.name: k for k, link in enumerate(robot.links)}

    def pose(self, name: str) -> tuple[sympy.Matrix, sympy.Expr, tuple[sympy.Expr, sympy.Expr]]:
        """(COM position, angle, COM offset in the link frame) of a link or the world."""
        if name == "world":
            zero = sympy.Integer(0)
            return sympy.Matrix([0, 0]), zero, (zero, zero)
        k = self.index[name]
        x, y, phi = self.table.qm[3 * k: 3 * k + 3]
        com = tuple(self.table.expr(e) for e in self.robot.links[k].com)
        return sympy.Matrix([x, y]), phi, com  # type: ignore[return-value]

    def point(self, name: str, x: sympy.Expr, y: sympy.Expr) -> sympy.Matrix:
        """World position of the point at ``(x, y)`` in the link frame of ``name``."""
        p, phi, com = self.pose(name)
        return p + rotated(phi, (x - com[0], y - com[1]))

    def slots(self, name: str) -> int | None:
        return None if name == "world" else 3 * self.index[name]


def joint_constraints(joint: Joint, bodies: _Bodies) -> list[sympy.Expr]:
    """Constraints a joint imposes, each zero when it holds.

    Revolute: the joint point seen from both links coincides (2). Prismatic: no offset of
    the child's frame across the axis, relative rotation fixed (2). Fixed: both (3). The
    rows of a loop joint whose child frame is the child's link frame (``loop_constraints``).
    """
    return loop_constraints(LoopJoint(joint.name, joint.type, joint.parent, joint.child, joint.origin, (0, 0, 0),
                                      joint.axis), bodies)


def joint_efforts(joint: Joint, bodies: _Bodies, size: int) -> sympy.Matrix:
    """The effort of one joint as equal and opposite wrenches on its two links.

    Revolute: torque ``u`` on the child, ``-u`` on the parent. Prismatic: force ``u`` along
    the axis (fixed in the parent) on the child at its frame origin and ``-u`` on the parent
    at the joint point; both lie on the axis line, so the pair does work ``u dq`` only.
    """
    Y = sympy.zeros(size, 1)
    if not joint.effort:
        return Y
    table = bodies.table
    u = table.efforts[joint.effort]
    child, parent = bodies.slots(joint.child), bodies.slots(joint.parent)
    if joint.kind.angle:
        Y[child + 2] += u  # type: ignore[operator]
        if parent is not None:
            Y[parent + 2] -= u
        return Y
    ox, oy, theta = (table.expr(e) for e in joint.origin)
    _, phi_parent, com_parent = bodies.pose(joint.parent)
    _, _, com_child = bodies.pose(joint.child)
    axis = unit(tuple(table.expr(e) for e in joint.axis))
    direction = rotated(phi_parent + theta, axis)
    # the child frame is parallel to the joint frame, so the axis reads the same in it
    moment = _cross((-com_child[0], -com_child[1]), axis)
    Y[child:child + 3, 0] += u * sympy.Matrix([*direction, moment])  # type: ignore[operator]
    if parent is not None:
        moment = _cross((ox - com_parent[0], oy - com_parent[1]), rotated(theta, axis))
        Y[parent:parent + 3, 0] -= u * sympy.Matrix([*direction, moment])
    return Y


def joint_coordinate(joint: Joint, bodies: _Bodies) -> sympy.Expr:
    """A moving joint's coordinate as a function of the maximal coordinates (zero at the joint's
    reference position, equal to ``q_i`` on ``h(q)``): revolute, the relative angle; prismatic,
    the child frame's offset from the joint point along the axis. The drive terms of the joint
    (springs, damping, friction, armature) act through it, on both links alike."""
    table = bodies.table
    ox, oy, theta = (table.expr(e) for e in joint.origin)
    phi_parent, phi_child = bodies.pose(joint.parent)[1], bodies.pose(joint.child)[1]
    if joint.kind.angle:
        return phi_child - phi_parent - theta
    zero = sympy.Integer(0)
    gap = bodies.point(joint.child, zero, zero) - bodies.point(joint.parent, ox, oy)
    direction = rotated(phi_parent + theta, unit(tuple(table.expr(e) for e in joint.axis)))
    return (direction.T * gap)[0, 0]


def _maximal_drives(robot: Robot, bodies: _Bodies, drives: Any) -> dict[str, Any]:
    """The joints' drive terms in maximal coordinates, through each joint's coordinate
    ``g_i(qm)`` and its gradient ``G_i``: springs ``k (g_i - rest)**2/2`` in V_m, armature
    ``Ia (G_i qmd)**2/2`` in T_m (``Ia G_i^T G_i`` in M_m), dissipation
    ``D_m = sum b (G_i qmd)**2/2`` and forces ``F_m = sum G_i^T (b G_i qmd + fc sign(G_i qmd))``.
    Since ``G_i H = e_i``, ``H^T F_m = F_g``: the same forces, equal and opposite on both links."""
    table, size = bodies.table, len(bodies.table.qm)
    qmd = sympy.Matrix(table.qmd)
    moving = [j for j in robot.joints if j.moves]
    half = sympy.Rational(1, 2)
    terms = {"T": sympy.Integer(0), "V": sympy.Integer(0), "D": sympy.Integer(0), "F": sympy.zeros(size, 1),
             "M": sympy.zeros(size, size)}
    for drive in drives.joints:
        g = tidy(joint_coordinate(moving[drive.coordinate], bodies))
        G = sympy.Matrix([g]).jacobian(table.qm).applyfunc(tidy)
        rate = tidy((G * qmd)[0, 0])
        terms["T"] += half * drive.armature * rate**2
        terms["V"] += half * drive.stiffness * (g - drive.rest) ** 2
        terms["D"] += half * drive.damping * rate**2
        terms["F"] += G.T * dissipative_force(drive.damping, drive.friction, rate)
        terms["M"] += drive.armature * G.T * G
    return terms


def maximal_body_jacobian(k: int, table: SymbolTable) -> sympy.Matrix:
    """Maps qm_dot to the body velocity of link k's COM frame: a rotation into its axes."""
    phi = table.qm[3 * k + 2]
    c, s = sympy.cos(phi), sympy.sin(phi)
    J = sympy.zeros(3, len(table.qm))
    J[0, 3 * k], J[0, 3 * k + 1] = c, s
    J[1, 3 * k], J[1, 3 * k + 1] = -s, c
    J[2, 3 * k + 2] = 1
    return J


def loop_constraints(loop: LoopJoint, bodies: _Bodies) -> list[sympy.Expr]:
    """The rows of a loop-closing joint in maximal coordinates, in the order of
    ``mechanics/loops.py``: revolute, the loop frames' origins coincide (2); prismatic, no
    offset across the axis and no relative rotation (2); fixed (a tree's joint), both (3)."""
    table = bodies.table
    ox, oy, theta = (table.expr(e) for e in loop.origin)
    cx, cy, child_theta = (table.expr(e) for e in loop.child_origin)
    phi_parent, phi_child = bodies.pose(loop.parent)[1], bodies.pose(loop.child)[1]
    gap = bodies.point(loop.child, cx, cy) - bodies.point(loop.parent, ox, oy)
    rotation = (phi_child + child_theta) - (phi_parent + theta)
    translation, turn = joint_kind(loop.type).frees or ("all", "all")
    if translation == "none":   # a turn (2 rows) or a weld (3)
        return [gap[0], gap[1]] + ([rotation] if turn == "none" else [])
    ux, uy = unit(tuple(table.expr(e) for e in loop.axis))
    normal = rotated(phi_parent + theta, (-uy, ux))
    return [(normal.T * gap)[0, 0], rotation]


class MaximalSteps(TypedDict):
    """The maximal stages' steps, for the sheet: where the constraints come from (the joints,
    or the file's ``maximal_constraints``), the bodies' Jacobians; after ``maximal_equations``,
    Lagrange's derivatives and whether lambda has a closed form; after the change of basis,
    ``Hdot`` and the model mapped through H (``M_tilde`` ... ``F_tilde``)."""

    constraint_origin: str   # "joints" or "override" (the file's maximal_constraints)
    jacobians: list[sympy.Matrix]
    lagrange: NotRequired[dict[str, sympy.Matrix]]
    lambda_symbolic: NotRequired[bool]
    Hdot: NotRequired[sympy.Matrix]
    M_tilde: NotRequired[sympy.Matrix]
    C_tilde: NotRequired[sympy.Matrix]
    N_tilde: NotRequired[sympy.Matrix]
    Y_tilde: NotRequired[sympy.Matrix]
    F_tilde: NotRequired[sympy.Matrix]


def maximal_model(robot: Robot, table: SymbolTable, links: list[PlanarLinkKinematics],
                  gravity: sympy.Matrix, drives: Any,
                  loop_rows: list[int] | None = None,
                  clean: Callable[[sympy.Expr], sympy.Expr] = tidy) -> tuple[dict[str, Any], MaximalSteps]:
    """The maximal model of Problem 2 (2.1-2.3, 2.5 and the change of basis 2.7): constraints,
    energies, efforts, ``M_m, C_m, N_m``, ``h`` and ``H``, by the reference's names, and the
    steps. Cheap for any size (each constraint involves two links); the generated module's
    maximal functions need only these. ``maximal_equations`` adds the equations of motion.

    With loops, ``loop_rows`` selects the loop constraints kept in generalized coordinates
    (redundant ones dropped there are dropped here too). ``clean`` tidies each entry (a large
    robot's: ``quick_tidy``, since ``tidy`` of full-precision floats costs seconds per entry)."""
    bodies = _Bodies(robot, table)
    qm, qmd = table.qm, table.qmd
    size = len(qm)

    # 2.1 constraints
    if robot.maximal_constraints is not None:
        a = sympy.Matrix([table.maximal_expr(e) for e in robot.maximal_constraints])
        origin = "override"
    else:
        rows = [row for joint in robot.joints for row in joint_constraints(joint, bodies)]
        closing = [row for loop in robot.loops for row in loop_constraints(loop, bodies)]
        rows += [closing[i] for i in (loop_rows or [])]
        a = sympy.Matrix(rows).applyfunc(clean)
        origin = "joints"
    K = a.shape[0]
    table.multipliers = [sympy.Symbol(f"lambda{k}") for k in range(1, K + 1)]
    A = jacobian(a, qm).applyfunc(clean)
    Adot = constraint_jacobian_dot(A, qm, qmd).applyfunc(clean)

    # 2.2 energies
    masses = [table.expr(link.mass) for link in robot.links]
    inertias = [table.expr(link.inertia[0]) for link in robot.links]
    T = V = sympy.Integer(0)
    for k, (mass, inertia) in enumerate(zip(masses, inertias)):
        x, y, phi = qmd[3 * k: 3 * k + 3]
        T += sympy.Rational(1, 2) * (mass * (x**2 + y**2) + inertia * phi**2)
        V += -mass * (gravity.T * sympy.Matrix(qm[3 * k: 3 * k + 2]))[0, 0]
    drive_terms = _maximal_drives(robot, bodies, drives)
    T, V = clean(T + drive_terms["T"]), clean(V + drive_terms["V"])
    F = drive_terms["F"].applyfunc(clean)

    # 2.3 efforts
    Y = sympy.zeros(size, 1)
    for joint in robot.joints:
        Y += joint_efforts(joint, bodies, size)
    Y = Y.applyfunc(clean)

    # 2.5 manipulator form
    jacobians = [maximal_body_jacobian(k, table) for k in range(len(robot.links))]
    spatial = [sympy.diag(m, m, i) for m, i in zip(masses, inertias)]
    M = (mass_matrix_from_jacobians(jacobians, spatial) + drive_terms["M"]).applyfunc(clean)
    C = christoffel_coriolis(M, qm, qmd).applyfunc(clean)
    N = gravity_vector(V, qm).applyfunc(clean)

    # 2.7 change of basis
    h = sympy.Matrix([e for kin in links for e in (*kin.com_world, kin.angle)]).applyfunc(clean)
    H = jacobian(h, table.q)
    if clean is not quick_tidy:   # expanded sines and cosines differentiate to expanded ones
        H = H.applyfunc(clean)
    quantities: dict[str, Any] = {
        "q_m": sympy.Matrix(qm), "a_m": a, "A_m": A, "Adot_m": Adot,
        "T_m": T, "V_m": V, "L_m": T - V, "Y_m": Y, "M_m": M, "C_m": C, "N_m": N,
        "h": h, "H": H,
    }
    if robot.dissipative:
        quantities |= {"D_m": tidy(drive_terms["D"]), "F_m": F}
    steps: MaximalSteps = {"constraint_origin": origin, "jacobians": jacobians}
    return quantities, steps


def maximal_equations(table: SymbolTable, model: dict[str, Any], steps: MaximalSteps,
                      loop_force: sympy.Matrix | None = None,
                      change_of_basis: bool = True,
                      clean: Callable[[sympy.Expr], sympy.Expr] = tidy) -> dict[str, Any]:
    """The equations of motion of Problem 2 on the quantities of ``maximal_model``: the
    constrained Lagrange equations ``EOM_m1`` (2.4), the manipulator form ``EOM_m2`` (2.5),
    ``lambdaVec`` in closed form while it stays small (2.6) and, with ``change_of_basis``,
    the model mapped through H, ``EOM_g3`` (2.7). Fills ``steps``; returns the quantities.

    ``loop_force`` is ``A_g^T lambda_g``: the maximal loop multipliers equal ``-lambda_g``,
    so EOM_g3 carries ``- A_g^T lambda_g`` like EOM_g1. ``clean`` tidies the equations and
    Lagrange's steps (a large robot's: ``quick_tidy``, as in ``maximal_model``)."""
    qm, qmd, qmdd = table.qm, table.qmd, table.qmdd
    a, A, Adot, Y, M, C, N = (model[k] for k in ("a_m", "A_m", "Adot_m", "Y_m", "M_m", "C_m", "N_m"))
    F = model.get("F_m", sympy.zeros(len(qm), 1))
    lam = sympy.Matrix(table.multipliers)
    lagrange = lagrange_steps(model["L_m"], qm, qmd, qmdd)
    EOM_m1 = (lagrange.lhs + F + matmul(A.T, lam) - Y).applyfunc(clean)
    qmd_vec = sympy.Matrix(qmd)
    EOM_m2 = (matmul(M, sympy.Matrix(qmdd)) + matmul(C, qmd_vec) + N + F + matmul(A.T, lam) - Y).applyfunc(clean)
    lambda_vec = _closed_form_lambda(M, A, Adot, Y - F, C, N, qmd_vec)
    quantities: dict[str, Any] = {"EOM_m1": EOM_m1, "EOM_m2": EOM_m2}
    if lambda_vec is not None:
        quantities["lambdaVec"] = lambda_vec
    steps |= {"lagrange": {"dL_dqd": lagrange.dL_dqd.applyfunc(clean),
                           "ddt_dL_dqd": lagrange.ddt_dL_dqd.applyfunc(clean), "dL_dq": lagrange.dL_dq.applyfunc(clean)},
              "lambda_symbolic": lambda_vec is not None}
    if not change_of_basis:
        return quantities
    q, qd, qdd = table.q, table.qd, table.qdd
    h, H = model["h"], model["H"]
    Hdot = constraint_jacobian_dot(H, q, qd)
    on_h = dict(zip(qm, h))
    on_hd = dict(zip(qmd, matmul(H, sympy.Matrix(qd))))
    M_h = M.xreplace(on_h)
    M_tilde = tidy_matrix(matmul(H.T, M_h, H))
    C_tilde = tidy_matrix(matmul(H.T, C.xreplace(on_h).xreplace(on_hd), H) + matmul(H.T, M_h, Hdot))
    N_tilde = tidy_matrix(matmul(H.T, N.xreplace(on_h)))
    Y_tilde = tidy_matrix(matmul(H.T, Y.xreplace(on_h)))
    F_tilde = tidy_matrix(matmul(H.T, F.xreplace(on_h).xreplace(on_hd).applyfunc(_tidy_sign)))
    EOM_g3 = (matmul(M_tilde, sympy.Matrix(qdd)) + matmul(C_tilde, sympy.Matrix(qd))
              + N_tilde + F_tilde - Y_tilde)
    if loop_force is not None:
        EOM_g3 = EOM_g3 - loop_force
    quantities["EOM_g3"] = EOM_g3.applyfunc(tidy)
    steps |= {"Hdot": tidy_matrix(Hdot), "M_tilde": M_tilde, "C_tilde": C_tilde, "N_tilde": N_tilde,
              "Y_tilde": Y_tilde, "F_tilde": F_tilde}
    return quantities


def _tidy_sign(expr: sympy.Expr) -> sympy.Expr:
    """Tidy the arguments of ``sign`` (a joint rate on h(q) is ``G_i H qd = qd_i``)."""
    return expr.replace(lambda e: isinstance(e, sympy.sign), lambda e: sympy.sign(tidy(e.args[0])))


def _closed_form_lambda(M: sympy.Matrix, A: sympy.Matrix, Adot: sympy.Matrix, Y: sympy.Matrix,
                        C: sympy.Matrix, N: sympy.Matrix, qmd: sympy.Matrix) -> sympy.Matrix | None:
    """``(A M^-1 A^T)^-1 (A M^-1 (Y - C qd - N) + Adot qd)``, or None when too large.

    Solved as ``adj(W) rhs / det(W)`` with each piece tidied: a general symbolic LU solve
    followed by ``cancel`` takes minutes even for the RP arm's 4 x 4 system.
    """
    if not M.is_diagonal() or A.shape[0] > LAMBDA_SYMBOLIC_ROWS or any(M[i, i] == 0 for i in range(M.shape[0])):
        return None
    M_inv = sympy.diag(*[1 / M[i, i] for i in range(M.shape[0])])
    W = (A * M_inv * A.T).applyfunc(tidy)
    if sum(sympy.count_ops(e) for e in W) > LAMBDA_SYMBOLIC_LIMIT:
        return None
    rhs = (A * M_inv * (Y - C * qmd - N) + Adot * qmd).applyfunc(tidy)
    adjugate = _symmetric_adjugate(W)
    # expanded along the first row: the cofactors are at hand
    det = tidy(sympy.Add(*(W[0, j] * adjugate[j, 0] for j in range(W.shape[0]))))
    if det == 0:
        return None
    numerator = (adjugate * rhs).applyfunc(tidy)
    return numerator.applyfunc(lambda e: tidy(e / det))


def _symmetric_adjugate(W: sympy.Matrix) -> sympy.Matrix:
    """The adjugate of the symmetric matrix ``W``, each entry tidied: the Berkowitz
    cofactors of the upper triangle only (the adjugate is symmetric too; SymPy's
    ``adjugate`` computes and simplifies all of them, the costliest step of lambda)."""
    n = W.shape[0]
    adjugate = sympy.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            adjugate[i, j] = adjugate[j, i] = tidy(W.cofactor(j, i, method="berkowitz"))
    return adjugate


__all__ = ["maximal_equations", "maximal_model", "joint_constraints", "joint_coordinate", "joint_efforts"]
