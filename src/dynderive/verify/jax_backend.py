"""``check --backend jax``: the JAX module (``solve --jax``) against the NumPy module, function
by function, in float64, with the comparison of the compiled extension (``compiled.py``)."""

from __future__ import annotations

from typing import Any

from ..errors import InputError, Problem
from .rows import Row


def require_jax() -> None:
    """``InputError`` at ``--backend``, before any work, when ``jax`` cannot be imported."""
    try:
        import jax  # noqa: F401
    except ImportError:
        raise InputError(Problem("--backend", 1, 1, "--backend jax needs the jax package "
                                 "(pip install jax)")) from None


def jax_checks(derivation: Any, source: str, states: int = 12) -> list[Row]:
    """Every function of the JAX module against the NumPy module (``source``) at random states,
    float64 (``jax_enable_x64`` is switched on for this process)."""
    import jax

    from ..render.targets.jax.jax import render_jax
    from .checks import generated_module
    from .compiled import compiled_checks

    jax.config.update("jax_enable_x64", True)
    module = generated_module(render_jax(derivation), f"{derivation.robot.name}_jax")
    return compiled_checks(derivation, source, module, states=states, label="JAX", target="jax")
