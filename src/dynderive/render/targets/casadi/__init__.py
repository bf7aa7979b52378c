"""The CasADi target (``--casadi``): ``<name>_dynamics_casadi.py``, every function of the
generated API as a ``casadi.Function`` built with ``casadi.SX`` (DESIGN.md section 9); its
check harness (``check --backend casadi``) and tests (``tests/test_casadi_target.py``) compare
it with the NumPy module."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ...codegen.constrained import FLOATING_LOOP_FUNCTIONS
from ..target import NotBuilt, OptionalPackage, Target


def _source(derivation: Derivation, template_dir: Any = None) -> str:
    from .casadi import render_casadi

    return render_casadi(derivation, template_dir)


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], **options: Any) -> dict[str, bytes]:
    """The module, for a fixed or a floating base."""
    return {f"{derivation.robot.name}_dynamics_casadi.py": _source(derivation, template_dir).encode()}


def offered(derivation: Derivation) -> set[str]:
    """The module's public Functions (top-level names bound to ``_function(...)``) and functions
    (``frame_transform``...)."""
    import ast

    from ..target import public

    source = _source(derivation)
    names = public(source)
    for node in ast.parse(source).body:
        if (
            isinstance(node, ast.Assign)
            and isinstance(node.value, ast.Call)
            and isinstance(node.value.func, ast.Name)
            and node.value.func.id == "_function"
        ):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name) and not t.id.startswith("_")}
    return names


#: CasADi, an optional dependency (the casadi extra) the module imports.
CASADI = OptionalPackage("casadi", "CasADi")


TARGET = Target(
    name="casadi",
    flag="--casadi",
    kind="casadi",
    title="CasADi",
    column=5,
    help="Write DIR/<name>_dynamics_casadi.py: every function as a casadi.Function built with casadi.SX "
    "(optimal control, automatic derivatives, C code generation); importing it needs CasADi "
    "(the casadi extra).",
    build_help="Write <name>_dynamics_casadi.py (CasADi).",
    outputs=("{}_dynamics_casadi.py",),
    templates=("casadi/dynamics.py.j2",),
    render=render,
    offered=offered,
    progress="generating CasADi",
    note=CASADI.missing_note,
    option_help=(("check --backend", "the same for the CasADi module (--casadi; needs casadi)"),
                 ("simulate --backend", "the CasADi module (--casadi), one Function call per state (generalized "
                                        "coordinates; needs casadi)")),
    not_built=(NotBuilt(("assemble",), "vector_space", "closed loops in CasADi: assemble (Newton's method, iterated on "
                                                "values) is not a casadi.Function"),
               NotBuilt(FLOATING_LOOP_FUNCTIONS, "quaternion_loops",
                        "loops on a floating base or with spherical joints: not printed for CasADi yet (it refuses such a robot)")),
)
