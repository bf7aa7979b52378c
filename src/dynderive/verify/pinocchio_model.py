"""Build a Pinocchio model of a ``Robot`` (optional: only when ``pin`` is installed).

Used by ``dynderive check`` to compare the generated dynamics with an independent engine.
Joints are added depth-first (Pinocchio's CRBA assumes each subtree has consecutive joint
indices; a branch holding a leader goes before a sibling branch holding its follower, as
Pinocchio adds a mimic joint only after the joint it follows), fixed joints append their
child's inertia to the parent's Pinocchio joint; the robot's frames become operational frames
of the same names; ``<mimic>`` joints become Pinocchio's mimic joints
(``transformJointIntoMimic``; a follower above its leader in one chain has no Pinocchio model:
``NoReference``); floating and spherical joints its
free flyer and spherical joint. The returned permutations map dynderive's configuration and
velocity orders to Pinocchio's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy

from ..mechanics import joint_types
from ..model.robot import Robot
from ..model.symbols import SymbolTable


class NoReference(ValueError):
    """The robot is one Pinocchio cannot model (the check that needs it is skipped, with this
    reason)."""


def pinocchio_model(robot: Robot, values: dict[str, float]) -> tuple[Any, np.ndarray]:
    """(model, perm) with ``v_pin = v[perm]`` (for a robot without quaternions ``q_pin = q[perm]``
    too); parameters take ``values``."""
    model, _, order = pinocchio_maps(robot, values)
    return model, order


def pinocchio_maps(robot: Robot, values: dict[str, float]) -> tuple[Any, np.ndarray, np.ndarray]:
    """(model, qp, vp) with ``q_pin = q[qp]`` and ``v_pin = v[vp]``: each joint its joint
    type's Pinocchio model (``JointType.pinocchio``: a floating joint ``JointModelFreeFlyer``,
    a spherical joint ``JointModelSpherical``, whose quaternions take NQ != NV entries), at the
    parameters' ``values`` (their defaults where not given)."""
    import pinocchio as pin

    table = SymbolTable.for_robot(robot)
    defaults = {p.name: p.value for p in robot.parameters if p.value is not None}
    numbers = {table.parameters[name]: sympy.Float(v) for name, v in (defaults | values).items()}

    def num(text: object) -> float:
        return float(table.expr(text).xreplace(numbers).evalf(17))

    model = pin.Model()
    model.gravity.linear = np.array([num(e) for e in robot.gravity] + ([0.0] if robot.planar else []))
    # where each link lives: (pinocchio joint id, placement of the link frame in that joint)
    frame_of: dict[str, tuple[int, Any]] = {"world": (0, pin.SE3.Identity())}

    def placement(joint: Any) -> Any:
        if robot.planar:
            x, y, theta = (num(e) for e in joint.origin)
            return pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, theta), np.array([x, y, 0.0]))
        x, y, z, roll, pitch, yaw = (num(e) for e in joint.origin)
        return pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.array([x, y, z]))

    def inertia(link_name: str) -> Any:
        link = robot.link(link_name)
        com = [num(e) for e in link.com] + ([0.0] if robot.planar else [])
        if robot.planar:
            izz = num(link.inertia[0])
            tensor = np.diag([izz, izz, izz])
        else:
            ixx, iyy, izz, ixy, ixz, iyz = (num(e) for e in link.inertia)
            tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        return pin.Inertia(num(link.mass), np.array(com), tensor)

    def kind(joint: Any) -> Any:
        """The joint type's Pinocchio model at the joint's unit axis (a planar robot's: its
        twist's, about z or along the plane) and its own keys' numbers."""
        joint_type = joint_types.of(joint)
        axis = np.zeros(3)
        if joint_type.spec.takes_axis and robot.planar:
            vx, vy, w = (float(e) for e in joint_type.planar(sympy.Integer(0), tuple(num(e) for e in joint.axis)).twist)
            axis = np.array([0.0, 0.0, w] if w else [vx, vy, 0.0])
        elif joint_type.spec.takes_axis:
            axis = np.array([num(e) for e in joint.axis])
        axis = axis / (np.linalg.norm(axis) or 1.0)
        return joint_type.pinocchio(pin, axis, {key: tuple(num(e) for e in value) if isinstance(value, tuple) else num(value)
                                                for key, value in joint.geometry})

    def visit(parent: str) -> None:
        for joint in _leaders_first(robot, [j for j in robot.joints if j.parent == parent]):
            parent_id, parent_frame = frame_of[parent]
            place = parent_frame * placement(joint)
            if not joint.moves:
                frame_of[joint.child] = (parent_id, place)
                model.appendBodyToJoint(parent_id, inertia(joint.child), place)
            else:
                joint_id = model.addJoint(parent_id, kind(joint), place, joint.name)
                model.appendBodyToJoint(joint_id, inertia(joint.child), pin.SE3.Identity())
                frame_of[joint.child] = (joint_id, pin.SE3.Identity())
            visit(joint.child)

    visit("world")
    for joint in (j for j in robot.joints if j.mimic is not None):
        if model.getJointId(joint.name) < model.getJointId(joint.mimic.joint):
            raise NoReference(f"joint '{joint.name}' follows '{joint.mimic.joint}', a joint below it: Pinocchio "
                              "adds a mimic joint only after the joint it follows")
        model = pin.transformJointIntoMimic(model, model.getJointId(joint.mimic.joint), model.getJointId(joint.name),
                                            float(joint.mimic.multiplier), float(joint.mimic.offset))
    where_q, where_v = robot.offsets()
    qp, vp = np.zeros(model.nq, dtype=int), np.zeros(model.nv, dtype=int)
    for index, (name, jmodel) in enumerate(zip(model.names, model.joints)):
        if index > 0 and index not in model.mimicking_joints:
            qp[jmodel.idx_q:jmodel.idx_q + jmodel.nq] = range(where_q[name], where_q[name] + jmodel.nq)
            vp[jmodel.idx_v:jmodel.idx_v + jmodel.nv] = range(where_v[name], where_v[name] + jmodel.nv)
    for frame in robot.frames:   # operational frames, by the robot's frame names
        joint_id, link_place = frame_of[frame.link]
        model.addFrame(pin.Frame(frame.name, joint_id, link_place * placement(frame), pin.FrameType.OP_FRAME))
    model.armature = PinocchioDrives(robot, values, vp).armature   # crba, rnea and aba use it
    return model, qp, vp


