"""How the commands show in ``--help``: boolean flags as ``--latex``, not ``--latex <bool>``.

Typer (0.2x) prints every option's type, also for flags, which take no value: ``--latex
<bool>`` reads as if ``--latex true`` worked, and it is an error. A flag gets an empty
metavar, so the type column stays blank.
"""

from __future__ import annotations

from typing import Any

from typer.core import TyperCommand, TyperGroup


class _FlagsTakeNoValue:
    def get_params(self, ctx: Any) -> Any:
        params = super().get_params(ctx)  # type: ignore[misc]
        for param in params:
            if getattr(param, "is_flag", False) and param.metavar is None:
                param.metavar = ""
        return params


class Command(_FlagsTakeNoValue, TyperCommand):
    """A command whose flags show without a type (``@app.command(cls=Command)``)."""


class Group(_FlagsTakeNoValue, TyperGroup):
    """The command group, likewise (``--version``, ``--help``)."""
