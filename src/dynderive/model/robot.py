"""The robot description as plain typed data (no SymPy).

``Robot`` holds what the file says, already validated: names, tree structure and the
expression *texts* of masses, inertias and offsets (parsed again by the kinematics). It fits
3-D robots and branching trees even where only planar chains are derived yet.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from .joint_kinds import JOINT_KINDS, JointKind, joint_kind

#: A joint type's name (``model/joint_kinds.JOINT_KINDS``).
JointType = str

def floating_names(joint: str, kind: str) -> tuple[list[str], list[str], list[str]]:
    """A joint's coordinate, velocity and acceleration names, for a joint type whose
    configuration holds a quaternion (``floating``, ``spherical``)."""
    return tuple(list(names) for names in joint_kind(kind).names(joint)[:3])  # type: ignore[return-value]


Expression = str | int | float


@dataclass(frozen=True)
class Mimic:
    """A joint coupled to another (URDF ``<mimic>``): its variable is ``multiplier *
    q_leader + offset``, so it has no coordinate of its own (DESIGN.md section 10)."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Parameter:
    """A free symbol of the robot, with an optional default value."""

    name: str
    value: float | None = None
    unit: str = ""
    description: str = ""


@dataclass(frozen=True)
class Link:
    """A rigid body. ``com`` is in the link frame; ``inertia`` is about the COM.

    Planar: ``inertia`` has one entry (about z). Spatial: six entries
    ``(ixx, iyy, izz, ixy, ixz, iyz)`` in link axes.
    """

    name: str
    mass: Expression
    com: tuple[Expression, ...]
    inertia: tuple[Expression, ...]


@dataclass(frozen=True)
class Joint:
    """A joint between ``parent`` (a link name or ``world``) and ``child``.

    ``origin`` places the joint frame in the parent link frame at q = 0: planar
    ``(x, y, theta)``, spatial ``(x, y, z, roll, pitch, yaw)``. ``axis`` is the motion axis
    in the joint frame (planar prismatic: 2 entries; spatial: 3 entries).
    """

    name: str
    type: JointType
    parent: str
    child: str
    origin: tuple[Expression, ...]
    axis: tuple[Expression, ...]
    effort: str | None = None
    #: Drive and dissipation terms (expressions over the parameters; None: absent). Viscous
    #: damping ``b`` (force ``-b qd``, Rayleigh ``D = b qd**2/2``), Coulomb friction ``fc``
    #: (``-fc sign(qd)``), a spring of stiffness ``k`` about ``rest`` (``V = k (q - rest)**2/2``),
    #: and armature (reflected rotor inertia, ``T = armature qd**2/2``).
    damping: Expression | None = None
    friction: Expression | None = None
    stiffness: Expression | None = None
    rest: Expression | None = None
    armature: Expression | None = None
    #: The joint this one follows (None: it has a coordinate of its own, or is fixed).
    mimic: Mimic | None = None
    #: The values of its type's own keys (``JointKind.keys``: a helical joint's ``pitch``), by key.
    geometry: tuple[tuple[str, Expression | tuple[Expression, ...]], ...] = ()

    @property
    def moves(self) -> bool:
        """Whether the joint moves (fixed joints do not). A ``mimic`` joint moves without a
        coordinate of its own: ``owns`` tells those apart."""
        return not self.kind.welded

    @property
    def kind(self) -> JointKind:
        """The joint's type, as the joint specification gives it (``model/joint_kinds.py``)."""
        return JOINT_KINDS[self.type]

    @property
    def effort_names(self) -> tuple[str, ...]:
        """The joint's efforts, one per velocity entry it drives: its ``effort`` name, or for a
        joint of several entries that name with its type's effort suffixes (velocity entries in
        the same order); none when unactuated (or a ``<mimic>`` follower, driven through its
        leader)."""
        if not self.effort or not self.owns:
            return ()
        return self.kind.names(self.name, self.effort)[3]

    @property
    def owns(self) -> bool:
        """Whether the joint has a coordinate of its own (it moves and follows no other)."""
        return self.moves and self.mimic is None

    @property
    def sizes(self) -> tuple[int, int]:
        """How many entries the joint has in ``q`` (NQ) and in ``qd`` (NV)."""
        if self.mimic is not None:
            return (0, 0)
        return self.kind.nq, self.kind.nv

    @property
    def multi(self) -> bool:
        """Whether the joint's configuration holds a unit quaternion (a floating or spherical
        joint: NQ != NV)."""
        return not self.kind.vector_space

    @property
    def dissipates(self) -> bool:
        """Whether the joint has viscous damping or Coulomb friction."""
        return self.damping is not None or self.friction is not None

    @property
    def driven(self) -> bool:
        """Whether the joint declares any drive or dissipation term."""
        return self.dissipates or self.stiffness is not None or self.armature is not None


