"""The check harnesses of the code targets (``check --backend c``, ``jax``, ``casadi``, ``torch``),
named by their registry entries (``render/targets``): each compares the target's functions with
the NumPy module, for a fixed or a floating base; a target with no harness of its own (all but
C) is checked through the module ``simulate`` loads (``loaded_backend``). ``check --backend c`` and
``simulate --backend c`` run the C target as the extension compiled for this process (``compiled_module``): the C
target's entry names these functions, not the extension's modules, so no target's entry
reaches into another target's folder."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..derivation import Derivation
from .rows import Row


def require_compiled() -> None:
    """``check --backend c``: ``InputError`` at ``--backend``, before any work, when this machine
    cannot compile the extension (no compiler, or no Python headers)."""
    from ..render.targets.c_extension.compile import require_compiler

    require_compiler("--backend")


def compiled_module(derivation: Derivation, progress: Callable[[str], None] | None = None) -> Any:
    """``simulate --backend c``: the extension of ``derivation``'s robot, compiled for this
    process and imported (the NumPy module's API)."""
    from ..render.targets.c_extension import compile as extension

    return extension.compiled_module(derivation, progress=progress)


def compiled_backend(derivation: Derivation, source: str, progress: Callable[[str], None], states: int = 12) -> list[Row]:
    """The C target's harness: the extension compiled for this process, each of its functions
    against the NumPy module ``source``."""
    from .compiled import compiled_checks

    compiled = compiled_module(derivation, progress=progress)
    progress("checking the compiled module")
    return compiled_checks(derivation, source, compiled, states=states)


def jax_module(derivation: Derivation, progress: Callable[[str], None] | None = None) -> Any:
    """``simulate`` and ``check --backend jax``: the JAX module of ``derivation``'s robot, imported, in float64
    (``jax_enable_x64`` is switched on for this process: the NumPy module's precision)."""
    import jax

    from ..render.targets.jax.jax import render_jax
    from .checks import generated_module

    jax.config.update("jax_enable_x64", True)
    return generated_module(render_jax(derivation), f"{derivation.robot.name}_jax")


def casadi_module(derivation: Derivation, progress: Callable[[str], None] | None = None) -> Any:
    """``simulate`` and ``check --backend casadi``: the CasADi module of ``derivation``'s robot behind the NumPy
    module's calling convention (``compiled.CasadiModule``)."""
    from ..render.targets.casadi.casadi import render_casadi
    from .checks import generated_module
    from .compiled import CasadiModule

    return CasadiModule(generated_module(render_casadi(derivation), f"{derivation.robot.name}_casadi"))


def loaded_backend(target: Any, derivation: Derivation, source: str, progress: Callable[[str], None],
                   states: int = 12) -> list[Row]:
    """The harness of a target without one of its own whose ``load`` gives a module with the
    NumPy module's API, taking and returning NumPy arrays: that module against the NumPy module
    ``source`` at random states (the compiled extension's comparison, ``compiled.py``)."""
    from ..render.targets import resolve
    from .compiled import compiled_checks

    module = resolve(target.load)(derivation, progress=progress)
    progress(f"checking the {target.title} module")
    return compiled_checks(derivation, source, module, states=states, label=target.title, target=target.name)
