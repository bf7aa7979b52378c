"""The C99 target (``--c``): ``<name>_dynamics.h`` and ``.c`` (DESIGN.md section 9); its check
harness compiles the extension and compares each function with the NumPy module."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ..target import MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS, Target


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], **options: Any) -> dict[str, bytes]:
    """The header and the source."""
    from .c import render_c

    header, source = render_c(derivation, template_dir)
    name = derivation.robot.name
    return {f"{name}_dynamics.h": header.encode(), f"{name}_dynamics.c": source.encode()}


def offered(derivation: Derivation) -> set[str]:
    """The functions whose prototypes the header declares (extra variants included)."""
    from .c import c_context
    from .c_loops import function_name

    return {function_name(f)[len(derivation.robot.name) + 1:] for f in c_context(derivation)["functions"]}


TARGET = Target(
    name="c", flag="--c", kind="c", title="C", column=1,
    help="Write DIR/<name>_dynamics.h and .c, C99.",
    build_help="Write <name>_dynamics.h and .c (C99).",
    outputs=("{}_dynamics.h", "{}_dynamics.c"),
    templates=("c/dynamics.h.j2", "c/dynamics.c.j2"),
    render=render, offered=offered, progress="generating C",
    option_help=(("check --backend", "also compile the C extension (--c-extension) and compare each of its functions "
                                     "with the NumPy module"),
                 ("simulate --backend", "the C extension (--c-extension), compiled for this run (generalized "
                                        "coordinates)")),
    not_built=(MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS),
)
