"""Independent references for the over-constrained Bennett linkage (``robots/bennett.yaml``).

No dynderive code here. Three references, each written from the mechanism:

* **Bennett's closed form** (from the file's geometry, the twists alpha = pi/3 of links 1 and
  3 and beta = pi/4 of link 2 and the ground): ``q3 = -q1`` and
  ``tan(q1/2) tan(q2/2) = sin((beta + alpha)/2) / sin((beta - alpha)/2)``, written here as the
  well-conditioned ``sin(q1/2) sin(q2/2) sin((beta - alpha)/2) - sin((beta + alpha)/2)
  cos(q1/2) cos(q2/2) = 0`` (no tangent blows up at the folded configuration q = (0, pi, 0));
* the **Pinocchio** open tree of ``tests/loop_references.py`` (built from the YAML text) with
  its five loop rows of the 3-D revolute joint, the KKT system solved by least squares
  (``kkt_least_squares``): the rows have rank 2 on the constraints, so ``[M J^T; J 0]`` is
  singular, but consistent at assembled states with admissible velocities, and its ``qdd``
  part is unique (M is positive definite);
* a **sympy.physics.mechanics** model (``MechanicsReference``): ReferenceFrames oriented with
  ``orient_axis`` from each origin's roll-pitch-yaw and each joint's rotation, Points at the
  joint origins and centres of mass, RigidBodies with the file's masses and inertias, gravity
  and the joint effort as loads; the open tree's ``M`` and forcing by ``KanesMethod``
  (generalized speeds = qd; ``LagrangesMethod`` with the five constraint rows gives the same
  numbers but takes 25 s to form), and the five holonomic loop rows written from the frames
  (the two loop-frame origins coincide: 3 rows in world axes; the child's loop axis is
  perpendicular to two normals of the parent's: 2 rows), their Jacobian and drift ``Jdot qd``
  by differentiating those expressions. Numbers are Floats (exact radicals slow SymPy down);
  everything is lambdified once.

Sign of the generalized loop force, for every reference: ``M qdd + C qd + N - Y`` (dynderive's
``A_g^T lambda_g``); it does not depend on the rows chosen or on their multipliers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sympy
import yaml
from sympy.physics import mechanics as me

from loop_references import ROBOTS

BENNETT = ROBOTS / "bennett.yaml"
#: twists of links 1 and 3 (alpha) and of link 2 and the ground (beta), from the file's header
ALPHA, BETA = np.pi / 3, np.pi / 4


# --- Bennett's closed form ------------------------------------------------------------------


def closed_form_residual(q1, q2, alpha: float = ALPHA, beta: float = BETA):
    """Zero exactly when tan(q1/2) tan(q2/2) = sin((beta + alpha)/2) / sin((beta - alpha)/2)."""
    s, t = np.sin((beta - alpha) / 2), np.sin((beta + alpha) / 2)
    return np.sin(q1 / 2) * np.sin(q2 / 2) * s - t * np.cos(q1 / 2) * np.cos(q2 / 2)


def closed_form(q1: float, qd1: float = 0.0, alpha: float = ALPHA, beta: float = BETA):
    """(q, qd) on the Bennett motion for the crank angle q1 and rate qd1: q2 from
    tan(q2/2) = K / tan(q1/2) (unique modulo 2 pi), q3 = -q1; qd2 from the implicit derivative
    of ``closed_form_residual``, qd3 = -qd1."""
    s, t = np.sin((beta - alpha) / 2), np.sin((beta + alpha) / 2)
    q2 = 2.0 * np.arctan2(t * np.cos(q1 / 2), s * np.sin(q1 / 2))
    q2 = -((-q2 + np.pi) % (2.0 * np.pi) - np.pi)
    c1, s1, c2, s2 = np.cos(q1 / 2), np.sin(q1 / 2), np.cos(q2 / 2), np.sin(q2 / 2)
    d1 = 0.5 * (c1 * s2 * s + t * s1 * c2)      # d residual / d q1
    d2 = 0.5 * (s1 * c2 * s + t * c1 * s2)      # d residual / d q2
    return np.array([q1, q2, -q1]), np.array([qd1, -d1 / d2 * qd1, -qd1])


# --- the KKT system with dependent rows ----------------------------------------------------


def kkt_least_squares(M: np.ndarray, top: np.ndarray, J: np.ndarray, bottom: np.ndarray,
                      consistency: float = 1e-10) -> np.ndarray:
    """qdd of ``[M J^T; J 0] [qdd; mu] = [top; bottom]`` by least squares (the system is
    singular when the rows of J are dependent; ``mu`` is then not unique, ``qdd`` is). Asserts
    that the system is consistent (the residual of the least-squares solution vanishes)."""
    n, k = M.shape[0], J.shape[0]
    kkt = np.block([[M, J.T], [J, np.zeros((k, k))]])
    rhs = np.concatenate([top, bottom])
    solution = np.linalg.lstsq(kkt, rhs, rcond=1e-12)[0]
    residual = np.max(np.abs(kkt @ solution - rhs))
    assert residual < consistency * (1.0 + np.max(np.abs(rhs))), f"inconsistent KKT system: {residual:.3g}"
    return solution[:n]


def pinocchio_dynamics(ref, q, qd, u) -> tuple[np.ndarray, np.ndarray]:
    """(qdd, M qdd + C qd + N - Y) of ``loop_references.Reference`` with all its loop rows,
    by ``kkt_least_squares`` (its own ``forward_dynamics`` needs independent rows)."""
    M, bias, tau = ref.mass(q), ref.bias(q, qd), ref.generalized_forces(u)
    qdd = kkt_least_squares(M, tau - bias, ref.jacobian(q), -ref.drift(q, qd))
    return qdd, M @ qdd + bias - tau


# --- sympy.physics.mechanics ----------------------------------------------------------------


def _oriented(parent: me.ReferenceFrame, rpy: list[sympy.Expr], name: str) -> me.ReferenceFrame:
    """The frame R = Rz(yaw) Ry(pitch) Rx(roll) relative to ``parent`` (URDF), by three
    successive rotations about the current axes: z, then the new y, then the newer x."""
    roll, pitch, yaw = rpy
    yawed = me.ReferenceFrame(f"{name}_yaw")
    yawed.orient_axis(parent, parent.z, yaw)
    pitched = me.ReferenceFrame(f"{name}_pitch")
    pitched.orient_axis(yawed, yawed.y, pitch)
    rolled = me.ReferenceFrame(f"{name}_roll")
    rolled.orient_axis(pitched, pitched.x, roll)
    return rolled


def _vector(frame: me.ReferenceFrame, components: list[sympy.Expr]) -> me.Vector:
    return components[0] * frame.x + components[1] * frame.y + components[2] * frame.z


def _normals(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``axis`` to an orthonormal triad."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


class MechanicsReference:
    """The equations of motion of a spatial serial chain of revolute joints closed by 3-D revolute
    loop joints, written with sympy.physics.mechanics from the robot file (PyYAML + SymPy)."""

    def __init__(self, path: str | Path = BENNETT):
        doc = yaml.safe_load(Path(path).read_text())
        assert not doc.get("planar", False)
        values = {name: sympy.Float(spec["value"]) for name, spec in doc["parameters"].items()}
        local = {name: sympy.Symbol(name) for name in values} | {"pi": sympy.pi}
        numbers = {local[name]: value for name, value in values.items()}

        def num(text) -> sympy.Expr:   # a Float: exact radicals make the derivation slow
            return sympy.Float(sympy.sympify(str(text), locals=local).xreplace(numbers).evalf(20), 20)

        def unit_axis(spec) -> list[sympy.Expr]:
            axis = [num(e) for e in (spec or [0, 0, 1])]
            norm = sympy.sqrt(sum(e**2 for e in axis))
            return [sympy.Float(e / norm, 20) for e in axis]

        joints = doc["joints"]
        assert all(j.get("type", "revolute") == "revolute" for j in joints)
        self.coordinates = [j["name"] for j in joints]
        self.efforts = [j["effort"] for j in joints if j.get("effort")]
        self.n = n = len(joints)
        q = me.dynamicsymbols(" ".join(self.coordinates), seq=True)
        qd = [c.diff(me.dynamicsymbols._t) for c in q]
        u = sympy.symbols(" ".join(self.efforts), seq=True)
        world, origin = me.ReferenceFrame("N"), me.Point("O")
        origin.set_vel(world, 0)
        gravity = _vector(world, [num(e) for e in doc["gravity"]])
        placed = {"world": (world, origin)}
        links = {link["name"]: link for link in doc["links"]}
        bodies, loads = [], []
        for i, joint in enumerate(joints):
            frame, point = placed[joint["parent"]]   # file order: parents come first (serial)
            spec = joint.get("origin") or {}
            at = point.locatenew(f"{joint['name']}_origin", _vector(frame, [num(e) for e in spec.get("xyz", [0] * 3)]))
            before = _oriented(frame, [num(e) for e in spec.get("rpy", [0] * 3)], joint["name"])
            axis = unit_axis(joint.get("axis"))
            child = me.ReferenceFrame(joint["child"])
            child.orient_axis(before, _vector(before, axis), q[i])
            at.v2pt_theory(point, world, frame)
            placed[joint["child"]] = (child, at)
            link = links[joint["child"]]
            mass = num(link["mass"])
            centre = at.locatenew(f"{joint['child']}_com", _vector(child, [num(e) for e in link["com"]]))
            centre.v2pt_theory(at, world, child)
            ixx, iyy, izz, ixy, ixz, iyz = (num(e) for e in link["inertia"])
            dyadic = me.inertia(child, ixx, iyy, izz, ixy, iyz, ixz)
            bodies.append(me.RigidBody(joint["child"], centre, child, mass, (dyadic, centre)))
            loads.append((centre, mass * gravity))
            if joint.get("effort"):
                torque = u[self.efforts.index(joint["effort"])] * _vector(before, axis)
                loads.append((child, torque))
                if joint["parent"] != "world":
                    loads.append((frame, -torque))
        rows = []
        for loop in doc["loops"]:
            assert loop["type"] == "revolute"
            frames = []
            for side, key in (("parent", "origin"), ("child", "child_origin")):
                frame, point = placed[loop[side]]
                spec = loop.get(key) or {}
                at = point.locatenew(f"{loop['name']}_{side}", _vector(frame, [num(e) for e in spec.get("xyz", [0] * 3)]))
                frames.append((_oriented(frame, [num(e) for e in spec.get("rpy", [0] * 3)], f"{loop['name']}_{side}"), at))
            (pf, pp), (cf, cp) = frames
            gap = cp.pos_from(pp)
            rows += [gap.dot(world.x), gap.dot(world.y), gap.dot(world.z)]
            axis = unit_axis(loop.get("axis"))
            e1, e2 = _normals(np.array([float(e) for e in axis]))
            rows += [_vector(pf, list(e)).dot(_vector(cf, axis)) for e in (e1, e2)]
        self.k = len(rows)
        # the open tree by Kane's method (generalized speeds qd): M qdd = f, f = Y - C qd - N
        speeds = me.dynamicsymbols(" ".join(f"w_{name}" for name in self.coordinates), seq=True)
        kane = me.KanesMethod(world, q_ind=q, u_ind=speeds, kd_eqs=[a - b for a, b in zip(qd, speeds)])
        kane.kanes_equations(bodies, loads)
        qs, qds = sympy.symbols(f"q_0:{n}"), sympy.symbols(f"qd_0:{n}")
        plain = dict(zip(qd, qds)) | dict(zip(speeds, qds)) | dict(zip(q, qs))
        # the loop rows a(q), their Jacobian J and the drift Jdot qd, from the frames' expressions
        constraints = sympy.Matrix(rows).xreplace(plain)
        jacobian = constraints.jacobian(qs)
        drift = (jacobian * sympy.Matrix(qds)).jacobian(qs) * sympy.Matrix(qds)
        arguments = (qs, qds, u)
        self._open = sympy.lambdify(arguments, [kane.mass_matrix.xreplace(plain), kane.forcing.xreplace(plain)],
                                    cse=True)
        self._rows = sympy.lambdify((qs,), [constraints, jacobian], cse=True)
        self._drift = sympy.lambdify((qs, qds), drift, cse=True)

    def constraints(self, q) -> np.ndarray:
        return np.asarray(self._rows(q)[0], dtype=float).ravel()

    def jacobian(self, q) -> np.ndarray:
        return np.asarray(self._rows(q)[1], dtype=float)

    def system(self, q, qd, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(M, f, J, gamma): M qdd = f + (loop force) with f = Y - C qd - N, and J qdd = gamma
        (gamma = -Jdot qd)."""
        M, f = (np.asarray(x, dtype=float) for x in self._open(q, qd, np.atleast_1d(u)))
        return M, f.ravel(), self.jacobian(q), -np.asarray(self._drift(q, qd), dtype=float).ravel()

    def forward_dynamics(self, q, qd, u) -> tuple[np.ndarray, np.ndarray]:
        """(qdd, M qdd + C qd + N - Y) with all loop rows, by ``kkt_least_squares``."""
        M, f, J, gamma = self.system(q, qd, u)
        qdd = kkt_least_squares(M, f, J, gamma)
        return qdd, M @ qdd - f
