"""The generated NumPy module of every robot: CSE per function, a NumPy printer, blocks into
one template (``dynamics.py.j2``). A robot with quaternions in ``q`` (floating base,
spherical joints: NQ != NV) takes its tangent-space sections (``dynamics_manifold.py.j2``),
its configuration maps printed from the joint types (``Derivation.configuration_programs``).

Numbers: constant sub-expressions (``sqrt(2)/2``, ``E``, a square root of a 17-digit
rational from a CAD file's axis) are folded to correctly rounded floats, printed with
``repr`` (17 significant digits, exact round trip); only integers and rationals that a double
holds exactly stay as they were written. Free text reaches the module only through the
encoders of ``encode.py``, and the rendered module is parsed back and checked before anyone
can write or import it.
"""

from __future__ import annotations

from pathlib import Path

from ....derivation import Derivation
from ...codegen.conventions import robot_kind
from ...codegen.python_context import code_context
from ...python_module import render_module, render_test_module

CODE_TEMPLATE = "dynamics.py.j2"


def render_code(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    return render_module(derivation, CODE_TEMPLATE, code_context(derivation), template_dir)


def render_code_tests(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """A pytest file of property checks for the generated module (``solve --code --tests``)."""
    robot = derivation.robot
    return render_test_module(derivation, "dynamics_test.py.j2", template_dir, maximal=robot.planar,
                              loops=bool(robot.loops), loop_partition=bool(robot.loops) and not robot.floating,
                              robot_kind=robot_kind(robot))
