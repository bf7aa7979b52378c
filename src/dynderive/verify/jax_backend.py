"""``check --backend jax``'s requirement: the ``jax`` package (the harness: ``backends.jax_backend``)."""

from __future__ import annotations

from ..errors import InputError, Problem


def require_jax() -> None:
    """``InputError`` at ``--backend``, before any work, when ``jax`` cannot be imported."""
    try:
        import jax  # noqa: F401
    except ImportError:
        raise InputError(Problem("--backend", 1, 1, "--backend jax needs the jax package "
                                 "(pip install jax)")) from None
