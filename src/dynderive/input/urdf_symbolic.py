"""A URDF's inertial values as named parameters (``--symbolic PATTERN[,PATTERN...]``).

A pattern is ``LINK.FIELD`` with shell-style wildcards (``panda_hand.mass``, ``panda_link7.*``,
``*.mass``), FIELD one of ``mass``, ``com``, ``inertia``. The values it matches become
parameters whose defaults are the file's values: ``m_<link>``; ``c_<link>_x``, ``_y``, ``_z``
(the ``<inertial><origin xyz>``, in the link frame); ``I_<link>_xx``, ``_xy``, ``_xz``, ``_yy``,
``_yz``, ``_zz`` (the ``<inertia>`` as written, about the COM in the axes of ``<inertial><origin
rpy>``). They enter the same arithmetic as the numbers (the rotation into link axes, the
merging of welded bodies), kept as SymPy expressions whose constants are doubles
(``sympy.Float``, rounded as IEEE doubles), so the robot's values at the defaults are today's
to rounding. Only links whose body enters the dynamics (an ``<inertial>``, not welded to the
world) match.

``<link>`` is the link's name made a name every target takes (``link_stem``): ASCII letters,
digits and single ``_`` (a C struct member), at most 58 characters so that every parameter name
has at most 63 (MATLAB's ``namelengthmax``, a field of the MATLAB struct), ``_2``, ``_3`` ...
when two links would share it. The parameter's description names the link in full.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy
from sympy.printing.str import StrPrinter

from ..errors import InputError, Problem
from ..model.expressions import RESERVED
from ..model.joint_kinds import BALL, FREE
from ..model.naming import acceleration_name, did_you_mean, latex_name, velocity_name
from ..model.robot import floating_names
from .free_joints import planar_floating_names
from .names import MODULE_NAMES

OPTION = "--symbolic"
FIELDS = ("mass", "com", "inertia")
#: The entries of a written inertia, in the URDF's attribute order, and their places in the tensor.
INERTIA_KEYS = (("xx", 0, 0), ("xy", 0, 1), ("xz", 0, 2), ("yy", 1, 1), ("yz", 1, 2), ("zz", 2, 2))
#: The longest parameter name: MATLAB's ``namelengthmax`` (a field of the MATLAB struct), and the
#: initial characters of an identifier C99 guarantees significant (a member of the C struct).
MAX_NAME = 63
#: The longest ``<link>`` of a parameter name: room for the longest, ``I_<link>_xx``.
MAX_STEM = MAX_NAME - len("I__xx")


@dataclass
class SymbolicBody:
    """A body's mass, COM (3) and inertia about the COM (3 x 3, link axes) as expressions."""

    mass: sympy.Expr
    com: list[sympy.Expr]
    inertia: list[list[sympy.Expr]]


def patterns_of(symbolic: str | Sequence[str] | None) -> tuple[str, ...]:
    """The option's text (``a,b``) or a sequence of patterns as one tuple of patterns."""
    if not symbolic:
        return ()
    text = symbolic if isinstance(symbolic, str) else ",".join(symbolic)
    return tuple(text.split(","))


def parse_patterns(patterns: tuple[str, ...]) -> list[tuple[str, str, str, int]]:
    """``(link pattern, field pattern, the pattern, its column)`` of each pattern; a pattern
    that is not ``LINK.FIELD`` or whose FIELD matches no field is refused at the option."""
    parsed, problems, column = [], [], 1
    for text in patterns:
        pattern = text.strip()
        at = column + len(text) - len(text.lstrip())
        link, dot, field = pattern.rpartition(".")
        if not dot or not link or not field:
            problems.append(Problem(OPTION, 1, at, f"expected LINK.FIELD (FIELD: {', '.join(FIELDS)} or *), "
                                                   f"got {pattern!r}"))
        elif not fnmatch.filter(FIELDS, field):
            problems.append(Problem(OPTION, 1, at + len(link) + 1, f"unknown field {field!r} in {pattern!r} "
                                    f"(fields: {', '.join(FIELDS)}){did_you_mean(field, FIELDS)}"))
        else:
            parsed.append((link, field, pattern, at))
        column += len(text) + 1
    if problems:
        raise InputError(problems)
    return parsed


