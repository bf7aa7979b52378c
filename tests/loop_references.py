"""Independent references for the closed-loop robots (no dynderive code at all).

Two kinds of reference, both written from the mechanism, never from dynderive's engine:

* **closed forms** of the bundled loop robots (``robots/four_bar.yaml``,
  ``robots/slider_crank.yaml``, ``robots/spatial_four_bar.yaml``): given the independent crank
  angle, the dependent coordinates (two-circle intersection for the four-bar, checked against
  Freudenstein's equation; the slider position of the slider-crank; a circle/sphere
  intersection and the universal-joint angles of the spatial RUSR linkage), their velocities
  for a crank rate and the positions of the link ends;
* a **Pinocchio reference** for any robot file with ``loops:``: the open spanning tree as a
  Pinocchio model built from the YAML text (read here with PyYAML and SymPy, not with
  dynderive's loader), operational frames at the two loop-frame origins of each loop joint, and
  the constrained dynamics by the KKT system ``[M J^T; J 0]`` with ``M = crba``, the bias
  ``rnea(q, v, 0)``, the loop Jacobian from the frame Jacobians (LOCAL_WORLD_ALIGNED) and the
  drift ``Jdot v`` from the frames' classical accelerations at zero joint acceleration.

Conventions (the rows and signs of the loop constraints are this module's own; compare only
invariants with dynderive):

* coordinates are in the robot file's order of the moving joints (dynderive's order);
  ``Reference.perm`` maps them to Pinocchio's depth-first order, ``q_pin = q[perm]``;
* the constraint rows are ``p_child - p_parent`` for coinciding loop-frame origins (planar: x,
  y; 3-D: x, y, z, world axes); a planar prismatic loop adds the relative angle and the offset
  across the axis (the axis is fixed in the parent's loop frame); a 3-D revolute loop adds
  two rows ``(R_p e_i) . (R_c k)`` (``e_i`` perpendicular to the axis ``k``); a 3-D prismatic
  loop three orientation rows and two offset rows;
* Baumgarte: ``J qdd + Jdot qd + 2 alpha (J qd) + beta**2 a(q) = 0``; at assembled states with
  admissible velocities both gains drop out;
* the generalized constraint force is ``M qdd + C qd + N - Y``, i.e. ``A^T lambda`` in the
  contract's sign (``M qdd + C qd + N - Y - A_g^T lambda_g = 0``); it does not depend on the
  choice of rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import sympy
import yaml

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"
LOOP_ROBOTS = ("four_bar", "slider_crank", "spatial_four_bar")


def wrap(angle):
    """Angle(s) wrapped to (-pi, pi]."""
    return -((-np.asarray(angle, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi)


# --- reading a robot file (PyYAML + SymPy; our own files only) ----------------------------


@dataclass
class RobotFile:
    """The numbers of a robot file at its default parameter values (or ``values``)."""

    name: str
    planar: bool
    values: dict[str, float]
    gravity: np.ndarray
    links: dict[str, dict[str, Any]]
    joints: list[dict[str, Any]]
    loops: list[dict[str, Any]]
    independent: list[str]
    coordinates: list[str] = field(default_factory=list)
    efforts: list[str] = field(default_factory=list)     # efforts in coordinate order
    effort_of: dict[str, str] = field(default_factory=dict)


def _evaluator(values: dict[str, float]):
    symbols = {name: sympy.Symbol(name) for name in values}
    numbers = {symbols[k]: sympy.Float(v) for k, v in values.items()}

    def num(text: Any) -> float:
        if isinstance(text, (int, float)):
            return float(text)
        expr = sympy.parse_expr(str(text).replace("^", "**"), local_dict=dict(symbols, pi=sympy.pi))
        return float(expr.xreplace(numbers).evalf())

    return num


def read_robot(path: str | Path, values: dict[str, float] | None = None) -> RobotFile:
    doc = yaml.safe_load(Path(path).read_text())
    defaults: dict[str, float] = {}
    for name, spec in (doc.get("parameters") or {}).items():
        defaults[name] = float(spec["value"] if isinstance(spec, dict) else spec)
    defaults.update(values or {})
    num = _evaluator(defaults)
    planar = bool(doc.get("planar", False))
    dim = 2 if planar else 3
    links = {}
    for link in doc["links"]:
        com = [num(e) for e in link.get("com", [0] * dim)]
        raw = link.get("inertia", 0 if planar else [0] * 6)
        inertia = [num(raw)] if planar and not isinstance(raw, list) else [num(e) for e in raw]
        links[link["name"]] = {"mass": num(link.get("mass", 0)), "com": com, "inertia": inertia}

    def origin(spec: Any) -> tuple[np.ndarray, np.ndarray]:
        """(rotation 3x3, translation 3)."""
        if spec is None:
            return np.eye(3), np.zeros(3)
        if planar:
            x, y, *rest = (num(e) for e in spec)
            theta = rest[0] if rest else 0.0
            c, s = np.cos(theta), np.sin(theta)
            return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([x, y, 0.0])
        xyz = [num(e) for e in spec.get("xyz", [0, 0, 0])]
        roll, pitch, yaw = (num(e) for e in spec.get("rpy", [0, 0, 0]))
        return rpy_matrix(roll, pitch, yaw), np.array(xyz)

    def axis(spec: Any, default: list[float]) -> np.ndarray:
        a = np.array([num(e) for e in (spec if spec is not None else default)] + ([0.0] if planar else []))
        return a / np.linalg.norm(a)

    joints = []
    for j in doc["joints"]:
        kind = j.get("type", "revolute")
        default_axis = [1, 0] if planar else [0, 0, 1]
        joints.append({"name": j["name"], "type": kind, "parent": j["parent"], "child": j["child"],
                       "origin": origin(j.get("origin")), "axis": axis(j.get("axis"), default_axis),
                       "effort": j.get("effort")})
    loops = []
    for lp in doc.get("loops") or []:
        kind = lp["type"]
        default_axis = [1, 0] if planar else [0, 0, 1]
        loops.append({"name": lp["name"], "type": kind, "parent": lp["parent"], "child": lp["child"],
                      "origin": origin(lp.get("origin")), "child_origin": origin(lp.get("child_origin")),
                      "axis": axis(lp.get("axis"), default_axis)})
    gravity = np.array([num(e) for e in doc["gravity"]] + ([0.0] if planar else []))
    robot = RobotFile(doc["name"], planar, defaults, gravity, links, joints, loops,
                      list(doc.get("independent") or []))
    robot.coordinates = [j["name"] for j in joints if j["type"] != "fixed"]
    robot.efforts = [j["effort"] for j in joints if j["type"] != "fixed" and j.get("effort")]
    robot.effort_of = {j["name"]: j["effort"] for j in joints if j["type"] != "fixed" and j.get("effort")}
    return robot


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


# --- closed forms -------------------------------------------------------------------------


def _perp(v: np.ndarray) -> np.ndarray:
    return np.array([-v[1], v[0]])


def four_bar_closed_form(q1: float, qd1: float = 0.0, *, a: float, b: float, c: float, d: float,
                         branch: int = +1, **_: float) -> dict[str, np.ndarray]:
    """Four-bar: crank O2 = (0, 0) -> A (length a, angle q1), coupler A -> B (length b, absolute
    angle q1 + q2), rocker O4 = (d, 0) -> B (length c, absolute angle q3).

    Two-circle intersection (A, b) and (O4, c). ``branch=+1`` (the default assembly of
    ``robots/four_bar.yaml``): B lies to the LEFT of the directed line A -> O4 (at q1 = 0, above
    the ground line: the "open", elbow-up circuit); -1 the mirror (crossed) circuit. For a
    Grashof crank-rocker the branch never changes along a full crank turn.

    Returns q = (q1, q2, q3) (q2, q3 wrapped to (-pi, pi]), qd for the crank rate qd1, and the
    points O2, A, B, O4.
    """
    A = a * np.array([np.cos(q1), np.sin(q1)])
    O4 = np.array([d, 0.0])
    D = O4 - A
    L = np.linalg.norm(D)
    u = D / L
    x = (b**2 - c**2 + L**2) / (2.0 * L)
    h = np.sqrt(b**2 - x**2)
    B = A + x * u + branch * h * _perp(u)
    theta3 = np.arctan2(B[1] - A[1], B[0] - A[0])       # coupler, absolute
    q3 = np.arctan2(B[1] - O4[1], B[0] - O4[0])         # rocker, absolute
    q2 = wrap(theta3 - q1)
    # velocities: a w1 e'(q1) + b w3 e'(theta3) = c w4 e'(q3), e'(t) = (-sin t, cos t)
    w3 = a * qd1 * np.sin(q3 - q1) / (b * np.sin(theta3 - q3))
    w4 = a * qd1 * np.sin(theta3 - q1) / (c * np.sin(theta3 - q3))
    return {"q": np.array([q1, q2, q3]), "qd": np.array([qd1, w3 - qd1, w4]),
            "O2": np.zeros(2), "A": A, "B": B, "O4": O4}


def freudenstein_residual(q1: float, q3: float, *, a: float, b: float, c: float, d: float, **_: float) -> float:
    """K1 cos(q3) - K2 cos(q1) + K3 - cos(q1 - q3) (zero on the loop; crank q1, rocker q3)."""
    K1, K2, K3 = d / a, d / c, (a**2 - b**2 + c**2 + d**2) / (2 * a * c)
    return K1 * np.cos(q3) - K2 * np.cos(q1) + K3 - np.cos(q1 - q3)


def slider_crank_closed_form(q1: float, qd1: float = 0.0, *, r: float, l: float, e: float,
                             **_: float) -> dict[str, np.ndarray]:
    """Slider-crank: crank O -> A (length r, angle q1), rod A -> B (length l, absolute angle
    q1 + q2), slider pin B = (s, e) on the line y = e. Branch: the slider to the right of the
    crank pin (s > r cos q1), the default assembly of ``robots/slider_crank.yaml``.

    s = r cos q1 + sqrt(l^2 - (e - r sin q1)^2); returns q = (q1, q2, s), qd, and A, B.
    """
    D = np.sqrt(l**2 - (e - r * np.sin(q1)) ** 2)
    s = r * np.cos(q1) + D
    phi = np.arctan2(e - r * np.sin(q1), D)
    sd = qd1 * (-r * np.sin(q1) + r * np.cos(q1) * (e - r * np.sin(q1)) / D)
    phid = -r * np.cos(q1) * qd1 / D
    A = r * np.array([np.cos(q1), np.sin(q1)])
    return {"q": np.array([q1, wrap(phi - q1), s]), "qd": np.array([qd1, phid - qd1, sd]),
            "A": A, "B": np.array([s, e])}


def _rz(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def spatial_four_bar_closed_form(q1: float, *, a: float, b: float, c: float, **_: float) -> dict[str, np.ndarray]:
    """Spatial RUSR four-bar of ``robots/spatial_four_bar.yaml``.

    Crank about world z at the origin, length a: A = a (cos q1, sin q1, 0). Universal joint at A
    (frame yawed by +90 deg from the crank: q2 about its z, then q3 about the new y); coupler of
    length b along its x axis. Rocker pivot O4 = (a, b, -c), axis world x, arm of length c along
    +z at q4 = 0: B = O4 + c (0, -sin q4, cos q4). Spherical loop joint: |B - A| = b.

    Writing P = O4 - A: -P_y sin q4 + P_z cos q4 = (b^2 - |P|^2 - c^2) / (2 c), i.e.
    q4 = psi + acos(gamma / R), psi = atan2(-P_y, P_z), R = hypot(P_y, P_z); the ``+`` branch is
    the default assembly (q = 0 exactly at q1 = 0). Then the coupler direction u = (B - A) / b
    in the universal-joint frame gives q2 = atan2(u_y, u_x), q3 = -asin(u_z).
    """
    A = a * np.array([np.cos(q1), np.sin(q1), 0.0])
    O4 = np.array([a, b, -c])
    P = O4 - A
    gamma = (b**2 - P @ P - c**2) / (2 * c)
    R = np.hypot(P[1], P[2])
    q4 = wrap(np.arctan2(-P[1], P[2]) + np.arccos(gamma / R))
    B = O4 + c * np.array([0.0, -np.sin(q4), np.cos(q4)])
    u = (_rz(q1) @ _rz(np.pi / 2)).T @ ((B - A) / b)
    q2 = np.arctan2(u[1], u[0])
    q3 = -np.arcsin(np.clip(u[2], -1.0, 1.0))
    return {"q": np.array([q1, q2, q3, q4]), "A": A, "B": B, "O4": O4, "gamma_over_R": gamma / R}


def closed_form(robot: str, q1: float, qd1: float, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(q, qd) of a bundled loop robot at crank angle q1 and rate qd1 (default branch).

    The spatial four-bar's velocity comes from the loop Jacobian of the Pinocchio reference
    (checked against finite differences of the closed-form positions in the tests).
    """
    if robot == "four_bar":
        out = four_bar_closed_form(q1, qd1, **values)
        return out["q"], out["qd"]
    if robot == "slider_crank":
        out = slider_crank_closed_form(q1, qd1, **values)
        return out["q"], out["qd"]
    if robot == "spatial_four_bar":
        q = spatial_four_bar_closed_form(q1, **values)["q"]
        return q, reference(robot).admissible_velocity(q, np.array([qd1]))
    raise KeyError(robot)


