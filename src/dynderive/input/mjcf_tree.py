"""A compiled MuJoCo model's body tree as robot-file data (``mjcf.read_mjcf``'s second half).

Each MuJoCo body with joints becomes one link per joint: MuJoCo applies a body's joints in
order, each about its anchor in the body frame as moved by the joints before it, so joint k is
a robot-file joint whose frame sits at its anchor (hinge, ball) or at the body frame (slide,
with its ``ref`` as an offset), and the links between a body's joints are massless
(``<body>_<joint>``); the last carries the body's name and inertia. A body without joints is
welded to the link it rides on (mass, centre of mass and inertia combined; a named one becomes
a frame); bodies welded to the world never move and are left out. Sites are frames.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path
from typing import Any

import numpy as np

from ..model.joint_kinds import BALL, JOINT_KINDS, mjcf_types
from ..model.naming import body_jacobian_index, frame_quantity_names
from ..model.written import significant_digits
from .loader import Path_, SourceDocument
from .mjcf_positions import Locator
from .urdf import identifier
from .urdf_values import IDENTITY, Rotation, _number, _numbers, axis_rotation

#: MuJoCo's joint types (``mjtJoint``) and the robot file's.
JOINT_TYPES = mjcf_types()
_XML_TAGS = {0: "freejoint", 1: "joint", 2: "joint", 3: "joint"}
#: Longest robot name: ``<name>_dynamics`` and the generated functions' names stay within 63.
NAME_LIMIT = 40
#: Entries below this fraction (over ``_numbers``' 1e-15) of a body's largest moment are rounding noise.
ROTATION_NOISE = 1e3


def disabled(mujoco: Any, model: Any, *flags: str) -> bool:
    """Whether ``<option><flag>`` switches off any of ``flags`` (``mjtDisableBit`` names without
    ``mjDSBL_``; a name this MuJoCo does not know is not set)."""
    bits = mujoco.mjtDisableBit.__members__
    return any(int(model.opt.disableflags) & int(bits[f"mjDSBL_{flag}"]) for flag in flags if f"mjDSBL_{flag}" in bits)


def quaternion_matrix(wxyz: Any) -> np.ndarray:
    """Rotation matrix of a unit quaternion written w first (MuJoCo's order)."""
    w, x, y, z = (float(v) for v in wxyz)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _rotation(R: np.ndarray) -> Rotation:
    """A composed rotation for the robot file: exact identity kept (it writes ``rpy: [0, 0, 0]``)."""
    return IDENTITY if np.allclose(R, np.eye(3), rtol=0, atol=1e-15) else Rotation(R)


class _Link:
    """A robot-file link being built: its name, XML position and the bodies welded into it."""

    def __init__(self, name: str, at: tuple[int, int]):
        self.name, self.at = name, at
        self.parts: list[tuple[float, np.ndarray, np.ndarray]] = []   # (mass, com, inertia about com), link axes

    def add(self, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
        if mass > 0 or np.any(inertia):
            self.parts.append((mass, com, inertia))

    def combined(self) -> tuple[float, np.ndarray, np.ndarray]:
        """Mass, centre of mass and inertia about it of the parts (parallel-axis theorem)."""
        mass = sum(m for m, _, _ in self.parts)
        if not self.parts:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        if len(self.parts) == 1:
            return self.parts[0]
        com = sum(m * c for m, c, _ in self.parts) / mass if mass > 0 else np.zeros(3)
        inertia = np.zeros((3, 3))
        for m, c, I in self.parts:
            d = c - com
            inertia += I + m * (d @ d * np.eye(3) - np.outer(d, d))
        return mass, com, inertia


class _Tree:
    """The walk over the compiled model's bodies, collecting links, joints, frames and notes."""

    def __init__(self, mujoco: Any, spec: Any, model: Any, doc: SourceDocument, locator: Locator):
        self.mj, self.spec, self.m, self.doc, self.locator = mujoco, spec, model, doc, locator
        self.links: list[_Link] = []
        self.joints: list[tuple[dict[str, Any], tuple[int, int]]] = []
        self.frames: list[tuple[dict[str, Any], tuple[int, int]]] = []
        #: per MuJoCo body: (robot link name or "world", R, p) taking body-frame points into that link's frame
        self.owner: dict[int, tuple[str, np.ndarray, np.ndarray]] = {0: ("world", np.eye(3), np.zeros(3))}
        self.link_of: dict[str, _Link] = {}
        self.joint_names: dict[int, str] = {}
        self.taken: set[str] = {"world"}

    # names -----------------------------------------------------------------------------------
    def _unique(self, name: str) -> str:
        base, k = name, 2
        while name in self.taken:
            name, k = f"{base}_{k}", k + 1
        self.taken.add(name)
        return name

    def body_name(self, b: int) -> str:
        return ascii_name(self.m.body(b).name, f"body{b}")

    def joint_name(self, j: int) -> str:
        if j not in self.joint_names:
            body = int(self.m.jnt_bodyid[j])
            k = j - int(self.m.body_jntadr[body]) + 1
            name = ascii_name(self.m.joint(j).name, f"{self.body_name(body)}_joint{k}")
            taken = set(self.joint_names.values())
            self.joint_names[j] = name if name not in taken else next(
                f"{name}_{n}" for n in range(2, len(taken) + 3) if f"{name}_{n}" not in taken)
        return self.joint_names[j]

    def at(self, kind: str, index: int, tag: str) -> tuple[int, int]:
        elements = getattr(self.spec, kind)
        element = next((e for e in elements if e.id == index), None)
        return self.locator.of(element, tag) if element is not None else self.locator.root

    # the walk ----------------------------------------------------------------------------------
    def walk(self) -> None:
        m = self.m
        for b in range(1, m.nbody):
            parent = int(m.body_parentid[b])
            owner, R_off, p_off = self.owner[parent]
            R_b = R_off @ quaternion_matrix(m.body_quat[b])
            p_b = R_off @ m.body_pos[b] + p_off
            first, count = int(m.body_jntadr[b]), int(m.body_jntnum[b])
            at = self.at("bodies", b, "body")
            if count == 0:   # welded to what it rides on
                self.owner[b] = (owner, R_b, p_b)
                if owner != "world":
                    self._inertia(b, self.link_of[owner], R_b, p_b)
                    if m.body(b).name:
                        self._frame(ascii_name(m.body(b).name, f"body{b}"), owner, R_b, p_b, at)
                continue
            previous, c_prev = owner, None   # c_prev: the previous joint's anchor (None: the parent link)
            for j in range(first, first + count):
                jtype = int(m.jnt_type[j])
                name = self.joint_name(j)
                last = j == first + count - 1
                link = _Link(self._unique(self.body_name(b) if last else f"{self.body_name(b)}_{name}"), at)
                self.links.append(link)
                self.link_of[link.name] = link
                anchor = np.array(m.jnt_pos[j], dtype=float) if jtype in (1, 3) else np.zeros(3)
                axis = np.array(m.jnt_axis[j], dtype=float)
                ref = float(m.qpos0[m.jnt_qposadr[j]]) if jtype in (2, 3) else 0.0
                R_ref = axis_rotation(axis, -ref) if jtype == 3 else np.eye(3)
                shift = -axis * ref if jtype == 2 else np.zeros(3)
                if jtype == 0:   # free: the body's pose is the coordinate itself, in the world
                    R_o, p_o = np.eye(3), np.zeros(3)
                elif c_prev is None:
                    R_o, p_o = R_b @ R_ref, R_b @ (anchor + shift) + p_b
                else:
                    R_o, p_o = R_ref, anchor + shift - c_prev
                self._joint(j, jtype, name, previous, link.name, R_o, p_o, axis)
                previous, c_prev = link.name, anchor
            self.owner[b] = (previous, np.eye(3), -c_prev)
            self._inertia(b, self.link_of[previous], np.eye(3), -c_prev)
        for s in range(m.nsite):
            owner, R_off, p_off = self.owner[int(m.site_bodyid[s])]
            name = ascii_name(m.site(s).name, f"site{s}")
            at = self.at("sites", s, "site")
            if owner == "world":
                self.doc.note(at, f"site '{name}' is on a body welded to the world: not made a frame")
                continue
            self._frame(name, owner, R_off @ quaternion_matrix(m.site_quat[s]), R_off @ m.site_pos[s] + p_off, at)

    def _inertia(self, b: int, link: _Link, R: np.ndarray, p: np.ndarray) -> None:
        m = self.m
        axes = R @ quaternion_matrix(m.body_iquat[b])
        link.add(float(m.body_mass[b]), R @ m.body_ipos[b] + p, axes @ np.diag(m.body_inertia[b]) @ axes.T)

    def _joint(self, j: int, jtype: int, name: str, parent: str, child: str, R: np.ndarray, p: np.ndarray,
               axis: np.ndarray) -> None:
        m = self.m
        dof, qpos = int(m.jnt_dofadr[j]), int(m.jnt_qposadr[j])
        at = self.at("joints", j, _XML_TAGS[jtype])
        entry: dict[str, Any] = {"name": name, "type": JOINT_TYPES[jtype], "parent": parent, "child": child,
                                 "origin": {"xyz": _numbers(p), "rpy": _rotation(R).rpy()}}
        if JOINT_KINDS[JOINT_TYPES[jtype]].takes_axis:
            entry["axis"] = _numbers(axis)
            # what <option><flag> switches off, MuJoCo leaves out of its dynamics
            terms = {"damping": 0 if disabled(self.mj, m, "DAMPER", "PASSIVE") else m.dof_damping[dof],
                     "friction": 0 if disabled(self.mj, m, "FRICTIONLOSS", "CONSTRAINT") else m.dof_frictionloss[dof],
                     "stiffness": 0 if disabled(self.mj, m, "SPRING", "PASSIVE") else m.jnt_stiffness[j],
                     "armature": m.dof_armature[dof]}
            for key, value in terms.items():
                if value != 0:
                    entry[key] = _number(value)
            if terms["stiffness"] != 0 and m.qpos_spring[qpos] != 0:
                entry["rest"] = _number(m.qpos_spring[qpos])
            if terms["friction"] != 0:
                self.doc.note(at, f"joint '{name}': frictionloss {m.dof_frictionloss[dof]:g} becomes Coulomb "
                              "friction -friction*sign(qd); MuJoCo solves it as a soft constraint")
        else:
            dofs = range(dof, dof + (6 if jtype == 0 else 3))
            dropped = [key for key, values in (("armature", m.dof_armature), ("damping", m.dof_damping),
                                               ("frictionloss", m.dof_frictionloss)) if any(values[d] for d in dofs)]
            if m.jnt_stiffness[j] != 0:
                dropped.append("stiffness")
            if dropped:
                self.doc.note(at, f"joint '{name}': {', '.join(dropped)} on a {JOINT_TYPES[jtype]} joint "
                              "not modelled (drive terms are built for hinge and slide joints)")
        self.joints.append((entry, at))

    def _frame(self, name: str, link: str, R: np.ndarray, p: np.ndarray, at: tuple[int, int]) -> None:
        if name in self.taken:   # a site named as its body (common in MJCF): the frame gets a suffix
            renamed = self._unique(f"{name}_site")
            self.doc.note(at, f"'{name}' is a link's name too: its frame is '{renamed}'")
            self.taken.discard(renamed)
            name = renamed
        clash = next((q for q in frame_quantity_names(name, False) if body_jacobian_index(q, len(self.links) + 99)),
                     None)
        if clash:
            self.doc.note(at, f"'{name}' is not made a frame: its Jacobian would be {clash}, a link's body Jacobian")
            return
        self.taken.add(name)
        self.frames.append(({"name": name, "link": link, "origin": {"xyz": _numbers(p), "rpy": _rotation(R).rpy()}},
                            at))


def robot_document(mujoco: Any, spec: Any, model: Any, doc: SourceDocument, locator: Locator) -> SourceDocument:
    """The compiled ``model`` as robot-file data in ``doc`` (positions, labels, notes)."""
    tree = _Tree(mujoco, spec, model, doc, locator)
    tree.walk()   # read_mjcf has refused a model without joints: every joint makes a link
    efforts = _actuators(tree)
    mimics, loops = _equalities(tree)
    _notes(tree)
    title = locator.model_name() or Path(doc.file).stem
    data: dict[str, Any] = {"name": robot_identifier(title), "title": title, "planar": False,
                            "parameters": {}, "gravity": [], "links": [], "joints": []}
    positions: dict[Path_, tuple[int, int]] = {(): locator.root}
    for key in data:
        positions[(key,)] = locator.root
    doc.labels[("name",)] = "<mujoco model>"
    gravity = np.zeros(3) if disabled(mujoco, model, "GRAVITY") else np.array(model.opt.gravity, dtype=float)
    g = float(np.linalg.norm(gravity))
    if g > 0 and gravity[0] == 0 and gravity[1] == 0 and gravity[2] < 0:
        used = tree.taken | set(tree.joint_names.values())   # a body or joint named g keeps its name
        symbol = "g" if "g" not in used else next(f"g_{k}" for k in range(2, len(used) + 3) if f"g_{k}" not in used)
        data["parameters"][symbol] = {"value": _number(g), "unit": "m/s^2", "description": "gravitational acceleration"}
        data["gravity"] = [0, 0, f"-{symbol}"]
    else:
        data["gravity"] = _numbers(gravity)
    if not data["parameters"]:
        del data["parameters"]
    for index, link in enumerate(tree.links):
        mass, com, inertia = link.combined()
        path = ("links", index)
        data["links"].append({"name": link.name, "mass": _number(mass),
                              "com": _numbers(com, max(1.0, float(np.max(np.abs(com))))),
                              # rotating MuJoCo's principal moments back into body axes leaves
                              # products of inertia of a few eps of the largest moment: zero
                              "inertia": _numbers([inertia[0, 0], inertia[1, 1], inertia[2, 2],
                                                   inertia[0, 1], inertia[0, 2], inertia[1, 2]],
                                                  ROTATION_NOISE * float(np.max(np.abs(inertia))))})
        doc.labels[path] = f"body '{link.name}'"
        positions[path] = link.at
        for key in data["links"][-1]:
            positions[path + (key,)] = link.at
    for index, (entry, at) in enumerate(tree.joints):
        if entry["name"] in efforts:
            entry["effort"] = efforts[entry["name"]]
        if entry["name"] in mimics:
            entry["mimic"] = mimics[entry["name"]]
            if entry.pop("effort", None):
                doc.note(at, f"joint '{entry['name']}' follows '{mimics[entry['name']]['joint']}' (a joint "
                         "equality): the force of its actuator is not modelled")
        data["joints"].append(entry)
        path = ("joints", index)
        doc.labels[path] = f"joint '{entry['name']}'"
        positions[path] = at
        for key in entry:
            positions[path + (key,)] = at
        for key in ((), (0,), (1,), (2,)):
            positions[path + ("axis",) + key] = at
        for key in ((), ("joint",), ("multiplier",), ("offset",)):
            positions[path + ("mimic",) + key] = at
    for key, items in (("frames", tree.frames), ("loops", loops)):
        if items:
            data[key] = [entry for entry, _ in items]
            positions[(key,)] = locator.root
            for index, (entry, at) in enumerate(items):
                doc.labels[(key, index)] = f"{key[:-1]} '{entry['name']}'"
                positions[(key, index)] = at
                for field in entry:
                    positions[(key, index, field)] = at
    doc.data, doc.positions = data, positions
    doc.key_positions = dict(positions)
    doc.digits = _written_digits(locator)
    return doc


def ascii_name(name: str, fallback: str) -> str:
    """A body's, joint's or site's name as the robot file's identifier: accents dropped
    (``épaule`` -> ``epaule``), any other character that is not an ASCII letter, digit or
    ``_`` made ``_``; ``fallback`` when nothing is left (``機械``)."""
    plain = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode()
    cleaned = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", plain)).strip("_")
    if not re.search(r"[A-Za-z0-9]", cleaned):
        return fallback
    return identifier(cleaned)


def robot_identifier(title: str) -> str:
    """The robot's name from ``<mujoco model>`` (or the file's stem): what every target can
    call its files and functions (ASCII letters, digits, single ``_``; a letter first; at most
    ``NAME_LIMIT`` characters, so ``<name>_dynamics`` fits MATLAB's 63)."""
    plain = unicodedata.normalize("NFKD", title).encode("ascii", "ignore").decode()   # bras_é -> bras_e
    name = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9]", "_", plain)).strip("_") or "robot"
    if not name[0].isalpha():
        name = f"m_{name}"
    return name[:NAME_LIMIT].rstrip("_")


def _actuators(tree: _Tree) -> dict[str, str]:
    """Effort names of the hinge and slide joints that actuators drive (``tau_<joint>``,
    ``f_<joint>``: the generalized force, gear times the actuator's force); what else the
    actuators are is a note."""
    m, mj = tree.m, tree.mj
    efforts: dict[str, str] = {}
    for a in range(m.nu):
        name = m.actuator(a).name or f"actuator{a}"
        at = tree.at("actuators", a, "")
        # jointinparent differs from joint only on ball and free joints (the frame of the rotation)
        if int(m.actuator_trntype[a]) not in (int(mj.mjtTrn.mjTRN_JOINT), int(mj.mjtTrn.mjTRN_JOINTINPARENT)):
            tree.doc.note(at, f"actuator '{name}': its transmission (not a joint) is not modelled")
            continue
        j = int(m.actuator_trnid[a, 0])
        joint, jtype = tree.joint_name(j), int(m.jnt_type[j])
        if jtype not in (2, 3):
            tree.doc.note(at, f"actuator '{name}': on {JOINT_TYPES[jtype]} joint '{joint}': not modelled "
                          "(efforts are built for hinge and slide joints)")
            continue
        if joint in efforts:
            tree.doc.note(at, f"actuator '{name}': joint '{joint}' has another actuator; its effort "
                          f"{efforts[joint]} is their generalized forces' sum")
        efforts[joint] = ("tau_" if jtype == 3 else "f_") + joint
        if int(m.actuator_dyntype[a]) != 0:
            tree.doc.note(at, f"actuator '{name}': its activation dynamics are not modelled "
                          f"(the effort {efforts[joint]} is the joint's force)")
        elif int(m.actuator_biastype[a]) != 0:
            tree.doc.note(at, f"actuator '{name}': its force depends on the state (a servo): not modelled "
                          f"(the effort {efforts[joint]} is the joint's force)")
    return efforts


def _equalities(tree: _Tree) -> tuple[dict[str, dict[str, Any]], list[tuple[dict[str, Any], tuple[int, int]]]]:
    """Joint equalities of degree one -> mimic; ``connect`` between two bodies (or two sites) ->
    a spherical loop joint; other equalities -> notes."""
    m, mj = tree.m, tree.mj
    follows: dict[str, tuple[str, float, float]] = {}   # follower: (leader, multiplier, offset)
    loops: list[tuple[dict[str, Any], tuple[int, int]]] = []
    for e in range(m.neq):
        kind = int(m.eq_type[e])
        name = m.equality(e).name or f"equality{e}"
        at = tree.at("equalities", e, "")
        data = m.eq_data[e]
        if not m.eq_active0[e] or disabled(mj, m, "EQUALITY", "CONSTRAINT"):
            why = "inactive at the start (active=\"false\")" if not m.eq_active0[e] else "switched off by <option><flag>"
            tree.doc.note(at, f"equality '{name}' is {why}: not modelled")
            continue
        if kind == int(mj.mjtEq.mjEQ_JOINT) and m.eq_obj2id[e] >= 0 and not np.any(data[2:5]):
            j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
            if int(m.jnt_type[j1]) in (2, 3) and int(m.jnt_type[j2]) in (2, 3):
                y0, x0 = float(m.qpos0[m.jnt_qposadr[j1]]), float(m.qpos0[m.jnt_qposadr[j2]])
                relation = (tree.joint_name(j1), tree.joint_name(j2), float(data[1]), float(data[0] + y0 - data[1] * x0))
                if _follow(follows, *relation):
                    continue
                tree.doc.note(at, f"equality '{name}': neither '{relation[0]}' nor '{relation[1]}' can follow the other "
                              "(it follows a joint already, or they would follow each other): not modelled")
                continue
        objects = (int(m.eq_objtype[e]), int(m.eq_obj1id[e]), int(m.eq_obj2id[e]))
        if kind == int(mj.mjtEq.mjEQ_CONNECT) and objects[0] in (int(mj.mjtObj.mjOBJ_BODY), int(mj.mjtObj.mjOBJ_SITE)):
            points = ((objects[1], data[0:3]), (objects[2], data[3:6]))
            if objects[0] == int(mj.mjtObj.mjOBJ_SITE):   # site1 and site2: the sites' origins coincide
                points = tuple((int(m.site_bodyid[s]), m.site_pos[s]) for s in objects[1:])
            ends = []
            for body, anchor in points:
                owner, R, p = tree.owner[body]
                ends.append((owner, R @ anchor + p))
            if ends[0][0] != "world" and ends[1][0] != "world" and ends[0][0] != ends[1][0]:
                loops.append(({"name": tree._unique(ascii_name(name, f"equality{e}")), "type": BALL, "parent": ends[0][0],
                               "child": ends[1][0], "origin": {"xyz": _numbers(ends[0][1]), "rpy": [0, 0, 0]},
                               "child_origin": {"xyz": _numbers(ends[1][1]), "rpy": [0, 0, 0]}}, at))
                continue
        kinds = {int(v): k[5:].lower() for k, v in mj.mjtEq.__members__.items() if k.startswith("mjEQ_")}
        tree.doc.note(at, f"equality '{name}' ({kinds.get(kind, kind)}) is not modelled (joint equalities of degree "
                      "one and connect between two moving bodies are)")
    mimics = {}
    for follower, (leader, multiplier, offset) in follows.items():
        while leader in follows:   # a joint that follows a follower follows its leader
            leader, inner, shift = follows[leader]
            multiplier, offset = multiplier * inner, offset + multiplier * shift
        mimics[follower] = {"joint": leader, "multiplier": _number(multiplier), "offset": _number(offset)}
    return mimics, loops


def _follow(follows: dict[str, tuple[str, float, float]], y: str, x: str, a: float, b: float) -> bool:
    """Record ``y = b + a x`` as y following x, or else (y already follows a joint) as x following
    y; False when neither is free to follow or it would close a cycle of followers."""
    for follower, leader, multiplier, offset in ((y, x, a, b), (x, y, 1 / a if a else 0.0, -b / a if a else 0.0)):
        if follower in follows or not multiplier:
            continue
        root = leader
        while root in follows and root != follower:
            root = follows[root][0]
        if root != follower:
            follows[follower] = (leader, multiplier, offset)
            return True
    return False


def _notes(tree: _Tree) -> None:
    """One note for each kind of thing the model holds that the equations leave out."""
    m = tree.m
    for t in range(m.ntendon):
        tree.doc.note(tree.at("tendons", t, ""), f"tendon '{m.tendon(t).name or t}' is not modelled")
    limited = [tree.joint_name(j) for j in range(m.njnt) if m.jnt_limited[j]]
    if limited:
        first = next(j for j in range(m.njnt) if m.jnt_limited[j])
        tree.doc.note(tree.at("joints", first, "joint"), f"joint limits ({len(limited)} joint"
                      f"{'s' * (len(limited) > 1)}: {', '.join(limited[:4])}{', ...' * (len(limited) > 4)}) are not "
                      "modelled: MuJoCo enforces them as constraints")
    colliding = [g for g in range(m.ngeom) if (m.geom_contype[g] or m.geom_conaffinity[g]) and m.geom_bodyid[g] != 0]
    if colliding:
        tree.doc.note(tree.at("geoms", colliding[0], "geom"), f"contacts of {len(colliding)} colliding geom"
                      f"{'s' * (len(colliding) > 1)} are not modelled (declare contacts: in a YAML robot file "
                      "made by import to hold chosen frames)")
    for pair in tree.spec.pairs:   # explicit <contact> entries, each at its own line
        named = f" '{pair.name}'" if pair.name else ""
        tree.doc.note(tree.locator.of(pair, "pair"), f"contact pair{named} of geoms '{pair.geomname1}' and "
                      f"'{pair.geomname2}' is not modelled (declare contacts: in a YAML robot "
                      "file made by import to hold chosen frames)")
    for exclude in tree.spec.excludes:
        tree.doc.note(tree.locator.of(exclude, "exclude"), f"contact exclude of bodies '{exclude.bodyname1}' and "
                      f"'{exclude.bodyname2}' changes nothing here: contacts are not modelled")
    if m.opt.viscosity or m.opt.density:
        tree.doc.note(tree.locator._first("option"), "fluid forces (option viscosity, density) are not modelled")
    for b in range(1, m.nbody):
        if m.body_gravcomp[b]:
            tree.doc.note(tree.at("bodies", b, "body"), f"body '{tree.body_name(b)}': gravcomp is not modelled")


def _written_digits(locator: Locator) -> int:
    """The most significant digits of a number written in the file (the sheet's precision)."""
    digits = 1
    for line in locator.lines:
        for word in re.findall(r"(?<=[\"' ])[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?(?=[\"' ])", line):
            digits = max(digits, significant_digits(word))
    return min(digits, 17)