def select(patterns: tuple[str, ...], bodies: dict[str, Any], links: list[str],
           frames: dict[str, tuple[str, Any, Any]]) -> dict[str, list[str]]:
    """The fields made parameters, by link (in the file's order); ``links``: every link of the
    file; ``bodies``: those with an ``<inertial>``; ``frames[link][0]``: ``world`` when it is
    welded to the world. A link pattern with wildcards matches only bodies with mass or
    inertia (not a massless flange); a pattern that matches nothing is refused at the option."""
    candidates = [name for name in links if name in bodies and frames[name][0] != "world"]
    massive = [name for name in candidates if bodies[name].mass or np.any(bodies[name].inertia)]
    chosen: dict[str, set[str]] = {}
    problems = []
    for link, field, pattern, column in parse_patterns(patterns):
        wild = any(char in link for char in "*?[")   # a wildcard skips massless bodies (a flange)
        matched = [name for name in (massive if wild else candidates) if fnmatch.fnmatchcase(name, link)]
        if not matched:
            why = ""
            if link in links and link not in bodies:
                why = f"link '{link}' has no <inertial>; "
            elif link in links:
                why = f"link '{link}' is welded to the world, so its inertia never enters the dynamics; "
            hint = "" if why else did_you_mean(link, candidates)
            problems.append(Problem(OPTION, 1, column, f"no link matches {pattern!r} ({why}links: "
                                    f"{', '.join(candidates) or 'none'}){hint}"))
            continue
        for name in matched:
            chosen.setdefault(name, set()).update(fnmatch.filter(FIELDS, field))
    if problems:
        raise InputError(problems)
    return {name: [f for f in FIELDS if f in chosen[name]] for name in links if name in chosen}


def taken_names(data: dict[str, Any]) -> set[str]:
    """The symbols a robot's data already makes (parameters, coordinates, their derivatives, efforts)."""
    taken = set(data.get("parameters") or {})
    for joint in data.get("joints", []):
        name, kind = joint["name"], joint["type"]
        if kind in (FREE, BALL):
            taken.update(n for names in floating_names(name, kind) for n in names)
        elif kind == "planar_floating":   # pragma: no cover - the planar reader's joints are split
            taken.update(planar_floating_names(name))
        else:
            taken.update((name, velocity_name(name), acceleration_name(name)))
        if joint.get("effort"):
            taken.add(joint["effort"])
    return taken


def free_name(base: str, taken: set[str]) -> str:
    """``base``, or ``base_2``, ``base_3`` ... the first that no symbol has, the generated
    module does not use, and that typesets unlike every taken name (``base`` cut before the
    suffix where the name would be longer than ``MAX_NAME``)."""
    typeset = {latex_name(name) for name in taken}
    name, k = base, 1
    while name in taken or name in MODULE_NAMES or name in RESERVED or latex_name(name) in typeset:
        k += 1
        name = f"{base[:MAX_NAME - len(str(k)) - 1].rstrip('_')}_{k}"   # at most MAX_NAME characters
    taken.add(name)
    return name


def link_stem(name: str, ident: Any, used: set[str]) -> str:
    """The ``<link>`` of a link's parameter names (``m_<link>``...): the name as ASCII
    letters, digits and single ``_`` without one at either end (C refuses ``__`` in a struct
    member: ``tool_`` would give ``c_tool__x``), ``link`` if nothing is left, made an identifier
    by ``ident`` (the URDF reader's: ``r_`` before a digit), cut to ``MAX_STEM`` characters
    (MATLAB's 63 for the whole name), and ``_2``, ``_3`` ... when ``used`` (the stems of the
    links before) has it."""
    cleaned = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_") or "link"
    stem = ident(cleaned)[:MAX_STEM].rstrip("_")
    base, k = stem, 1
    while stem in used:
        k += 1
        stem = f"{base[:MAX_STEM - len(str(k)) - 1].rstrip('_')}_{k}"
    used.add(stem)
    return stem


class _Printer(StrPrinter):
    """SymPy's text with every float as its shortest round-trip decimal (the parser reads it back exactly)."""

    def _print_Float(self, expr: sympy.Float) -> str:
        return repr(float(expr))


def text(expr: sympy.Expr) -> str:
    return _Printer().doprint(expr)


def _f(x: float) -> sympy.Expr:
    return sympy.Float(float(x))


def scaled(c: float, e: sympy.Expr) -> sympy.Expr:
    """``c * e`` without the noise of ``1.0 *`` and ``0.0 *``."""
    if c == 0:
        return sympy.S.Zero
    return e if c == 1 else (-e if c == -1 else _f(c) * e)


def rotate(R: np.ndarray, T: list[list[sympy.Expr]]) -> list[list[sympy.Expr]]:
    """``R T R^T`` of a symbolic 3 x 3 tensor (``T`` itself when ``R`` is the identity)."""
    if np.array_equal(R, np.eye(3)):
        return [row[:] for row in T]
    RT = [[sympy.Add(*(scaled(R[i, k], T[k][j]) for k in range(3))) for j in range(3)] for i in range(3)]
    return [[sympy.Add(*(scaled(R[j, k], RT[i][k]) for k in range(3))) for j in range(3)] for i in range(3)]


def transform(R: np.ndarray, p: np.ndarray, c: list[sympy.Expr]) -> list[sympy.Expr]:
    """``R c + p`` of a symbolic point."""
    return [sympy.Add(*(scaled(R[i, k], c[k]) for k in range(3))) + _f(p[i]) for i in range(3)]


