"""How ``check --backend`` and ``simulate --backend`` run the code targets' modules (``HARNESSES``,
by target name): ``simulate`` loads a module with the NumPy module's API (``load``) and ``check``
compares it with the NumPy module at random states, through the target's own harness where it
has one (``check``: the C extension's) or the generic comparison of a loaded module
(``loaded_backend``), for a fixed or a floating base. ``--backend c`` runs the C target as the
extension compiled for this process (``compiled_module``), so no target's entry reaches into
another target's folder."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..derivation import Derivation
from ..render.targets import Target, by_name
from ..render.targets.casadi import CASADI
from ..render.targets.jax import JAX
from ..render.targets.torch import TORCH
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


def torch_module(derivation: Derivation, progress: Callable[[str], None] | None = None) -> Any:
    """``simulate`` and ``check --backend torch``: the PyTorch module of ``derivation``'s robot behind the
    NumPy module's calling convention (``harness.NumpyFacade``: NumPy arrays in, float64 tensors to
    the module, NumPy arrays out)."""
    from ..render.targets.torch.harness import NumpyFacade, module_from_source
    from ..render.targets.torch.printer import render_torch

    if progress is not None:
        progress("generating PyTorch")
    return NumpyFacade(module_from_source(render_torch(derivation), f"{derivation.robot.name}_dynamics_torch"))


@dataclass(frozen=True)
class Harness:
    """How the commands run one target's module."""

    #: The target's name (``--backend NAME``).
    name: str
    #: (derivation, progress) -> a module with the NumPy module's API, taking and returning NumPy
    #: arrays, built for this process (``simulate --backend``).
    load: Callable[..., Any]
    #: () -> None, raising an InputError at ``--backend`` before any work when it cannot run here.
    needs: Callable[[], None]
    #: (derivation, source, progress, states) -> rows: a harness of its own in place of the
    #: generic comparison of the loaded module (``compare``), or None.
    check: Callable[..., list[Row]] | None = None

    @property
    def target(self) -> Target:
        return by_name(self.name)

    def compare(self, derivation: Derivation, source: str, progress: Callable[[str], None], states: int = 12) -> list[Row]:
        """``check --backend``: the target's module against the NumPy module ``source`` at random
        states (its own harness, or the loaded module compared function by function as the
        compiled extension is, ``compiled.py``)."""
        if self.check is not None:
            return self.check(derivation, source, progress, states=states)
        from .compiled import compiled_checks

        module = self.load(derivation, progress=progress)
        progress(f"checking the {self.target.title} module")
        return compiled_checks(derivation, source, module, states=states, label=self.target.title, target=self.name)


#: The targets ``check --backend`` and ``simulate --backend`` run, in their options' order.
HARNESSES: tuple[Harness, ...] = (
    Harness("c", compiled_module, require_compiled, check=compiled_backend),
    Harness("jax", jax_module, JAX.require),
    Harness("casadi", casadi_module, CASADI.require),
    Harness("torch", torch_module, TORCH.require),
)


def backends() -> tuple[str, ...]:
    """``--backend``'s choices: the NumPy module (the reference, always checked), then every
    target with a harness."""
    return ("numpy", *(harness.name for harness in HARNESSES))


def harness_of(name: str) -> Harness | None:
    """The harness of ``--backend name`` (None for the NumPy module)."""
    return next((harness for harness in HARNESSES if harness.name == name), None)
