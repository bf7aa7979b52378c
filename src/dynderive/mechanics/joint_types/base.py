"""What every joint type answers, with the defaults of a vector-space joint (DESIGN.md
section 10; Pinocchio's ``JointModelBase`` and ``liegroup/vector-space.hpp``,
RigidBodyDynamics.jl's ``joint_types/joint_types.jl``).

A joint type says how many entries it has in ``q`` (``nq``) and in ``v`` (``nv``), what they
are called, how it moves its child frame (a rotation and a translation in its joint frame),
its motion subspace ``S`` (one ``(angular, linear)`` column per velocity entry, in the child
frame), the configuration's tangent per velocity entry (the seed of the derivatives along
``integrate``) and its configuration maps: ``neutral``, ``integrate(q, v, dt)``,
``difference(q0, q1)`` and the configuration rate ``qdot = rate(q, v)``. The maps are
target-neutral: they write straight-line program lines (``program.Program.let``) of SymPy
expressions, branches as ``sympy.Piecewise``, which every target's printer can print.

A vector-space joint (revolute, prismatic; ``nq == nv``) takes the defaults: neutral 0,
``q + v dt``, ``q1 - q0``, rate ``v``. The quaternion joints (``floating``, ``spherical``)
override them (``quaternion.py``: SO(3) and SE(3) as Pinocchio's).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar

import sympy

from ...model.joint_kinds import JointKind
from ..joint_variables import PlanarMotion
from ..program import motion_cross

Vector = tuple[sympy.Expr, sympy.Expr, sympy.Expr]
Vector2 = tuple[sympy.Expr, sympy.Expr]
#: A motion column ``(angular, linear)`` in the child frame.
Column = tuple[Vector, Vector]
#: ``Program.let``: names an expression (or returns it, if cheap), for the program's lines.
Let = Callable[[sympy.Expr], sympy.Expr]

#: The values of a joint's type-specific keys (``JointKind.keys``, e.g. ``pitch``) as SymPy
#: expressions (a key of n entries: a tuple), by key.
Geometry = Mapping[str, Any]
NO_GEOMETRY: Geometry = MappingProxyType({})

ZERO, ONE = sympy.Integer(0), sympy.Integer(1)
ZERO3: Vector = (ZERO, ZERO, ZERO)


def basis(k: int) -> Vector:
    """The unit vector ``e_k`` of 3-D space."""
    return tuple(sympy.Integer(int(i == k)) for i in range(3))  # type: ignore[return-value]


@dataclass(frozen=True)
class Segment:
    """One one-coordinate screw motion of a joint: its type (revolute, prismatic, helical),
    unit axis in the frame it starts from, and that type's own keys."""

    kind: JointType
    axis: Vector
    geometry: Geometry = field(default_factory=lambda: NO_GEOMETRY)


def keep(expr: sympy.Expr) -> sympy.Expr:
    """A ``Let`` that names nothing: the expression itself (maps and seeds outside a program)."""
    return expr


