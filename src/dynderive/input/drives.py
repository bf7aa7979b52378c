"""Validation of a joint's drive and dissipation terms (``damping``, ``friction``,
``stiffness``, ``rest``, ``armature``): expressions over the parameters, on moving joints
only, not negative at the parameter defaults (``rest`` may be), ``rest`` only with a spring.
Part of validation (``schema._joints`` calls ``drive_terms``)."""

from __future__ import annotations

from typing import Any

import sympy

from ..model.joint_kinds import find_kind

#: The drive keys of a joint, in the order the sheet lists them, and what each is.
DRIVE_KEYS = {
    "damping": "viscous damping",
    "friction": "Coulomb friction",
    "stiffness": "spring stiffness",
    "rest": "spring rest position",
    "armature": "armature (reflected rotor inertia)",
}
#: Terms that must not be negative: a negative one would feed energy in (or make M indefinite).
NON_NEGATIVE = ("damping", "friction", "stiffness", "armature")


def drive_terms(v: Any, item: dict[str, Any], path: tuple[Any, ...], jtype: str | None,
                symbols: dict[str, sympy.Expr]) -> dict[str, Any]:
    """The drive terms of one joint entry, checked; problems go to the validator ``v``.

    Returns ``{key: expression text}`` for the keys present and valid.
    """
    terms: dict[str, Any] = {}
    kind = find_kind(jtype)
    for key in DRIVE_KEYS:
        if key not in item:
            continue
        kpath = path + (key,)
        if kind is not None and (kind.welded or not kind.vector_space):
            v.report(kpath, f"a {jtype} joint has no coordinate, so no {DRIVE_KEYS[key]}" if kind.welded
                     else f"drive terms on a {jtype} joint are not built yet", key=True)
            continue
        if item[key] is None or isinstance(item[key], (bool, list, dict)):
            kind = "nothing" if item[key] is None else type(item[key]).__name__
            v.report(kpath, f"expected a number or an expression, got {kind}")
            continue
        expr = v.expression(item[key], kpath, symbols)
        if expr is None:
            continue
        value = v.numeric(expr)
        if key in NON_NEGATIVE and value is not None and value < 0:
            v.report(kpath, f"{DRIVE_KEYS[key]} must not be negative (got {value:g})")
            continue
        terms[key] = item[key]
    if "rest" in item and "stiffness" not in item and not (kind is not None and kind.welded):
        rpath = path + ("rest",)
        v.report(rpath, "a rest position needs a spring: add 'stiffness'", key=True)
        terms.pop("rest", None)
    return terms
