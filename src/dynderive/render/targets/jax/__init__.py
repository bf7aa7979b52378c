"""The JAX target (``--jax``): ``<name>_dynamics_jax.py``, the NumPy module's API on
``jax.numpy`` (DESIGN.md section 9); its check harness compares it with the NumPy module."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ..target import OptionalPackage, Target, public


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], **options: Any) -> dict[str, bytes]:
    """The module, for a fixed or a floating base."""
    from .jax import render_jax

    return {f"{derivation.robot.name}_dynamics_jax.py": render_jax(derivation, template_dir).encode()}


def offered(derivation: Derivation) -> set[str]:
    """The module's public functions."""
    from .jax import render_jax

    return public(render_jax(derivation))


#: JAX, an optional dependency (the jax extra) the module imports.
JAX = OptionalPackage("jax", "JAX", install="pip install jax")


TARGET = Target(
    name="jax", flag="--jax", kind="jax", title="JAX", column=4,
    help="Write DIR/<name>_dynamics_jax.py, the NumPy module's API on jax.numpy (jit, vmap, grad; float32 and "
         "float64); importing it needs JAX (the jax extra).",
    build_help="Write <name>_dynamics_jax.py (JAX).",
    outputs=("{}_dynamics_jax.py",),
    # the macro file is imported by a name the template sets (python_backend), which build's
    # walk of the includes cannot follow: named here
    templates=("jax/dynamics.py.j2", "jax/python_backend.j2"),
    render=render, offered=offered, progress="generating JAX",
    note=JAX.missing_note,
    option_help=(("check --backend", "the same for the JAX module (--jax; needs jax)"),
                 ("simulate --backend", "the JAX module (--jax), in float64, called eagerly (generalized "
                                        "coordinates; needs jax)")),
)