# --- the Pinocchio reference --------------------------------------------------------------


@dataclass
class _Pair:
    """The two loop frames of one loop joint (world axes; accelerations at qdd = 0)."""

    Rp: np.ndarray
    Rc: np.ndarray
    Jp: np.ndarray      # (6, n): linear rows, then angular
    Jc: np.ndarray
    wp: np.ndarray
    wc: np.ndarray
    alpha_p: np.ndarray
    alpha_c: np.ndarray
    d: np.ndarray       # p_c - p_p
    dv: np.ndarray      # its rate
    da: np.ndarray      # its classical acceleration at qdd = 0


def _dot_row(f: _Pair, u_local: np.ndarray, w_local: np.ndarray) -> tuple[float, np.ndarray, float]:
    """a = (R_p u) . (R_c w) (relative orientation): (a, J row, Jdot qd)."""
    E, K = f.Rp @ u_local, f.Rc @ w_local
    n = np.cross(K, E)
    ndot = np.cross(np.cross(f.wc, K), E) + np.cross(K, np.cross(f.wp, E))
    return E @ K, n @ (f.Jc[3:] - f.Jp[3:]), n @ (f.alpha_c - f.alpha_p) + ndot @ (f.wc - f.wp)


def _offset_row(f: _Pair, n_local: np.ndarray) -> tuple[float, np.ndarray, float]:
    """a = (R_p n) . (p_c - p_p) (no offset across the axis): (a, J row, Jdot qd)."""
    N = f.Rp @ n_local
    Ndot = np.cross(f.wp, N)
    Nddot = np.cross(f.alpha_p, N) + np.cross(f.wp, Ndot)
    return (N @ f.d, N @ (f.Jc[:3] - f.Jp[:3]) + np.cross(N, f.d) @ f.Jp[3:],
            Nddot @ f.d + 2.0 * Ndot @ f.dv + N @ f.da)


