"""Large robots' generalized quantities in intermediate-variable form.

Expanded, the entries of a generic 7-DOF arm's C_g run to hundreds of thousands of terms:
minutes to build, unreadable, impossible to typeset. Here, as in OpenSYMORO's customized
Newton-Euler, every non-atomic sub-expression gets a name: one straight-line program
(``recursive.GeneralizedProgram``: composite rigid bodies for M, its Christoffel symbols
for C, Newton-Euler at rest for N, the potential, the body Jacobians) is pruned to the lines
the quantities use and renumbered ``_w1, _w2, ...`` in order. ``M_g`` is then a matrix of
names and short sums, ``Derivation.intermediates`` defines the names, and the work grows with
the program (about n^3 lines for C), not with the expanded entries. The inertial parameters
enter linearly, as mass, first moment ``m c`` and inertia about the link origin.

>>> d = derive(load_robot("panda"))                  # doctest: +SKIP
>>> d["M_g"][0, 0], d.intermediates[0]                # doctest: +SKIP
(_w57, (_w1, sin(q2)))
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .drives import drive_terms
from .generalized import LAGRANGE_DOF_LIMIT, GeneralizedSteps, applied_forces
from .polynomial import expand
from .program import lines_read
from .recursive import GeneralizedProgram
from .tidy import group_terms, tidy

#: Planar robots with more coordinates than this are derived in intermediate-variable form, as
#: 3-D ones beyond LAGRANGE_DOF_LIMIT. Measured, every output of a planar chain of 6 links:
#: expanded 25 s (round numbers) and 41 s (full precision), in this form 2.3 s and 4.3 s.
PLANAR_EXPLICIT_DOF = 4


def intermediate_form(robot: Robot) -> bool:
    """Whether ``robot``'s generalized quantities are derived in intermediate-variable form:
    3-D robots beyond LAGRANGE_DOF_LIMIT joint variables (coordinates and ``<mimic>`` joints),
    planar ones beyond PLANAR_EXPLICIT_DOF coordinates."""
    return robot.kinematic_size > (PLANAR_EXPLICIT_DOF if robot.planar else LAGRANGE_DOF_LIMIT)


def structured_generalized(robot: Robot, table: SymbolTable, built: GeneralizedProgram,
                           report: Callable[[str], None] = lambda stage: None
                           ) -> tuple[dict[str, Any], GeneralizedSteps]:
    """The quantities of ``derive_generalized`` over intermediate variables; the steps hold
    ``intermediates``, the ordered ``(name, definition)`` pairs, for ``Derivation.intermediates``,
    and Lagrange's steps. ``EOM_g1`` takes Lagrange's route over the same names: ``dM/dq_k``
    from the mass-matrix program differentiated, ``dV/dq`` from the potential program
    differentiated (where ``N_g`` is Newton-Euler's), so ``EOM_g1 == EOM_g2`` checks the
    Christoffel assembly of C and the gravity terms."""
    n = len(robot.coordinates)
    jacobians = [built.jacobians[link.name] for link in robot.links]
    report("intermediate variables")
    trig = {name: expr for name, expr in built.trig}
    M = sympy.Matrix(n, n, [e for row in built.mass_matrix for e in row])
    C = sympy.Matrix(n, n, built.coriolis)
    N = sympy.Matrix(built.gravity)
    # Lagrange's route over the same names: dL/dqd = M qd, d/dt dL/dqd = M qdd + sum_k dM/dq_k
    # qd_k qd, dL/dq_i = qd^T dM/dq_i qd / 2 - dV/dq_i (the potential program differentiated)
    qd, qdd = sympy.Matrix(table.qd), sympy.Matrix(table.qdd)
    dM = built.mass_matrix_derivatives   # [k][i][j]: names or numbers
    dV = built.potential_gradient
    outputs: list[Any] = [M, C, N, built.potential, sympy.Matrix(n * n, n, [e for d in dM for r in d for e in r]),
                          sympy.Matrix(dV), *jacobians]
    # keep the lines the outputs use, in order; names for them, sines and cosines inlined
    needed = lines_read(outputs, dict(built.program.lines))
    rename: dict[sympy.Symbol, sympy.Expr] = dict(trig)
    intermediates: list[tuple[sympy.Symbol, sympy.Expr]] = []
    for name, expr in built.program.lines:
        if name in trig or name not in needed:
            continue
        value = expr.xreplace(rename)
        if value.is_Atom:        # a copy: no name of its own
            rename[name] = value
        else:
            rename[name] = sympy.Symbol(f"_w{len(intermediates) + 1}")
            intermediates.append((rename[name], value))
    table.intermediates = [s for s, _ in intermediates]
    M, C, N = (m.xreplace(rename) for m in (M, C, N))
    V = sympy.sympify(built.potential).xreplace(rename)
    jacobians = [j.xreplace(rename) for j in jacobians]
    lagrange = _lagrange_steps(M, [[[sympy.sympify(e).xreplace(rename) for e in r] for r in d] for d in dM],
                               [sympy.sympify(e).xreplace(rename) for e in dV], table)

    drives = drive_terms(robot, table)
    T = expand((qd.T * M * qd)[0, 0] / 2)
    F = drives.forces.applyfunc(tidy)
    Y = applied_forces(robot, table)
    rates = set(table.qd) | set(table.qdd)
    EOM_g1 = (lagrange["ddt_dL_dqd"] - lagrange["dL_dq"] + F - Y).applyfunc(lambda e: _by_rates(e, rates))
    EOM_g2 = (M * qdd + C * qd + N + F - Y).applyfunc(expand)
    quantities: dict[str, Any] = {"T_g": T, "V_g": V, "L_g": T - V, "Y_g": Y, "EOM_g1": EOM_g1,
                                  "M_g": M, "C_g": C, "N_g": N, "EOM_g2": EOM_g2}
    if robot.dissipative:
        quantities |= {"D_g": tidy(drives.dissipation), "F_g": F}
    for k, jacobian in enumerate(jacobians, start=1):
        quantities[f"J_b{k}"] = jacobian
    steps: GeneralizedSteps = {"links": [], "lagrange": lagrange, "drives": drives, "intermediates": intermediates,
                               "gravity": sympy.Matrix([table.expr(e) for e in robot.gravity])}
    return quantities, steps


def _lagrange_steps(M: sympy.Matrix, dM: list[list[list[sympy.Expr]]], dV: list[sympy.Expr],
                    table: SymbolTable) -> dict[str, sympy.Matrix]:
    """Lagrange's steps over the names, each grouped by products of joint rates:
    ``dL/dqd_i = sum_j M_ij qd_j``, ``d/dt dL/dqd_i = sum_j M_ij qdd_j + sum_jk dM_ij/dq_k qd_j qd_k``,
    ``dL/dq_i = 1/2 sum_jk dM_jk/dq_i qd_j qd_k - dV/dq_i`` (``dM[k][i][j]``, M symmetric)."""
    n = len(table.q)
    qd, qdd = table.qd, table.qdd

    def grouped(coefficients: dict[tuple[int, int], list[sympy.Expr]]) -> sympy.Expr:
        return sympy.Add(*(sympy.Add(*terms) * qd[j] * qd[k] for (j, k), terms in coefficients.items()))

    dL_dqd, ddt, dL_dq = [], [], []
    for i in range(n):
        dL_dqd.append(sympy.Add(*(M[i, j] * qd[j] for j in range(n))))
        velocity: dict[tuple[int, int], list[sympy.Expr]] = {}
        for j in range(n):
            for k in range(n):
                if dM[k][i][j] != 0:
                    velocity.setdefault((min(j, k), max(j, k)), []).append(dM[k][i][j])
        ddt.append(sympy.Add(*(M[i, j] * qdd[j] for j in range(n))) + grouped(velocity))
        position: dict[tuple[int, int], list[sympy.Expr]] = {}
        for j in range(n):
            for k in range(j, n):
                if dM[i][j][k] != 0:
                    position.setdefault((j, k), []).append(dM[i][j][k] / 2 if j == k else dM[i][j][k])
        dL_dq.append(grouped(position) - dV[i])
    return {"dL_dqd": sympy.Matrix(dL_dqd), "ddt_dL_dqd": sympy.Matrix(ddt), "dL_dq": sympy.Matrix(dL_dq)}


def _by_rates(expr: sympy.Expr, rates: set[sympy.Symbol]) -> sympy.Expr:
    """``expr`` expanded, then grouped by its products of joint rates and accelerations:
    ``(w_151 + w_164) qd_2 qd_3`` rather than two terms (each dM/dq_k entry is a name)."""
    return group_terms(sympy.Add.make_args(expand(expr)), rates.__contains__)
