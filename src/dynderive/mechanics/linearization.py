"""Linearization of the equations of motion about a state: ``xdot = A dx + B du`` with
``x = (q, qd)``.

Two routes. ``inverse_dynamics_derivatives_program`` differentiates the Newton-Euler
program line by line (forward mode, one pass per coordinate and per velocity), so the
generated ``linearize`` of any robot size gets ``dtau/dq`` and ``dtau/dqd`` as straight-line
code, and then ``qdd``'s derivatives by one solve with M:

    M dqdd/dx = dY/dx - dtau/dx(q, qd, qdd)      (tau = M qdd + C qd + N, Newton-Euler)

as Pinocchio's ``computeABADerivatives`` does. ``symbolic_linearization`` gives A and B of a
small robot in closed form over its parameters (the cart-pole about upright), from the
manipulator form's quantities, for the terminal, JSON and LaTeX of ``dynderive linearize``.
"""

from __future__ import annotations

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .exact_fast import jacobian, matmul
from .program import Program
from .recursive import _carry, _forward, _newton_euler
from .tidy import tidy
from .tree import Tree


def inverse_dynamics_derivatives_program(robot: Robot, table: SymbolTable, tree: Tree | None = None) -> Program:
    """``dtau/dq`` then ``dtau/dqd`` (each n x n, row i = tau_i, column k = the variable),
    row by row, of ``tau = M qdd + C qd + N`` (armature and springs included; damping and
    friction are added by the module). ``dtau/dq`` is along each velocity column's tangent of
    the configuration (``Tree.tangent_seeds``: ``q_k`` itself for a scalar joint, the tangent
    of ``integrate(q, e_k h)`` for a quaternion's, Pinocchio's convention in
    ``computeABADerivatives``)."""
    tree = tree or Tree(robot, table)
    program = tree.program
    tau = _newton_euler(tree, table.qd, table.qdd)
    trig = {expr: name for name, expr in tree.trig}
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    n = tree.size
    seeds = tree.tangent_seeds() + [{rate: sympy.Integer(1)} for rate in table.qd]
    by_variable: list[list[sympy.Expr]] = []
    partials: dict[tuple[sympy.Expr, sympy.Symbol], sympy.Expr] = {}
    for seed in seeds:
        tangent = dict(seed)
        _carry(program, tangent, trig, lines, partials)
        by_variable.append([program.let(_forward(t, tangent, trig)) for t in tau])
    # row by row: d tau_i / d q_k, then d tau_i / d qd_k
    outputs = [by_variable[k][i] for i in range(n) for k in range(n)]
    outputs += [by_variable[n + k][i] for i in range(n) for k in range(n)]
    program.outputs = outputs
    return program


def loop_linearization_terms(quantities: dict[str, sympy.Matrix],
                             table: SymbolTable) -> tuple[sympy.Matrix, sympy.Matrix]:
    """What ``linearize`` of a closed-loop robot needs beyond Newton-Euler's derivatives, for
    every target: the loop force's ``d(A_g^T lambda_g)/dq`` at fixed multipliers (n x n) and
    the constraint acceleration's ``d(A_g qdd + Adot_g qd)/dq`` at fixed qdd (k x n);
    ``d(Adot_g qd)/dqd`` is ``2 Adot_g`` (``A_g`` is a Hessian's rows)."""
    coordinates = list(table.q)
    A, Adot = quantities["A_g"], quantities["Adot_g"]
    force = jacobian(matmul(A.T, quantities["lambda_g"]), coordinates)
    acceleration = jacobian(matmul(A, sympy.Matrix(table.qdd)) + matmul(Adot, sympy.Matrix(table.qd)), coordinates)
    return force, acceleration


def symbolic_linearization(quantities: dict[str, sympy.Matrix], table: SymbolTable,
                           point: dict[sympy.Symbol, sympy.Expr]) -> tuple[sympy.Matrix, sympy.Matrix, sympy.Matrix]:
    """``(A, B, qdd0)`` at ``point`` (values of q, qd, u), over the parameters, from the
    manipulator form ``M qdd + C qd + N + F = Y``.

    ``qdd0`` is the acceleration at the point; Coulomb friction's ``sign(qd)`` is taken as
    constant (its slope is zero away from qd = 0, and no stiction is modelled at 0).
    """
    n = len(table.q)
    M, C, N, Y = quantities["M_g"], quantities["C_g"], quantities["N_g"], quantities["Y_g"]
    F = quantities.get("F_g", sympy.zeros(n, 1))
    signs = {s: sympy.Dummy("sign") for s in F.atoms(sympy.sign)}
    qdd = sympy.Matrix(table.qdd)
    residual = M * qdd + C * sympy.Matrix(table.qd) + N + F.xreplace(signs) - Y
    efforts = list(table.efforts.values())
    state = {s: v for s, v in point.items() if s in set(table.q) | set(table.qd) | set(efforts)}
    back = {d: s.xreplace(state) for s, d in signs.items()}

    def at(matrix: sympy.Matrix) -> sympy.Matrix:
        return matrix.xreplace(state).xreplace(back)

    M0 = at(M).applyfunc(tidy)
    forces = at(Y - C * sympy.Matrix(table.qd) - N - F)
    inverse = M0.inv(method="LU") if n > 2 else M0.inv()
    inverse = inverse.applyfunc(lambda e: tidy(sympy.cancel(e)))

    def solve(matrix: sympy.Matrix) -> sympy.Matrix:
        return (inverse * matrix).applyfunc(lambda e: tidy(sympy.cancel(e)))

    qdd0 = solve(forces)
    at_qdd = dict(zip(table.qdd, qdd0))
    d_q = at(residual.jacobian(sympy.Matrix(table.q))).xreplace(at_qdd)
    d_qd = at(residual.jacobian(sympy.Matrix(table.qd))).xreplace(at_qdd)
    d_u = at(Y.jacobian(sympy.Matrix(efforts))) if efforts else sympy.zeros(n, 0)
    A = sympy.Matrix.vstack(sympy.Matrix.hstack(sympy.zeros(n, n), sympy.eye(n)),
                            sympy.Matrix.hstack(solve(-d_q), solve(-d_qd)))
    B = sympy.Matrix.vstack(sympy.zeros(n, len(efforts)), solve(d_u))
    return A, B, qdd0
