"""Joint types, one module each, owning their configuration space (DESIGN.md sections 2 and
10): ``revolute``, ``prismatic``, ``fixed``, ``spherical`` and ``floating`` (3-D free flyer),
each a ``base.JointType`` answering nq, nv, its entries' names, how it moves its child frame,
its motion columns, the tangent seed of the derivatives and its configuration maps (neutral,
integrate, difference, configuration rate) as target-neutral program lines. Vector-space
joints take ``base.py``'s defaults; the quaternion joints override them (``quaternion.py``).

Not types of their own: a URDF ``<mimic>`` joint is its scalar type coupled to its leader's
coordinate (``joint_variables.Coupling``: no entries in ``q`` or ``v``, its column its leader's times
the multiplier), and a planar robot's ``floating`` joint is three scalar joints once loaded
(``input/free_joints.py``, ``expand_planar_floating``).

>>> joint_type("floating").nq, joint_type("floating").nv
(7, 6)

``configuration_programs`` runs the maps joint by joint over a robot's ``q`` and ``v``
(Pinocchio's ``algorithm/joint-configuration.hxx``), giving the programs a target prints as
``neutral_configuration``, ``integrate``, ``difference`` and ``configuration_rate``.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass, field

import sympy

from ...model.joint_kinds import JOINT_KINDS
from ...model.robot import Joint, Robot
from ..program import Program
from .base import Geometry, JointType


def _discover() -> dict[str, JointType]:
    """Every joint type: each module of this package defines one class with a ``spec`` (its
    entry of ``model/joint_kinds.JOINT_KINDS``), found here, so adding a type adds a module and
    its specification's entry, no line here. In the specification's order."""
    for module in pkgutil.iter_modules(__path__):
        importlib.import_module(f"{__name__}.{module.name}")
    found: dict[str, JointType] = {}
    classes: list[type[JointType]] = [JointType]
    while classes:
        cls = classes.pop()
        classes.extend(cls.__subclasses__())
        if "spec" in cls.__dict__:
            found[cls.spec.name] = cls()
    missing = [name for name in JOINT_KINDS if name not in found]
    if missing:
        raise RuntimeError(f"joint types without a module in mechanics/joint_types/: {', '.join(missing)}")
    return {name: found[name] for name in JOINT_KINDS}


#: Every joint type, by the name the robot file gives it.
JOINT_TYPES: dict[str, JointType] = _discover()


def joint_type(name: str) -> JointType:
    """The joint type of that name (``joints[i].type`` in the robot file)."""
    try:
        return JOINT_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown joint type {name!r} (known: {', '.join(JOINT_TYPES)})") from None


def of(joint: Joint) -> JointType:
    """A joint's type."""
    return joint_type(joint.type)


def geometry_of(joint: Joint, expr: Callable[[object], sympy.Expr]) -> Geometry:
    """The values of the joint's type-specific keys (``Joint.geometry``) as expressions
    (``expr``: the symbol table's parser), by key: what ``rotation``, ``displacement`` and
    ``columns`` read besides the axis."""
    return {key: tuple(expr(e) for e in value) if isinstance(value, tuple) else expr(value)
            for key, value in joint.geometry}


@dataclass
class ConfigurationProgram:
    """One configuration map of a whole robot: its program (outputs: the result's entries)
    and its arguments, by name in the generated function's signature, each the symbols of
    its entries in order (``dt`` a single symbol)."""

    program: Program
    arguments: dict[str, list[sympy.Symbol]] = field(default_factory=dict)


def configuration_programs(robot: Robot, table: object) -> dict[str, ConfigurationProgram]:
    """The robot's configuration maps, joint by joint over its moving joints with entries
    (``Robot.offsets``): ``neutral_configuration`` (no arguments, NQ outputs), ``integrate``
    (``q``, ``v``, ``dt``; NQ), ``difference`` (``q_from``, ``q_to``; NV) and
    ``configuration_rate`` (``q``, ``v``; NQ). ``q`` and ``v`` are the symbol table's
    ``q`` and ``qd``."""
    where_q, where_v = robot.offsets()
    q, v = list(table.q), list(table.qd)   # type: ignore[attr-defined]
    dt = sympy.Symbol("_dt")
    # the entries of difference's two configurations: _q_from<i>, _q_to<i>, names no robot symbol takes
    q_from, q_to = ([sympy.Symbol(f"_{name}{i}") for i in range(len(q))] for name in ("q_from", "q_to"))
    arguments = {"neutral_configuration": {}, "integrate": {"q": q, "v": v, "dt": [dt]},
                 "difference": {"q_from": q_from, "q_to": q_to}, "configuration_rate": {"q": q, "v": v}}
    programs = {name: ConfigurationProgram(Program(), given) for name, given in arguments.items()}
    outputs = {name: [sympy.Integer(0)] * len(v if name == "difference" else q) for name in programs}
    for joint in (j for j in robot.joints if j.owns):
        kind = of(joint)
        i, k = where_q[joint.name], where_v[joint.name]
        qs, vs = slice(i, i + kind.nq), slice(k, k + kind.nv)
        outputs["neutral_configuration"][qs] = kind.neutral()
        outputs["integrate"][qs] = kind.integrate(programs["integrate"].program.let, q[qs], v[vs], dt)
        outputs["difference"][vs] = kind.difference(programs["difference"].program.let, q_from[qs], q_to[qs])
        outputs["configuration_rate"][qs] = kind.rate(programs["configuration_rate"].program.let, q[qs], v[vs])
    for name, entry in programs.items():
        entry.program.outputs = outputs[name]
    return programs


__all__ = ["JOINT_TYPES", "ConfigurationProgram", "Geometry", "JointType", "configuration_programs", "geometry_of",
           "joint_type", "of"]
