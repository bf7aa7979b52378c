"""The one specification of the joint types (DESIGN.md sections 3, 10, 12 and 13), SymPy-free:
what the robot file, the readers, the symbol table and the docs need to know of a joint type
without its motion. ``mechanics/joint_types/`` extends each entry with how it moves (its
rotation, displacement, motion columns and configuration maps), one module per type.

Everything else reads this table: the robot file's accepted types (``input/schema.py``), the
JSON Schema's enum, the URDF and MuJoCo type maps, the names of a joint's entries in ``q``,
``qd``, ``qdd`` and of its efforts, and the docs' table of joint types. Adding a joint type is
one entry here and one module in ``mechanics/joint_types/``.

Entry names: a joint with one coordinate names it after itself (``q1``); a joint with several
names them ``<joint>_<suffix>``. A vector-space joint's velocities and accelerations are its
coordinates' rates (named as any coordinate's, ``model/naming.py``); a joint whose
configuration holds a unit quaternion names its velocities (a local twist) and accelerations
by suffixes of their own, Pinocchio's order.
"""

from __future__ import annotations

from dataclasses import dataclass

#: A 3-D floating joint's entries, Pinocchio's order (DESIGN.md section 10): position and unit
#: quaternion; local linear then angular velocity; their rates; the wrench dual to the twist.
FREE_CONFIGURATION = ("x", "y", "z", "qx", "qy", "qz", "qw")
FREE_VELOCITY = ("vx", "vy", "vz", "wx", "wy", "wz")
FREE_ACCELERATION = ("dvx", "dvy", "dvz", "dwx", "dwy", "dwz")
FREE_EFFORT = ("fx", "fy", "fz", "tx", "ty", "tz")


@dataclass(frozen=True)
class JointKey:
    """A key of the robot file's joint entry that only some types read (a helical joint's
    ``pitch``): its name, what it holds, and its size (0: one expression; n: a list of n)."""

    name: str
    description: str
    size: int = 0


