"""The table ``dynderive build`` prints: a row per robot file with its status and seconds (and,
for sheets, their pages, LaTeX's time and the widest overfull line), the orphaned and pruned
outputs under their rows, and a count line."""

from __future__ import annotations

from pathlib import Path

import typer

from .build import Outcome


def report(outcomes: list[Outcome], out: Path, quiet: bool, check_only: bool) -> int:
    """Print the build's table; the exit status it asks for (1: a robot failed or differs, or
    ``--check`` found orphaned outputs)."""
    counts = {s: sum(o.status == s for o in outcomes)
              for s in ("built", "up to date", "current", "differs", "failed", "orphaned", "pruned")}
    if quiet:   # what needs the user: rows of robots that failed, differ, or whose outputs are orphaned
        outcomes = [o for o in outcomes if o.status in ("differs", "failed", "orphaned")
                    or any(": kept (" in line for line in o.problems)]
    width = max([len(o.source) for o in outcomes] + [5])
    sheets = any(o.sheet for o in outcomes)   # a PDF: its pages, LaTeX's time, the widest overfull line
    if outcomes or not quiet:
        typer.echo(f"{'robot':<{width}}  {'status':<10}  seconds" + ("  pages  LaTeX s  overfull pt" if sheets else ""))
    for o in outcomes:
        extra = ""
        if sheets and o.sheet:
            seconds = f"{o.sheet['seconds']:7.1f}" if "seconds" in o.sheet else f"{'-':>7}"
            extra = f"  {o.sheet.get('pages', 0):5.0f}  {seconds}  {o.sheet.get('overfull', 0):11.1f}"
        seconds = f"{'-':>7}" if o.status in ("orphaned", "pruned") else f"{o.seconds:7.1f}"   # nothing was built
        typer.echo(f"{o.source:<{width}}  {o.status:<10}  {seconds}{extra}")
        for line in o.problems:
            typer.echo(f"  {line}")
        for line in o.message.splitlines():
            typer.echo(f"  {line}", err=True)
    if not quiet:
        typer.echo(", ".join(f"{n} {s}" for s, n in counts.items() if n))
    if (n := counts["orphaned"]) and not quiet:
        typer.echo(f"note: {n} robot file{'s' if n > 1 else ''} whose outputs are in {out} no longer "
                   f"exist{'' if n > 1 else 's'} (their outputs are listed as orphaned): "
                   f"build --prune --out {out} removes them", err=True)
    if counts["failed"] or counts["differs"] or (check_only and counts["orphaned"]):
        return 1
    return 0
