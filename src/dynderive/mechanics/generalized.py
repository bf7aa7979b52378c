"""Equations of motion in generalized coordinates (Problem 1 of the reference).

Two independent routes, as in the reference: Lagrange's equations applied to ``L_g = T_g -
V_g`` (``EOM_g1``), and the manipulator form from body Jacobians and Christoffel symbols
(``EOM_g2``). The derivation compares them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NotRequired, TypedDict

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .drives import DriveTerms, drive_terms
from .exact_fast import matmul
from .lagrange import christoffel_coriolis, gravity_vector, lagrange_steps, mass_matrix_from_jacobians
from .spatial import inertia_tensor
from .tidy import FOURIER_LIMIT, fewest_operations, is_small, quick_tidy, tidy, trig_group, trig_linear
from .tree import efforts

#: 3-D robots with more coordinates than this, or whose Lagrangian has more tree nodes than
#: LAGRANGE_LIMIT, skip the symbolic Lagrange route (EOM_g1): differentiating it twice costs
#: more than the rest of the derivation for 6-7 DOF arms (whose sheets cannot show it anyway),
#: while the manipulator form comes from the body Jacobians directly. `dynderive check`
#: verifies such robots against Pinocchio instead.
LAGRANGE_DOF_LIMIT = 4
LAGRANGE_LIMIT = 6000
#: 3-D entries larger than this (tree nodes) are kept as built: they are too large to typeset,
#: and expanding them (floats, six angles) costs seconds for a few per cent fewer operations.
SPATIAL_TIDY_LIMIT = 400
#: Planar C entries larger than this are only grouped by trigonometric factor (M is in
#: Fourier form already, so its derivatives are too), not offered to ``tidy``.
PLANAR_TIDY_LIMIT = 300


def tidier(robot: Robot) -> Callable[[sympy.Expr], sympy.Expr]:
    """The clean-up used for ``robot``'s quantities: full ``tidy`` for planar robots; for 3-D
    robots only entries small enough to be read, and for arms beyond LAGRANGE_DOF_LIMIT
    coordinates only the cheap ``quick_tidy`` (full ``tidy`` costs 2 s on the Panda's
    entries for 4 % fewer operations)."""
    if robot.planar:
        return tidy
    clean = tidy if robot.kinematic_size <= LAGRANGE_DOF_LIMIT else quick_tidy
    return lambda expr: clean(expr) if is_small(expr, SPATIAL_TIDY_LIMIT) else expr


@dataclass
class LinkTerms:
    """Per-link pieces of the energies, kept for the worked solution."""

    name: str
    index: int
    mass: sympy.Expr
    inertia: sympy.Expr | sympy.Matrix   # planar: scalar about z; spatial: 3 x 3 about the COM
    spatial_inertia: sympy.Matrix        # planar diag(m, m, I); spatial diag(m, m, m) + I
    body_jacobian: sympy.Matrix
    body_velocity: sympy.Matrix          # J_b qd
    com_position: sympy.Matrix           # world
    orientation: sympy.Expr | sympy.Matrix  # planar: angle; spatial: world rotation matrix
    kinetic: sympy.Expr
    potential: sympy.Expr


class GeneralizedSteps(TypedDict):
    """The generalized stage's steps, for the sheets: the links' terms (none for a large
    robot), Lagrange's derivatives ``dL_dqd``, ``ddt_dL_dqd`` and ``dL_dq`` (None where not
    derived), gravity, the drive terms, and a large robot's intermediate variables in order."""

    links: list[LinkTerms]
    lagrange: dict[str, sympy.Matrix] | None
    gravity: sympy.Matrix
    drives: DriveTerms
    intermediates: NotRequired[list[tuple[sympy.Symbol, sympy.Expr]]]


def link_terms(robot: Robot, table: SymbolTable, links: list[Any],
               gravity: sympy.Matrix) -> list[LinkTerms]:
    """Per-link inertias, velocities and energies, planar or spatial."""
    qd_vec = sympy.Matrix(table.qd)
    clean = tidier(robot)
    terms = []
    for k, (link, kin) in enumerate(zip(robot.links, links), start=1):
        mass = table.expr(link.mass)
        velocity = matmul(kin.body_jacobian, qd_vec).applyfunc(clean)
        com = kin.com_world.applyfunc(clean)
        potential = clean(-mass * matmul(gravity.T, com)[0, 0])
        if robot.planar:
            inertia = table.expr(link.inertia[0])
            G = sympy.diag(mass, mass, inertia)
            kinetic = sympy.Rational(1, 2) * (mass * (velocity[0] ** 2 + velocity[1] ** 2)
                                              + inertia * velocity[2] ** 2)
            orientation = kin.angle
        else:
            inertia = inertia_tensor(tuple(table.expr(e) for e in link.inertia))
            G = sympy.diag(mass, mass, mass, inertia)
            v, w = velocity[0:3, 0], velocity[3:6, 0]
            kinetic = sympy.Rational(1, 2) * (mass * (v.T * v)[0, 0] + (w.T * inertia * w)[0, 0])
            orientation = kin.rotation
        terms.append(LinkTerms(link.name, k, mass, inertia, G, kin.body_jacobian, velocity, com,
                               orientation, kinetic, potential))
    return terms


def applied_forces(robot: Robot, table: SymbolTable) -> sympy.Matrix:
    """``Y_g``: each joint's effort symbol on its own coordinate (0 where it has none)."""
    return sympy.Matrix(efforts(robot, table))


def _trig_squares(expr: sympy.Expr) -> bool:
    """Whether ``expr`` squares a sine or cosine of the coordinates, or a sum holding one
    (``m2 (l1 cos q2 + l2)^2``); ``sin(0.38)^2``, a joint origin's constant, is a number."""
    return any(p.exp.is_Integer and p.exp > 1 and any(f.free_symbols for f in p.base.atoms(sympy.sin, sympy.cos))
               for p in expr.atoms(sympy.Pow))


