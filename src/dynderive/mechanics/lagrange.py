"""Reusable operators of Lagrangian mechanics on plain SymPy objects.

These are the "reusable functions" of the reference problem set's hint, public so that a
student can apply them to a Lagrangian written by hand:

>>> import sympy
>>> q, qd, qdd, m, g, l = sympy.symbols("q qd qdd m g l")
>>> L = m * l**2 * qd**2 / 2 + m * g * l * sympy.cos(q)
>>> lagrange_equations(L, [q], [qd], [qdd])
Matrix([[g*l*m*sin(q) + l**2*m*qdd]])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy

from .exact_fast import diff as exact_diff
from .exact_fast import jacobian as jacobian  # d column / d variables, the same entries as Matrix.jacobian
from .polynomial import expand


def derivative(expr: sympy.Expr, symbol: sympy.Symbol) -> sympy.Expr:
    """``d expr / d symbol``, zero at once when ``symbol`` does not occur in ``expr``: a
    maximal model's 36 coordinates each appear in a few entries only, and SymPy's ``diff``
    costs a tree walk even when the answer is zero; otherwise SymPy's result, built faster
    (``exact_fast.diff``)."""
    expr = sympy.sympify(expr)
    if symbol not in expr.free_symbols:
        return sympy.Integer(0)
    return exact_diff(expr, symbol) if isinstance(symbol, sympy.Symbol) else sympy.diff(expr, symbol)


def matrix_derivative(matrix: sympy.Matrix, symbol: sympy.Symbol) -> sympy.Matrix:
    """``d matrix / d symbol`` entry by entry (``derivative``)."""
    if symbol not in matrix.free_symbols:
        return sympy.zeros(*matrix.shape)
    return matrix.applyfunc(lambda e: derivative(e, symbol))


def time_derivative(expr: sympy.Expr, q: Sequence[sympy.Symbol], qd: Sequence[sympy.Symbol],
                    qdd: Sequence[sympy.Symbol] | None = None) -> sympy.Expr:
    """d/dt of ``expr(q, qd)`` along a trajectory, by the chain rule."""
    total = sum((derivative(expr, qi) * qdi for qi, qdi in zip(q, qd)), sympy.Integer(0))
    if qdd is not None:
        total += sum((derivative(expr, qdi) * qddi for qdi, qddi in zip(qd, qdd)), sympy.Integer(0))
    return total


@dataclass(frozen=True)
class LagrangeSteps:
    """The intermediate results of Lagrange's equations, one column entry per coordinate."""

    dL_dqd: sympy.Matrix       # dL/d(qd_i)
    ddt_dL_dqd: sympy.Matrix   # d/dt dL/d(qd_i)
    dL_dq: sympy.Matrix        # dL/d(q_i)

    @property
    def lhs(self) -> sympy.Matrix:
        """d/dt dL/dqd - dL/dq (equal to the applied forces Y)."""
        return self.ddt_dL_dqd - self.dL_dq


def lagrange_steps(L: sympy.Expr, q: Sequence[sympy.Symbol], qd: Sequence[sympy.Symbol],
                   qdd: Sequence[sympy.Symbol]) -> LagrangeSteps:
    dL_dqd = sympy.Matrix([derivative(L, v) for v in qd])
    ddt = sympy.Matrix([time_derivative(e, q, qd, qdd) for e in dL_dqd])
    dL_dq = sympy.Matrix([derivative(L, c) for c in q])
    return LagrangeSteps(dL_dqd, ddt, dL_dq)


def lagrange_equations(L: sympy.Expr, q: Sequence[sympy.Symbol], qd: Sequence[sympy.Symbol],
                       qdd: Sequence[sympy.Symbol]) -> sympy.Matrix:
    """Left side of Lagrange's equations, ``d/dt dL/dqd - dL/dq``, as a column."""
    return lagrange_steps(L, q, qd, qdd).lhs.applyfunc(expand)


def mass_matrix_from_jacobians(jacobians: Sequence[sympy.Matrix],
                               inertias: Sequence[sympy.Matrix]) -> sympy.Matrix:
    """``M = sum_i J_i^T G_i J_i`` for body Jacobians ``J_i`` and spatial inertias ``G_i``."""
    n = jacobians[0].shape[1]
    total = sympy.zeros(n, n)
    for jac, inertia in zip(jacobians, inertias):
        weighted = inertia * jac
        # only the columns a body moves (a maximal body: its own 3 of 3 n) give entries
        columns = [i for i in range(n) if any(jac[r, i] != 0 for r in range(jac.shape[0]))]
        for a, i in enumerate(columns):
            for j in columns[a:]:
                entry = sum((jac[r, i] * weighted[r, j] for r in range(jac.shape[0])), sympy.Integer(0))
                total[i, j] += entry
                if i != j:
                    total[j, i] = total[i, j]
    return total


def christoffel_coriolis(M: sympy.Matrix, q: Sequence[sympy.Symbol],
                         qd: Sequence[sympy.Symbol],
                         dM: Sequence[sympy.Matrix] | None = None) -> sympy.Matrix:
    """Coriolis matrix from Christoffel symbols of the first kind.

    ``C_ij = 1/2 sum_k (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) qd_k``; with this choice
    ``Mdot - 2C`` is skew-symmetric. Each dM/dq_k is computed once (or passed in ``dM``).
    """
    n = M.shape[0]
    C = sympy.zeros(n, n)
    if dM is None:
        if not M.free_symbols & set(q):   # M constant (maximal coordinates): C = 0
            return C
        dM = [matrix_derivative(M, qk) for qk in q]
    half = sympy.Rational(1, 2)
    for i in range(n):
        for j in range(n):
            # Mul(half, qd_k, sum) keeps the sum whole: half * sum alone would distribute
            C[i, j] = sympy.Add(*(
                sympy.Mul(half, qd[k], dM[k][i, j] + dM[j][i, k] - dM[i][j, k]) for k in range(n)))
    return C


def gravity_vector(V: sympy.Expr, q: Sequence[sympy.Symbol]) -> sympy.Matrix:
    """``N = dV/dq`` as a column."""
    return sympy.Matrix([derivative(V, c) for c in q])


def constraint_jacobian_dot(A: sympy.Matrix, q: Sequence[sympy.Symbol],
                            qd: Sequence[sympy.Symbol]) -> sympy.Matrix:
    """``Adot = sum_k dA/dq_k qd_k`` (chain rule, as in the reference's 2.6)."""
    total = sympy.zeros(*A.shape)
    present = A.free_symbols
    for qk, qdk in zip(q, qd):
        if qk in present:
            total += matrix_derivative(A, qk) * qdk
    return total
