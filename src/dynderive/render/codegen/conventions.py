"""The words of a generated Python module that describe its robot's ``q`` and ``qd``: what
kind of robot it is, and for each joint whose configuration holds a unit quaternion (NQ != NV),
which of its entries are which, read from the joint's own entries rather than from its type's
name, so the templates write them without asking which joints the robot has."""

from __future__ import annotations

import textwrap

from ...model.robot import Robot
from ...model.symbols import SymbolTable

#: The width the module docstrings are wrapped to.
WIDTH = 95


def robot_kind(robot: Robot) -> str:
    """The words after the module title's robot name: a floating base, quaternion joints, or none."""
    if robot.floating_base:
        return "a floating-base robot"
    return "a robot with quaternion joints" if robot.floating else ""


def joint_entries(robot: Robot, table: SymbolTable) -> list[str]:
    """Per joint with a unit quaternion in ``q``, its entries of ``q`` and ``qd``, by name."""
    where_q, where_v = robot.offsets()
    sentences = []
    for joint, quaternion in zip([j for j in robot.joints if j.multi], robot.quaternion_starts, strict=True):
        nq, nv = joint.sizes
        q = [str(s) for s in table.q[where_q[joint.name]:where_q[joint.name] + nq]]
        v = [str(s) for s in table.qd[where_v[joint.name]:where_v[joint.name] + nv]]
        start = quaternion - where_q[joint.name]
        held = f"{', '.join(q[:start])} and the unit quaternion " if start else "the unit quaternion "
        sentences.append(f"joint {joint.name} holds {held}{', '.join(q[start:])} (x, y, z, w) in ``q`` and "
                         f"its velocity {', '.join(v)} in its own frame in ``qd``")
    return sentences


def conventions(robot: Robot, table: SymbolTable) -> str:
    """The module docstring's paragraph on ``q`` and ``qd``: their sizes NQ and NV (equal for a
    robot of vector-space joints), and Pinocchio's conventions for each quaternion joint."""
    nq, nv = len(table.q), len(table.qd)
    text = (f"``q`` has NQ = {nq} entries (COORDINATES), ``qd``, ``qdd`` and ``integrate``'s ``v`` have "
            f"NV = {nv} entries (VELOCITIES), in joint order.")
    joints = joint_entries(robot, table)
    if joints:
        text += " Conventions are Pinocchio's: " + "; ".join(joints) + "."
    return textwrap.fill(text, WIDTH, break_on_hyphens=False, break_long_words=False)


def _force_word(nv: int) -> str:
    """What acts on a quaternion joint's velocity entries: a wrench on six, a torque on three."""
    return "wrench" if nv == 6 else "torque"


def notes(robot: Robot, table: SymbolTable) -> dict[str, str]:
    """The docstring sentences on the quaternion joints' entries, by function (empty for a
    robot of vector-space joints): the Jacobian's columns, inverse dynamics' entries, the
    efforts of an actuated quaternion joint, friction's zero entries, the regressor."""
    joints = [j for j in robot.joints if j.multi]
    names = ", ".join(j.name for j in joints)
    actuated = [j for j in joints if j.effort_names]
    return {
        "frame_jacobian": f"; the columns of {names} take their velocity in their own frame" if joints else "",
        "inverse_dynamics": "".join(f"\n    Joint {j.name}'s entries are the {_force_word(j.sizes[1])} its child would need."
                                    for j in joints),
        "efforts": "".join(f" Joint {j.name}'s efforts ({', '.join(j.effort_names)}) are the {_force_word(j.sizes[1])} "
                           "on its child in its frame." for j in actuated),
        "friction": ("; zero on the entries of " + names + " (they take no drive term)") if joints else
                    " (F_g = dD/dqd + fc sign(qd), D the Rayleigh dissipation function)",
        "contact_efforts": " (u at EFFORT_COLUMNS)" if joints else "",
        **_map_notes(joints),
        "regressor": ("\n    Where each link's frame is its joint's (no welded links), the columns are Pinocchio's\n"
                      "    ``computeJointTorqueRegressor``'s.") if joints else "",
    }


def _map_notes(joints: list) -> dict[str, str]:
    """The configuration maps' sentences on the quaternion joints, grouped by their velocity
    size (six: a free body's SE(3); three: a ball's SO(3)); none without them."""
    free = ", ".join(j.name for j in joints if j.sizes[1] == 6)
    ball = ", ".join(j.name for j in joints if j.sizes[1] == 3)
    integrate = difference = rate = ""
    if free:
        integrate += (f", for {free} the exponential map of SE(3), the pose times exp(v dt), with its quaternion "
                      "normalized in the hemisphere of q's")
        difference += f", for {free} log of SE(3) of the relative pose"
        rate += f", for {free} R(quaternion) (vx, vy, vz) and the quaternion's 1/2 quaternion * (wx, wy, wz, 0)"
    if ball:
        integrate += f", for {ball} the exponential map of SO(3), the quaternion times exp(v dt), normalized"
        difference += f", for {ball} log of SO(3)"
        rate += f", for {ball} the quaternion's 1/2 quaternion * (wx, wy, wz, 0)"
    if joints:
        rate += ", tangent to the unit sphere (an integrator on (q, v) keeps the quaternion unit up to its own error)"
    return {"neutral": ", and identity quaternions" if joints else "", "integrate": _indented(integrate),
            "difference": _indented(difference), "rate": _indented(rate)}


def _indented(clauses: str) -> str:
    """Clauses that continue a docstring's sentence (``, for ...``), wrapped on lines of their own."""
    if not clauses:
        return ""
    return ",\n" + textwrap.fill(clauses.removeprefix(", "), WIDTH, initial_indent="    ", subsequent_indent="    ",
                                  break_on_hyphens=False, break_long_words=False)