def _textbook(built: sympy.Expr, fourier: sympy.Expr) -> bool:
    """Whether a mass-matrix entry is shown in its Fourier form (``trig_linear``): when that is
    shorter, or when it removes the squares the built form has and is at most half as long
    again: ``(m1 + m2) l1^2 + 2 m2 l1 l2 cos q2 + m2 l2^2``, as textbooks write the point-mass
    double pendulum's M11, not ``m1 l1^2 + m2 (l2 + l1 cos q2)^2 + m2 l1^2 sin^2 q2``."""
    if not built.has(sympy.sin, sympy.cos):
        return False
    built_ops, fourier_ops = sympy.count_ops(built), sympy.count_ops(fourier)
    return fourier_ops < built_ops or (_trig_squares(built) and not _trig_squares(fourier)
                                       and 2 * fourier_ops <= 3 * built_ops)


def derive_generalized(robot: Robot, table: SymbolTable, links: list[Any],
                       report: Callable[[str], None] = lambda stage: None) -> tuple[dict[str, Any], GeneralizedSteps]:
    """Quantities (by the reference's names) and intermediate steps, generalized coordinates.

    ``report`` is called with the name of each stage as it starts (for progress and timing).
    """
    q, qd, qdd = table.q, table.qd, table.qdd
    qd_vec = sympy.Matrix(qd)
    gravity = sympy.Matrix([table.expr(e) for e in robot.gravity])
    terms = link_terms(robot, table, links, gravity)

    drives = drive_terms(robot, table)
    T = tidy(sum((t.kinetic for t in terms), drives.kinetic))
    V = tidy(sum((t.potential for t in terms), drives.potential))
    L = T - V
    F = drives.forces.applyfunc(tidy)
    Y = applied_forces(robot, table)

    steps_tidy: dict[str, sympy.Matrix] | None = None
    EOM_g1 = None
    if robot.planar or (robot.kinematic_size <= LAGRANGE_DOF_LIMIT and is_small(L, LAGRANGE_LIMIT)):
        report("Lagrange's equations")
        steps = lagrange_steps(L, q, qd, qdd)
        steps_tidy = {key: getattr(steps, key).applyfunc(tidy) for key in ("dL_dqd", "ddt_dL_dqd", "dL_dq")}
        # Lagrange's equations with Rayleigh's dissipation function and Coulomb friction:
        # d/dt dL/dqd - dL/dq + dD/dqd + fc sign(qd) = Y
        EOM_g1 = (steps.lhs + F - Y).applyfunc(tidy)
        if robot.planar:   # products such as sin(q2 + q3) cos(q3) that cancel in pairs: Fourier form
            EOM_g1 = EOM_g1.applyfunc(lambda e: fewest_operations(e, trig_linear))

    jacobians = [t.body_jacobian for t in terms]
    inertias = [t.spatial_inertia for t in terms]
    clean = tidier(robot)
    n = len(q)
    report("mass matrix")
    M = (mass_matrix_from_jacobians(jacobians, inertias) + drives.armature).applyfunc(clean)
    report("Coriolis matrix")
    # a <mimic> joint's angle (multiplier * q + offset) makes the Fourier forms long (products
    # of sines of several multiples of one coordinate): such robots keep M as built
    small = robot.planar or (n <= LAGRANGE_DOF_LIMIT and not robot.mimics
                             and all(is_small(e, FOURIER_LIMIT) for e in M))
    if robot.mimics:   # coupled columns: dM/dq_k by differentiation, not by twist brackets
        C = christoffel_coriolis(M, q, qd).applyfunc(clean)
    elif small:
        # Fourier form where shorter: trig products of different angles combine, and C (from
        # dM/dq) then has single sines instead of products that cancel in pairs
        fourier = M.applyfunc(trig_linear)
        M = sympy.Matrix(n, n, [f if _textbook(e, f) else e for e, f in zip(M, fourier)])
        C = christoffel_coriolis(fourier, q, qd).applyfunc(
            lambda e: fewest_operations(trig_group(e), *([tidy] if is_small(e, PLANAR_TIDY_LIMIT) else [])))
    else:
        from .spatial import mass_matrix_derivatives

        index = {name: i for i, name in enumerate(robot.coordinates)}
        paths = [[index[j.name] for j in robot.path_to(link.name) if j.moves] for link in robot.links]
        # dM/dq_k is an intermediate: C's entries are tidied, not the derivatives
        dM = mass_matrix_derivatives(jacobians, inertias, paths)
        C = christoffel_coriolis(M, q, qd, dM).applyfunc(clean)
    report("gravity vector")
    N = gravity_vector(V, q).applyfunc(clean)
    if small and not robot.planar:
        N = N.applyfunc(lambda e: fewest_operations(e, trig_linear))
    report("equations of motion")
    EOM_g2 = (matmul(M, sympy.Matrix(qdd)) + matmul(C, qd_vec) + N + F - Y).applyfunc(clean)

    quantities: dict[str, Any] = {
        "T_g": T, "V_g": V, "L_g": L, "Y_g": Y, "EOM_g1": EOM_g1,
        "M_g": M, "C_g": C, "N_g": N, "EOM_g2": EOM_g2,
    }
    if robot.dissipative:
        quantities |= {"D_g": tidy(drives.dissipation), "F_g": F}
    if EOM_g1 is None:
        del quantities["EOM_g1"]
    for t in terms:
        quantities[f"J_b{t.index}"] = t.body_jacobian
    intermediate: GeneralizedSteps = {"links": terms, "lagrange": steps_tidy, "gravity": gravity, "drives": drives}
    return quantities, intermediate
