"""The centre of mass and the centroidal momentum matrix of a small 3-D robot, symbolically and
step by step, for the sheet and the JSON (``Derivation.centroidal_steps``); the generated code
computes them with the programs of ``centroidal_programs.py`` at every size.

From each moving link's quantities the derivation already has (mass ``m_i``, inertia ``I_i``
about its centre of mass in link axes, world rotation ``R_i``, centre of mass ``p_i`` in the
world, and the body Jacobian ``J_i`` of its centre-of-mass frame, rows ``(v, w)`` in link
axes, ``(v_i, w_i) = J_i qd``):

* ``m = sum m_i`` and ``p_G = sum m_i p_i / m``;
* the world Jacobians of the centre of mass, ``Jv_i = R_i J_i[v]``, and of the rotation,
  ``Jw_i = R_i J_i[w]``; then ``J_G = sum m_i Jv_i / m``;
* ``A_G`` (Pinocchio's ``ccrba``): linear rows ``m J_G``, angular rows
  ``sum m_i (p_i - p_G) x Jv_i + R_i I_i J_i[w]`` (``R_i I_i R_i^T Jw_i``), the momentum about
  the centre of mass in world axes per velocity coordinate; written over the pairs of links,
  ``sum_{i<j} m_i m_j (p_i - p_j) x (Jv_i - Jv_j) / m``, the relative positions and velocities
  being shorter than the world ones.

Links welded to the world (no moving joint above them) are left out, as Pinocchio and the
generated code leave them out. With quaternion joints ``qd`` is the quasi-velocity ``v``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from . import joint_types
from .joint_types.quaternion import quaternion_matrix
from .quasi_velocity import QuasiVelocitySheet, _Ring
from .rotations import rpy_matrix
from .spatial import inertia_tensor
from .tidy import fold_constants, tidy

#: Centroidal quantity names (``naming.CENTROIDAL_QUANTITIES``), by what they are.
DESCRIPTIONS = {
    "m_total": "total mass of the moving links",
    "p_G": "centre of mass of the moving links in the world",
    "J_G": "centre-of-mass Jacobian: dp_G/dt = J_G qd (world axes)",
    "A_G": "centroidal momentum matrix (Pinocchio's ccrba): A_G qd is the linear, then the angular momentum "
           "about the centre of mass, in world axes",
}


@dataclass
class CentroidalLink:
    """One moving link's part: its index and name, mass, centre of mass in the world, and the
    world Jacobians of that point's velocity and of the link's angular velocity."""

    index: int
    name: str
    mass: sympy.Expr
    position: sympy.Matrix   # 3 x 1
    linear: sympy.Matrix     # 3 x NV: Jv_i
    angular: sympy.Matrix    # 3 x NV: Jw_i


@dataclass
class CentroidalSteps:
    """The moving links' parts and the results (module docstring), in the axes of ``base``:
    the world for a fixed base; with a floating or spherical root (``base`` its frame's world
    rotation and position), that frame, the world's quantities following as
    ``p_G = p_B + R_B p_G'``, ``J_G = R_B J_G'``, ``A_G = diag(R_B, R_B) A_G'``."""

    links: list[CentroidalLink]
    mass: sympy.Expr
    com: sympy.Matrix        # p_G, 3 x 1
    jacobian: sympy.Matrix   # J_G, 3 x NV
    matrix: sympy.Matrix     # A_G, 6 x NV
    base: tuple[sympy.Matrix, sympy.Matrix] | None = None

    def quantities(self) -> dict[str, object]:
        """The named quantities in the world: ``m_total``, ``p_G``, ``J_G``, ``A_G``."""
        if self.base is None:
            return {"m_total": self.mass, "p_G": self.com, "J_G": self.jacobian, "A_G": self.matrix}
        R, p = self.base
        rotate = sympy.diag(R, R)
        return {"m_total": self.mass, "p_G": p + R * self.com, "J_G": R * self.jacobian, "A_G": rotate * self.matrix}


#: One link's inputs: index (1-based, the file's order), name, mass, world rotation, centre of
#: mass in the world, body Jacobian of the centre-of-mass frame (6 x NV, rows v then w), inertia.
LinkInput = tuple[int, str, sympy.Expr, sympy.Matrix, sympy.Matrix, sympy.Matrix, sympy.Matrix]


def moving_links(robot: Robot) -> set[str]:
    """The links with a moving joint on their path from the world."""
    return {link.name for link in robot.links if any(j.moves for j in robot.path_to(link.name))}


