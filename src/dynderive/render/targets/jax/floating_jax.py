"""Compatible name for imports not yet moved (tests of other areas): the JAX target's one
renderer is ``jax.py``, for every robot. To be deleted once nothing imports it."""

from .jax import render_jax as render_floating_jax

__all__ = ["render_floating_jax"]