@dataclass(frozen=True)
class LoopJoint:
    """A joint that closes a kinematic loop between two links of the spanning tree (or a
    link and the world). It has no coordinate: it adds constraints ``a_g(q) = 0``.

    ``origin`` places the loop frame in the parent link's frame, ``child_origin`` in the
    child's (planar ``(x, y, theta)``, spatial ``(x, y, z, roll, pitch, yaw)``); the joint
    holds when the two frames meet as its type allows. ``axis`` (in the loop frame) is the
    prismatic direction, or the 3-D revolute axis.
    """

    name: str
    type: str   # planar: revolute | prismatic; 3-D: revolute | spherical | prismatic
    parent: str
    child: str
    origin: tuple[Expression, ...]
    child_origin: tuple[Expression, ...]
    axis: tuple[Expression, ...]


@dataclass(frozen=True)
class Frame:
    """A named frame fixed on a link (a tool flange, a sensor, a contact point), for the
    kinematics outputs: its pose, Jacobian and the wrenches applied there.

    ``origin`` places it in the link frame: planar ``(x, y, theta)``, spatial
    ``(x, y, z, roll, pitch, yaw)``.
    """

    name: str
    link: str
    origin: tuple[Expression, ...]


#: The kinds of contact a frame can hold (DESIGN.md section 11): ``point`` constrains the
#: frame origin's acceleration in world-aligned axes (3 forces), ``surface`` the frame's whole
#: twist in its own axes (a force and a moment, 6).
CONTACT_KINDS = ("point", "surface")


@dataclass(frozen=True)
class Contact:
    """A frame held by a contact (the robot file's ``contacts:``): its name and ``kind``, one
    of CONTACT_KINDS. A 3-D robot's generated module holds these contacts by default in
    ``constrained_forward_dynamics`` and ``impulse_dynamics``."""

    frame: str
    kind: Literal["point", "surface"] = "point"