def _leaders_first(robot: Robot, siblings: list[Any]) -> list[Any]:
    """Sibling joints in the robot's order, except that a branch holding the leader of a
    follower in a later sibling's branch moves before that sibling (a finger following the
    other finger of a hand written before it); a stable order, so the usual case is unchanged."""
    def below(joint: Any) -> set[str]:
        names, stack = set(), [joint]
        while stack:
            current = stack.pop()
            names.add(current.name)
            stack += [j for j in robot.joints if j.parent == current.child]
        return names

    branches = [(joint, below(joint)) for joint in siblings]
    led = {j.name: j.mimic.joint for j in robot.joints if j.mimic is not None}
    ordered: list[tuple[Any, set[str]]] = []
    for joint, names in branches:
        # the first earlier branch whose followers' leaders are in this one
        at = next((k for k, (_, earlier) in enumerate(ordered) if any(led.get(n) in names for n in earlier)),
                  len(ordered))
        ordered.insert(at, (joint, names))
    return [joint for joint, _ in ordered]


class PinocchioDrives:
    """The joints' springs, damping and friction in Pinocchio's velocity order, which Pinocchio
    does not model (its ``armature`` it does): ``spring(q)`` = k (q - rest), ``dissipative(v)``
    = b v + fc sign(v); per velocity column, a ``<mimic>`` joint's terms mapped onto its leader's
    (``mechanics.drives``; floating and spherical joints take none)."""

    def __init__(self, robot: Robot, values: dict[str, float], perm: np.ndarray):
        from ..mechanics.drives import joint_drives  # by velocity column

        table = SymbolTable.for_robot(robot)
        numbers = {table.parameters[name]: sympy.Float(v) for name, v in values.items()}
        drives = {d.coordinate: d for d in joint_drives(robot, table)}

        def column(key: str) -> np.ndarray:
            return np.array([float(sympy.sympify(getattr(drives[i], key)).xreplace(numbers).evalf()) if i in drives
                             else 0.0 for i in perm])

        self.armature, self.damping, self.friction = column("armature"), column("damping"), column("friction")
        self.stiffness, self.rest = column("stiffness"), column("rest")

    def spring(self, q: np.ndarray) -> np.ndarray:
        return self.stiffness * (q - self.rest)

    def dissipative(self, v: np.ndarray) -> np.ndarray:
        return self.damping * v + self.friction * np.sign(v)
