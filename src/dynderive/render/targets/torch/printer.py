"""The PyTorch target (``solve --torch``): ``<name>_dynamics_torch.py``, the NumPy module's API on
torch tensors, for every robot class: the shared Python templates (``dynamics_api.py.j2`` and
those it includes) rendered with this folder's ``python_backend.j2`` (``torch/dynamics.py.j2``
names it), the engine's straight-line programs as the NumPy module prints them (plain Python
whose functions, ``sin``, ``cos``..., are the body's parameters, bound here to torch's), and
the explicit expressions (a planar robot's M, C, N, the loop and maximal-coordinate
functions) printed by SymPy's ``TorchPrinter`` through the project's printer base.

Every function is pure: results are stacked from their entries (``torch.stack``), blocks
joined with ``torch.cat``, never written in place, so autograd runs through every function
and ``torch.compile`` traces them. Python numbers are weak (a float32 input stays float32):
the printed code writes them as literals, and a function of a Python number alone (a
parameter's ``cos``) takes it as a float64 scalar tensor, which torch's promotion lets a
float32 batch keep its type; each result is cast to its inputs' type once.

Free text reaches the module only through the code environment's encoders (``|docstring``,
``|py``), as in the NumPy module; the rendered module is parsed back and checked (only
``torch`` is imported) before anyone can write or import it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import sympy
from sympy.printing.pytorch import TorchPrinter
from sympy.printing.str import StrPrinter

from ....derivation import Derivation
from ...codegen.array_program import ArrayPrinter
from ...codegen.functions import flat_entries
from ...codegen.printer import _Printer
from ...codegen.python_context import code_context
from ...python_module import render_module

TORCH_TEMPLATE = "torch/dynamics.py.j2"
#: Modules the generated PyTorch module may import.
TORCH_IMPORTS = frozenset({"torch", "__future__"})


class _TorchPrinter(TorchPrinter, _Printer):
    """SymPy's PyTorch printer writing ``_torch.sin`` rather than ``torch.sin``, floats as exact
    ``repr`` literals, powers with Python's ``**`` (a parameter is a Python number, which
    ``torch.pow`` refuses) and each argument of a torch function through ``_tensor`` (a
    Python number becomes a float64 scalar tensor; a tensor stays as it is)."""

    _short = ("torch.", "_torch.", "PyTorch")

    def _call(self, function: str, arguments: tuple[sympy.Basic, ...]) -> str:
        texts = ", ".join(f"_tensor({self._print(a)})" for a in arguments)
        return f"{self._module_format(function)}({texts})"

    def _print_Function(self, expr: sympy.Basic) -> str:
        function = self.mapping.get(type(expr))
        if function is None or function == "torch.pow" or len(expr.args) > 2:
            return _Printer._print_Function(self, expr)   # no torch function: refused
        return self._call(function, expr.args)

    _print_Expr = _print_Function
    _print_Application = _print_Function
    _print_Relational = _print_Function

    def _print_Pow(self, expr: sympy.Pow, rational: bool = False) -> str:
        if expr.exp == sympy.S.Half:
            return self._call("torch.sqrt", (expr.base,))
        if expr.exp == -sympy.S.Half:
            return f"1/{self._call('torch.sqrt', (expr.base,))}"
        return StrPrinter._print_Pow(self, expr, rational)

    def _print_NumberSymbol(self, expr: sympy.Basic) -> str:   # pi, E: folded before printing
        return repr(float(expr))

    _print_Pi = _print_Exp1 = _print_NumberSymbol


# the functions NumPy's printer has a method of its own for (``_print_sin``) print as torch's
for _function in TorchPrinter.mapping:
    if issubclass(_function, sympy.Function) or issubclass(_function, sympy.core.relational.Relational):
        setattr(_TorchPrinter, f"_print_{_function.__name__}", _TorchPrinter._print_Function)


class _TorchArrays(ArrayPrinter):
    """The engine's array programs over torch: the cross product along the last axis (``torch.cross``
    without ``dim`` takes the first axis of size 3, a batch axis perhaps)."""

    def _cross(self, node: Any, a: Any, b: Any) -> str:
        return f"{self.xp}.linalg.cross({self.expression(a)}, {self.expression(b)})"


def torch_context(derivation: Derivation) -> dict[str, Any]:
    """The NumPy module's context (``code_context``) with the expressions printed for torch and
    each expression function's entries by flat index."""
    context = code_context(derivation, _TorchPrinter({"fully_qualified_modules": True, "strict": False}), "_torch",
                           _TorchArrays)
    context["sizes"] = {f.name: (math.prod(f.shape), flat_entries(f)) for f in context["functions"]}
    context["module"] = f"{derivation.robot.name}_dynamics_torch"
    return context


def render_torch(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The text of ``<name>_dynamics_torch.py``, checked (it parses, imports only ``torch``, and
    its docstring reads back the robot's title) before it is returned."""
    return render_module(derivation, TORCH_TEMPLATE, torch_context(derivation), template_dir, TORCH_IMPORTS)


__all__ = ["TORCH_IMPORTS", "TORCH_TEMPLATE", "render_torch", "torch_context"]