@dataclass(frozen=True)
class JointKind:
    """One joint type as data.

    ``coordinates``, ``velocities``, ``accelerations`` and ``efforts`` are the suffixes of the
    joint's entries (empty: one entry named after the joint, or after its ``effort``);
    ``velocities``/``accelerations`` None: the coordinates' rates (a vector-space joint).
    ``quaternion_start``: where its unit quaternion starts among its coordinates (None: none).
    ``takes_axis``: whether a 3-D joint of this type reads ``axis`` (default z; a loop joint's too).
    ``planar``: allowed in a planar robot's file; ``spatial``: in a 3-D robot's.
    ``closes_loops``: allowed as a loop-closing joint (its rows: the frame's 6 (3 planar) minus nv).
    ``urdf``: the URDF ``type`` attributes read as this type; ``mjcf``: MuJoCo's ``mjtJoint``
    values read as this type (``mjJNT_FREE`` 0, ``mjJNT_BALL`` 1, ``mjJNT_SLIDE`` 2, ``mjJNT_HINGE`` 3).
    """

    name: str
    #: One line for the docs' table and the JSON Schema.
    summary: str
    coordinates: tuple[str, ...] = ()
    velocities: tuple[str, ...] | None = None
    accelerations: tuple[str, ...] | None = None
    efforts: tuple[str, ...] = ()
    quaternion_start: int | None = None
    takes_axis: bool = False
    #: Whether a planar robot's joint of this type reads ``axis`` (2 entries; a planar revolute
    #: joint turns about z), and why a joint that takes none takes none (for the error).
    planar_axis: bool = False
    no_axis: str = ""
    planar: bool = False
    spatial: bool = True
    closes_loops: bool = False
    urdf: tuple[str, ...] = ()
    mjcf: tuple[int, ...] = ()
    #: Whether the joint has no coordinate and no motion (its child welded to its parent).
    welded: bool = False
    #: The keys of its own the joint entry must give (beyond name, type, origin, axis, ...).
    keys: tuple[JointKey, ...] = ()
    #: A one-coordinate joint's motion along its axis, for the sheet's figures: the turn about
    #: the axis and the shift along it per unit of its coordinate, as expression texts over its
    #: own keys (None: not a screw motion about one axis).
    screw: tuple[str, str] | None = None
    #: How the sheet's 3-D figure draws it: "cylinder", "box" or "ball" ("": not drawn, as a
    #: fixed joint); ``drawn``: whether the figure can place the links below it at all.
    glyph: str = ""
    drawn: bool = True
    #: Whether a joint of this type may follow another's coordinate, or lead (URDF ``<mimic>``).
    follows: bool = False
    #: The suffixes of its coordinates that are angles (a one-coordinate joint's: from ``screw``).
    angles: tuple[str, ...] = ()
    #: What it lets move between its two frames, translation then rotation: "none", "axis" (along
    #: or about its axis) or "all"; the rows a loop joint (or a maximal-coordinates joint) keeps
    #: are the rest (None: not built as a loop joint).
    frees: tuple[str, str] | None = None

    @property
    def nq(self) -> int:
        """Entries in ``q`` (Pinocchio's NQ)."""
        return 0 if self.welded else max(1, len(self.coordinates))

    @property
    def nv(self) -> int:
        """Entries in ``qd`` and ``qdd`` (Pinocchio's NV)."""
        if self.welded:
            return 0
        return self.nq if self.velocities is None else len(self.velocities)

    @property
    def vector_space(self) -> bool:
        """Whether its configuration is a vector space (no quaternion: NQ = NV, ``q + v dt``)."""
        return self.quaternion_start is None

    @property
    def free(self) -> bool:
        """Whether it moves its child in all six directions (a free joint: position and orientation)."""
        return self.nv == 6

    @property
    def angle_entries(self) -> tuple[bool, ...]:
        """Per coordinate, whether it is an angle (shown in degrees, a turn's sine and cosine)."""
        if self.nq == 1 and self.screw is not None:
            return (self.screw[0] != "0",)
        return tuple(s in self.angles for s in self.coordinates)

    @property
    def angle(self) -> bool:
        """Whether it is one angle (revolute, helical): a turn the sheets draw and write in degrees."""
        return self.angle_entries == (True,)

    @property
    def slides(self) -> bool:
        """Whether it is one travel along its axis (a prismatic joint)."""
        return self.screw is not None and self.screw[0] == "0"

    def names(self, joint: str, effort: str | None = None) -> tuple[tuple[str, ...], ...]:
        """A joint's coordinate names and, for a joint with a quaternion, its velocity and
        acceleration names (empty for a vector-space joint: those are named from the
        coordinates), then its efforts' names (``effort``: the file's effort name, or None)."""
        entries = (tuple(f"{joint}_{s}" for s in self.coordinates) or ((joint,) if self.nq else ()),
                   tuple(f"{joint}_{s}" for s in self.velocities or ()),
                   tuple(f"{joint}_{s}" for s in self.accelerations or ()))
        efforts = () if effort is None else (tuple(f"{effort}_{s}" for s in self.efforts) or (effort,))
        return (*entries, efforts)

    def loop_rows(self, planar: bool) -> int:
        """The constraints it imposes as a loop-closing joint: the relative motion it forbids."""
        return (3 if planar else 6) - self.nv