def centroidal_steps(links: Sequence[LinkInput], clean: Callable[[sympy.Expr], sympy.Expr],
                     over: Callable[[sympy.Expr], sympy.Expr] | None = None) -> CentroidalSteps:
    """The steps of the module docstring over ``links`` (the moving ones), each entry passed
    through ``clean`` (``tidy`` for trigonometric entries; polynomial arithmetic for the
    quasi-velocity sheet's), and each quotient by the total mass through ``over`` (default:
    ``clean``)."""
    over = over or clean
    tidy = lambda m: m.applyfunc(clean)  # noqa: E731
    parts = []
    for index, name, mass, R, position, J, _ in links:
        parts.append(CentroidalLink(index, name, mass, position, tidy(R * J[:3, :]), tidy(R * J[3:, :])))
    nv = links[0][5].shape[1] if links else 0
    total = clean(sum((part.mass for part in parts), sympy.Integer(0)))
    moment = tidy(sum((part.position * part.mass for part in parts), sympy.zeros(3, 1)))   # m p_G
    linear = tidy(sum((part.linear * part.mass for part in parts), sympy.zeros(3, nv)))
    # about G: sum_i m_i (p_i - p_G) x Jv_i, with p_i - p_G = sum_j m_j (p_i - p_j) / m, is
    # sum over the pairs i < j of m_i m_j (p_i - p_j) x (Jv_i - Jv_j) / m: the links' relative
    # positions and velocities, shorter than their world ones; and each link's spin R_i I_i [J_i]_w
    pairs, spin = sympy.zeros(3, nv), sympy.zeros(3, nv)
    for a, first in enumerate(parts):
        for second in parts[a + 1:]:
            lever = tidy(first.position - second.position)
            relative = tidy(first.linear - second.linear)
            for j in range(nv):
                pairs[:, j] += lever.cross(relative[:, j]) * first.mass * second.mass
    for _, _, _, R, _, J, inertia in links:
        spin += R * inertia * J[3:, :]
    divide = lambda m: m.applyfunc(lambda e: over(e / total))  # noqa: E731
    angular = divide(tidy(pairs)) + tidy(spin)
    return CentroidalSteps(parts, total, divide(moment), divide(linear), sympy.Matrix.vstack(linear, angular))


def fixed_base_centroidal(robot: Robot, table: SymbolTable, kinematics: Sequence[Any]) -> CentroidalSteps:
    """The steps of a robot without quaternion joints from its links' kinematics
    (``spatial.SpatialLinkKinematics``, in the file's link order), entries tidied."""
    moving = moving_links(robot)
    inputs = [(index, link.name, table.expr(link.mass), kin.rotation, kin.com_world, kin.body_jacobian,
               inertia_tensor(tuple(table.expr(e) for e in link.inertia)))
              for index, (link, kin) in enumerate(zip(robot.links, kinematics), 1) if link.name in moving]
    return centroidal_steps(inputs, tidy)


def quasi_velocity_centroidal(robot: Robot, table: SymbolTable, sheet: QuasiVelocitySheet) -> CentroidalSteps:
    """The steps of a small robot with one floating or spherical joint at the world (the
    quasi-velocity sheet's robots), in that joint's child frame B: its links' poses are the
    sheet's at the joint's zero (identity quaternion, zero position), seen from the joint's
    placement; ``J_i`` does not depend on the base's pose. Polynomial arithmetic with sines and
    cosines as variables (``quasi_velocity._Ring``)."""
    root = next(j for j in robot.joints if j.multi)
    where_q = robot.offsets()[0]
    start = where_q[root.name] + joint_types.of(root).quaternion_start  # type: ignore[operator]
    quaternion = table.q[start:start + 4]
    x, y, z, roll, pitch, yaw = (table.expr(e) for e in root.origin)
    R_o, p_o = fold_constants(rpy_matrix(roll, pitch, yaw)), fold_constants(sympy.Matrix([x, y, z]))
    # the entries before its quaternion are its position (a free joint's), if it has them
    position = sympy.Matrix(table.q[where_q[root.name]:start]) if start > where_q[root.name] else sympy.zeros(3, 1)
    zero = {s: 0 for s in (*quaternion[:3], *position)} | {quaternion[3]: 1}
    moving = moving_links(robot)
    links = [k for k in sheet.links if k.name in moving]
    relative = [(R_o.T * k.rotation.xreplace(zero), R_o.T * (k.com_position.xreplace(zero) - p_o)) for k in links]
    values = [e for k, (R, p) in zip(links, relative) for m in (R, p, k.jacobian, k.inertia) for e in m]
    revolute = [table.q[where_q[j.name]] for j in robot.joints   # the angles inside sines and cosines
                if j.owns and j.kind.vector_space and joint_types.of(j).turns]
    ring = _Ring(table, revolute, [*values, *(k.mass for k in links)])

    def clean(e: sympy.Expr) -> sympy.Expr:
        return ring.expr(ring.of(sympy.Matrix([e]))[0][0])

    inputs = [(k.index, k.name, k.mass, R, p, k.jacobian, k.inertia) for k, (R, p) in zip(links, relative)]
    steps = centroidal_steps(inputs, clean, over=lambda e: e)
    if steps.mass.is_Number:   # rounding noise measured against each matrix's largest entry
        def settle(matrix: sympy.Matrix) -> sympy.Matrix:
            return ring.matrix(ring.of(matrix))

        for part in steps.links:
            part.linear, part.angular = settle(part.linear), settle(part.angular)
        steps.com, steps.jacobian, steps.matrix = settle(steps.com), settle(steps.jacobian), settle(steps.matrix)
    steps.base = (R_o * quaternion_matrix(*quaternion), p_o + R_o * position)
    return steps
