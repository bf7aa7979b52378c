"""``simulate --contacts``: which frames a run holds (``parse_contacts``) and the forward
dynamics that holds them (``held_contacts``), with the generated module's contact dynamics."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import InputError, Problem
from ..model.naming import did_you_mean
from ..model.robot import Robot
from .options import problem


def parse_contacts(robot: Robot, text: str | None, coordinates: str, compiled: bool) -> list[tuple[str, str]]:
    """``--contacts FRAME[:KIND][,FRAME[:KIND]...]`` (KIND point or surface; default the robot
    file's kind, else point), ``none``, or (not given) the robot file's ``contacts:``: the
    contacts a run holds, as (frame, kind). Refused (exit 2) where they are not built: planar
    robots, maximal coordinates, the compiled backend."""
    declared = {c.frame: c.kind for c in robot.contacts}
    if text is None and declared and compiled:
        raise InputError(problem("--backend", "the compiled module has no contact dynamics, and the robot file "
                                 "declares contacts: use --backend numpy, or --contacts none"))
    if text is None:
        return list(declared.items())
    if text.strip().lower() == "none":
        return []
    why = ("contact dynamics are 3-D only (this robot is planar)" if robot.planar else
           "contacts are held in generalized coordinates only" if coordinates == "maximal" else
           "the compiled module has no contact dynamics: use --backend numpy" if compiled else None)
    if why:
        raise InputError(problem("--contacts", why))
    frames = [f.name for f in robot.frames]
    held: list[tuple[str, str]] = []
    column = 1
    for part in text.split(","):
        name, _, kind = part.strip().partition(":")
        if name not in frames:
            hint = did_you_mean(name, frames) or (f" (frames: {', '.join(frames)})" if frames else
                                                  " (this robot declares no frames)")
            raise InputError(problem("--contacts", f"unknown frame {name!r}{hint}", column))
        kind = kind.strip() or declared.get(name, "point")
        if kind not in ("point", "surface"):
            raise InputError(problem("--contacts", f"unknown contact kind {kind!r} of {name}; expected point or "
                                     "surface", column))
        if any(name == other for other, _ in held):
            raise InputError(problem("--contacts", f"frame {name!r} is listed twice", column))
        held.append((name, kind))
        column += len(part) + 1
    return held


def held_contacts(module: Any, held: list[tuple[str, str]], q0: np.ndarray, qd0: np.ndarray, baumgarte: float,
                  values: dict[str, float], declared_at: tuple[str, int, int] | None = None
                  ) -> tuple[np.ndarray, Callable[..., np.ndarray]]:
    """(the start velocity after a plastic impact on the contacts, forward dynamics holding
    them): anchors at their start poses, Baumgarte gains kp = b**2, kd = 2 b. Redundant
    contacts are refused at ``--contacts``, or at ``declared_at`` (the robot file's
    ``contacts:``, ``(file, line, column)``) when they are the file's."""
    anchors = [module.frame_transform(q0, frame, **values) for frame, _ in held]
    anchors = [pose[:3, 3] if kind == "point" else pose for pose, (_, kind) in zip(anchors, held)]
    try:
        with np.errstate(all="ignore"):
            qd0 = module.impulse_dynamics(q0, qd0, held, 0.0, **values)[0]
    except ValueError as exc:
        if declared_at is None:
            raise InputError(problem("--contacts", str(exc))) from None
        raise InputError(Problem(*declared_at, f"contacts: {exc}; or run with --contacts naming fewer, or "
                                 "--contacts none")) from None

    def forward(q: np.ndarray, qd: np.ndarray, u: np.ndarray, w: Any, **options: Any) -> np.ndarray:
        return module.constrained_forward_dynamics(q, qd, u, held, (baumgarte ** 2, 2.0 * baumgarte),
                                                   anchors=anchors, wrenches=w, **options)[0]
    return qd0, forward
