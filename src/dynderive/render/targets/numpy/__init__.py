"""The NumPy target (``--code``): ``<name>_dynamics.py``, the reference module every other
target is compared with (DESIGN.md section 6), and with ``--tests`` its pytest checks."""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ..target import NotBuilt, Target


def source(derivation: Derivation, template_dir: Any = None) -> str:
    """The module's text, for a fixed or a floating base (``check`` and ``simulate`` run it): one
    template, ``dynamics.py.j2``; its public functions are ``dynamics_api.py.j2``'s, written once
    for this module and the JAX one, with the tangent-space functions of a robot with quaternions
    in ``q`` (``dynamics_manifold.py.j2``)."""
    from .code import render_code

    return render_code(derivation, template_dir)


def render(derivation: Derivation, template_dir: Any, made: dict[str, bytes], tests: bool = False,
           **options: Any) -> dict[str, bytes]:
    """The module and, with ``tests``, its checks."""
    name = derivation.robot.name
    files = {f"{name}_dynamics.py": source(derivation, template_dir).encode()}
    if tests:
        from .code import render_code_tests

        files[f"test_{name}_dynamics.py"] = render_code_tests(derivation, template_dir).encode()
    return files


def offered(derivation: Derivation) -> set[str]:
    """The module's public functions."""
    from ..target import public

    return public(source(derivation))


TARGET = Target(
    name="numpy", flag="--code", kind="code", title="NumPy", column=0,
    help="Write DIR/<name>_dynamics.py, a NumPy module.",
    build_help="Write <name>_dynamics.py.",
    outputs=("{}_dynamics.py",),
    # the macro file is imported by a name the template sets (python_backend), which build's
    # walk of the includes cannot follow: named here
    templates=("dynamics.py.j2", "numpy/python_backend.j2"),
    render=render, offered=offered, progress="generating code",
    option_help=(("check --backend", "check the generated NumPy module"),
                 ("simulate --backend", "the generated NumPy module"),
                 ("--tests", "also write DIR/test_<name>_dynamics.py, pytest property checks of the generated module")),
    # the reference's rows are every target's: MATLAB, which builds it, offers it all the same
    not_built=(NotBuilt(("generalized_forces",), "quaternions",
                        "floating base: not built (the efforts enter forward_dynamics and linearize; MATLAB has it)"),),
)
