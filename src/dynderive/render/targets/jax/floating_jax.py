"""The JAX target of a floating-base robot (``solve --floating-base --jax``):
``<name>_dynamics_jax.py``, the floating-base NumPy module's API (``floating_code.py``) on
``jax.numpy``.

The same straight-line programs (``floating_context``'s bodies) run on the columns of
``jax.numpy`` arrays through ``render/targets/jax/jax.py``'s machinery, shared by template includes
(``jax/arrays.py.j2``: ``_coordinates``, ``_stack``, ``_blocks``; ``jax/bodies.py.j2``:
``_evaluate``, ``_hold`` at the lines ``holds`` picks, the bodies); the manifold functions
(``integrate``, ``difference``, ``configuration_rate``, ``neutral_configuration``) are written
without in-place writes (``.at[...].set``) or branches on values (``jnp.where``, with a norm
whose derivative at zero is 0, not NaN), so ``jax.jacfwd`` of a function composed with
``integrate`` at ``dq = 0`` is finite and equals the generated ``linearize``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ....derivation import Derivation
from ...python_module import render_module
from ..numpy.floating_code import floating_context
from .jax import JAX_IMPORTS, holds

FLOATING_JAX_TEMPLATE = "jax/floating_dynamics.py.j2"


def floating_jax_context(derivation: Derivation) -> dict[str, Any]:
    """The floating-base NumPy module's context (``floating_context``) with where each body
    holds its values (``holds``) and the functions each body takes."""
    context = floating_context(derivation)
    context["holds"] = {p.name: holds(p.lines, p.outputs) for p in context["programs"]}
    context["body_functions"] = {p.name: tuple(p.functions) + (("_hold",) if context["holds"][p.name] else ())
                                 for p in context["programs"]}
    context["module"] = f"{derivation.robot.name}_dynamics_jax"
    return context


def render_floating_jax(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The text of a floating-base robot's ``<name>_dynamics_jax.py``, checked as ``render_jax``
    checks a fixed-base robot's (it parses, imports only ``jax``, its docstring reads back the
    robot's title) before it is returned."""
    return render_module(derivation, FLOATING_JAX_TEMPLATE, floating_jax_context(derivation), template_dir,
                         JAX_IMPORTS)


__all__ = ["FLOATING_JAX_TEMPLATE", "floating_jax_context", "render_floating_jax"]
