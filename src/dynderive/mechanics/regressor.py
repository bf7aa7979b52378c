"""The inverse-dynamics regressor ``Y(q, qd, qdd)`` with ``Y pi = tau``, as a straight-line program.

Newton-Euler is linear in each link's *standard inertial parameters* (Pinocchio's
``Inertia.toDynamicParameters()``, in its order)::

    m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz

with ``c`` the centre of mass in the link frame and ``I = I_C + m (|c|^2 1 - c c^T)`` the
inertia about the *link frame's origin*, in link axes. The force link ``k`` needs,
``f_k = I_k a_k + v_k x* I_k v_k`` (``recursive.body_force``), is therefore a sum of one
wrench per parameter, and joint ``j``'s force is the projection of every descendant's force
on its motion axis: ``tau_j = sum_k S_j . X*_{j<-k} f_k = sum_k (X_{k<-j} S_j) . f_k``. The
program carries each joint's axis *down* into the frames of the links below it (like
Newton-Euler's velocities; n(n+1)/2 carried axes for a chain) and takes one dot product per
joint, link and parameter, ``Y[j, (k, p)] = (X_{k<-j} S_j) . f_k(e_p)``, where
``f_k(e_p)`` is ``body_force`` with the unit parameter vector ``e_p``: SymPy's arithmetic
drops every zero. Carrying the per-parameter wrenches *up* the tree instead (Pinocchio's
order of work: 10 wrenches per link moved through every ancestor) was measured longer: the
UR5's body 606 lines and 2275 operations against 368 and 1401, the Panda's 749 and 2680
against 521 and 2293.
Gravity enters as Newton-Euler's upward base acceleration, so ``Y`` depends on the
geometric parameters and ``g``, never on ``pi``.

Conventions (README "Identification"):

* every link of the file, in file order, takes its own parameters in its own frame; a link
  welded by a fixed joint keeps its own ten (its columns are those of its parent's moving
  joint mapped through the weld, so they are right, and linearly dependent on the parent's:
  the base parameters group them); a link welded to the world has zero columns;
* planar robots take four parameters per link, ``m, mcx, mcy, Izz`` (Pinocchio's order
  with the six that planar motion never excites left out: their columns are identically
  zero, and a planar file does not define their values);
* then the joints' declared drive terms, per coordinate: viscous damping ``b`` (column
  ``qd_i``), Coulomb friction ``fc`` (``sign(qd_i)``), armature ``Ia`` (``qdd_i``) and a
  spring's stiffness ``k`` (``q_i - rest_i``, the rest position taken as known geometry);
  a floating or spherical joint takes none. A ``<mimic>`` follower has no parameter of its
  own: its terms are folded into its leader's coordinate (``drives.joint_drives``: ``b +
  m^2 b_f``, ``fc + |m| fc_f``, ``Ia + m^2 Ia_f``), as Pinocchio keeps ``damping``,
  ``friction`` and ``armature`` per velocity entry, and as identification needs: the
  follower's column would be ``m^2`` times its leader's, so the two are never identifiable
  apart. Every robot class (fixed or floating base, spherical joints) follows these rules.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .drives import joint_drives
from .program import Program, Vector, _dot
from .recursive import _advance, body_force
from .tree import ZERO, Tree, gravity, origin_inertia

#: Pinocchio's order of a link's standard parameters (``Inertia.toDynamicParameters``).
SPATIAL_KINDS = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
#: What planar motion excites (the rest have identically zero columns).
PLANAR_KINDS = ("m", "mcx", "mcy", "Izz")
#: Drive terms with a column, in this order per coordinate: (kind, JointDrive attribute).
DRIVE_KINDS = ("damping", "friction", "armature", "stiffness")
#: Entry of the inertia matrix about the origin each inertia parameter is.
_ENTRY = {"Ixx": (0, 0), "Ixy": (0, 1), "Iyy": (1, 1), "Ixz": (0, 2), "Iyz": (1, 2), "Izz": (2, 2)}


@dataclass(frozen=True)
class Parameter:
    """One entry of the parameter vector ``pi``: its name, its value as an expression of the
    robot's parameters, and what it belongs to (a link, or a coordinate's drive)."""

    name: str
    kind: str          # one of SPATIAL_KINDS or DRIVE_KINDS
    owner: str         # link name, or joint (coordinate) name
    value: sympy.Expr


def parameter_vector(robot: Robot, table: SymbolTable) -> list[Parameter]:
    """``pi``: per link (file order) its standard parameters in Pinocchio's order (four for
    planar robots), then the declared drive terms per coordinate. Names are
    ``<kind>_<link>`` (``m_link1``, ``mcx_link1``, ``Izz_link1``) and ``<term>_<joint>``
    (``damping_q1``): ASCII identifiers, since link and joint names are."""
    entries = []
    kinds = PLANAR_KINDS if robot.planar else SPATIAL_KINDS
    for link in robot.links:
        mass = table.expr(link.mass)
        com, inertia = origin_inertia(robot, table, link, mass)
        values = {"m": mass, "mcx": mass * com[0], "mcy": mass * com[1], "mcz": mass * com[2]}
        values |= {kind: inertia[a][b] for kind, (a, b) in _ENTRY.items()}
        entries += [Parameter(f"{kind}_{link.name}", kind, link.name, values[kind]) for kind in kinds]
    return entries + _drive_parameters(robot, table)


def _drive_parameters(robot: Robot, table: SymbolTable) -> list[Parameter]:
    entries = []
    for drive in joint_drives(robot, table):
        joint = _leader_name(robot, drive.coordinate)
        entries += [Parameter(f"{kind}_{joint}", kind, joint, getattr(drive, kind)) for kind in DRIVE_KINDS
                    if getattr(drive, kind) != 0]
    return entries


def sign_symbols(n: int) -> list[sympy.Symbol]:
    """Inputs of the regressor body for robots with Coulomb friction: ``sign(qd_i)`` (or its
    smoothed form), computed outside the body as for ``friction_forces``."""
    return [sympy.Symbol(f"_sign{i}") for i in range(n)]


def _unit_parameters(kind: str) -> tuple[sympy.Expr, Vector, tuple[Vector, Vector, Vector]]:
    """``(m, h, I)`` of the unit parameter vector of ``kind``."""
    one, zero = sympy.Integer(1), sympy.Integer(0)
    mass = one if kind == "m" else zero
    h = tuple(one if kind == f"mc{axis}" else zero for axis in "xyz")
    entry = _ENTRY.get(kind)
    inertia = tuple(tuple(one if entry in ((a, b), (b, a)) else zero for b in range(3)) for a in range(3))
    return mass, h, inertia  # type: ignore[return-value]


def regressor_program(robot: Robot, table: SymbolTable, tree: Tree | None = None) -> Program:
    """``Y(q, qd, qdd)``, outputs row by row (NV rows of ``len(parameter_vector)``)."""
    tree = tree or Tree(robot, table)
    program, vec, n = tree.program, tree.program.vector, tree.size
    parameters = parameter_vector(robot, table)
    column = {p.name: i for i, p in enumerate(parameters)}
    Y: list[list[sympy.Expr]] = [[ZERO] * len(parameters) for _ in range(n)]
    zero = (ZERO,) * 3
    motion = {"world": (zero, zero, zero, vec([-g for g in gravity(robot, table)]))}
    axes: dict[str, dict[int, tuple[Vector, Vector]]] = {"world": {}}
    for body in tree.bodies:
        motion[body.link] = _advance(tree, body, motion[body.parent], table.qd, table.qdd)
        if body.link in tree.static:       # no joint moves it: zero columns
            axes[body.link] = {}
            continue
        own = axes[body.link] = tree.carry_columns(body, axes[body.parent])   # a <mimic> joint's: G^T Y_joints
        w, v, alpha, acc = motion[body.link]
        for kind in (PLANAR_KINDS if robot.planar else SPATIAL_KINDS):
            mass, h, inertia = _unit_parameters(kind)
            n_k, f_k = body_force(vec, mass, h, inertia, w, v, alpha, acc)
            for j, (s_w, s_v) in sorted(own.items()):
                Y[j][column[f"{kind}_{body.link}"]] = program.let(_dot(s_w, n_k) + _dot(s_v, f_k))
    signs = sign_symbols(n)
    rates = {"damping": table.qd, "friction": signs, "armature": table.qdd}
    for drive in joint_drives(robot, table):
        i, joint = drive.coordinate, _leader_name(robot, drive.coordinate)
        for kind in DRIVE_KINDS:
            if f"{kind}_{joint}" in column:
                value = tree.coordinate[i] - drive.rest if kind == "stiffness" else rates[kind][i]
                Y[i][column[f"{kind}_{joint}"]] = program.let(value)
    program.outputs = [e for row in Y for e in row]
    if any(p.kind == "friction" for p in parameters):
        program.extra_inputs = signs
    return program


def _leader_name(robot: Robot, column: int) -> str:
    """The coordinate of velocity column ``column`` of a vector-space joint: a one-coordinate
    joint's name, a universal joint's entry (``<joint>_1``)."""
    where_v = robot.offsets()[1]
    joint = next(j for j in robot.joints if j.owns and where_v[j.name] <= column < where_v[j.name] + j.sizes[1])
    return joint.kind.names(joint.name)[0][column - where_v[joint.name]]


__all__ = ["DRIVE_KINDS", "PLANAR_KINDS", "SPATIAL_KINDS", "Parameter", "parameter_vector", "regressor_program",
           "sign_symbols"]
