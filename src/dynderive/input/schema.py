"""Validate a parsed robot file and build the ``Robot`` it describes.

Every problem is collected with its position and raised once as an ``InputError``, so a
user sees all of them in one run. Expressions are parsed here (safely) only to check them;
the kinematics parses them again from the texts kept in ``Robot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import sympy

from ..errors import InputError
from ..model.expressions import LARGEST, RESERVED, Evaluator
from ..model.joint_kinds import JOINT_KINDS, WELDED, find_kind, is_free, is_welded, kinds
from ..model.naming import did_you_mean, maximal_coordinate_names
from ..model.robot import Joint, Link, LoopJoint, Parameter, Robot
from . import inertia
from .contacts import read_contacts
from .drives import DRIVE_KEYS, drive_terms
from .frames import read_frames
from .free_joints import check_floating, expand_planar_floating, planar_floating_names, virtual_links
from .joint_keys import TYPE_KEYS, read_joint_keys
from .loader import SourceDocument
from .mimic import check_mimics, read_mimic
from .names import check_names, engine_quantities
from .validator import Validator, kind

#: The joint types a robot file may write (the joint specification's, ``model/joint_kinds.py``).
JOINT_TYPES = kinds()

TOP_KEYS = ("name", "title", "planar", "parameters", "gravity", "links", "joints", "loops", "independent",
            "frames", "contacts", "maximal")
PARAMETER_KEYS = ("value", "unit", "description")
LINK_KEYS = ("name", "mass", "com", "inertia")
JOINT_KEYS = ("name", "type", "parent", "child", "origin", "axis", "effort", *DRIVE_KEYS, "mimic", *TYPE_KEYS)
MAXIMAL_KEYS = ("constraints",)
LOOP_KEYS = ("name", "type", "parent", "child", "origin", "child_origin", "axis")
#: Loop-closing joint types, and how many constraints each imposes, for planar (True) and 3-D robots.
LOOP_TYPES = {planar: {name: JOINT_KINDS[name].loop_rows(planar) for name in kinds(planar=planar, loops=True)}
              for planar in (True, False)}
ORIGIN_KEYS = ("xyz", "rpy")
#: Longest robot name: it names the output files (``test_<name>_dynamics.py``, and their
#: temporary files while written), which the file system limits to 255 bytes.
MAX_NAME_LENGTH = 100


def validate(doc: SourceDocument) -> Robot:
    """Check a parsed robot file and return its ``Robot``; raise ``InputError`` otherwise.

    Every problem is collected (top level, parameters, links, joints, tree, names, maximal
    constraints) and raised once, so a user fixes a file in one pass.
    """
    v = Validator(doc)
    top = v.mapping(doc.data, (), TOP_KEYS, required=("name", "links", "joints", "gravity"))
    if top is None:
        raise InputError(v.problems)

    name = v.identifier(top.get("name"), ("name",), "robot name") if "name" in top else None
    if name is not None and len(name) > MAX_NAME_LENGTH:
        v.report(("name",), f"robot name is {len(name)} characters long, at most {MAX_NAME_LENGTH} (it names "
                 "the output files, e.g. test_<name>_dynamics.py)")
        name = None
    title = v.text(top.get("title"), ("title",), default=name or "")
    planar = top.get("planar", False)
    if not isinstance(planar, bool):
        v.error(("planar",), f"planar: expected true or false, got {planar!r}")
        planar = True

    parameters = _parameters(v, top)
    symbols = {p.name: sympy.Symbol(p.name) for p in parameters}
    v.evaluate = Evaluator({sympy.Symbol(p.name): sympy.Float(p.value) for p in parameters
                            if p.value is not None})

    gravity = top.get("gravity")
    if not planar and isinstance(gravity, list) and len(gravity) == 2 and _looks_planar(top):
        why = "'planar: false' makes this robot 3-D" if "planar" in top else "this robot is 3-D"
        v.error(("gravity",), f"gravity: has 2 entries, but {why}; planar robots need 'planar: true'")
        planar = True  # check the rest as the planar robot it is, without piling up follow-on errors
    if "gravity" in top:
        v.vector(top["gravity"], ("gravity",), (2 if planar else 3,), symbols)

    links, tree, inertias = _links(v, top, planar, symbols)
    joints = _joints(v, top, planar, symbols, tree)
    raw_joints = top.get("joints") if isinstance(top.get("joints"), list) else []
    types_read = all(item.get("type") in JOINT_TYPES for item in raw_joints if isinstance(item, dict))
    if joints and types_read and not any(j.moves for j in joints):   # an unread type is reported already
        v.error(("joints",), "joints: every joint is fixed, so the robot has no coordinate to derive")
    _check_tree(v, joints, tree.names)
    check_floating(v, top, joints, planar, links)
    check_mimics(v, top, joints, planar)
    links = inertia.check_links(v, links, joints, inertias)
    loops = _loops(v, top, planar, symbols, tree, joints)
    independent = _independent(v, top, joints, loops, planar)
    all_links = links + virtual_links(joints, planar)
    frames = read_frames(v, top, tree, lambda value, path: _origin(v, value, path, planar, symbols), planar,
                         engine_quantities(all_links, planar, "loops" in top))
    contacts = read_contacts(v, top, frames, planar)
    check_names(v, parameters, all_links, joints, planar,
                sum(LOOP_TYPES[planar].get(lp.type, 5) for lp in loops))
    constraints = _maximal_constraints(v, top, planar, symbols, links, joints)
    if loops and constraints is not None:
        v.error(("maximal", "constraints"), "maximal.constraints: a robot with loops derives its maximal "
                "constraints from its joints and loops (an override is not supported yet)")

    if v.problems:
        raise InputError(v.problems)
    positions = {f"{prefix}:{item.name}": doc.where((f"{prefix}s", i))
                 for prefix, items in (("joint", joints), ("link", links), ("loop", loops), ("frame", frames))
                 for i, item in enumerate(items)}
    positions |= {f"parameter:{p.name}": doc.where(("parameters", p.name), key=True) for p in parameters}
    positions["maximal.constraints"] = doc.where(("maximal", "constraints"))
    positions |= {key: doc.where((key,)) for key in ("loops", "independent", "name")}
    positions["contacts"] = doc.where(("contacts",), key=True)   # the entry, for a refusal of all of them
    if planar:   # a floating joint: prismatic x, prismatic y, revolute theta and two massless links
        joints, links = expand_planar_floating(joints, links, positions)
    return Robot(
        name=name or "robot", title=title, planar=planar, parameters=tuple(parameters),
        gravity=tuple(top["gravity"]), links=tuple(links), joints=tuple(joints),
        maximal_constraints=constraints, source=doc.file, positions=positions, notes=tuple(doc.notes),
        loops=tuple(loops), independent=independent, frames=tuple(frames), contacts=tuple(contacts),
        digits=doc.digits,
    )


@dataclass
class _LinkNames:
    """What the joints need to know of the links: their names (-> path), the names already
    reported as bad (joints naming them are not re-reported), and whether the list is broken."""

    names: dict[str, tuple[Any, ...]]
    bad: set[Any]
    broken: bool

    def check(self, v: Validator, item: dict[str, Any], path: tuple[Any, ...], role: str,
              world: bool = True) -> None:
        """Report ``item[role]`` (when given) unless it names a link, or ``world`` where it may."""
        end, where = item.get(role), path + (role,)
        if role not in item or (world and end == "world"):
            return
        if not isinstance(end, str):
            v.report(where, f"expected a link's name, got {kind(end)}")
        elif end == "world":
            v.report(where, "'world' cannot be a child")
        elif end not in self.names and not (self.broken or end in self.bad):
            v.report(where, f"unknown link {end!r}"
                     + did_you_mean(end, [*self.names, "world"] if world else list(self.names)))


def _parameters(v: Validator, top: dict[str, Any]) -> list[Parameter]:
    """The ``parameters`` block: names, default values (finite doubles), units, descriptions."""
    parameters: list[Parameter] = []
    raw_parameters = top.get("parameters", {}) or {}
    if not isinstance(raw_parameters, dict):
        v.error(("parameters",), f"parameters: expected a mapping of name: value, got {kind(raw_parameters)}")
        v.parameters_broken = True
        raw_parameters = {}
    for pname, spec in raw_parameters.items():
        path: tuple[Any, ...] = ("parameters", pname)
        if v.identifier(pname, path, "parameter name", key=True) is None:
            continue
        if pname in RESERVED:
            v.error(path, f"parameters.{pname}: '{pname}' is a built-in function or constant", key=True)
            continue
        value, unit, description, vpath = spec, "", "", path
        if isinstance(spec, dict):
            v.mapping(spec, path, PARAMETER_KEYS)
            value, vpath = spec.get("value"), path + ("value",)
            unit = v.text(spec.get("unit"), path + ("unit",))
            description = v.text(spec.get("description"), path + ("description",))
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
            quoted = isinstance(value, str) and _looks_numeric(value)
            v.report(vpath, f"default value must be a number, got {kind(value)}"
                     + (f" ({value!r} in quotes: write it without them)" if quoted else ""))
            value = None
        elif value is not None and isinstance(value, int) and abs(value) > 1.7976931348623157e308:
            v.report(vpath, "default value is out of the range of a double")
            value = None
        elif value is not None and not math.isfinite(float(value)):
            v.report(vpath, f"default value must be finite, got {value}")
            value = None
        elif value is not None and abs(float(value)) > LARGEST:
            v.report(vpath, f"default value {value:g} is out of range (a robot's numbers are at most 1e10 in size: "
                     "products of them must stay within a double)")
            value = None
        parameters.append(Parameter(pname, None if value is None else float(value), unit, description))
    return parameters


def _links(v: Validator, top: dict[str, Any], planar: bool,
           symbols: dict[str, sympy.Expr]) -> tuple[list[Link], _LinkNames, list[inertia.Written | None]]:
    """The ``links`` list: names, masses (positive; 3-D: not negative), centres of mass, physical inertias."""
    dimension = 2 if planar else 3
    links: list[Link] = []
    raw_links = top.get("links")
    links_broken = "links" in top and (not isinstance(raw_links, list) or not raw_links)
    taken: dict[str, tuple[Any, ...]] = {}   # link name -> the path of its name
    bad_link_names: set[Any] = set()  # reported already; joints naming them are not re-reported
    inertias: list[inertia.Written | None] = []   # judged once the joints are read
    for i, path, item, lname, _ in v.named_items(top, "links", "link", LINK_KEYS, ("name", "mass"), taken):
        if lname is None and isinstance(item.get("name"), (str, int, float)):
            bad_link_names.add(item["name"])
        if lname == "world":
            v.report(path + ("name",), "'world' is reserved for the fixed frame")
            taken.pop("world", None)
            lname = None
        mass = v.expression(item.get("mass"), path + ("mass",), symbols) if "mass" in item else None
        value = v.numeric(mass)
        if value is not None and (value <= 0 if planar else value < 0):  # 3-D: massless links (M checked regular)
            v.negative_value(mass, path + ("mass",), value, "must be positive" if planar else "must not be negative")
        com = item.get("com", [0] * dimension)
        v.vector(com, path + ("com",), (dimension,), symbols)
        entries, written = inertia.read(v, item.get("inertia", 0 if planar else [0] * 6), path + ("inertia",),
                                        planar, symbols)
        links.append(Link(lname or f"link{i + 1}", item.get("mass", 1), tuple(com) if isinstance(com, list) else (),
                          entries))
        inertias.append(written)

    link_names = {name: where[:-1] for name, where in taken.items()}
    return links, _LinkNames(link_names, bad_link_names, links_broken), inertias


def _joints(v: Validator, top: dict[str, Any], planar: bool, symbols: dict[str, sympy.Expr],
            tree: _LinkNames) -> list[Joint]:
    """The ``joints`` list: names, types, parent and child links, origins, axes, efforts."""
    joints: list[Joint] = []
    required = ("name", "type", "parent", "child")
    for i, path, item, jname, _ in v.named_items(top, "joints", "joint", JOINT_KEYS, required, {}):
        jtype = item.get("type")
        if "type" in item and jtype not in JOINT_TYPES:
            extra = {"continuous": " (write 'revolute')"}.get(str(jtype))
            if extra is None:
                extra = did_you_mean(jtype, JOINT_TYPES) if isinstance(jtype, str) else ""
            v.report(path + ("type",), f"unsupported joint type {jtype!r}; "
                     f"expected one of {', '.join(JOINT_TYPES)}{extra}")
            jtype = None
        tree.check(v, item, path, "parent")
        tree.check(v, item, path, "child", world=False)
        origin = _origin(v, item.get("origin"), path + ("origin",), planar, symbols)
        axis = _axis(v, item, path, jtype, planar, symbols)
        effort = item.get("effort")
        if effort is not None:
            effort = v.identifier(effort, path + ("effort",), "effort name")
        if effort is not None and (is_welded(jtype) or (is_free(jtype) and planar)):
            v.report(path + ("effort",), "a fixed joint has no effort" if is_welded(jtype) else
                     "a planar floating joint is unactuated (push its body with a wrench at a frame)")
            effort = None
        drives = drive_terms(v, item, path, jtype, symbols)
        mimic = read_mimic(v, item, path, jtype)
        geometry = read_joint_keys(v, item, path, jtype, symbols)
        parent, child = item.get("parent"), item.get("child")
        joints.append(Joint(jname or f"joint{i + 1}", jtype or WELDED, str(parent), str(child),
                            origin, axis, None if mimic else effort, **drives, mimic=mimic, geometry=geometry))

    return joints


def _loops(v: Validator, top: dict[str, Any], planar: bool, symbols: dict[str, sympy.Expr],
           tree: _LinkNames, joints: list[Joint]) -> list[LoopJoint]:
    """The optional ``loops`` list: loop-closing joints between two links (or a link and the
    world) of the spanning tree. Their constraints are derived, and checked for redundancy
    and assembly, by ``mechanics/loops.py``."""
    types = LOOP_TYPES[planar]
    raw_joints = top.get("joints") if isinstance(top.get("joints"), list) else []
    taken = {item["name"]: ("joints", k, "name") for k, item in reversed(list(enumerate(raw_joints)))
             if isinstance(item, dict) and isinstance(item.get("name"), str)}
    loops: list[LoopJoint] = []
    clash = "name '{name}' is already used by a joint or another loop joint"
    for i, path, item, name, _ in v.named_items(top, "loops", "loop joint", LOOP_KEYS,
                                                ("name", "type", "parent", "child"), taken, clash):
        ltype = item.get("type")
        if "type" in item and ltype not in types:
            shape = "planar" if planar else "3-D"
            hint = did_you_mean(ltype, types) if isinstance(ltype, str) else ""
            v.report(path + ("type",), f"unsupported {shape} loop joint type {ltype!r}; "
                     f"expected one of {', '.join(types)}{hint}")
            ltype = None
        ends = [item.get("parent"), item.get("child")]
        tree.check(v, item, path, "parent")
        tree.check(v, item, path, "child")
        if "parent" in item and "child" in item and ends[0] == ends[1]:
            v.report(path + ("child",), "a loop joint needs two different links "
                     f"(parent and child are both {ends[0]!r})")
        origin = _origin(v, item.get("origin"), path + ("origin",), planar, symbols)
        child_origin = _origin(v, item.get("child_origin"), path + ("child_origin",), planar, symbols)
        kind = find_kind(ltype)
        takes_axis = kind is None or (kind.planar_axis if planar else kind.takes_axis)
        if "axis" in item and not takes_axis:
            v.report(path + ("axis",), f"a {'planar ' if planar else ''}{ltype} loop joint takes no axis")
        axis = _axis(v, item if takes_axis else {}, path, ltype, planar, symbols)
        loops.append(LoopJoint(name or f"loop{i + 1}", ltype or next(iter(types)), str(ends[0]), str(ends[1]),
                               origin, child_origin, axis))
    return loops


def _independent(v: Validator, top: dict[str, Any], joints: list[Joint],
                 loops: list[LoopJoint], planar: bool) -> tuple[str, ...] | None:
    """The optional ``independent`` list: coordinates kept in the reduced form (loops only)."""
    if "independent" not in top:
        return None
    raw = top["independent"]
    if not loops:
        v.error(("independent",), "independent: only robots with loops have dependent coordinates")
        return None
    if not isinstance(raw, list) or not raw:
        v.error(("independent",), f"independent: expected a non-empty list of coordinate names, got "
                f"{kind(raw, empty=True)}")
        return None
    coordinates = [n for j in joints if j.owns
                   for n in (planar_floating_names(j.name) if planar and is_free(j.type) else [j.name])]
    names: list[str] = []
    for k, name in enumerate(raw):
        if name not in coordinates:
            v.error(("independent", k), f"independent[{k}]: {name!r} is not a coordinate (coordinates: "
                    f"{', '.join(coordinates)})")
        elif name in names:
            v.error(("independent", k), f"independent[{k}]: {name!r} is listed twice")
        else:
            names.append(name)
    return tuple(names)


def _maximal_constraints(v: Validator, top: dict[str, Any], planar: bool, symbols: dict[str, sympy.Expr],
                         links: list[Link], joints: list[Joint]) -> tuple[Any, ...] | None:
    """The optional ``maximal.constraints`` override: planar only, 3 per link minus the DOF."""
    block = v.mapping(top["maximal"], ("maximal",), MAXIMAL_KEYS) if "maximal" in top else None
    if block is None or "constraints" not in block:
        return None
    raw_constraints, cpath = block["constraints"], ("maximal", "constraints")
    if not planar:
        v.error(cpath, "maximal.constraints: maximal coordinates are planar-only for now")
        return None
    if not isinstance(raw_constraints, list):
        v.error(cpath, f"maximal.constraints: expected a list of expressions, got {kind(raw_constraints)}")
        return None
    scope = dict(symbols) | {n: sympy.Symbol(n) for n in maximal_coordinate_names(len(links))}
    for k, expr in enumerate(raw_constraints):
        v.expression(expr, cpath + (k,), scope)
    moving = sum(1 for j in joints if j.moves)
    needed = 3 * len(links) - moving
    if len(raw_constraints) != needed:
        v.error(cpath, f"maximal.constraints: expected {needed} constraint{'s' * (needed != 1)} (3 per link "
                f"minus {moving} degree{'s' * (moving != 1)} of freedom), got {len(raw_constraints)}")
    return tuple(raw_constraints)


def _looks_planar(top: dict[str, Any]) -> bool:
    """Whether nothing in the file has a 3-D shape (com, inertia, origin, axis)."""
    links, joints = top.get("links"), top.get("joints")
    for link in links if isinstance(links, list) else []:
        if isinstance(link, dict):
            com = link.get("com")
            if (isinstance(com, list) and len(com) != 2) or isinstance(link.get("inertia"), (list, dict)):
                return False
    for joint in joints if isinstance(joints, list) else []:
        if isinstance(joint, dict):
            origin, axis = joint.get("origin"), joint.get("axis")
            if (isinstance(origin, dict) or (isinstance(origin, list) and len(origin) not in (2, 3))
                    or (isinstance(axis, list) and len(axis) != 2)):
                return False
    return True


def _looks_numeric(text: str) -> bool:
    try:
        return math.isfinite(float(text.strip()))
    except ValueError:
        return False


def _origin(v: Validator, value: Any, path: tuple[Any, ...], planar: bool,
            symbols: dict[str, sympy.Expr]) -> tuple[Any, ...]:
    if value is None:
        return (0, 0, 0) if planar else (0,) * 6
    if planar:
        if v.vector(value, path, (2, 3), symbols) is None:
            return (0, 0, 0)
        return tuple(value) + ((0,) if len(value) == 2 else ())
    block = v.mapping(value, path, ORIGIN_KEYS)
    if block is None:
        return (0,) * 6
    xyz = block.get("xyz", [0, 0, 0])
    rpy = block.get("rpy", [0, 0, 0])
    ok_xyz = v.vector(xyz, path + ("xyz",), (3,), symbols) is not None
    ok_rpy = v.vector(rpy, path + ("rpy",), (3,), symbols) is not None
    return tuple(xyz if ok_xyz else [0] * 3) + tuple(rpy if ok_rpy else [0] * 3)


def _axis(v: Validator, item: dict[str, Any], path: tuple[Any, ...], jtype: str | None,
          planar: bool, symbols: dict[str, sympy.Expr]) -> tuple[Any, ...]:
    default = (1, 0) if planar else (0, 0, 1)
    if "axis" not in item:
        return default
    apath = path + ("axis",)
    kind = find_kind(jtype)
    if planar and kind is not None and not kind.planar:   # the type's own error says it all
        return default
    if planar and kind is not None and kind.takes_axis and not kind.planar_axis:
        v.report(apath, f"a planar {jtype} joint takes no axis (planar revolute joints turn about z)")
        return default
    if kind is not None and not kind.takes_axis:
        v.report(apath, f"a {jtype} joint takes no axis" + (f" ({kind.no_axis})" if kind.no_axis else ""))
        return default
    entries = v.vector(item["axis"], apath, (2,) if planar else (3,), symbols)
    if entries is None:
        return default
    numbers = [v.numeric(e) for e in entries]
    if all(x is not None for x in numbers) and math.hypot(*numbers) < 1e-12:  # type: ignore[arg-type]
        v.report(apath, "axis has zero length")
    return tuple(item["axis"])


def _check_tree(v: Validator, joints: list[Joint], link_names: dict[str, tuple[Any, ...]]) -> None:
    """Each link has exactly one parent joint, and every link hangs from the world."""
    parent_of: dict[str, int] = {}
    for i, joint in enumerate(joints):
        first = parent_of.setdefault(joint.child, i) if joint.child in link_names else i
        if first != i:
            v.report(("joints", i, "child"), f"link '{joint.child}' already has a parent joint "
                     f"({v.label(('joints', first))}); robots must be trees")
    for lname, lpath in link_names.items():
        if lname not in parent_of:
            v.report(lpath, f"link '{lname}' is not the child of any joint")
    reported: set[str] = set()
    for lname in link_names:
        seen: list[str] = []
        current = lname
        while current in parent_of and current not in seen:
            seen.append(current)
            current = joints[parent_of[current]].parent
        if current in seen and not reported.intersection(seen):
            reported.update(seen)
            i = parent_of[current]
            v.report(("joints", i), f"links {' -> '.join(seen[seen.index(current):] + [current])}"
                     " form a cycle not connected to 'world'")
