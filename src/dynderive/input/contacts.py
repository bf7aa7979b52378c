"""The optional ``contacts`` list of a robot file: frames held by contacts.

Each entry names a ``frame`` of the robot (one of ``frames:``) and its ``kind``: ``point``
(default; the frame origin's acceleration is held, three forces in world-aligned axes) or
``surface`` (the frame's whole twist is held, a force and a moment in the frame's axes). The
generated module's ``constrained_forward_dynamics`` and ``impulse_dynamics`` hold these frames
by default (DESIGN.md section 11). Contacts are 3-D only (with closed loops, the loops hold too). Part of
validation: ``schema.validate`` calls ``read_contacts`` after the frames are read; every problem
is reported on the validator with its position.
"""

from __future__ import annotations

from typing import Any

from ..model.naming import did_you_mean
from ..model.robot import CONTACT_KINDS, Contact, Frame
from .validator import Validator, kind

CONTACT_KEYS = ("frame", "kind")


def read_contacts(v: Validator, top: dict[str, Any], frames: list[Frame], planar: bool) -> list[Contact]:
    """The contacts of ``top`` (none without the key), every problem reported on ``v``: not a
    non-empty list, an entry that is not a mapping or has unknown keys, an unknown frame (with
    the closest name), an unknown kind, a frame listed twice; a planar robot is refused at the
    key."""
    if "contacts" not in top:
        return []
    raw = top["contacts"]
    if planar:
        v.error(("contacts",), "contacts: contact dynamics are 3-D only (this robot is planar)")
        return []
    if not isinstance(raw, list) or not raw:
        v.error(("contacts",), f"contacts: expected a non-empty list of {{frame: NAME, kind: point|surface}}, "
                f"got {kind(raw, empty=True)}")
        return []
    names = [f.name for f in frames]
    written = _written_frame_names(top)   # a frame reported as bad already is not reported again
    taken: dict[str, tuple[Any, ...]] = {}
    contacts: list[Contact] = []
    for i, value in enumerate(raw):
        path = ("contacts", i)
        item = v.mapping(value, path, CONTACT_KEYS, ("frame",))
        if item is None:
            continue
        frame, ok = item.get("frame"), True
        if "frame" in item:
            if not isinstance(frame, str):
                v.report(path + ("frame",), f"expected a frame's name, got {kind(frame)}")
                ok = False
            elif frame not in names:
                if frame not in written:
                    known = "" if names else " (the robot declares no 'frames': declare the contact frame there)"
                    v.report(path + ("frame",), f"unknown frame {frame!r}{did_you_mean(frame, names) or known}")
                ok = False
            elif frame in taken:
                v.report(path + ("frame",), f"frame {frame!r} is already a contact "
                         f"(first at {v.at(taken[frame])})")
                ok = False
            else:
                taken[frame] = path + ("frame",)
        contact_kind = item.get("kind", "point")
        if contact_kind not in CONTACT_KINDS:
            hint = did_you_mean(str(contact_kind), CONTACT_KINDS) if isinstance(contact_kind, str) else ""
            v.report(path + ("kind",), f"unknown contact kind {contact_kind!r}{hint}; expected "
                     f"{' or '.join(CONTACT_KINDS)}")
            ok = False
        if ok and "frame" in item:
            contacts.append(Contact(frame, contact_kind))
    return contacts


def _written_frame_names(top: dict[str, Any]) -> set[Any]:
    """The ``name`` of every mapping of the ``frames`` list as written (valid or not)."""
    raw = top.get("frames")
    return {item.get("name") for item in raw if isinstance(item, dict)} if isinstance(raw, list) else set()
