"""A joint entry's keys that only some joint types read (``JointKind.keys``: a helical joint's
``pitch``), checked against the entry's type: each of its type's keys present and valid, no
other type's key (``model/joint_kinds.py`` lists them; nothing here names a type)."""

from __future__ import annotations

from typing import Any

import sympy

from ..model.joint_kinds import find_kind, joint_keys
from .validator import Validator

#: Every type's own keys: the schema accepts them on any joint entry, and this module says which.
TYPE_KEYS = tuple(joint_keys())


def read_joint_keys(v: Validator, item: dict[str, Any], path: tuple[Any, ...], jtype: str | None,
                    symbols: dict[str, sympy.Expr]) -> tuple[tuple[str, Any], ...]:
    """The values of ``jtype``'s own keys in the entry ``item``, by key, in the type's order;
    problems (a key of another type, a missing or malformed one) go to ``v``."""
    kind = find_kind(jtype)
    own = {key.name: key for key in (kind.keys if kind is not None else ())}
    for name in TYPE_KEYS:
        if name in item and kind is not None and name not in own:
            v.report(path + (name,), f"a {jtype} joint takes no {name}", key=True)
    values: list[tuple[str, Any]] = []
    for name, key in own.items():
        if name not in item:
            v.report(path + ("type",), f"a {jtype} joint needs '{name}' ({key.description})")
            continue
        kpath = path + (name,)
        if key.size:
            if v.vector(item[name], kpath, (key.size,), symbols) is not None:
                values.append((name, tuple(item[name])))
        elif item[name] is None or isinstance(item[name], (bool, list, dict)):
            v.report(kpath, f"expected a number or an expression, got {type(item[name]).__name__}")
        elif v.expression(item[name], kpath, symbols) is not None:
            values.append((name, item[name]))
    return tuple(values)
