"""``dynderive identify``: the regressor's parameter vector and the robot's base parameters
(``verify.identification``), printed as text or JSON. Floating-base robots sample their
configurations on the manifold (``integrate`` from the neutral configuration)."""

from __future__ import annotations

import json

import typer

from ..errors import InputError
from .options import problem, require_scipy, with_parameters
from .output import echo_notes
from .progress import Progress


def run_identify(argument: str, assignments: list[str], states: int | None, json_: bool, quiet: bool,
                 floating_base: bool) -> None:
    from .. import derive, load_robot
    from ..verify.checks import generated_module

    require_scipy("identify")
    from ..verify.identification import base_parameters, fewest_states

    progress = Progress(quiet)
    model = load_robot(argument, size_limits=True, floating_base=floating_base)
    model = with_parameters(model, argument, assignments, required=True)
    echo_notes(model, quiet)
    if states is not None:
        least = fewest_states(model)
        if states < least:
            raise InputError(problem("--states", f"expected at least {least} states for {model.name} (one per "
                                      "regressor parameter: fewer can make the rank, and so the base parameters, "
                                      f"come out too small), got {states}"))
    derivation = derive(model, progress=progress)
    progress("generating code")
    from ..render.targets import reference  # the NumPy module, for a fixed or a floating base

    source = reference(derivation)
    module = generated_module(source, model.name)
    progress("sampling the regressor")
    values = {p.name: float(p.value) for p in model.parameters}
    result = base_parameters(derivation, module, values, states)
    if json_:
        typer.echo(json.dumps({"robot": model.name, **result.as_dict()}, indent=2, allow_nan=False))
        return
    rows = len(derivation.symbols.qd)
    per_link = "4 per link (planar)" if model.planar else "10 per link"
    typer.echo(f"{model.name}: regressor Y(q, qd, qdd) of shape ({rows}, {len(result.names)}), "
               f"parameters {per_link} then drives\n\nParameter vector pi:")
    width = max(len(name) for name in result.names)
    for name, value in zip(result.names, result.values):
        typer.echo(f"  {name:<{width}}  {value:.10g}")
    typer.echo(f"\nBase parameters: {result.rank} of {len(result.names)} (rank of Y at {result.states} random "
               "states; Y pi = Y_base pi_base):")
    for k, grouping in enumerate(result.groupings, 1):
        typer.echo(f"  {k:>3}  {grouping.text}  =  {grouping.value:.10g}")
    if result.unidentifiable:
        typer.echo("\nNot identifiable (zero columns): " + ", ".join(result.names[i] for i in result.unidentifiable))
    if model.loops:
        typer.echo("\nNote: the regressor is the spanning tree's (no loop forces).")
