"""The check harnesses of the code targets (``check --backend c``, ``--backend jax``), named by
their registry entries (``render/targets``): each compares the target's functions with the
NumPy module, for a fixed or a floating base."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .rows import Row


def compiled_backend(derivation: Any, source: str, progress: Callable[[str], None], states: int = 12) -> list[Row]:
    """The C target's harness: the extension compiled for this process, each of its functions
    against the NumPy module ``source``."""
    from ..render.targets.c_extension.compile import compiled_module

    compiled = compiled_module(derivation, progress=progress)
    progress("checking the compiled module")
    from .compiled import compiled_checks

    return compiled_checks(derivation, source, compiled, states=states)


def jax_backend(derivation: Any, source: str, progress: Callable[[str], None], states: int = 12) -> list[Row]:
    """The JAX target's harness: the JAX module against the NumPy module, in float64."""
    progress("checking the JAX module")
    from .jax_backend import jax_checks

    return jax_checks(derivation, source, states=states)