#: Every joint type, in the order the docs and messages list them.
JOINT_KINDS: dict[str, JointKind] = {kind.name: kind for kind in (
    JointKind("revolute", "one angle about its unit axis (3-D: axis, default z; planar: about z)",
              takes_axis=True, planar=True, closes_loops=True, urdf=("revolute", "continuous"), mjcf=(3,),
              screw=("1", "0"), glyph="cylinder", follows=True, frees=("none", "axis")),
    JointKind("prismatic", "one displacement along its unit axis (3-D: 3 entries, planar: 2)",
              takes_axis=True, planar_axis=True, planar=True, closes_loops=True, urdf=("prismatic",), mjcf=(2,),
              screw=("0", "1"), glyph="box", follows=True, frees=("axis", "none")),
    JointKind("fixed", "no coordinate: the child is welded to the parent", welded=True, planar=True,
              urdf=("fixed",), frees=("none", "none")),
    JointKind("floating", "a free joint: 3-D position and unit quaternion (planar: x, y, theta, "
              "expanded into three joints); unactuated unless it names an effort",
              coordinates=FREE_CONFIGURATION, velocities=FREE_VELOCITY, accelerations=FREE_ACCELERATION,
              efforts=FREE_EFFORT, quaternion_start=3, planar=True, urdf=("floating",), mjcf=(0,), drawn=False),
    JointKind("spherical", "a ball joint (3-D): a unit quaternion, the local angular velocity",
              coordinates=FREE_CONFIGURATION[3:], velocities=FREE_VELOCITY[3:],
              accelerations=FREE_ACCELERATION[3:], efforts=FREE_EFFORT[3:], quaternion_start=0,
              closes_loops=True, mjcf=(1,), no_axis="it turns about all three", glyph="ball", frees=("none", "all")),
    JointKind("helical", "a screw (3-D): one angle about its unit axis (default z), moving pitch along it per radian",
              takes_axis=True, keys=(JointKey("pitch", "translation along the axis per radian, an expression"),),
              screw=("1", "pitch"), glyph="cylinder"),
    JointKind("universal", "two angles (3-D): about its unit axis (default z), then about axis2, orthogonal to it",
              coordinates=("1", "2"), efforts=("1", "2"), takes_axis=True,
              keys=(JointKey("axis2", "the second unit axis, orthogonal to axis, in the frame the first turn leaves", 3),),
              glyph="ball", angles=("1", "2")),
    JointKind("planar", "a plane (3-D): x and y in the plane normal to its unit axis (default z), then the angle theta "
              "about it", coordinates=("x", "y", "theta"), efforts=("x", "y", "theta"), takes_axis=True, glyph="box",
              angles=("theta",), urdf=("planar",)),
)}


#: The type of a welded joint, which a reader gives a joint whose type it could not read (the
#: error is reported once, where it is read).
WELDED = next(name for name, kind in JOINT_KINDS.items() if kind.welded)
#: The free joint's type (a floating base: all six directions).
FREE = next(name for name, kind in JOINT_KINDS.items() if kind.free)
#: The ball joint's type (a unit quaternion, nothing else; a MuJoCo ball, a connect equality).
BALL = next(name for name, kind in JOINT_KINDS.items() if kind.quaternion_start is not None and not kind.free)
#: A motion in a plane as one-coordinate joints in a row: along x, along y, about the plane's
#: normal (a planar robot's floating joint and a URDF planar joint are read so).
PLANE_AS_JOINTS = ("prismatic", "prismatic", "revolute")


def is_welded(name: object) -> bool:
    """Whether a file's type value names a welded joint (no coordinate, no motion)."""
    return (kind := find_kind(name)) is not None and kind.welded


def is_free(name: object) -> bool:
    """Whether a file's type value names the free joint (a floating base)."""
    return (kind := find_kind(name)) is not None and kind.free


def is_angle(name: object) -> bool:
    """Whether a file's type value names a joint of one angle (its effort a torque)."""
    return (kind := find_kind(name)) is not None and kind.angle


def joint_keys() -> dict[str, JointKey]:
    """Every type's own keys, by name (the schema accepts them on a joint of that type)."""
    return {key.name: key for k in JOINT_KINDS.values() for key in k.keys}


def find_kind(name: object) -> JointKind | None:
    """The joint type a file's ``type`` value names, or None (not a type's name, or not text:
    the readers report that once, where they read it)."""
    return JOINT_KINDS.get(name) if isinstance(name, str) else None


def joint_kind(name: str) -> JointKind:
    """The joint type of that name (``joints[i].type`` in the robot file)."""
    try:
        return JOINT_KINDS[name]
    except KeyError:
        raise ValueError(f"unknown joint type {name!r} (known: {', '.join(JOINT_KINDS)})") from None


def kinds(*, planar: bool | None = None, loops: bool = False) -> tuple[str, ...]:
    """The types' names a robot file may write: for a planar (True) or 3-D (False) robot, or
    either (None); as loop-closing joints with ``loops``."""
    return tuple(k.name for k in JOINT_KINDS.values()
                 if (planar is None or (k.planar if planar else k.spatial)) and (k.closes_loops or not loops))


def urdf_types() -> dict[str, str]:
    """URDF ``type`` attribute -> joint type."""
    return {attribute: k.name for k in JOINT_KINDS.values() for attribute in k.urdf}


def mjcf_types() -> dict[int, str]:
    """MuJoCo ``mjtJoint`` value -> joint type."""
    return {value: k.name for k in JOINT_KINDS.values() for value in k.mjcf}
