"""Drive and dissipation terms of the joints: viscous damping, Coulomb friction, springs and
armature (reflected rotor inertia), as they enter Lagrange's equations.

With the Rayleigh dissipation function ``D = 1/2 sum b_i qd_i**2`` and Coulomb friction the
equations read ``d/dt dL/dqd - dL/dq + dD/dqd + fc sign(qd) = Y``: springs enter ``L``
through ``V`` (``k (q - rest)**2/2``), armature through ``T`` (``Ia qd**2/2``, so ``Ia`` joins
``M[i, i]``), and the dissipative forces ``F = dD/dqd + fc sign(qd)`` join the manipulator
form ``M qdd + C qd + N + F = Y``.

>>> terms = drive_terms(robot, table)          # doctest: +SKIP
>>> terms.forces                                 # doctest: +SKIP
Matrix([[b1*qd1 + fc1*sign(qd1)], [0]])
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable


@dataclass(frozen=True)
class JointDrive:
    """The drive terms of one coordinate (zero where the file declares none)."""

    coordinate: int
    damping: sympy.Expr
    friction: sympy.Expr
    stiffness: sympy.Expr
    rest: sympy.Expr
    armature: sympy.Expr


@dataclass(frozen=True)
class DriveTerms:
    """What the drives add to a robot's energies and forces, in generalized coordinates."""

    joints: list[JointDrive]          # the coordinates that declare any drive term
    kinetic: sympy.Expr               # armature: sum Ia_i qd_i**2 / 2
    potential: sympy.Expr             # springs: sum k_i (q_i - rest_i)**2 / 2
    dissipation: sympy.Expr           # Rayleigh: sum b_i qd_i**2 / 2      (D_g)
    forces: sympy.Matrix              # dD/dqd + fc sign(qd)               (F_g)
    armature: sympy.Matrix            # diag(Ia), added to M

    @property
    def empty(self) -> bool:
        return not self.joints


def dissipative_force(damping: sympy.Expr, friction: sympy.Expr, rate: sympy.Expr) -> sympy.Expr:
    """``b v + fc sign(v)``: the force a damper and a Coulomb friction oppose to the rate ``v``."""
    return damping * rate + friction * sympy.sign(rate)


def joint_drives(robot: Robot, table: SymbolTable) -> list[JointDrive]:
    """The velocity columns whose joints declare drive terms, each with its terms (absent ones
    0); ``coordinate`` is the leader's column in ``qd`` (its coordinate's index for a robot
    without quaternions; floating and spherical joints take no drive term).

    A ``<mimic>`` joint's terms act on its leader's coordinate: with its rate ``m qd`` (``m``
    the multiplier) its damper gives the generalized force ``m (b m qd)``, its friction
    ``m fc sign(m qd) = |m| fc sign(qd)``, its armature ``m^2 Ia qdd``, and its spring
    ``k (m q + o - rest)^2 / 2 = m^2 k (q - (rest - o)/m)^2 / 2``: so the coordinate's terms
    are ``b + m^2 b_f``, ``fc + |m| fc_f``, ``Ia + m^2 Ia_f`` and (one spring per coordinate,
    the validator's rule) ``m^2 k_f`` about ``(rest_f - o)/m``."""
    index = robot.offsets()[1]

    def value(text: object) -> sympy.Expr:
        return sympy.Integer(0) if text is None else table.expr(text)

    terms: dict[int, list[sympy.Expr]] = {}
    for joint in (j for j in robot.joints if j.moves and not j.multi and j.driven):
        leader, multiplier, offset = robot.driver(joint)
        m, o = table.expr(multiplier), table.expr(offset)
        # a joint of several coordinates (universal): the same terms on each
        for column in range(index[leader], index[leader] + max(joint.sizes[1], 1)):
            damping, friction, stiffness, rest, armature = terms.setdefault(column, [sympy.Integer(0)] * 5)
            terms[column] = [damping + m**2 * value(joint.damping), friction + abs(m) * value(joint.friction),
                             stiffness + m**2 * value(joint.stiffness),
                             (value(joint.rest) - o) / m if joint.stiffness is not None else rest,
                             armature + m**2 * value(joint.armature)]
    return [JointDrive(i, *terms[i]) for i in sorted(terms)]


def drive_terms(robot: Robot, table: SymbolTable) -> DriveTerms:
    """The drive terms of ``robot``'s moving joints, in coordinate order."""
    half = sympy.Rational(1, 2)
    drives = joint_drives(robot, table)
    n = len(robot.coordinates)
    q, qd = table.q, table.qd
    kinetic = sympy.Add(*(half * d.armature * qd[d.coordinate] ** 2 for d in drives))
    potential = sympy.Add(*(half * d.stiffness * (q[d.coordinate] - d.rest) ** 2 for d in drives))
    dissipation = sympy.Add(*(half * d.damping * qd[d.coordinate] ** 2 for d in drives))
    forces = sympy.zeros(n, 1)
    armature = sympy.zeros(n, n)
    for d in drives:
        forces[d.coordinate] = dissipative_force(d.damping, d.friction, qd[d.coordinate])
        armature[d.coordinate, d.coordinate] = d.armature
    return DriveTerms(drives, kinetic, potential, dissipation, forces, armature)


__all__ = ["DriveTerms", "JointDrive", "dissipative_force", "drive_terms", "joint_drives"]
