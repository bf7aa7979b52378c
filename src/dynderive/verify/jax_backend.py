"""``check --backend jax``: the JAX module (``solve --jax``) against the NumPy module, function
by function, in float64, for a fixed or a floating base."""

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


def jax_checks(derivation: Any, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    """Every function of the JAX module against the NumPy module (``source``) at random states,
    float64 (``jax_enable_x64`` is switched on for this process): with the compiled extension's
    comparison (``compiled.py``), or for a robot with quaternions in ``q`` at states on the
    manifold (random unit quaternions), for a batch and for one state, to 1e-12 relative to the
    result's largest entry (``compiled.floating_rows``, shared with ``check --backend c``)."""
    import jax

    from ..render.targets.jax.jax import render_jax
    from .checks import generated_module

    jax.config.update("jax_enable_x64", True)
    robot = derivation.robot
    module = generated_module(render_jax(derivation), f"{robot.name}_jax")
    from .compiled import compiled_checks, floating_rows

    if robot.floating:
        return floating_rows(generated_module(source, robot.name), module, robot, "JAX", states, seed)
    return compiled_checks(derivation, source, module, states=states, label="JAX", target="jax")
