"""The PyTorch target (``--torch``): ``<name>_dynamics_torch.py``, the NumPy module's API on torch
tensors (batched, float32 and float64, autograd, ``torch.compile``), for every robot class.
``simulate --backend torch`` runs it through ``load`` (NumPy arrays in and out, float64), and
``check --backend torch`` compares that with the NumPy module (the registry's generic
comparison of a loaded module)."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ..target import OptionalPackage, Target, public


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], **options: Any) -> dict[str, bytes]:
    """The module, for every robot class."""
    from .printer import render_torch

    return {f"{derivation.robot.name}_dynamics_torch.py": render_torch(derivation, template_dir).encode()}


def offered(derivation: Derivation) -> set[str]:
    """The module's public functions."""
    from .printer import render_torch

    return public(render_torch(derivation))


#: PyTorch, an optional dependency (the torch extra) the module imports.
TORCH = OptionalPackage("torch", "PyTorch", imports="torch")


def load(derivation: Derivation, progress: Any = None) -> Any:
    """The PyTorch module of ``derivation``'s robot, imported, behind the NumPy module's calling
    convention (``harness.NumpyFacade``: NumPy arrays in, float64 tensors to the module, NumPy
    arrays out)."""
    from .harness import NumpyFacade, module_from_source
    from .printer import render_torch

    if progress is not None:
        progress("generating PyTorch")
    source = render_torch(derivation)
    return NumpyFacade(module_from_source(source, f"{derivation.robot.name}_dynamics_torch"))


TARGET = Target(
    name="torch", flag="--torch", kind="torch", title="PyTorch", column=6,
    help="Write DIR/<name>_dynamics_torch.py, the NumPy module's API on torch tensors (batches, float32 and "
         "float64, autograd, torch.compile); importing it needs PyTorch (the torch extra).",
    build_help="Write <name>_dynamics_torch.py (PyTorch).",
    outputs=("{}_dynamics_torch.py",),
    # the macro file is imported by a name the template sets (python_backend), which build's
    # walk of the includes cannot follow: named here
    templates=("torch/dynamics.py.j2", "torch/python_backend.j2"),
    render=f"{__name__}:render", offered=f"{__name__}:offered", progress="generating PyTorch",
    note=f"{__name__}:TORCH.missing_note", check_needs=f"{__name__}:TORCH.require", load=f"{__name__}:load",
    option_help=(("check --backend", "the same for the PyTorch module (--torch; needs torch)"),
                 ("simulate --backend", "the PyTorch module in float64 (--torch; needs torch)")),
)
