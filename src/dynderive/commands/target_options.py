"""The code targets' options, read from the registry (``render/targets``): commands name no
target, so adding one adds its ``--flag`` to ``solve`` and ``build`` and its help everywhere."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Annotated, Any, TypeVar

import typer

from ..render.targets import COLUMNS, TARGETS, by_name
from ..verify.backends import backends

F = TypeVar("F", bound=Callable[..., Any])


def target_options(after: str, build: bool = False) -> Callable[[F], F]:
    """One boolean option per code target (``--code``, ``--c``, ... from the registry, in its
    column order, with its entry's help), inserted after the parameter ``after`` of the
    command's signature; the function receives them by kind in ``**targets``."""
    def decorate(function: F) -> F:
        signature = inspect.signature(function, eval_str=True)
        parameters = [p for p in signature.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        at = [p.name for p in parameters].index(after) + 1
        options = [inspect.Parameter(target.kind, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=False,
                                     annotation=Annotated[bool, typer.Option(target.flag, help=target.build_help
                                                                             if build else target.help)])
                   for target in COLUMNS]
        function.__signature__ = signature.replace(parameters=parameters[:at] + options + parameters[at:])  # type: ignore[attr-defined]
        return function

    return decorate


def option_help(option: str) -> str:
    """The help of an option whose choices are code targets, from the registry's entries
    (``Target.option_help``): ``--tests`` says which target's option it goes with, ``--backend``
    lists each choice, ``check``'s and ``simulate``'s in their order."""
    if option == "--tests":
        target = next(target for target in TARGETS if target.help_for(option))
        return f"With {target.flag}: {target.help_for(option)}."
    return "; ".join(f"{name}: {by_name(name).help_for(option)}" for name in backends()) + "."


def target_flags(targets: dict[str, bool]) -> dict[str, bool]:
    """The code targets' options by kind (``c_extension``), in the registry's order."""
    return {target.kind: bool(targets.get(target.kind)) for target in TARGETS}


def target_needs(targets: dict[str, bool]) -> None:
    """What the asked targets need, before any work: a refusal (no C compiler) stops the run."""
    for target in TARGETS:
        if targets[target.kind] and target.needs:
            target.needs()


def target_notes(targets: dict[str, bool]) -> None:
    """The asked targets' notes (the JAX module is written without JAX installed here)."""
    for target in TARGETS:
        if targets[target.kind] and target.note and (text := target.note()):
            typer.echo(text, err=True)
