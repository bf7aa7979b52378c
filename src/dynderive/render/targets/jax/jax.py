"""The JAX target (``solve --jax``): ``<name>_dynamics_jax.py``, the NumPy module's API on
``jax.numpy``, for a fixed or a floating base (one template, ``jax/dynamics.py.j2``, whose public
functions are the NumPy module's ``dynamics_api.py.j2`` with ``jax`` set; a robot with quaternions
in ``q`` takes ``dynamics_manifold.py.j2``, its configuration maps the same printed bodies as the
NumPy module's, ``where`` as ``jnp.where``, ``sqrt`` with derivative 0 at 0, so ``jax.jacfwd``
through ``integrate`` at ``v = 0`` is finite).

The same straight-line programs as the NumPy module (``code.program_function``: plain Python
text whose functions, ``sin``, ``cos``..., are the body's parameters) run here on
``jax.numpy`` arrays; the explicit expressions (a planar robot's M, C, N, the loop and
maximal-coordinate functions) are printed by SymPy's own ``JaxPrinter`` (``_jnp.sin``: the
module imports ``jax`` as ``_jax`` and ``jax.numpy`` as ``_jnp``, names no robot symbol can
take, since they start with ``_``). Every function is pure: results are stacked from their
entries (``jnp.stack``), blocks joined with ``jnp.concatenate``, never written in place; no
Python ``if`` or loop depends on a value (friction's sign and its smooth form are chosen by
``jnp.where``; ``assemble`` runs a fixed number of Newton steps in ``jax.lax.fori_loop``), so
every function works under ``jax.jit``, ``vmap``, ``grad`` and ``jacfwd``/``jacrev``,
parameters included (keyword arguments, or a dict passed as ``**p``), in float32 and float64.

Free text reaches the module only through the code environment's encoders (``|docstring``,
``|py``), as in the NumPy module; the rendered module is parsed back and checked (only
``jax`` is imported) before anyone can write or import it.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from sympy.printing.numpy import JaxPrinter

from ....derivation import Derivation
from ...codegen.functions import flat_entries
from ...codegen.printer import _Printer
from ...codegen.python_context import code_context
from ...python_module import render_module

JAX_TEMPLATE = "jax/dynamics.py.j2"
#: Modules the generated JAX module may import.
JAX_IMPORTS = frozenset({"jax", "__future__"})
#: Lines of a straight-line body between two holds (``_hold`` in the module): fewer means
#: fewer repeated operations and more loops. 3-6 were within 10 % of each other for the
#: Panda's forward dynamics on CPU (``benchmarks/jax_batch.py``); no hold was 3x slower.
HOLD_EVERY = 4
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class _JaxPrinter(_Printer, JaxPrinter):
    """SymPy's JAX printer writing ``_jnp.sin`` rather than ``jax.numpy.sin``, floats as exact
    ``repr`` literals (weakly typed: they keep float32 float32)."""

    _short = ("jax.numpy.", "_jnp.", "jax.numpy")


def holds(lines: list[tuple[str, str]], outputs: list[str], every: int = HOLD_EVERY) -> dict[int, str]:
    """Where a body holds its values (``_hold``) and which: after every ``every`` lines, the
    values those lines assigned that are read later, before they are assigned again (names are
    reused once dead, see ``code.program_function``), as ``{line index: "a, b"}``.

    On CPU, XLA fuses each use of a value with the arithmetic that makes it, and so repeats
    that arithmetic for every use: the Panda's forward dynamics ran 5x its operations and 20x
    its sines. A value passed through ``_hold`` is computed once and kept in memory.
    """
    targets = {name for name, _ in lines}
    reads = [set(_NAME.findall(expr)) & targets for _, expr in lines]
    read_at_end = set().union(*(_NAME.findall(expr) for expr in outputs)) & targets if outputs else set()
    found: dict[int, str] = {}
    assigned: dict[str, None] = {}
    for index, (name, _) in enumerate(lines):
        assigned[name] = None
        if (index + 1) % every or index + 1 >= len(lines):
            continue
        alive = []
        for candidate in assigned:
            for later in range(index + 1, len(lines)):
                if candidate in reads[later]:
                    alive.append(candidate)
                    break
                if lines[later][0] == candidate:
                    break
            else:
                if candidate in read_at_end:
                    alive.append(candidate)
        if alive:
            found[index] = ", ".join(alive)
        assigned = {}
    return found


def jax_context(derivation: Derivation) -> dict[str, Any]:
    """The NumPy module's context (``code.code_context``) with the expressions printed for
    ``jax.numpy`` and each expression function's entries by flat index."""
    context = code_context(derivation, _JaxPrinter({"fully_qualified_modules": True, "strict": False}), "_jnp")
    context["sizes"] = {f.name: (math.prod(f.shape), flat_entries(f)) for f in context["functions"]}
    context["holds"] = {p.name: holds(p.lines, p.outputs) for p in context["programs"]}
    context["body_functions"] = {p.name: tuple(p.functions) + (("_hold",) if context["holds"][p.name] else ())
                                 for p in context["programs"]}
    context["module"] = f"{derivation.robot.name}_dynamics_jax"
    return context


def render_jax(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The text of ``<name>_dynamics_jax.py``, checked (it parses, imports only ``jax``, and its
    docstring reads back the robot's title) before it is returned."""
    return render_module(derivation, JAX_TEMPLATE, jax_context(derivation), template_dir, JAX_IMPORTS)


__all__ = ["HOLD_EVERY", "JAX_IMPORTS", "JAX_TEMPLATE", "holds", "jax_context", "render_jax"]
