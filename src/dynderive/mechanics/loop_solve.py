"""The closed loops' constrained solve as a program every target prints (DESIGN.md section 13),
written once here: the loop rows are constraints on the one tree, as contacts are, and their
solve is the contacts' with the loop functions in place of the frames' rows.

M qdd = tau - h + A^T lambda and A qdd = -Adot qd - 2 alpha A qd - beta^2 a(q) (the loop
constraints a(q) = 0 differentiated twice, with Baumgarte's gains alpha and beta against drift),
h = inverse_dynamics(q, qd, 0) (with the wrenches and friction the target passes), tau the
efforts' generalized forces (a robot with quaternions in q: the efforts at their velocity
columns, ``effort_map``). One ``RowSpaceSolve`` ends it: the loop rows of a mechanism that is
over-constrained have a rank below their count, known from the symbolic loops (a robot without
quaternions) or found at each state (the rows on the tree's twists, ``loop_programs.py``).
"""

from __future__ import annotations

from ..model.array_program import ArrayProgram, Call, Let, RowSpaceSolve, array, scale


def loop_rows(n: int, k: int, floating: bool, drift_name: str = "drift") -> tuple:
    """The steps of the loop rows' Jacobian ``jac`` (k x NV) and their target ``bottom`` = -Adot qd
    - 2 alpha A qd - beta^2 a(q), which the loops' solve and the contacts' (on a robot with loops)
    share; ``floating``: the drift Adot qd from its own program; ``drift_name`` its array's name
    (the contacts' programs have a ``drift`` of their own)."""
    qd, drift, loop_rows = array("qd", n), array(drift_name, k), array("jac", k, n)
    if floating:
        rates: tuple = (Call(drift_name, "loop_jacobian_dot_qd", ("q", "qd"), (k,)),)
    else:
        rates = (Call("Adot", "loop_jacobian_dot", ("q", "qd"), (k, n)), Let(drift_name, array("Adot", k, n) @ qd))
    rate = array("rate", k)
    return (Call("jac", "loop_jacobian", ("q",), (k, n)), *rates, Call("a", "loop_constraints", ("q",), (k,)),
            Let("rate", loop_rows @ qd),
            Let("bottom", -drift - scale("alpha", rate + rate) - scale("beta", scale("beta", array("a", k)))))


def efforts(n: int, floating: bool) -> Call:
    """tau, the efforts' generalized forces: at their velocity columns with quaternions in q."""
    if floating:
        return Call("tau", "effort_map", ("u",), (n,))
    return Call("tau", "generalized_forces", ("q", "u"), (n,))


def loop_solve_program(n: int, k: int, rank: int | None, floating: bool) -> ArrayProgram:
    """``loop_solve(q, qd, u; alpha, beta) -> (qdd, lam)`` for NV = ``n`` and ``k`` loop rows of
    ``rank`` (None: found at each state); ``floating``: quaternions in q, the drift Adot qd from
    its own program and the efforts at their columns."""
    steps = (Call("M", "mass_matrix", ("q",), (n, n)), Call("h", "inverse_dynamics", ("q", "qd", "zeros"), (n,)),
             efforts(n, floating), *loop_rows(n, k, floating),
             RowSpaceSolve("qdd", "lam", "M", "jac", array("tau", n) - array("h", n), array("bottom", k), rank))
    return ArrayProgram("loop_solve", ("q", "qd", "u"), ("alpha", "beta"), steps, ("qdd", "lam"))
