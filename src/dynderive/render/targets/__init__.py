"""The code targets' registry: one folder per target (``numpy/``, ``c/``, ``c_extension/``,
``matlab/``, ``jax/``, ``casadi/``), whose ``__init__.py`` holds its entry (``TARGET``, a ``Target``),
listed here in the order the commands render them: C first and MATLAB next (a robot that either
refuses stops the run before the others' work), the extension after the C (it compiles the C
files this run made), the NumPy module last. Adding a target: a folder with its entry, its
templates and its tests, and one line here.
"""

from __future__ import annotations

from typing import Any

from ...derivation import Derivation
from .c import TARGET as _C
from .c_extension import TARGET as _C_EXTENSION
from .casadi import TARGET as _CASADI
from .jax import TARGET as _JAX
from .matlab import TARGET as _MATLAB
from .numpy import TARGET as _NUMPY
from .target import NotBuilt, Target
from .torch import TARGET as _TORCH

#: Every code target, in the order they are rendered.
TARGETS: tuple[Target, ...] = (_C, _MATLAB, _JAX, _CASADI, _TORCH, _C_EXTENSION, _NUMPY)
#: The same, in the order of their options and of the table of offered functions.
COLUMNS: tuple[Target, ...] = tuple(sorted(TARGETS, key=lambda target: target.column))
#: The NumPy module, the reference every target is compared with: its API is the one every
#: target offers, and what it does not build no target is expected to.
REFERENCE: Target = _NUMPY


def by_kind(kind: str) -> Target:
    """The target ``build``'s output kind (the option's name, ``c_extension``) names."""
    return next(target for target in TARGETS if target.kind == kind)


def by_name(name: str) -> Target:
    """The target called ``name`` (``c-extension``, a ``--backend``)."""
    return next(target for target in TARGETS if target.name == name)


def reference(derivation: Derivation, template_dir: Any = None) -> str:
    """The NumPy module's text (fixed or floating base), the reference every target is
    compared with (``check`` runs it)."""
    from .numpy import source

    return source(derivation, template_dir)


__all__ = ["COLUMNS", "REFERENCE", "TARGETS", "NotBuilt", "Target", "by_kind", "by_name", "reference"]
