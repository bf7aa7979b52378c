"""dynderive: equations of motion of robots, derived symbolically, rendered for people and code."""

from __future__ import annotations

from pathlib import Path

from .derivation import Derivation, derive
from .errors import DynderiveError, InputError
from .lagrange import (
    christoffel_coriolis,
    constraint_jacobian_dot,
    gravity_vector,
    lagrange_equations,
    time_derivative,
)
from .model import Joint, Link, Parameter, Robot

__version__ = "0.1.0"


def load_robot(robot: str | Path) -> Robot:
    """Load and validate a robot file (YAML path) or a bundled robot by name."""
    from .loader import load_document, resolve_robot_path
    from .schema import validate

    path = resolve_robot_path(robot)
    if path.suffix.lower() == ".urdf":
        from .loader import read_text
        from .urdf import read_urdf

        return validate(read_urdf(read_text(path), str(path)))
    return validate(load_document(path))


def render_latex(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The LaTeX solution sheet as a string (nothing is written)."""
    from .render.latex import render_latex as _render

    return _render(derivation, template_dir)


def render_code(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The generated NumPy module as a string (nothing is written)."""
    from .render.code import render_code as _render

    return _render(derivation, template_dir)


def render_json(derivation: Derivation) -> str:
    """The JSON dump of every quantity (DESIGN.md section 5) as a string."""
    from .render.json import render_json as _render

    return _render(derivation)


__all__ = [
    "Derivation", "DynderiveError", "InputError", "Joint", "Link", "Parameter", "Robot",
    "christoffel_coriolis", "constraint_jacobian_dot", "derive", "gravity_vector",
    "lagrange_equations", "load_robot", "render_code", "render_json", "render_latex",
    "time_derivative", "__version__",
]
