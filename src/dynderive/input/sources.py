"""One entry for every kind of robot file: YAML, URDF, or MJCF (an ``.xml`` whose root is
``<mujoco>``; one whose root is ``<robot>`` is a URDF). Only this module chooses the reader."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError, Problem
from .loader import SourceDocument, parse_yaml, read_text


def kind_of(path: Path, text: str | None = None) -> str:
    """``"urdf"``, ``"mjcf"`` or ``"yaml"``, by suffix (and an ``.xml`` file's root element)."""
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        return "urdf"
    if suffix == ".xml":
        from .mjcf_positions import root_tag

        return "urdf" if root_tag(read_text(path) if text is None else text) == "robot" else "mjcf"
    return "yaml"


def read_source(path: Path, floating_base: bool = False,
                symbolic: str | tuple[str, ...] | list[str] | None = None) -> SourceDocument:
    """The robot file at ``path`` as data with positions (not yet validated)."""
    if isinstance(symbolic, str) and not symbolic:   # --symbolic '': a pattern left out, not "none"
        from .urdf_symbolic import parse_patterns

        parse_patterns(("",))
    text = read_text(path)
    kind = kind_of(path, text)
    if kind == "urdf":
        from .urdf import read_urdf

        return read_urdf(text, str(path), floating_base, symbolic)
    what = "an MJCF file" if kind == "mjcf" else "a YAML robot file"
    if floating_base:
        raise InputError(Problem("--floating-base", 1, 1, f"--floating-base floats a URDF's root link; {what} "
                                 "declares its floating joint itself (" +
                                 ("<freejoint/>" if kind == "mjcf" else "type: floating") + ")"))
    if symbolic:
        raise InputError(Problem("--symbolic", 1, 1, f"--symbolic makes a URDF's inertial values parameters; "
                                 f"{what} " + ("is read with its compiled values" if kind == "mjcf"
                                               else "names its parameters itself (its parameters block)")))
    if kind == "mjcf":
        from .mjcf import read_mjcf

        return read_mjcf(path, text, str(path))
    return parse_yaml(text, str(path))
