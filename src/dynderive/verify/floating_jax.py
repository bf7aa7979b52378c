"""``check --backend jax`` of a floating-base robot: its JAX module (``solve --floating-base
--jax``) against its NumPy module, function by function, in float64, at random states on the
manifold (random unit quaternions), to 1e-12 relative to the result's largest entry (the
comparison of ``floating_c.py``, shared with ``check --backend c``)."""

from __future__ import annotations

from typing import Any

from .floating_c import FUNCTIONS, floating_rows
from .rows import Row

__all__ = ["FUNCTIONS", "floating_jax_checks"]


def floating_jax_checks(derivation: Any, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    """One row per function of the floating-base NumPy module (``source``) against the JAX
    module, for a batch of ``states`` states and for one state; ``jax_enable_x64`` is switched
    on for this process."""
    import jax

    from ..render.targets.jax.floating_jax import render_floating_jax
    from .checks import generated_module

    jax.config.update("jax_enable_x64", True)
    robot = derivation.robot
    module = generated_module(source, robot.name)
    traced = generated_module(render_floating_jax(derivation), f"{robot.name}_jax")
    return floating_rows(module, traced, robot, "JAX", states, seed)
