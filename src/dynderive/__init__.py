"""dynderive: equations of motion of robots, derived symbolically, rendered for people and code.

The package imports nothing heavy until an attribute is used (SymPy takes half a second to
import), so the command line starts at once and an early Ctrl-C exits quietly.

>>> import dynderive
>>> d = dynderive.derive(dynderive.load_robot("rp_arm"))       # doctest: +SKIP
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from ._version import __version__
    from .derivation import Derivation, derive
    from .errors import DynderiveError, InputError
    from .mechanics.lagrange import (
        christoffel_coriolis,
        constraint_jacobian_dot,
        gravity_vector,
        lagrange_equations,
        time_derivative,
    )
    from .model.robot import Joint, Link, Parameter, Robot

#: Public names and the modules that define them, imported on first use.
_LAZY = {
    "__version__": "_version",
    "Derivation": "derivation", "derive": "derivation",
    "DynderiveError": "errors", "InputError": "errors",
    "christoffel_coriolis": "mechanics.lagrange", "constraint_jacobian_dot": "mechanics.lagrange",
    "gravity_vector": "mechanics.lagrange", "lagrange_equations": "mechanics.lagrange", "time_derivative": "mechanics.lagrange",
    "Joint": "model.robot", "Link": "model.robot", "Parameter": "model.robot", "Robot": "model.robot",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'dynderive' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)


def load_robot(robot: str | Path, size_limits: bool = False, floating_base: bool = False,
               symbolic: str | tuple[str, ...] | list[str] | None = None) -> Robot:
    """Load and validate a robot file (YAML or URDF path) or a bundled robot by name.

    With ``size_limits`` (the command line's), a robot beyond the documented limits of the
    whole derivation (``input/limits.py``) is refused before any work; the library leaves it
    to the caller, who may want only the programs that do not grow like n^3. With
    ``floating_base`` a URDF's root link floats (a ``floating`` joint ``root_joint``). ``symbolic``:
    patterns ``LINK.FIELD`` (``"panda_hand.*"``, ``"*.mass"``; FIELD ``mass``, ``com`` or
    ``inertia``) whose inertial values of a URDF become parameters (``m_<link>``, ``c_<link>_x``,
    ``I_<link>_xx``...), the file's values their defaults (``--symbolic``)."""
    from .input.limits import check_size
    from .input.loader import resolve_robot_path
    from .input.schema import validate
    from .input.sources import read_source

    document = read_source(resolve_robot_path(robot), floating_base, symbolic)
    model = validate(document)
    if size_limits:
        check_size(model, document)
    return model


def render_latex(derivation: Derivation, template_dir: str | Path | None = None,
                 sections: tuple[str, ...] | None = None, digits: int | None = None) -> str:
    """The LaTeX solution sheet as a string (nothing is written): ``sections`` among
    ``"generalized", "maximal", "checks"`` (default: what the robot's size makes readable);
    numbers to ``digits`` significant digits at most (default: as many as the file wrote)."""
    from .render.sheets.latex import render_latex as _render

    return _render(derivation, template_dir, sections, digits)


def render_code(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The generated NumPy module as a string (nothing is written)."""
    from .render.targets.numpy.code import render_code as _render

    return _render(derivation, template_dir)


def render_json(derivation: Derivation) -> str:
    """The JSON dump of every quantity (DESIGN.md section 5) as a string."""
    from .render.sheets.json import render_json as _render

    return _render(derivation)


__all__ = [
    "Derivation", "DynderiveError", "InputError", "Joint", "Link", "Parameter", "Robot",
    "christoffel_coriolis", "constraint_jacobian_dot", "derive", "gravity_vector",
    "lagrange_equations", "load_robot", "render_code", "render_json", "render_latex",
    "time_derivative", "__version__",
]
