"""Equations of motion in generalized coordinates (Problem 1 of the reference).

Two independent routes, as in the reference: Lagrange's equations applied to ``L_g = T_g -
V_g`` (``EOM_g1``), and the manipulator form from body Jacobians and Christoffel symbols
(``EOM_g2``). The derivation compares them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy

from .kinematics import PlanarLinkKinematics
from .lagrange import (
    christoffel_coriolis,
    gravity_vector,
    lagrange_steps,
    mass_matrix_from_jacobians,
)
from .model import Robot
from .symbols import SymbolTable
from .tidy import tidy, tidy_matrix


@dataclass
class LinkTerms:
    """Per-link pieces of the energies, kept for the worked solution."""

    name: str
    index: int
    mass: sympy.Expr
    inertia: sympy.Expr
    spatial_inertia: sympy.Matrix   # diag(m, m, I)
    body_jacobian: sympy.Matrix
    body_velocity: sympy.Matrix     # J_b qd
    com_position: sympy.Matrix      # world
    angle: sympy.Expr
    kinetic: sympy.Expr
    potential: sympy.Expr


def spatial_inertia_planar(mass: sympy.Expr, inertia: sympy.Expr) -> sympy.Matrix:
    return sympy.diag(mass, mass, inertia)


def derive_generalized(robot: Robot, table: SymbolTable,
                       links: list[PlanarLinkKinematics]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Quantities (by the reference's names) and intermediate steps, generalized coordinates."""
    q, qd, qdd = table.q, table.qd, table.qdd
    qd_vec = sympy.Matrix(qd)
    gravity = sympy.Matrix([table.expr(e) for e in robot.gravity])
    terms: list[LinkTerms] = []
    for k, (link, kin) in enumerate(zip(robot.links, links), start=1):
        mass = table.expr(link.mass)
        inertia = table.expr(link.inertia[0])
        G = spatial_inertia_planar(mass, inertia)
        velocity = (kin.body_jacobian * qd_vec).applyfunc(tidy)
        kinetic = sympy.Rational(1, 2) * (mass * (velocity[0] ** 2 + velocity[1] ** 2)
                                          + inertia * velocity[2] ** 2)
        com = kin.com_world.applyfunc(tidy)
        potential = tidy(-mass * (gravity.T * com)[0, 0])
        terms.append(LinkTerms(link.name, k, mass, inertia, G, kin.body_jacobian, velocity, com,
                               kin.angle, kinetic, potential))

    T = tidy(sum((t.kinetic for t in terms), sympy.Integer(0)))
    V = tidy(sum((t.potential for t in terms), sympy.Integer(0)))
    L = T - V
    efforts = {j.name: j.effort for j in robot.joints if j.moves}
    Y = sympy.Matrix([table.efforts[efforts[n]] if efforts[n] else 0 for n in robot.coordinates])

    steps = lagrange_steps(L, q, qd, qdd)
    steps_tidy = {
        "dL_dqd": tidy_matrix(steps.dL_dqd),
        "ddt_dL_dqd": tidy_matrix(steps.ddt_dL_dqd),
        "dL_dq": tidy_matrix(steps.dL_dq),
    }
    EOM_g1 = (steps.lhs - Y).applyfunc(tidy)

    M = tidy_matrix(mass_matrix_from_jacobians([t.body_jacobian for t in terms],
                                               [t.spatial_inertia for t in terms]))
    C = tidy_matrix(christoffel_coriolis(M, q, qd))
    N = tidy_matrix(gravity_vector(V, q))
    EOM_g2 = (M * sympy.Matrix(qdd) + C * qd_vec + N - Y).applyfunc(tidy)

    quantities: dict[str, Any] = {
        "T_g": T, "V_g": V, "L_g": L, "Y_g": Y, "EOM_g1": EOM_g1,
        "M_g": M, "C_g": C, "N_g": N, "EOM_g2": EOM_g2,
    }
    for t in terms:
        quantities[f"J_b{t.index}"] = t.body_jacobian
    intermediate = {"links": terms, "lagrange": steps_tidy, "gravity": gravity}
    return quantities, intermediate
