"""Spatial (3-D) kinematics: COM frames, world poses and 6 x n body Jacobians.

Each body Jacobian column is the joint's unit twist carried into the COM frame by the
*relative* transform from the joint to that COM, composed from local transforms only; world
rotations never enter, which keeps entries short. Products are tidied piece by piece as they
are composed (small pieces only), never the final large expressions.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .joint_variables import couplings, scalar_motions
from .rotations import _tidy, rpy_matrix


@dataclass(frozen=True)
class Transform:
    """Rigid transform ``x -> R x + p``."""

    R: sympy.Matrix
    p: sympy.Matrix

    @classmethod
    def identity(cls) -> Transform:
        return cls(sympy.eye(3), sympy.zeros(3, 1))

    def __mul__(self, other: Transform) -> Transform:
        return Transform(_tidy(self.R * other.R), _tidy(self.R * other.p + self.p))

    def inverse(self) -> Transform:
        Rt = self.R.T
        return Transform(Rt, _tidy(-(Rt * self.p)))


def inertia_tensor(entries: tuple[sympy.Expr, ...]) -> sympy.Matrix:
    """``(ixx, iyy, izz, ixy, ixz, iyz)`` as a symmetric 3 x 3 matrix."""
    ixx, iyy, izz, ixy, ixz, iyz = entries
    return sympy.Matrix([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


@dataclass
class SpatialLinkKinematics:
    """Kinematics of one link's COM frame (axes parallel to the link frame)."""

    name: str
    rotation: sympy.Matrix        # world rotation of the link frame
    com_world: sympy.Matrix       # world position of the COM
    body_jacobian: sympy.Matrix   # 6 x n: (v, omega) of the COM frame in its own axes


def spatial_kinematics(robot: Robot, table: SymbolTable) -> list[SpatialLinkKinematics]:
    """COM poses and body Jacobians of every link, in the file's link order."""
    coupling = couplings(robot, table)
    n = len(robot.coordinates)
    results = []
    for link in robot.links:
        # local transforms from the world to the COM; remember where each joint's frame ends
        local: list[Transform] = []
        twists: list[tuple[int, int, sympy.Matrix, sympy.Matrix]] = []  # (coord, position, v, w)
        for joint in robot.path_to(link.name):
            x, y, z, roll, pitch, yaw = (table.expr(e) for e in joint.origin)
            local.append(Transform(rpy_matrix(roll, pitch, yaw), sympy.Matrix([x, y, z])))
            if not joint.moves:
                continue
            for motion in scalar_motions(robot, table, joint, coupling):   # one per coordinate it moves with
                c, kind, axis, geometry = motion.coupling, motion.kind, motion.axis, motion.geometry
                shift = kind.displacement(sympy.eye(3), [c.variable], axis, geometry)
                local.append(Transform(kind.rotation([c.variable], axis, geometry),
                                       sympy.zeros(3, 1) if shift is None else shift))
                # a <mimic> joint: multiplier * q_leader + offset, its column the multiplier's
                (w, v), = kind.columns([c.variable], tuple(a * c.multiplier for a in axis), geometry)
                twists.append((c.coordinate, len(local), sympy.Matrix(v), sympy.Matrix(w)))
        local.append(Transform(sympy.eye(3), sympy.Matrix([table.expr(e) for e in link.com])))
        # suffix[i] = local[i] * ... * local[-1]: the COM seen from the frame before local[i]
        suffix = [Transform.identity()] * (len(local) + 1)
        for i in range(len(local) - 1, -1, -1):
            suffix[i] = local[i] * suffix[i + 1]
        jacobian = sympy.zeros(6, n)
        for coordinate, position, v, w in twists:
            to_com = suffix[position].inverse()  # joint frame (after motion) seen from the COM
            omega = _tidy(to_com.R * w)
            velocity = _tidy(to_com.R * v + to_com.p.cross(omega))
            # a leader's column sums its followers' twists on the path (G of q = G q_c + offset)
            jacobian[:, coordinate] += sympy.Matrix.vstack(velocity, omega)
        world = suffix[0]
        results.append(SpatialLinkKinematics(link.name, world.R, world.p, jacobian))
    return results


def twist_bracket(a: sympy.Matrix, b: sympy.Matrix) -> sympy.Matrix:
    """Lie bracket ``ad_a b`` of twists ``(v, omega)``: ``(w_a x v_b - w_b x v_a, w_a x w_b)``."""
    va, wa, vb, wb = a[0:3, 0], a[3:6, 0], b[0:3, 0], b[3:6, 0]
    return sympy.Matrix.vstack(wa.cross(vb) - wb.cross(va), wa.cross(wb))


def mass_matrix_derivatives(jacobians: list[sympy.Matrix], inertias: list[sympy.Matrix],
                            paths: list[list[int]]) -> list[sympy.Matrix]:
    """``dM/dq_k`` for every k, without differentiating any expression.

    For a body Jacobian, ``dJ_i/dq_j = ad(J_i) J_j`` when joint i precedes joint j on the
    link's path (and 0 otherwise), so ``dM/dq_k = sum (dJ^T G J + J^T G dJ)`` comes from the
    Jacobian columns alone.
    """
    n = jacobians[0].shape[1]
    derivatives = [sympy.zeros(n, n) for _ in range(n)]
    for jac, inertia, path in zip(jacobians, inertias, paths):
        weighted = inertia * jac
        for position, k in enumerate(path):
            dJ = sympy.zeros(6, n)
            for i in path[:position]:
                dJ[:, i] = twist_bracket(jac[:, i], jac[:, k])
            if dJ.is_zero_matrix:
                continue
            half = dJ.T * weighted
            derivatives[k] += half + half.T
    return derivatives