class Reference:
    """Open-tree Pinocchio model of a loop robot file plus its loop constraints, all numeric."""

    def __init__(self, path: str | Path, values: dict[str, float] | None = None):
        import pinocchio as pin

        self.pin = pin
        self.robot = robot = read_robot(path, values)
        self.n = len(robot.coordinates)
        model = pin.Model()
        model.gravity.linear = robot.gravity
        coordinate = {name: i for i, name in enumerate(robot.coordinates)}
        frame_of: dict[str, tuple[int, Any]] = {"world": (0, pin.SE3.Identity())}
        perm: list[int] = []

        def inertia(name: str) -> Any:
            link = robot.links[name]
            com = np.array(link["com"] + ([0.0] if robot.planar else []))
            if robot.planar:
                tensor = np.eye(3) * link["inertia"][0]
            else:
                ixx, iyy, izz, ixy, ixz, iyz = link["inertia"]
                tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            return pin.Inertia(link["mass"], com, tensor)

        def visit(parent: str) -> None:
            for joint in robot.joints:
                if joint["parent"] != parent:
                    continue
                parent_id, parent_frame = frame_of[parent]
                place = parent_frame * pin.SE3(*joint["origin"])
                if joint["type"] == "fixed":
                    model.appendBodyToJoint(parent_id, inertia(joint["child"]), place)
                    frame_of[joint["child"]] = (parent_id, place)
                else:
                    if joint["type"] == "revolute":
                        kind = pin.JointModelRZ() if robot.planar else pin.JointModelRevoluteUnaligned(joint["axis"])
                    else:
                        kind = pin.JointModelPrismaticUnaligned(joint["axis"])
                    jid = model.addJoint(parent_id, kind, place, joint["name"])
                    model.appendBodyToJoint(jid, inertia(joint["child"]), pin.SE3.Identity())
                    frame_of[joint["child"]] = (jid, pin.SE3.Identity())
                    perm.append(coordinate[joint["name"]])
                visit(joint["child"])

        visit("world")
        assert model.nq == model.nv == self.n
        # world-welded bodies: Pinocchio's potential energy skips them (a constant); fine here.
        self.loop_frames: list[tuple[dict[str, Any], int, int]] = []
        for lp in robot.loops:
            ids = []
            for side, key in (("parent", "origin"), ("child", "child_origin")):
                jid, place = frame_of[lp[side]]
                frame = pin.Frame(f"{lp['name']}_{side}", jid, place * pin.SE3(*lp[key]), pin.FrameType.OP_FRAME)
                ids.append(model.addFrame(frame))
            self.loop_frames.append((lp, ids[0], ids[1]))
        self.model, self.data = model, model.createData()
        self.perm = np.array(perm, dtype=int)
        self.k = sum(self._rows(lp) for lp in robot.loops)
        self.independent = [robot.coordinates.index(name) for name in robot.independent]

    # coordinate order ------------------------------------------------------------------
    def _in(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=float)[self.perm]

    def _out(self, v: np.ndarray) -> np.ndarray:
        out = np.empty(self.n)
        out[self.perm] = v
        return out

    def _cols(self, J: np.ndarray) -> np.ndarray:
        out = np.empty_like(J)
        out[:, self.perm] = J
        return out

    # open tree -------------------------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        self.pin.crba(self.model, self.data, self._in(q))
        upper = np.triu(self.data.M)
        full = upper + np.triu(upper, 1).T
        out = np.empty_like(full)
        out[np.ix_(self.perm, self.perm)] = full
        return out

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """C qd + N = rnea(q, qd, 0)."""
        return self._out(self.pin.rnea(self.model, self.data, self._in(q), self._in(qd), np.zeros(self.n)))

    def gravity(self, q: np.ndarray) -> np.ndarray:
        return self._out(self.pin.computeGeneralizedGravity(self.model, self.data, self._in(q)))

    def energy(self, q: np.ndarray, qd: np.ndarray) -> float:
        pin = self.pin
        return (pin.computeKineticEnergy(self.model, self.data, self._in(q), self._in(qd))
                + pin.computePotentialEnergy(self.model, self.data, self._in(q)))

    def generalized_forces(self, u: np.ndarray | None) -> np.ndarray:
        """Y from the efforts ``u`` (in the robot's effort order, as dynderive's EFFORTS)."""
        tau = np.zeros(self.n)
        if u is None:
            return tau
        u = np.atleast_1d(np.asarray(u, dtype=float))
        for i, name in enumerate(self.robot.coordinates):
            if name in self.robot.effort_of:
                tau[i] = u[self.robot.efforts.index(self.robot.effort_of[name])]
        return tau

    # loops -----------------------------------------------------------------------------
    def _rows(self, lp: dict[str, Any]) -> int:
        kind, planar = lp["type"], self.robot.planar
        if planar:
            return 2
        return {"spherical": 3, "revolute": 5, "prismatic": 5}[kind]

    @staticmethod
    def _normals(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = np.cross(axis, helper)
        e1 /= np.linalg.norm(e1)
        return e1, np.cross(axis, e1)

    def _kinematics(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        pin = self.pin
        qp = self._in(q)
        vp = self._in(qd) if qd is not None else np.zeros(self.n)
        pin.forwardKinematics(self.model, self.data, qp, vp, np.zeros(self.n))
        pin.updateFramePlacements(self.model, self.data)
        pin.computeJointJacobians(self.model, self.data, qp)

    def _evaluate(self, q: np.ndarray, qd: np.ndarray | None = None):
        """(a, J, Jdot qd) with this module's rows (see the module docstring)."""
        pin = self.pin
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        self._kinematics(q, qd)
        a_rows, j_rows, g_rows = [], [], []

        def add(row: tuple[float, np.ndarray, float]) -> None:
            a_rows.append(row[0])
            j_rows.append(row[1])
            g_rows.append(row[2])

        for lp, fp, fc in self.loop_frames:
            Mp, Mc = self.data.oMf[fp], self.data.oMf[fc]
            Jp = self._cols(pin.getFrameJacobian(self.model, self.data, fp, lwa))
            Jc = self._cols(pin.getFrameJacobian(self.model, self.data, fc, lwa))
            Vp = pin.getFrameVelocity(self.model, self.data, fp, lwa)
            Vc = pin.getFrameVelocity(self.model, self.data, fc, lwa)
            Ap = pin.getFrameClassicalAcceleration(self.model, self.data, fp, lwa)
            Ac = pin.getFrameClassicalAcceleration(self.model, self.data, fc, lwa)
            d = Mc.translation - Mp.translation
            pair = _Pair(Mp.rotation, Mc.rotation, Jp, Jc, Vp.angular, Vc.angular, Ap.angular, Ac.angular,
                         d, Vc.linear - Vp.linear, Ac.linear - Ap.linear)

            point_rows = range(2) if self.robot.planar else range(3)
            kind = lp["type"]
            if kind in ("revolute", "spherical"):
                for i in point_rows:
                    add((d[i], Jc[i] - Jp[i], Ac.linear[i] - Ap.linear[i]))
            if self.robot.planar and kind == "prismatic":
                R = Mp.rotation.T @ Mc.rotation
                add((np.arctan2(R[1, 0], R[0, 0]), Jc[5] - Jp[5], Ac.angular[2] - Ap.angular[2]))
                add(_offset_row(pair, np.cross([0.0, 0.0, 1.0], lp["axis"])))
            elif not self.robot.planar and kind == "revolute":
                e1, e2 = self._normals(lp["axis"])
                add(_dot_row(pair, e1, lp["axis"]))
                add(_dot_row(pair, e2, lp["axis"]))
            elif not self.robot.planar and kind == "prismatic":
                x, y, z = np.eye(3)
                add(_dot_row(pair, x, y))
                add(_dot_row(pair, y, z))
                add(_dot_row(pair, z, x))
                e1, e2 = self._normals(lp["axis"])
                add(_offset_row(pair, e1))
                add(_offset_row(pair, e2))
        return np.array(a_rows), np.array(j_rows).reshape(-1, self.n), np.array(g_rows)

    def constraints(self, q: np.ndarray) -> np.ndarray:
        return self._evaluate(q)[0]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        return self._evaluate(q)[1]

    def drift(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Jdot qd."""
        return self._evaluate(q, qd)[2]

    def loop_points(self, q: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """World positions of the (parent, child) loop-frame origins of each loop."""
        self._kinematics(q)
        return [(self.data.oMf[fp].translation.copy(), self.data.oMf[fc].translation.copy())
                for _, fp, fc in self.loop_frames]

    def admissible_velocity(self, q: np.ndarray, qd_independent: np.ndarray) -> np.ndarray:
        """qd with the independent coordinates' rates given and J qd = 0."""
        J = self.jacobian(q)
        ind = self.independent
        dep = [i for i in range(self.n) if i not in ind]
        qd = np.zeros(self.n)
        qd[ind] = qd_independent
        qd[dep] = np.linalg.solve(J[:, dep], -J[:, ind] @ qd[ind])
        return qd

    def assemble(self, q_guess: np.ndarray, tol: float = 1e-13, iterations: int = 50) -> np.ndarray:
        """Newton on the dependent coordinates (independent ones kept)."""
        q = np.array(q_guess, dtype=float)
        dep = [i for i in range(self.n) if i not in self.independent]
        for _ in range(iterations):
            a, J, _g = self._evaluate(q)
            if np.max(np.abs(a)) < tol:
                return q
            q[dep] -= np.linalg.lstsq(J[:, dep], a, rcond=None)[0]
        raise RuntimeError(f"assembly did not converge: |a| = {np.max(np.abs(a)):.3g}")

    def forward_dynamics(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray | None = None, *,
                         alpha: float = 0.0, beta: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(qdd, A^T lambda) of the constrained system by the KKT system [M J^T; J 0].

        ``J qdd + Jdot qd + 2 alpha J qd + beta^2 a = 0``; ``A^T lambda = M qdd + C qd + N - Y``.
        """
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        M = self.mass(q)
        b = self.bias(q, qd)
        a, J, gamma = self._evaluate(q, qd)
        tau = self.generalized_forces(u)
        k = J.shape[0]
        kkt = np.block([[M, J.T], [J, np.zeros((k, k))]])
        rhs = np.concatenate([tau - b, -gamma - 2.0 * alpha * (J @ qd) - beta**2 * a])
        qdd = np.linalg.solve(kkt, rhs)[: self.n]
        return qdd, M @ qdd + b - tau

    def constraint_dynamics(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """qdd from Pinocchio's own ``constraintDynamics`` (3-D point loops only)."""
        pin = self.pin
        models = pin.StdVec_RigidConstraintModel()
        for lp, fp, fc in self.loop_frames:
            if self.robot.planar or lp["type"] != "spherical":
                raise NotImplementedError("constraintDynamics cross-check: 3-D spherical loops only")
            f1, f2 = self.model.frames[fp], self.model.frames[fc]
            models.append(pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, self.model, f1.parentJoint,
                                                   f1.placement, f2.parentJoint, f2.placement,
                                                   pin.ReferenceFrame.LOCAL))
        datas = pin.StdVec_RigidConstraintData()
        for m in models:
            datas.append(m.createData())
        pin.initConstraintDynamics(self.model, self.data, models, datas)
        tau = self._in(self.generalized_forces(u))
        qdd = pin.constraintDynamics(self.model, self.data, self._in(q), self._in(qd), tau, models, datas)
        return self._out(np.array(qdd))


@cache
def reference(robot: str) -> Reference:
    """The Pinocchio reference of a bundled loop robot at its default parameters."""
    return Reference(ROBOTS / f"{robot}.yaml")


def defaults(robot: str) -> dict[str, float]:
    return dict(read_robot(ROBOTS / f"{robot}.yaml").values)