class JointType:
    """A joint type's answers; the defaults are a one-coordinate vector-space joint's."""

    #: Its entry in the joint specification (``model/joint_kinds.py``): name, sizes, entry
    #: names, readers' names. The class attributes below are read from it.
    spec: ClassVar[JointKind]
    #: The name in the robot file (``joints[i].type``).
    name: ClassVar[str] = ""
    #: Entries in ``q`` and in ``v`` (Pinocchio's NQ, NV).
    nq: ClassVar[int] = 1
    nv: ClassVar[int] = 1
    #: Where its unit quaternion starts among its entries of ``q`` (None: it has none).
    quaternion_start: ClassVar[int | None] = None
    #: Whether its child frame moves relative to its joint frame (a fixed joint's does not).
    moves: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs: object) -> None:
        """Take the sizes and names from the class's ``spec``, the one place they are written."""
        super().__init_subclass__(**kwargs)
        if "spec" in cls.__dict__:
            spec = cls.spec
            cls.name, cls.nq, cls.nv = spec.name, spec.nq, spec.nv
            cls.quaternion_start, cls.moves = spec.quaternion_start, not spec.welded
    #: Whether its motion is a turn about its axis (revolute): its column is angular.
    turns: ClassVar[bool] = False

    # --- how it moves its child frame -------------------------------------------------
    def rotation(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                 geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        """The child frame's axes in the joint frame at configuration ``q`` (its entries, or
        for a scalar joint the one variable, ``[multiplier * q_leader + offset]`` if it
        follows another). ``axis``: the unit axis, for the types that have one."""
        return sympy.eye(3)

    def displacement(self, origin: sympy.Matrix, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix | None:
        """The child frame's origin relative to the joint frame's, in the parent's axes
        (``origin``: the joint frame's rotation in the parent), or None for none."""
        return None

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        """The motion subspace ``S`` at configuration ``q``: per velocity entry, the child
        frame's ``(angular, linear)`` velocity per unit rate, in the child frame (Pinocchio's
        ``S``, local). Constant for every type but a product of screw motions (``Product``)."""
        raise NotImplementedError

    def column_rates(self, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> list[Column] | None:
        """Per column, its rate of change in the child frame at velocity ``v`` (Featherstone's
        apparent derivative; the joint's bias acceleration ``c_J = sum_k rate_k v_k``), or None
        when the columns are constant in the child frame (every type but a ``Product``)."""
        return None

    def segments(self, axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Segment]:
        """The one-coordinate screw motions its motion is the product of, in order, one per
        coordinate (the sheet's kinematics compose them): a one-coordinate joint is its own."""
        if self.nq != 1 or self.quaternion_start is not None:
            raise NotImplementedError(f"a {self.name} joint is not a product of one-coordinate motions")
        return [Segment(self, tuple(axis), geometry)]  # type: ignore[arg-type]

    def planar(self, q: sympy.Expr, axis: Vector2) -> PlanarMotion:
        """The motion in the plane z = 0 of a planar robot at variable ``q`` (``planar.py``
        reads it); ``axis``: the joint's axis in the plane."""
        raise NotImplementedError(f"a {self.name} joint is not a planar robot's joint")

    def pinocchio(self, pin: Any, axis: Any, geometry: Mapping[str, float]) -> Any:
        """Pinocchio's joint model of this type (``pin``: the ``pinocchio`` module; ``axis``
        the unit axis as 3 floats, ``geometry`` the type's own keys as floats), for ``check``'s
        reference model (``verify/pinocchio_model.py``)."""
        raise NotImplementedError(f"a {self.name} joint has no Pinocchio joint model here")

    # --- configuration space -------------------------------------------------------------
    def tangent_seed(self, q: Sequence[sympy.Symbol], let: Let = keep) -> list[dict[sympy.Symbol, sympy.Expr]]:
        """Per velocity entry ``k``, the tangent of the configuration along it, ``d/dh
        integrate(q, e_k h)`` at h = 0, by entry of ``q`` (the derivatives of
        ``linearization.py`` and ``frames.py`` start from it): ``q_k = 1`` for a vector-space joint. It
        is the rate's derivative by ``v_k`` (``tests/test_joint_types.py``)."""
        return [{q[k]: ONE} for k in range(self.nv)]

    def typical(self) -> list[float]:
        """A configuration away from the neutral one, where ``simulate`` starts by default:
        half a radian for a joint that turns, 0.2 for one that slides."""
        return [0.5 if self.turns else 0.2] * self.nq

    def neutral(self) -> list[sympy.Expr]:
        """Pinocchio's ``neutral``: zeros (identity quaternions)."""
        return [ZERO] * self.nq

    def integrate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr],
                  dt: sympy.Expr) -> list[sympy.Expr]:
        """The configuration reached from ``q`` moving at ``v`` for ``dt`` (Pinocchio's
        ``integrate(q, v dt)``): ``q + v dt``."""
        return [let(a + b * dt) for a, b in zip(q, v)]

    def difference(self, let: Let, q0: Sequence[sympy.Expr], q1: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        """The velocity ``v`` with ``integrate(q0, v, 1) = q1`` (Pinocchio's ``difference``):
        ``q1 - q0``."""
        return [let(b - a) for a, b in zip(q0, q1)]

    def rate(self, let: Let, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr]) -> list[sympy.Expr]:
        """``dq/dt`` at velocity ``v``: the derivative of ``integrate(q, v, t)`` at t = 0; ``v``."""
        return list(v)

    def __repr__(self) -> str:
        return f"<joint type {self.name}: nq={self.nq}, nv={self.nv}>"


class Product(JointType):
    """A vector-space joint whose motion is a product of one-coordinate screw motions, one per
    coordinate (``segments``; Pinocchio's ``JointModelComposite``): a universal joint two
    turns, a 3-D planar joint two shifts and a turn. Its placement composes theirs; its column
    ``k`` is segment k's, carried into the child frame through the segments after it, so it
    changes with those coordinates: ``rate_k = -(sum_{l>k} S_l v_l) x S_k`` (the child frame
    moves relative to segment k's by the later segments' motion), and ``c_J = sum_k rate_k v_k``."""

    def segments(self, axis: Sequence[sympy.Expr], geometry: Geometry = NO_GEOMETRY) -> list[Segment]:
        raise NotImplementedError

    def _poses(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
               geometry: Geometry) -> list[tuple[sympy.Matrix, sympy.Matrix]]:
        """Each segment's rotation and displacement in the frame it starts from."""
        poses = []
        for segment, entry in zip(self.segments(axis, geometry), q):
            shift = segment.kind.displacement(sympy.eye(3), [entry], segment.axis, segment.geometry)
            poses.append((segment.kind.rotation([entry], segment.axis, segment.geometry),
                          sympy.zeros(3, 1) if shift is None else shift))
        return poses

    @staticmethod
    def _compose(poses: Sequence[tuple[sympy.Matrix, sympy.Matrix]]) -> tuple[sympy.Matrix, sympy.Matrix]:
        R, p = sympy.eye(3), sympy.zeros(3, 1)
        for rotation, shift in poses:
            R, p = R * rotation, p + R * shift
        return R, p

    def rotation(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                 geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix:
        return self._compose(self._poses(q, axis, geometry))[0]

    def displacement(self, origin: sympy.Matrix, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> sympy.Matrix | None:
        p = self._compose(self._poses(q, axis, geometry))[1]
        return None if p.is_zero_matrix else origin * p

    def columns(self, q: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                geometry: Geometry = NO_GEOMETRY) -> list[Column]:
        poses, segments = self._poses(q, axis, geometry), self.segments(axis, geometry)
        found = []
        for k, (segment, entry) in enumerate(zip(segments, q)):
            (w, v), = segment.kind.columns([entry], segment.axis, segment.geometry)
            R, p = self._compose(poses[k + 1:])   # the child frame in segment k's
            w_child = R.T * sympy.Matrix(w)
            v_child = R.T * (sympy.Matrix(v) + sympy.Matrix(w).cross(p))
            found.append((tuple(w_child), tuple(v_child)))
        return found  # type: ignore[return-value]

    def column_rates(self, q: Sequence[sympy.Expr], v: Sequence[sympy.Expr], axis: Sequence[sympy.Expr],
                     geometry: Geometry = NO_GEOMETRY) -> list[Column] | None:
        columns = self.columns(q, axis, geometry)
        rates = []
        for k, column in enumerate(columns):
            later = [tuple(sum((c[part][i] * v[l] for l, c in enumerate(columns) if l > k), ZERO) for i in range(3))
                     for part in range(2)]
            w, lin = motion_cross((later[0], later[1]), column)  # type: ignore[arg-type]
            rates.append((tuple(-x for x in w), tuple(-x for x in lin)))
        return rates  # type: ignore[return-value]
