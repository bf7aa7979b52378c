"""Size limits of a robot, checked when it is loaded, before any derivation.

The symbolic work grows like n^3 in the coordinates (the Coriolis stage makes n forward
derivatives of the mass matrix's program, whose length grows like n^2), and so does its
memory. A robot beyond these limits would run for many minutes and past 4 GB, so it is
refused at once with the limit and what to do (README, "Limits"). Measured on the 2-core
reference machine: a planar chain of 30 links, ``--code``, 40 s and 0.5 GB; a generic 3-D
chain of 20 joints 29 s and 0.5 GB; 60 planar links passed 3.4 GB.
"""

from __future__ import annotations

from ..errors import InputError
from ..model.robot import Robot
from .loader import SourceDocument

#: Most coordinates (moving joints, loop joints included) of a planar robot.
MAX_PLANAR_COORDINATES = 40
#: Most coordinates of a 3-D robot (each link's kinematics carries a rotation matrix).
MAX_SPATIAL_COORDINATES = 30
#: Most coordinates (moving joints, the floating one counted once) of a floating-base robot:
#: its module builds no Coriolis stage, so its work grows like n^2 (talos_reduced floating, 33
#: joints and 38 velocities: 12 s and 0.15 GB).
MAX_FLOATING_COORDINATES = 60
#: Seconds of ``--code`` at the limits' reference sizes (planar 30, 3-D 20), for the estimate.
_REFERENCE = {True: (30, 40.0), False: (20, 29.0)}


def coordinate_limit(robot: Robot) -> int:
    if robot.floating:
        return MAX_FLOATING_COORDINATES
    return MAX_PLANAR_COORDINATES if robot.planar else MAX_SPATIAL_COORDINATES


def estimated_seconds(robot: Robot) -> float:
    """Rough time of the symbolic work for ``--code`` on the reference machine (n^3)."""
    if robot.floating:   # n^2, measured on talos_reduced
        return 12.0 * (len(robot.coordinates) / 33) ** 2
    size, seconds = _REFERENCE[robot.planar]
    return seconds * (len(robot.coordinates) / size) ** 3


def check_size(robot: Robot, doc: SourceDocument) -> None:
    """Raise ``InputError`` (positioned at ``joints``) when ``robot`` exceeds the limits."""
    n, limit = len(robot.coordinates), coordinate_limit(robot)
    if n <= limit:
        return
    kind = "floating-base" if robot.floating else "planar" if robot.planar else "3-D"
    minutes = estimated_seconds(robot) / 60
    raise InputError([doc.problem(
        ("joints",), f"joints: {n} coordinates exceed the limit of {limit} for a {kind} robot "
        f"(the derivation would take about {minutes:.0f} min and several GB); weld the joints "
        "you do not need (type: fixed) or derive the robot in parts", key=True)])