@dataclass(frozen=True)
class Robot:
    """A validated robot description. Links and joints keep the file's order."""

    name: str
    title: str
    planar: bool
    parameters: tuple[Parameter, ...]
    gravity: tuple[Expression, ...]
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    maximal_constraints: tuple[Expression, ...] | None = None
    #: Loop-closing joints (closed kinematic chains); empty for trees.
    loops: tuple[LoopJoint, ...] = ()
    #: Coordinates kept independent in the reduced form (robots with loops); None: chosen.
    independent: tuple[str, ...] | None = None
    #: Named frames fixed on links (kinematics outputs, external wrenches).
    frames: tuple[Frame, ...] = ()
    #: Frames held by contacts by default (``contacts:``; 3-D robots only).
    contacts: tuple[Contact, ...] = ()
    source: str = ""
    #: Where each named item was written, for errors found after validation.
    positions: dict[str, tuple[int, int]] = field(default_factory=dict, compare=False)
    #: Remarks from the reader about input accepted but changed or ignored (``note:`` lines).
    notes: tuple[str, ...] = field(default=(), compare=False)
    #: The most significant digits of a number the source file wrote, when the reader counted
    #: them (URDF: its attributes, angles of whole quarter turns aside); None: those of the
    #: expressions above (the sheet's precision, ``render.numbers``).
    digits: int | None = field(default=None, compare=False)

    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of the generalized coordinates: the moving joints, in file order (a ``mimic``
        joint has none: it follows its leader's); a joint of several coordinates without a
        quaternion (universal) names each (``<joint>_1, <joint>_2``), one with a quaternion is
        named once (its entries: ``configuration_names``)."""
        return tuple(name for j in self.joints if j.owns
                     for name in (j.kind.names(j.name)[0] if j.kind.vector_space else (j.name,)))

    @property
    def floating(self) -> bool:
        """Whether the robot takes the floating-base path (DESIGN.md section 10): some joint's
        configuration holds a unit quaternion (a ``floating`` joint, or a ``spherical`` joint
        anywhere, even on a fixed base), so NQ != NV and the free-flyer programs derive it."""
        return any(j.multi for j in self.joints)

    @property
    def floating_base(self) -> bool:
        """Whether the robot floats as a whole: its one joint to the world is ``floating``
        (then, without gravity, its momentum is conserved)."""
        roots = [j for j in self.joints if j.parent == "world"]
        return len(roots) == 1 and roots[0].kind.free

    @property
    def quaternion_starts(self) -> tuple[int, ...]:
        """Where each quaternion (of a floating or spherical joint) starts in ``q``, joint order."""
        where_q, _ = self.offsets()
        return tuple(where_q[j.name] + j.kind.quaternion_start for j in self.joints if j.multi)  # type: ignore[operator]

    @property
    def configuration_names(self) -> tuple[str, ...]:
        """The entries of ``q`` (NQ): a floating joint's seven, a spherical joint's four, every
        other moving joint's name."""
        return tuple(name for j in self.joints if j.owns
                     for name in j.kind.names(j.name)[0])

    @property
    def velocity_count(self) -> int:
        """NV: the entries of ``qd``, ``qdd`` (a floating joint's six, a spherical joint's three,
        one per other moving joint)."""
        return sum(j.sizes[1] for j in self.joints)

    def offsets(self) -> tuple[dict[str, int], dict[str, int]]:
        """Where each moving joint's entries start in ``q`` and in ``qd``, by joint name."""
        q, v, i, k = {}, {}, 0, 0
        for joint in (j for j in self.joints if j.owns):
            q[joint.name], v[joint.name] = i, k
            i, k = i + joint.sizes[0], k + joint.sizes[1]
        return q, v

    @property
    def dissipative(self) -> bool:
        """Whether some joint has damping or friction (the robot has ``D_g`` and ``F_g``)."""
        return any(j.dissipates for j in self.joints if j.moves)

    @property
    def efforts(self) -> tuple[str, ...]:
        """Names of the actuator efforts, in joint order (unactuated joints give none; a floating
        or spherical joint's several, ``Joint.effort_names``)."""
        return tuple(name for j in self.joints for name in j.effort_names)

    def effort_columns(self) -> tuple[int, ...]:
        """The entry of ``qd`` each effort (``efforts``' order) acts on."""
        where_v = self.offsets()[1]
        return tuple(where_v[j.name] + k for j in self.joints for k in range(len(j.effort_names)))

    @property
    def kinematic_size(self) -> int:
        """How many joint variables the kinematics composes: the coordinates and the ``<mimic>``
        joints that follow them (what the cost of the symbolic route grows with)."""
        return len(self.coordinates) + sum(1 for j in self.joints if j.mimic is not None)

    @property
    def mimics(self) -> bool:
        """Whether some joint follows another (URDF ``<mimic>``)."""
        return any(j.mimic is not None for j in self.joints)

    def driver(self, joint: Joint) -> tuple[str, float, float]:
        """The coordinate that moves a moving joint and how: ``(name, multiplier, offset)``,
        the joint's variable being ``multiplier * name + offset`` (``(joint, 1, 0)`` for a
        joint with a coordinate of its own)."""
        if joint.mimic is None:
            return joint.name, 1.0, 0.0
        return joint.mimic.joint, joint.mimic.multiplier, joint.mimic.offset

    def link(self, name: str) -> Link:
        return next(link for link in self.links if link.name == name)

    def parent_joint(self, link_name: str) -> Joint:
        return next(j for j in self.joints if j.child == link_name)

    def path_to(self, link_name: str) -> list[Joint]:
        """Joints from the world down to ``link_name``, root first."""
        path: list[Joint] = []
        name = link_name
        while name != "world":
            joint = self.parent_joint(name)
            path.append(joint)
            name = joint.parent
        return path[::-1]
