"""The MATLAB/Octave target (``--matlab``): the package ``+<name>/`` (one numeric function per
file) and ``<name>_derivation.m``, the derivation as a Symbolic Math Toolbox script (fixed base
only) (DESIGN.md section 9)."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ...api import group
from ..target import MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS, NotBuilt, Target


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], **options: Any) -> dict[str, bytes]:
    """The package's files (paths relative to the output folder) and, for a fixed base, the script."""
    from .matlab import render_matlab
    from .matlab_script import render_matlab_script

    files = {path: text.encode() for path, text in render_matlab(derivation, template_dir).items()}
    if not derivation.robot.floating:   # the symbolic path does not apply to quaternion coordinates
        files[f"{derivation.robot.name}_derivation.m"] = render_matlab_script(derivation, template_dir).encode()
    return files


def offered(derivation: Derivation) -> set[str]:
    """The package's numeric functions."""
    from .matlab import numeric_functions as functions

    return {f.name for f in functions(derivation)}


TARGET = Target(
    name="matlab", flag="--matlab", kind="matlab", title="MATLAB", column=3,
    help="Write DIR/<name>_derivation.m, the derivation as a Symbolic Math Toolbox script, and DIR/+<name>/, numeric "
         "MATLAB/Octave functions (one per file: mass_matrix, forward_dynamics, ...).",
    build_help="Write <name>_derivation.m and +<name>/ (MATLAB/Octave).",
    # the package +<name>/ (every one has parameters.m) and the derivation script
    outputs=("+{}/parameters.m", "{}_derivation.m"),
    templates=("matlab/function.m.j2", "matlab/derivation.m.j2"),
    render=render, offered=offered, progress="generating MATLAB",
    reads=("code", "sheet", "kinematics"),   # the script derives the sheet's quantities and checks
    not_built=(MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS,
               NotBuilt(group("frames"), "frameless", "a robot without frames: MATLAB writes no frame functions "
                                                      "(the NumPy module's raise for any frame name)")),
)
