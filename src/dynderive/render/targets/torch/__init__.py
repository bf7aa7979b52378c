"""The PyTorch target (``--torch``): ``<name>_dynamics_torch.py``, the NumPy module's API on torch
tensors (batched, float32 and float64, autograd, ``torch.compile``), for every robot class.
``simulate --backend torch`` runs it behind the NumPy module's calling convention (NumPy arrays
in and out, float64; ``verify/backends.py``), and ``check --backend torch`` compares that with
the NumPy module."""

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


TARGET = Target(
    name="torch", flag="--torch", kind="torch", title="PyTorch", column=6,
    help="Write DIR/<name>_dynamics_torch.py, the NumPy module's API on torch tensors (batches, float32 and "
         "float64, autograd, torch.compile); importing it needs PyTorch (the torch extra).",
    build_help="Write <name>_dynamics_torch.py (PyTorch).",
    outputs=("{}_dynamics_torch.py",),
    # the macro file is imported by a name the template sets (python_backend), which build's
    # walk of the includes cannot follow: named here
    templates=("torch/dynamics.py.j2", "torch/python_backend.j2"),
    render=render, offered=offered, progress="generating PyTorch",
    note=TORCH.missing_note,
    option_help=(("check --backend", "the same for the PyTorch module (--torch; needs torch)"),
                 ("simulate --backend", "the PyTorch module in float64 (--torch; needs torch)")),
)
