"""Panda point-to-point motion with torque limits, by trajectory optimization with IPOPT.

The dynamics are the CasADi module that ``dynderive solve robots/panda.urdf --casadi`` writes.
The arm starts at rest at one configuration and stops at rest at another after ``duration``
seconds. The decision variables are the positions and velocities at ``knots + 1`` knots and
a constant acceleration on each interval (so the knots integrate exactly: ``qd' = qd + h a``,
``q' = q + h qd + h^2 a / 2``); the torque of each interval, the module's ``inverse_dynamics``
at its start, must stay within the URDF's ``effort`` limits and the positions within its
``lower``/``upper`` limits. The cost is the sum of the torques squared.

Run it: ``python docs/tutorials/panda_point_to_point.py``.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

ROBOT = Path(__file__).resolve().parents[2] / "robots" / "panda.urdf"
START = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])   # the "ready" pose
GOAL = np.array([1.2, 0.3, -0.4, -1.6, 0.6, 2.2, -0.3])


def generate(robot: Path, directory: Path):
    """Run ``dynderive solve ROBOT --casadi --out DIRECTORY`` and import the module it writes."""
    subprocess.run(
        [sys.executable, "-m", "dynderive", "solve", str(robot), "--casadi", "--out", str(directory),
         "--quiet"],
        check=True,
    )
    (path,) = Path(directory).glob("*_dynamics_casadi.py")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module
    spec.loader.exec_module(module)
    return module


def limits(urdf: Path, coordinates) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``<limit>`` of each coordinate's joint in the URDF: (lower, upper, effort)."""
    joints = {joint.get("name"): joint.find("limit") for joint in ElementTree.parse(urdf).iter("joint")}
    table = np.array([[float(joints[name].get(key)) for key in ("lower", "upper", "effort")]
                      for name in coordinates])
    return table[:, 0], table[:, 1], table[:, 2]


@dataclass
class Motion:
    """The solution: knot times ``t`` (K + 1), positions ``q`` and velocities ``qd`` at the
    knots (K + 1 x 7), the accelerations ``qdd`` and torques ``tau`` of the intervals (K x 7),
    and IPOPT's return status."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    status: str


def point_to_point(panda, start=START, goal=GOAL, duration: float = 0.5, knots: int = 8,
                   verbose: bool = False) -> Motion:
    """Solve the motion with ``panda``, the imported CasADi module of ``panda.urdf``."""
    lower, upper, effort = limits(ROBOT, panda.COORDINATES)
    # --8<-- [start:problem]
    n, h = panda.NV, duration / knots
    torque = panda.inverse_dynamics.map(knots)     # one call for every interval

    opti = ca.Opti()
    Q = opti.variable(n, knots + 1)
    QD = opti.variable(n, knots + 1)
    QDD = opti.variable(n, knots)
    TAU = torque(Q[:, :-1], QD[:, :-1], QDD, panda.default_parameters(), 0)

    opti.subject_to(QD[:, 1:] == QD[:, :-1] + h * QDD)
    opti.subject_to(Q[:, 1:] == Q[:, :-1] + h * QD[:, :-1] + h**2 / 2 * QDD)
    opti.subject_to(Q[:, 0] == start)
    opti.subject_to(QD[:, 0] == 0)
    opti.subject_to(Q[:, -1] == goal)
    opti.subject_to(QD[:, -1] == 0)
    for k in range(knots):
        opti.subject_to(opti.bounded(-effort, TAU[:, k], effort))
        opti.subject_to(opti.bounded(lower, Q[:, k + 1], upper))
    opti.minimize(ca.sumsqr(TAU))
    # --8<-- [end:problem]

    s = np.linspace(0, 1, knots + 1)
    opti.set_initial(Q, np.outer(start, 1 - s) + np.outer(goal, s))

    quiet = {} if verbose else {"print_level": 0, "sb": "yes"}
    opti.solver("ipopt", {"print_time": verbose}, {"tol": 1e-9, **quiet})
    solution = opti.solve()
    return Motion(
        t=np.linspace(0, duration, knots + 1),
        q=np.asarray(solution.value(Q)).T,
        qd=np.asarray(solution.value(QD)).T,
        qdd=np.asarray(solution.value(QDD)).T,
        tau=np.asarray(solution.value(TAU)).T,
        status=opti.stats()["return_status"],
    )


def main() -> None:
    with tempfile.TemporaryDirectory() as directory:
        panda = generate(ROBOT, Path(directory))
        motion = point_to_point(panda, verbose=True)
    _, _, effort = limits(ROBOT, panda.COORDINATES)
    print(f"IPOPT: {motion.status}")
    ratio = np.max(np.abs(motion.tau), axis=0) / effort
    print(f"largest |tau| / effort limit per joint: {np.array2string(ratio, precision=2)}")
    print(f"final position error: {np.max(np.abs(motion.q[-1] - GOAL)):.2e}")


if __name__ == "__main__":
    main()
