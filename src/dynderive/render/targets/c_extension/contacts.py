"""The C extension's contact dynamics (DESIGN.md sections 11 and 13): ``constrained_forward_dynamics``
and ``impulse_dynamics`` of a 3-D robot (its closed loops held too, with the Baumgarte gains
``alpha`` and ``beta`` as keywords), with the NumPy module's signatures.

Their arguments (contacts as names, indices of FRAMES or (frame, kind) pairs, the Baumgarte
gains, the anchors) are read by a little Python (``c_extension/extension_contacts.py.j2``) that
the module runs once when it is imported, as the NumPy module reads them; the batch loop is C
(``c_extension/extension_contacts.c.j2``), one call of the C target's
``<name>_constrained_forward_dynamics`` or ``<name>_impulse_dynamics`` per state. Redundant
contacts raise ValueError (the NumPy module's message); a state whose M is not positive definite
gives NaN. No external wrenches: ``wrenches`` must be None (the C target takes none there).
"""

from __future__ import annotations

from pathlib import Path

from ....derivation import Derivation
from ... import api
from ...encode import Code, docstring, python_literal
from ...environment import render

TEMPLATE = "c_extension/extension_contacts.py.j2"
NAMES = ("constrained_forward_dynamics", "impulse_dynamics")


def contact_names(derivation: Derivation) -> set[str]:
    """The functions the extension adds for this robot."""
    return set() if derivation.contact_programs is None else set(NAMES)


def contact_source(derivation: Derivation, template_dir: str | Path | None = None) -> list[str]:
    """The Python's lines (``extension.c.j2`` prints them as C string literals); none where
    contact dynamics are not built."""
    robot = derivation.robot
    if derivation.contact_programs is None:
        return []
    size = api.sizes(derivation)
    notes = {"constrained_forward_dynamics": " contacts: names or indices of FRAMES or (frame, kind) pairs "
             "(kind 'point' or 'surface'; default CONTACT_KINDS, else point); baumgarte: (kp, kd); anchors: one "
             "per contact (a point's position (..., 3), a surface's pose (..., 4, 4)), needed for kp. "
             "wrenches: None only (the compiled module applies no external wrench here). Redundant contacts "
             "raise ValueError; NaN where M is not positive definite.",
             "impulse_dynamics": " contacts as for constrained_forward_dynamics; restitution: a number. Redundant "
             "contacts raise ValueError; NaN where M is not positive definite."}
    source = render("code", TEMPLATE, {
        "contacts_tuple": python_literal(tuple(c.frame for c in robot.contacts)),
        "contact_kinds": Code("{" + ", ".join(f"{python_literal(c.frame)}: {python_literal(c.kind)}"
                                              for c in robot.contacts) + "}"),
        "parameters": [{"name": p.name, "default": None if p.value is None else python_literal(float(p.value))}
                       for p in robot.parameters],
        "nq": size["NQ"], "nv": size["NV"], "nu": len(derivation.symbols.efforts), "loops": bool(robot.loops),
        "doc_forward": docstring(api.python_doc("constrained_forward_dynamics", size) + notes[NAMES[0]]),
        "doc_impulse": docstring(api.python_doc("impulse_dynamics", size) + notes[NAMES[1]]),
    }, template_dir)
    return source.splitlines(keepends=True)
