"""Which functions of the generated API each code target offers, read from the targets' own
code, and the functions a target does not build, each with its reason (``NOT_BUILT``, gathered
from the registry: each target's entry lists its own, ``Target.not_built``).

The NumPy module's API is the reference: every other target (the C99 target, its compiled
Python extension, MATLAB/Octave, JAX, CasADi) offers each of its functions or lists it in its
entry's ``not_built``. ``offered`` reads a target's functions from what it generates (the public
functions of the rendered Python modules, the C target's prototypes, the extension's binding
table, the MATLAB function files), so the table in the documentation (``markdown_table``) and
``check --backend c`` / ``--backend jax`` (``not_built``) cannot drift from the code.
"""

from __future__ import annotations

from typing import Any

from ..derivation import Derivation
from .targets import COLUMNS, REFERENCE, NotBuilt, by_name

#: The targets by name, in the table's column order (the registry's, ``render/targets``).
TARGETS = tuple(target.name for target in COLUMNS)
TITLES = {target.name: target.title for target in COLUMNS}

#: What each target does not build, (target, row), gathered from the registry's entries
#: (``Target.not_built``) in the table's column order.
NOT_BUILT: tuple[tuple[str, NotBuilt], ...] = tuple((target.name, row) for target in COLUMNS for row in target.not_built)


def not_built(target: str, function: str, floating: bool = False, frames: bool = True,
              loops: bool = False) -> str | None:
    """Why ``target`` does not build ``function`` for a robot with a ``floating`` base (or not),
    ``frames`` (or none) and closed ``loops`` (or none), or None if it should: its entry's rows,
    then the reference's (what the NumPy module does not build is expected of no target)."""
    entry = next((t for t in COLUMNS if t.name == target), None)
    if entry is None:
        return None
    for row in (*entry.not_built, *(REFERENCE.not_built if entry is not REFERENCE else ())):
        if function in row.functions and row.concerns(floating, frames, loops):
            return row.reason
    return None


def _why(derivation: Derivation, target: str, function: str) -> str | None:
    robot = derivation.robot
    return not_built(target, function, bool(robot.floating), bool(robot.frames), bool(robot.loops))


def offered(derivation: Derivation, target: str) -> set[str]:
    """The API functions ``target`` generates for ``derivation``'s robot (extra C variants
    such as ``inverse_dynamics_wrenches`` included): its registry entry reads them from its
    own code."""
    try:
        entry = by_name(target)
    except StopIteration:
        raise ValueError(f"unknown target {target!r}") from None
    return entry.offered(derivation)


def api(derivation: Derivation) -> set[str]:
    """The functions of the generated API that concern this robot: the NumPy module's, and
    those NOT_BUILT lists for the NumPy module of such a robot."""
    listed = {f for row in REFERENCE.not_built for f in row.functions}
    return offered(derivation, REFERENCE.name) | {f for f in listed if _why(derivation, REFERENCE.name, f)}


def gaps(derivation: Derivation, target: str) -> dict[str, str | None]:
    """The API functions ``target`` does not offer for this robot, each with its reason from
    NOT_BUILT (None: not listed there, an omission)."""
    missing = api(derivation) - offered(derivation, target)
    return {f: _why(derivation, target, f) for f in sorted(missing)}


def markdown_table(derivations: list[Any]) -> str:
    """One Markdown table of the API functions of ``derivations``' robots (rows, in the order
    first met) against the targets: "yes" where each robot's target offers it, else the
    NOT_BUILT reason's letter; the reasons, lettered, after the table."""
    order: list[str] = []
    cells: dict[tuple[str, str], set[str]] = {}
    robots: dict[str, list[str]] = {}
    reasons: list[str] = []
    for derivation in derivations:
        wanted = api(derivation)
        reference = offered(derivation, REFERENCE.name)
        order += sorted(wanted - set(order), key=lambda f: (f not in reference, f))
        for function in wanted:
            robots.setdefault(function, []).append(derivation.robot.name + (" (floating base)"
                                                                           if derivation.robot.floating else ""))
        for target in TARGETS:
            have = offered(derivation, target)
            for function in (f for f in order if f in wanted):   # in order: the reasons' letters never hash-dependent
                reason = None if function in have else _why(derivation, target, function)
                if function not in have and reason is None:
                    raise ValueError(f"{target} lacks {function} for {derivation.robot.name}, not listed in NOT_BUILT")
                if reason is not None and reason not in reasons:
                    reasons.append(reason)
                cells.setdefault((function, target), set()).add("yes" if reason is None else reason)
    every = len(derivations)
    order.sort(key=lambda f: len(robots[f]) != every)   # stable: the functions of every robot first
    lines = ["| Function | Robots | " + " | ".join(TITLES[t] for t in TARGETS) + " |",
             "| --- | --- |" + " --- |" * len(TARGETS)]
    for function in order:
        row = [f"`{function}`", "all" if len(robots[function]) == every else ", ".join(robots[function])]
        for target in TARGETS:
            values = cells[(function, target)]
            marks = [f"not built ({chr(97 + reasons.index(v))})" for v in sorted(values - {"yes"}, key=reasons.index)]
            row.append(", ".join((["yes"] if "yes" in values else []) + marks))
        lines.append("| " + " | ".join(row) + " |")
    lines += [""] + [f"- ({chr(97 + i)}) {reason}." for i, reason in enumerate(reasons)]
    return "\n".join(lines) + "\n"


__all__ = ["NOT_BUILT", "TARGETS", "api", "gaps", "markdown_table", "not_built", "offered"]
