"""Random spatial (3-D) robot trees, as YAML text plus the plain numbers behind it.

``random_spatial_tree(rng, n)`` draws a branching tree of ``n`` moving joints (revolute and
prismatic mixed) about arbitrary, non-unit axes, sometimes with one ``fixed`` weld, with
arbitrary joint origins (``xyz`` and general ``rpy`` rotations) and full inertia tensors
(a random rotation of random principal moments that satisfy the triangle inequality). Every
number is written at full precision (``repr`` of the double, 17 digits, as CAD exporters
write them), and the numeric description holds exactly those values, so an independent model (e.g. Pinocchio) built from
``SpatialTree.links``/``joints`` is the same robot as the file.

Conventions (those of dynderive's 3-D files, which are URDF's):

* link ``k`` (``b{k+1}``) is the child of joint ``k``; joints and links are listed in the same
  order, so a joint's parent link always comes earlier;
* joint frame = parent link frame * Trans(xyz) * Rz(yaw) Ry(pitch) Rx(roll); the child link
  frame is the joint frame rotated by ``q`` about ``axis / |axis|`` (revolute) or shifted by
  ``q * axis / |axis|`` (prismatic);
* the COM sits at ``com`` in the link frame; the 3x3 inertia is about the COM, in link axes.

``spatial_from_planar`` rewrites a planar tree (``tests/random_robots.py``) as the same
robot in the 3-D format, for cross-checks between the two code paths.

No dynderive import: this module only writes text.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

Vector3 = tuple[float, float, float]
Matrix3 = tuple[Vector3, Vector3, Vector3]


@dataclass(frozen=True)
class SpatialLink:
    name: str
    mass: float
    com: Vector3
    inertia: Matrix3       # about the COM, in link axes; symmetric
    nested: bool = False   # written as a 3x3 nested list (else the 6-list)

    @property
    def inertia6(self) -> tuple[float, float, float, float, float, float]:
        """``[ixx, iyy, izz, ixy, ixz, iyz]``."""
        i = self.inertia
        return (i[0][0], i[1][1], i[2][2], i[0][1], i[0][2], i[1][2])


@dataclass(frozen=True)
class SpatialJoint:
    name: str
    type: str                   # 'revolute' | 'prismatic' | 'fixed'
    parent: int                 # parent link index, -1 for the world
    child: int                  # child link index
    xyz: Vector3                # joint frame origin in the parent link frame
    rpy: Vector3                # roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
    axis: Vector3 | None        # moving joints; not unit length; None for fixed joints
    effort: str | None          # None for fixed joints
    write_axis: bool = True     # False: the YAML omits it (the default [0, 0, 1])

    @property
    def moves(self) -> bool:
        return self.type != "fixed"

    @property
    def unit_axis(self) -> Vector3:
        assert self.axis is not None
        norm = math.sqrt(sum(a * a for a in self.axis))
        return (self.axis[0] / norm, self.axis[1] / norm, self.axis[2] / norm)


@dataclass(frozen=True)
class SpatialTree:
    yaml_text: str
    links: tuple[SpatialLink, ...]
    joints: tuple[SpatialJoint, ...]       # file order; joints[k].child == k
    gravity: Vector3

    @property
    def moving_joints(self) -> tuple[SpatialJoint, ...]:
        """The joints with a coordinate, in coordinate order."""
        return tuple(j for j in self.joints if j.moves)

    @property
    def n_dof(self) -> int:
        return len(self.moving_joints)

    @property
    def has_fixed(self) -> bool:
        return any(not j.moves for j in self.joints)

    @property
    def branches(self) -> bool:
        """Whether some link (or the world) has two or more children."""
        parents = [j.parent for j in self.joints]
        return len(set(parents)) < len(parents)


def _r(value: float) -> float:
    """The value at full precision, as CAD exporters write it (no negative zero): round
    numbers hide bugs (exact rationals of 17 digits must still give working code)."""
    return 0.0 if value == 0 else float(value)


def _fmt(value: float) -> str:
    return repr(float(value))


def _list(values) -> str:
    return "[" + ", ".join(_fmt(v) for v in values) + "]"


def _matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _random_rotation(rng: random.Random) -> list[list[float]]:
    """A uniformly random rotation matrix (from a random unit quaternion)."""
    while True:
        w, x, y, z = (rng.gauss(0.0, 1.0) for _ in range(4))
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if norm > 1e-3:
            break
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def _random_inertia(rng: random.Random) -> Matrix3:
    """``R diag(a, b, c) R^T`` at full precision; the moments stay 0.02 inside the triangle
    limits, so the tensor as written is positive definite and physical."""
    a = rng.uniform(0.05, 0.3)
    b = rng.uniform(0.05, 0.3)
    c = rng.uniform(abs(a - b) + 0.02, a + b - 0.02)
    rot = _random_rotation(rng)
    diag = [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]]
    full = _matmul(_matmul(rot, diag), [list(row) for row in zip(*rot, strict=True)])
    ixx, iyy, izz = _r(full[0][0]), _r(full[1][1]), _r(full[2][2])
    ixy, ixz, iyz = _r(full[0][1]), _r(full[0][2]), _r(full[1][2])
    return ((ixx, ixy, ixz), (ixy, iyy, iyz), (ixz, iyz, izz))


def _random_axis(rng: random.Random) -> Vector3:
    """A non-unit axis: mostly a random direction, sometimes along (+/-) a coordinate axis."""
    if rng.random() < 0.15:
        k = rng.randrange(3)
        length = _r(rng.choice((-1.0, 1.0)) * rng.uniform(0.5, 2.0))
        return tuple(length if i == k else 0.0 for i in range(3))  # type: ignore[return-value]
    while True:
        axis = tuple(_r(rng.uniform(-2.0, 2.0)) for _ in range(3))
        if math.sqrt(sum(a * a for a in axis)) > 0.3:
            return axis  # type: ignore[return-value]


def render_yaml(links, joints, gravity, *, name: str = "random_tree3d",
                comment: str = "Random spatial tree (generated by tests/random_robots3d.py).") -> str:
    """The 3-D YAML file of the given numbers (written with ``repr``, so exactly these)."""
    lines = [
        f"# {comment}",
        f"name: {name}",
        "planar: false",
        "parameters: {}",
        f"gravity: {_list(gravity)}",
        "links:",
    ]
    for link in links:
        if link.nested:
            inertia = "[" + ", ".join(_list(row) for row in link.inertia) + "]"
        else:
            inertia = _list(link.inertia6)
        lines += [
            f"  - name: {link.name}",
            f"    mass: {_fmt(link.mass)}",
            f"    com: {_list(link.com)}",
            f"    inertia: {inertia}",
        ]
    lines.append("joints:")
    for joint in joints:
        parent = "world" if joint.parent < 0 else links[joint.parent].name
        lines += [
            f"  - name: {joint.name}",
            f"    type: {joint.type}",
            f"    parent: {parent}",
            f"    child: {links[joint.child].name}",
            f"    origin: {{xyz: {_list(joint.xyz)}, rpy: {_list(joint.rpy)}}}",
        ]
        if joint.axis is not None and joint.write_axis:
            lines.append(f"    axis: {_list(joint.axis)}")
        if joint.effort is not None:
            lines.append(f"    effort: {joint.effort}")
    return "\n".join(lines) + "\n"


def random_spatial_tree(rng: random.Random, n_joints: int, *, fixed: bool | None = None) -> SpatialTree:
    """A random branching spatial tree with ``n_joints`` moving joints (2 to 7).

    ``fixed``: include one fixed weld (True), none (False) or decide at random (None).
    """
    if not 2 <= n_joints <= 7:
        raise ValueError(f"n_joints must be between 2 and 7, got {n_joints}")
    if fixed is None:
        fixed = rng.random() < 0.4
    types = [rng.choice(("revolute", "revolute", "prismatic")) for _ in range(n_joints)]
    if len(set(types)) == 1:  # always mix the kinds
        k = rng.randrange(n_joints)
        types[k] = "prismatic" if types[k] == "revolute" else "revolute"
    if fixed:
        types.insert(rng.randrange(n_joints + 1), "fixed")
    nested_tree = rng.random() < 0.3  # some trees write (some) inertias as 3x3 nested lists

    links: list[SpatialLink] = []
    joints: list[SpatialJoint] = []
    moving = 0
    for k, jtype in enumerate(types):
        parent = rng.randrange(-1, k)  # the world or any earlier link
        xyz = tuple(_r(rng.uniform(-0.6, 0.6)) for _ in range(3))
        rpy = tuple(_r(rng.uniform(-math.pi, math.pi)) for _ in range(3))
        axis = None
        write_axis = True
        if jtype == "fixed":
            name, effort = "weld1", None
        else:
            moving += 1
            name, effort = f"q{moving}", f"u{moving}"
            if jtype == "revolute" and rng.random() < 0.1:
                axis, write_axis = (0.0, 0.0, 1.0), False  # the default axis
            else:
                axis = _random_axis(rng)
        joints.append(SpatialJoint(name, jtype, parent, k, xyz, rpy, axis, effort, write_axis))  # type: ignore[arg-type]
        links.append(SpatialLink(
            f"b{k + 1}",
            _r(rng.uniform(0.5, 3.0)),
            tuple(_r(rng.uniform(-0.5, 0.5)) for _ in range(3)),  # type: ignore[arg-type]
            _random_inertia(rng),
            nested_tree and rng.random() < 0.6,
        ))

    while True:
        direction = [rng.gauss(0.0, 1.0) for _ in range(3)]
        norm = math.sqrt(sum(d * d for d in direction))
        if norm > 1e-3:
            break
    magnitude = rng.uniform(5.0, 12.0)
    gravity = tuple(_r(magnitude * d / norm) for d in direction)
    text = render_yaml(links, joints, gravity)
    return SpatialTree(text, tuple(links), tuple(joints), gravity)  # type: ignore[arg-type]


def spatial_from_planar(tree) -> SpatialTree:
    """The planar tree ``tree`` (a ``random_robots.PlanarTree``) as the same 3-D robot.

    Origins ``(x, y, theta)`` become ``xyz = (x, y, 0)``, ``rpy = (0, 0, theta)``; revolute
    joints turn about z, prismatic axes get a zero z; the scalar inertia ``I`` becomes
    ``diag(I, I, I)`` (only ``Izz`` matters for motion in the plane, and it is physical);
    the COM and gravity get a zero z.
    """
    links = tuple(
        SpatialLink(link.name, link.mass, (link.com[0], link.com[1], 0.0),
                    ((link.inertia, 0.0, 0.0), (0.0, link.inertia, 0.0), (0.0, 0.0, link.inertia)))
        for link in tree.links
    )
    joints = []
    for joint in tree.joints:
        if joint.type == "revolute":
            axis = (0.0, 0.0, 1.0)
        elif joint.type == "prismatic":
            axis = (joint.axis[0], joint.axis[1], 0.0)
        else:
            axis = None
        x, y, theta = joint.origin
        joints.append(SpatialJoint(joint.name, joint.type, joint.parent, joint.child, (x, y, 0.0),
                                   (0.0, 0.0, theta), axis, joint.effort))
    gravity = (tree.gravity[0], tree.gravity[1], 0.0)
    text = render_yaml(links, joints, gravity, name="planar_as_spatial",
                       comment="A planar random tree written in the 3-D format.")
    return SpatialTree(text, links, tuple(joints), gravity)


if __name__ == "__main__":  # pragma: no cover - eyeballing aid
    import sys

    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 0
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    print(random_spatial_tree(random.Random(seed), n).yaml_text)
