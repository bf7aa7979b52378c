"""Independent anchors for the benchmarks: the same robot in ``sympy.physics.mechanics``.

The robot is rebuilt the way a typical SymPy user writes a multibody model, and measured:

* ``kane_equations``: ``KanesMethod(...).kanes_equations(bodies, loads)``, unsimplified (the
  anchor for the size and time of an unsimplified symbolic derivation);
* ``kane_trigsimp``: the same, then ``trigsimp`` of every entry of the mass matrix and of the
  forcing vector (the anchor for a "readable" result), in a child process with a time limit.

Modelling choices (``kane_model``):

* generalized coordinates ``q1..qn`` (moving joints in file order), generalized speeds
  ``u1..un`` with the kinematic differential equations ``qk' - uk = 0``;
* one ``ReferenceFrame`` per link. A joint origin with a nonzero rotation gets its own
  intermediate frame (``orient_body_fixed(parent, (yaw, pitch, roll), "ZYX")``, i.e. URDF's
  ``Rz(yaw) Ry(pitch) Rx(roll)``; planar: ``orient_axis(parent, parent.z, theta)``); a zero
  rotation reuses the parent frame. A revolute joint is ``orient_axis(joint_frame, axis, q)``,
  a prismatic or fixed joint keeps the joint frame's orientation;
* points: the joint point is placed on the parent with ``set_pos`` and its velocity given by
  ``v2pt_theory``; a prismatic child origin slides along the axis (``set_vel(joint_frame,
  u axis)`` then ``v1pt_theory``); the COM is placed on the child and ``v2pt_theory``;
* ``RigidBody(link, com, frame, mass, (inertia(frame, ixx, iyy, izz, ixy, iyz, izx), com))``;
  links with zero mass and zero inertia are left out;
* loads: gravity ``m g`` at every COM, and every actuated joint's effort as an equal and
  opposite pair (revolute: torque ``tau axis`` on the child frame, ``-tau axis`` on the parent
  frame; prismatic: force ``tau axis`` at the child origin, ``-tau axis`` at the joint point of
  the parent; the reaction on the world is left out). So the forcing vector *includes* the
  efforts as the robot's own effort symbols (``tau1``, ``F2``, ...): forcing = tau - (C qd + N)
  in dynderive's terms; its operation counts include those few terms;
* every parameter with a default value is replaced by that value, as an *exact* number (the
  decimal text of the value as a ``Rational``, e.g. ``g = 981/100``), like the numbers written
  in the robot file, which dynderive also parses to exact rationals. ``floats=True`` (``--floats``)
  turns every non-integer number into a ``Float`` instead (``pi`` stays exact, so ``rpy``
  angles of ``pi/2`` still give exact zeros); the sizes and times then differ by some per cent
  (ur5, panda: about 5 % fewer operations, 20 % more time).

    python benchmarks/anchors.py robots/panda.urdf
    python benchmarks/anchors.py pendulum5 --trigsimp 120    # planar n-link pendulum

prints one JSON line: ``kane_equations``' figures (without the matrices) and, with
``--trigsimp``, ``trigsimp_s``, ``trigsimp_mass_matrix_ops``, ``trigsimp_forcing_ops`` and
``trigsimp_timed_out``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import queue
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import sympy
from sympy.physics.mechanics import (
    KanesMethod,
    Point,
    ReferenceFrame,
    RigidBody,
    Vector,
    dynamicsymbols,
    inertia,
)

from dynderive.model.robot import Robot
from dynderive.model.symbols import SymbolTable

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import load  # noqa: E402,F401  (re-exported: tests load robots through the anchor module)

# --- the model ---------------------------------------------------------------------------


def kane_model(robot: Robot, floats: bool = False):
    """The robot as ``sympy.physics.mechanics`` objects, numeric in the parameters.

    Returns ``(q, u, bodies, loads, kd_eqs, N, parameter_values)``: lists of the coordinates
    and speeds (dynamic symbols, in ``robot.coordinates`` order), the ``RigidBody`` list, the
    loads (gravity and efforts, see the module docstring), ``[qk' - uk]``, the inertial frame
    and ``{parameter symbol: value}`` as substituted.
    """
    table = SymbolTable.for_robot(robot)
    values = {s: (sympy.Float(v) if floats else sympy.Rational(repr(float(v))))
              for s, v in table.defaults(robot).items()}

    def num(text: object) -> sympy.Expr:
        value = table.expr(text).xreplace(values)
        if floats:  # fractions become Floats; pi stays exact (cos(0.5*pi) is still 0)
            value = value.xreplace({r: sympy.Float(r) for r in value.atoms(sympy.Rational) if not r.is_Integer})
        return value

    n = len(robot.coordinates)
    q, u = list(dynamicsymbols(f"q1:{n + 1}")), list(dynamicsymbols(f"u1:{n + 1}"))
    kd_eqs = [qk.diff() - uk for qk, uk in zip(q, u)]
    index = {name: k for k, name in enumerate(robot.coordinates)}
    efforts = {name: sympy.Symbol(name) for name in robot.efforts}

    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    frame: dict[str, ReferenceFrame] = {"world": N}
    origin: dict[str, Point] = {"world": O}
    bodies: list[RigidBody] = []
    loads: list[tuple[Any, Any]] = []
    gravity = [num(e) for e in robot.gravity] + ([sympy.Integer(0)] if robot.planar else [])
    g = gravity[0] * N.x + gravity[1] * N.y + gravity[2] * N.z

    for joint in _parents_first(robot):
        parent, parent_origin = frame[joint.parent], origin[joint.parent]
        child = joint.child
        if robot.planar:
            x, y, theta = (num(e) for e in joint.origin)
            offset, rotation = x * parent.x + y * parent.y, (theta,)
        else:
            x, y, z, roll, pitch, yaw = (num(e) for e in joint.origin)
            offset, rotation = x * parent.x + y * parent.y + z * parent.z, (roll, pitch, yaw)
        # the joint frame and joint point (fixed in the parent)
        if all(a == 0 for a in rotation):
            joint_frame = parent
        else:
            joint_frame = ReferenceFrame(f"J_{joint.name}")
            if robot.planar:
                joint_frame.orient_axis(parent, parent.z, rotation[0])
            else:
                joint_frame.orient_body_fixed(parent, (yaw, pitch, roll), "ZYX")
        if offset == 0:
            joint_point = parent_origin
        else:
            joint_point = parent_origin.locatenew(f"P_{joint.name}", offset)
            joint_point.v2pt_theory(parent_origin, N, parent)
        # the motion
        axis = [num(e) for e in joint.axis]
        if robot.planar:
            axis = [*axis, sympy.Integer(0)] if joint.type == "prismatic" else [0, 0, sympy.Integer(1)]
        norm = sympy.sqrt(sum(a**2 for a in axis))
        axis_vector = Vector(0)
        for a, unit_vector in zip(axis, (joint_frame.x, joint_frame.y, joint_frame.z)):
            if a != 0:
                axis_vector += (a / norm) * unit_vector
        if joint.type == "revolute":
            child_frame = ReferenceFrame(child)
            child_frame.orient_axis(joint_frame, axis_vector, q[index[joint.name]])
            child_origin = joint_point
        elif joint.type == "prismatic":
            child_frame = joint_frame
            k = index[joint.name]
            child_origin = joint_point.locatenew(f"O_{child}", q[k] * axis_vector)
            child_origin.set_vel(joint_frame, u[k] * axis_vector)
            child_origin.v1pt_theory(joint_point, N, joint_frame)
        else:
            child_frame, child_origin = joint_frame, joint_point
        frame[child], origin[child] = child_frame, child_origin
        # the body
        link = robot.link(child)
        mass = num(link.mass)
        com = [num(e) for e in link.com] + ([sympy.Integer(0)] if robot.planar else [])
        zero = sympy.Integer(0)
        if robot.planar:  # only izz acts in the plane
            ixx, iyy, izz, ixy, ixz, iyz = zero, zero, num(link.inertia[0]), zero, zero, zero
        else:
            ixx, iyy, izz, ixy, ixz, iyz = (num(e) for e in link.inertia)
        if mass != 0 or any(i != 0 for i in (ixx, iyy, izz, ixy, ixz, iyz)):
            if all(c == 0 for c in com):
                mass_center = child_origin
            else:
                mass_center = child_origin.locatenew(f"G_{child}",
                                                     com[0] * child_frame.x + com[1] * child_frame.y
                                                     + com[2] * child_frame.z)
                mass_center.v2pt_theory(child_origin, N, child_frame)
            tensor = inertia(child_frame, ixx, iyy, izz, ixy, iyz, ixz)
            bodies.append(RigidBody(child, mass_center, child_frame, mass, (tensor, mass_center)))
            if mass != 0:
                loads.append((mass_center, mass * g))
        # the actuator
        if joint.moves and joint.effort:
            tau = efforts[joint.effort]
            if joint.type == "revolute":
                loads.append((child_frame, tau * axis_vector))
                if parent is not N:
                    loads.append((parent, -tau * axis_vector))
            else:
                loads.append((child_origin, tau * axis_vector))
                if parent is not N:
                    loads.append((joint_point, -tau * axis_vector))
    return q, u, bodies, loads, kd_eqs, N, values


def _parents_first(robot: Robot) -> list:
    """The joints depth-first from the world (a file may list a child's joint before its parent's)."""
    order: list = []

    def visit(link: str) -> None:
        for joint in robot.joints:
            if joint.parent == link:
                order.append(joint)
                visit(joint.child)

    visit("world")
    return order


# --- the measurements ----------------------------------------------------------------------


def ops(matrix: sympy.MatrixBase) -> int:
    """``sympy.count_ops`` summed over the entries (not visual)."""
    return sum(sympy.count_ops(e, visual=False) for e in matrix)


def kane_equations(robot: Robot, floats: bool = False) -> dict:
    """KanesMethod on the robot, unsimplified, timed.

    ``setup_s`` is ``kane_model`` (frames, points, velocities, bodies, loads); ``kane_s`` is
    ``KanesMethod(N, q, u, kd_eqs)`` + ``kanes_equations(bodies, loads)`` + reading
    ``mass_matrix`` and ``forcing`` (``forcing`` holds the efforts, see the module docstring).
    """
    start = time.perf_counter()
    q, u, bodies, loads, kd_eqs, N, _ = kane_model(robot, floats)
    setup = time.perf_counter() - start
    start = time.perf_counter()
    kane = KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd_eqs)
    kane.kanes_equations(bodies, loads)
    mass_matrix, forcing = kane.mass_matrix, kane.forcing
    kane_s = time.perf_counter() - start
    return {"setup_s": setup, "kane_s": kane_s, "mass_matrix_ops": ops(mass_matrix),
            "forcing_ops": ops(forcing), "mass_matrix": mass_matrix, "forcing": forcing,
            "q": q, "u": u}


def _trigsimp_child(robot: Robot, floats: bool, out: Any) -> None:
    result = kane_equations(robot, floats)
    out.put(("kane", result["kane_s"]))
    start = time.perf_counter()
    mass_matrix = result["mass_matrix"].applyfunc(sympy.trigsimp)
    forcing = result["forcing"].applyfunc(sympy.trigsimp)
    out.put(("trigsimp", time.perf_counter() - start, ops(mass_matrix), ops(forcing)))


def kane_trigsimp(robot: Robot, timeout_s: float, floats: bool = False) -> dict:
    """KanesMethod, then ``trigsimp`` of every entry of the mass matrix and the forcing vector.

    Runs in a spawned child process. ``trigsimp_s`` times the ``trigsimp`` calls alone (not
    KanesMethod). The child is killed when the trigsimp phase exceeds ``timeout_s`` (or when
    starting it and running KanesMethod exceed ``timeout_s`` + 60 s); the figures are then
    ``None`` and ``timed_out`` is true. A child that fails raises ``RuntimeError``.
    """
    context = multiprocessing.get_context("spawn")
    out = context.Queue()
    child = context.Process(target=_trigsimp_child, args=(robot, floats, out), daemon=True)
    child.start()

    def receive(limit: float) -> tuple | None:
        deadline = time.monotonic() + limit
        while (left := deadline - time.monotonic()) > 0:
            try:
                return out.get(timeout=min(left, 0.5))
            except queue.Empty:
                if not child.is_alive() and out.empty():
                    raise RuntimeError(f"the trigsimp child failed (exit code {child.exitcode})") from None
        return None

    try:
        message = receive(timeout_s + 60) and receive(timeout_s)
    finally:
        if child.is_alive():
            child.kill()
        child.join()
        out.close()
    if message is None:
        return {"trigsimp_s": None, "mass_matrix_ops": None, "forcing_ops": None, "timed_out": True}
    _, seconds, mass_matrix_ops, forcing_ops = message
    return {"trigsimp_s": seconds, "mass_matrix_ops": mass_matrix_ops, "forcing_ops": forcing_ops,
            "timed_out": False}


def numeric_mass_matrix(result: dict, q_values) -> np.ndarray:
    """The mass matrix of ``kane_equations``' result at ``q_values`` (robot coordinate order)."""
    # constants evaluated first: NumPy has no sqrt of the 30-digit integers of full-precision inputs
    function = sympy.lambdify([result["q"]], result["mass_matrix"].evalf(20), "numpy")
    return np.array(function(np.asarray(q_values, dtype=float)), dtype=float)


def numeric_forcing(result: dict, q_values, u_values, efforts: dict[str, float] | None = None) -> np.ndarray:
    """The forcing vector at ``(q, u)``; efforts not given (by name) are zero."""
    forcing = result["forcing"]
    taus = sorted((s for s in forcing.free_symbols if isinstance(s, sympy.Symbol)), key=str)
    given = efforts or {}
    function = sympy.lambdify([result["q"], result["u"], taus], forcing.evalf(20), "numpy")
    return np.array(function(np.asarray(q_values, dtype=float), np.asarray(u_values, dtype=float),
                             [given.get(str(s), 0.0) for s in taus]), dtype=float).reshape(-1)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("robot", help="a robot file, a bundled robot name, or pendulumN")
    parser.add_argument("--trigsimp", type=float, metavar="SECONDS",
                        help="also run KanesMethod + trigsimp in a child process with this time limit")
    parser.add_argument("--floats", action="store_true", help="substitute Float parameter values, not exact ones")
    args = parser.parse_args(argv)
    robot = load(args.robot)
    result = kane_equations(robot, args.floats)
    row = {"robot": robot.name, "dof": len(robot.coordinates)}
    row |= {k: v for k, v in result.items() if k not in ("mass_matrix", "forcing", "q", "u")}
    row["q"], row["u"] = [str(s) for s in result["q"]], [str(s) for s in result["u"]]
    if args.trigsimp is not None:
        row |= {f"trigsimp_{k}" if k != "trigsimp_s" else k: v
                for k, v in kane_trigsimp(robot, args.trigsimp, args.floats).items()}
    print(json.dumps(row), flush=True)


if __name__ == "__main__":
    sys.exit(main())