def of_numbers(mass: float, com: np.ndarray, inertia: np.ndarray) -> SymbolicBody:
    tensor = [[_f(inertia[i, j]) for j in range(3)] for i in range(3)]
    return SymbolicBody(_f(mass), [_f(x) for x in com], tensor)


def combine(a: SymbolicBody, b: SymbolicBody) -> SymbolicBody:
    """Two bodies welded together (mass, COM, inertia about the COM), as ``urdf_bodies.combine``
    does with numbers, written about the origin and shifted back to the COM (shorter
    expressions than shifting each body to a COM that is itself a quotient):
    ``I = sum(I_k + m_k (|c_k|^2 E - c_k c_k^T)) - (|h|^2 E - h h^T) / M``, ``h = sum m_k c_k``."""
    mass = a.mass + b.mass
    h = [a.mass * a.com[i] + b.mass * b.com[i] for i in range(3)]
    com = [h[i] / mass for i in range(3)]
    hh = sum(x * x for x in h)
    inertia = [[-((hh if i == j else 0) - h[i] * h[j]) / mass for j in range(3)] for i in range(3)]
    for body in (a, b):
        cc = sum(x * x for x in body.com)
        for i in range(3):
            for j in range(3):
                shift = (cc if i == j else 0) - body.com[i] * body.com[j]
                inertia[i][j] += body.inertia[i][j] + body.mass * shift
    return SymbolicBody(mass, com, inertia)


@dataclass
class Declared:
    """A parameter made of a URDF value: a placeholder symbol until it is named (``name``)."""

    symbol: sympy.Symbol
    base: str
    value: float
    unit: str
    description: str
    at: tuple[int, int]


def attach(bodies: dict[str, Any], chosen: dict[str, list[str]], ident: Any) -> list[Declared]:
    """Give each chosen body (``Body`` of ``urdf_bodies``) its values as expressions, the chosen
    fields as placeholder symbols; ``ident``: a link name as an identifier (``link_stem``)."""
    declared: list[Declared] = []
    stems: set[str] = set()

    def declare(base: str, value: float, unit: str, description: str, element: Any) -> sympy.Symbol:
        symbol = sympy.Dummy(base)
        declared.append(Declared(symbol, base, float(value), unit, description, element.at))
        return symbol

    for name, fields in chosen.items():
        body = bodies[name]
        link = link_stem(name, ident, stems)
        inertial = body.element
        mass: sympy.Expr = _f(body.mass)
        if "mass" in fields:
            mass = declare(f"m_{link}", body.mass, "kg", f"mass of link '{name}' (URDF)",
                           inertial.find("mass") or inertial)
        com = [_f(x) for x in body.com]
        if "com" in fields:
            where = inertial.find("origin") or inertial
            com = [declare(f"c_{link}_{axis}", body.com[i], "m", f"centre of mass of link '{name}', "
                           f"{axis} (URDF)", where) for i, axis in enumerate("xyz")]
        if "inertia" in fields and body.written is not None:
            written: list[list[sympy.Expr]] = [[sympy.S.Zero] * 3 for _ in range(3)]
            where = inertial.find("inertia") or inertial
            for key, i, j in INERTIA_KEYS:
                written[i][j] = written[j][i] = declare(
                    f"I_{link}_{key}", body.written[i, j], "kg m^2",
                    f"inertia of link '{name}' about its centre of mass, {key} (URDF)", where)
            inertia = rotate(body.axes if body.axes is not None else np.eye(3), written)
        else:
            inertia = [[_f(body.inertia[i, j]) for j in range(3)] for i in range(3)]
        body.symbolic = SymbolicBody(mass, com, inertia)
    return declared


def name_parameters(data: dict[str, Any], declared: list[Declared]) -> dict[sympy.Symbol, sympy.Symbol]:
    """Name the parameters (valid, unique: ``free_name``) and add them to the robot data's
    ``parameters``; the placeholder -> named symbol."""
    taken = taken_names(data)
    named = {}
    for item in declared:
        name = free_name(item.base, taken)
        named[item.symbol] = sympy.Symbol(name)
        data["parameters"][name] = {"value": item.value, "unit": item.unit, "description": item.description}
    return named


def entries(body: SymbolicBody, named: dict[sympy.Symbol, sympy.Symbol]) -> dict[str, list[Any]]:
    """The robot file's ``mass``, ``com`` and ``inertia`` (xx, yy, zz, xy, xz, yz) of a body: an
    expression's text where it depends on a parameter, else None (the caller keeps the number)."""
    def one(expr: sympy.Expr) -> str | None:
        return text(expr.xreplace(named)) if expr.free_symbols else None

    T = body.inertia
    return {"mass": [one(body.mass)], "com": [one(c) for c in body.com],
            "inertia": [one(T[i][j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]}
