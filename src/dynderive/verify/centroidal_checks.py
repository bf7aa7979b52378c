"""``dynderive check``'s rows on the centre of mass and the centroidal momentum of a 3-D robot
(DESIGN.md section 11): the generated functions against the links' momenta summed link by link
from an independent forward kinematics (``link_states``, NumPy, straight from the robot's
description), against central differences of ``center_of_mass`` and of the Jacobians along
``integrate``, and against Pinocchio (``pinocchio_rows``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..mechanics import joint_types
from ..render.sheets.figure_3d import rpy
from .rows import Row, _row, peak

#: The rows' names (what each compares: the module docstring, docs/guides/check-and-simulate.md).
MOMENTA = "centroidal: A_G qd, center_of_mass, total_mass = sum over the links (own kinematics)"
DIFFERENCES = "centroidal: J_G, J qd, Jdot qd, Adot_G qd = central differences along {along}"
PINOCCHIO = "centroidal agrees with Pinocchio (ccrba, centerOfMass, jacobianCenterOfMass, dhg)"


def _motion(joint: Any, num: Callable[[object], float]) -> Callable[..., tuple[Any, Any, Any]]:
    """A moving joint's motion as NumPy: its entries of q (one variable for a ``<mimic>``
    joint) -> its rotation and displacement in its joint frame and its motion columns
    (angular over linear, 6 x nv, in its child frame), from its joint type at the numbers."""
    kind = joint_types.of(joint)
    axis = np.array([num(e) for e in joint.axis]) if kind.spec.takes_axis else np.zeros(3)
    axis = tuple(sympy.Float(a) for a in axis / (np.linalg.norm(axis) or 1.0))
    geometry = joint_types.geometry_of(joint, lambda e: sympy.Float(num(e)))
    entries = sympy.symbols(f"x0:{kind.nq if joint.mimic is None else 1}")
    shift = kind.displacement(sympy.eye(3), entries, axis, geometry)
    columns = kind.columns(entries, axis, geometry)
    S = sympy.Matrix([[*w, *v] for w, v in columns]).T if columns else sympy.zeros(6, 0)
    return sympy.lambdify(entries, (kind.rotation(entries, axis, geometry),
                                    sympy.zeros(3, 1) if shift is None else shift, S), "numpy")


class LinkModel:
    """The robot's numbers for ``link_states``: each joint's placement and unit axis, each
    link's mass, centre of mass and inertia, at the parameters ``values`` (no SymPy after
    construction)."""

    def __init__(self, derivation: Derivation, values: dict[str, float]):
        robot, table = derivation.robot, derivation.symbols
        numbers = {table.parameters[name]: sympy.Float(value) for name, value in values.items()}

        def num(e: object) -> float:
            return float(sympy.sympify(table.expr(e)).xreplace(numbers).evalf(17))

        self.robot = robot
        self.offsets = robot.offsets()
        self.placements = {}
        self.motions: dict[str, Callable[..., tuple[Any, Any, Any]]] = {}
        for joint in robot.joints:
            x, y, z, roll, pitch, yaw = (num(e) for e in joint.origin)
            self.placements[joint.name] = (rpy(roll, pitch, yaw), np.array([x, y, z]))
            if joint.moves:
                self.motions[joint.name] = _motion(joint, num)
        self.moving = [link for link in robot.links if any(j.moves for j in robot.path_to(link.name))]
        self.inertial = {}
        for link in self.moving:
            ixx, iyy, izz, ixy, ixz, iyz = (num(e) for e in link.inertia)
            self.inertial[link.name] = (num(link.mass), np.array([num(e) for e in link.com]),
                                        np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))

    def link_states(self, q: np.ndarray, v: np.ndarray) -> dict[str, tuple[np.ndarray, ...]]:
        """Each link frame's world rotation and origin, and its angular velocity and the velocity
        of its origin, in world axes: joint by joint from the world, by the conventions of
        DESIGN.md sections 3 and 10 (a floating or spherical joint's velocity in its own frame)."""
        robot, (where_q, where_v) = self.robot, self.offsets
        zero = np.zeros(3)
        states: dict[str, tuple[np.ndarray, ...]] = {"world": (np.eye(3), zero, zero, zero)}

        def state(link: str) -> tuple[np.ndarray, ...]:
            if link in states:
                return states[link]
            joint = robot.parent_joint(link)
            R_p, p_p, w_p, v_p = state(joint.parent)
            R_o, p_o = self.placements[joint.name]
            R, p = R_p @ R_o, p_p + R_p @ p_o
            w, velocity = w_p, v_p + np.cross(w_p, p - p_p)
            if joint.moves:   # a <mimic> joint's variable multiplier * q_leader + offset, its rate the leader's times it
                if joint.mimic is None:
                    qi, vi, nq, nv = where_q[joint.name], where_v[joint.name], *joint.sizes
                    values, rates = q[qi:qi + nq], v[vi:vi + nv]
                else:
                    leader, multiplier, offset = robot.driver(joint)
                    values, rates = [multiplier * q[where_q[leader]] + offset], multiplier * v[where_v[leader]:where_v[leader] + 1]
                R_joint, shift, S = (np.asarray(a, dtype=float) for a in self.motions[joint.name](*values))
                shift = R @ shift.reshape(3)
                p, velocity = p + shift, velocity + np.cross(w, shift)
                R = R @ R_joint
                twist = S.reshape(6, -1) @ rates
                w, velocity = w + R @ twist[:3], velocity + R @ twist[3:]
            states[link] = (R, p, w, velocity)
            return states[link]

        for item in robot.links:
            state(item.name)
        return states

    def momentum(self, q: np.ndarray, v: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Total mass, centre of mass and ``(linear, angular about the centre of mass)``
        momentum of the moving links, summed link by link."""
        states = self.link_states(q, v)
        total, moment = 0.0, np.zeros(3)
        points = []
        for link in self.moving:
            R, p, w, velocity = states[link.name]
            mass, com, inertia = self.inertial[link.name]
            c = p + R @ com
            points.append((mass, c, velocity + np.cross(w, c - p), R @ inertia @ R.T @ w))
            total, moment = total + mass, moment + mass * c
        G = moment / total
        linear = sum((mass * vc for mass, _, vc, _ in points), np.zeros(3))
        angular = sum((np.cross(c - G, mass * vc) + spin for mass, c, vc, spin in points), np.zeros(3))
        return total, G, np.concatenate([linear, angular])


def centroidal_rows(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                    vs: np.ndarray) -> list[Row]:
    """The rows of a 3-D robot (none for a planar one): the links' momenta, then the
    differences (module docstring)."""
    if derivation.robot.planar:
        return []
    model = LinkModel(derivation, values)
    worst, scale = 0.0, 1.0
    for q, v in zip(qs, vs):
        mass, com, momentum = model.momentum(q, v)
        A = module.centroidal_momentum_matrix(q, **values)
        worst = max(worst, abs(float(module.total_mass(**values)) - mass), peak(module.center_of_mass(q, **values) - com),
                    peak(A @ v - momentum), peak(module.centroidal_momentum(q, v, **values) - momentum))
        scale = max(scale, mass, peak(momentum), peak(com))
    rows = [_row(MOMENTA, worst < 1e-9 * scale, "numeric", worst)]
    return rows + [_differences(derivation, module, values, qs, vs)]


def _differences(derivation: Derivation, module: Any, values: dict[str, float], qs: np.ndarray,
                 vs: np.ndarray) -> Row:
    """``J_G`` column by column against central differences of ``center_of_mass`` along each
    velocity coordinate, and the biases against the differences of ``J qd`` and ``A_G qd``
    along the motion: ``integrate(q, v, t)`` with quaternions, ``q + t v`` without."""
    floating = derivation.robot.floating
    move: Callable[[np.ndarray, np.ndarray, float], np.ndarray] = (
        module.integrate if floating else (lambda q, v, t: q + t * v))
    h, worst, scale = 1e-6, 0.0, 1.0
    for q, v in zip(qs, vs):
        J = module.center_of_mass_jacobian(q, **values)
        numeric = np.array([(module.center_of_mass(move(q, e, h), **values)
                             - module.center_of_mass(move(q, e, -h), **values)) / (2 * h)
                            for e in np.eye(len(v))]).T
        ahead, behind = move(q, v, h), move(q, v, -h)
        com_rate = (module.center_of_mass_jacobian(ahead, **values) - module.center_of_mass_jacobian(behind, **values)) \
            @ v / (2 * h)
        momentum_rate = (module.centroidal_momentum_matrix(ahead, **values)
                         - module.centroidal_momentum_matrix(behind, **values)) @ v / (2 * h)
        worst = max(worst, peak(J - numeric), peak(module.center_of_mass_velocity(q, v, **values) - J @ v),
                    peak(module.center_of_mass_acceleration_bias(q, v, **values) - com_rate),
                    peak(module.centroidal_momentum_bias(q, v, **values) - momentum_rate))
        scale = max(scale, peak(J), peak(momentum_rate))
    along = "integrate" if floating else "q"
    return _row(DIFFERENCES.format(along=along), worst < 1e-5 * scale, f"numeric (h = {h:g})", worst)


def pinocchio_centroidal(pin: Any, model: Any, module: Any, values: dict[str, float], qp: np.ndarray, vp: np.ndarray,
                         qs: np.ndarray, vs: np.ndarray) -> Row:
    """The module's centre of mass and centroidal momentum against Pinocchio's algorithms:
    ``computeTotalMass``, ``centerOfMass`` (position, velocity, acceleration at zero qdd),
    ``jacobianCenterOfMass``, ``ccrba`` (A_G and the composite inertia Ig) and
    ``computeCentroidalMomentumTimeVariation`` (h_G and its rate ``dhg`` at zero qdd); with
    ``<mimic>`` joints A_G column by column from ``computeCentroidalMomentum`` instead of ``ccrba``."""
    name = PINOCCHIO
    data = model.createData()
    mimic = bool(model.mimicking_joints)
    worst, scale = abs(float(module.total_mass(**values)) - pin.computeTotalMass(model)), 1.0
    for q, v in zip(qs, vs):
        qm, vm = q[qp], v[vp]
        zero = np.zeros(model.nv)
        pin.centerOfMass(model, data, qm, vm, zero)
        com, vcom, acom = (np.array(x[0]) for x in (data.com, data.vcom, data.acom))
        J = np.reshape(pin.jacobianCenterOfMass(model, data, qm), (3, model.nv))   # one joint: Pinocchio gives (3,)
        diffs = [module.center_of_mass(q, **values) - com, module.center_of_mass_velocity(q, v, **values) - vcom,
                 module.center_of_mass_acceleration_bias(q, v, **values) - acom,
                 module.center_of_mass_jacobian(q, **values)[:, vp] - J]
        if mimic:   # ccrba's composite pass, like crba's, may miss a mimic joint: A_G from the momentum per column
            A = np.column_stack([np.array(pin.computeCentroidalMomentum(model, data, qm, e).vector)
                                 for e in np.eye(model.nv)])
        else:
            A = np.reshape(pin.ccrba(model, data, qm, vm), (6, model.nv))   # one joint: Pinocchio gives (6,)
            inertia = data.Ig.matrix()
            diffs.append(module.centroidal_inertia(q, **values) - inertia)
            scale = max(scale, peak(inertia))
        pin.computeCentroidalMomentumTimeVariation(model, data, qm, vm, zero)
        diffs += [module.centroidal_momentum_matrix(q, **values)[:, vp] - A,
                  module.centroidal_momentum(q, v, **values) - data.hg.vector,
                  module.centroidal_momentum_bias(q, v, **values) - data.dhg.vector]
        worst = max(worst, *(peak(d) for d in diffs))
        scale = max(scale, peak(A), peak(data.dhg.vector))
    method = "numeric (mimic joints: A_G column by column from computeCentroidalMomentum)" if mimic else "numeric"
    return _row(name, worst < 1e-9 * scale, method, worst)
