"""``dynderive solve`` and ``build`` for a floating-base robot: the code targets
(``render/targets``, each printing a floating base itself), its sheet (LaTeX, PDF, HTML) and
JSON dump (``floating_outputs.py``) and one note saying what is not built yet; every other
output is refused (exit 2) before any work."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from ..errors import InputError
from ..model.robot import Robot
from .options import problem

#: The message of an output or command not built yet for floating-base robots.
NOT_BUILT = "not built yet for floating-base robots"


def built() -> tuple[str, ...]:
    """The output kinds a floating-base robot has: every code target's, the sheets and the JSON."""
    from ..render.targets import TARGETS
    from .floating_outputs import SHEET_KINDS

    return (*(target.kind for target in TARGETS), *SHEET_KINDS)


def floating_note(robot: Robot) -> str:
    """The note ``solve`` prints for a floating-base robot: what its module has and what not."""
    what = ("has a floating base" if robot.floating_base else "has floating joints"
            if any(j.type == "floating" for j in robot.joints) else "has spherical joints")
    return (f"note: {robot.name} {what} (NQ = {len(robot.configuration_names)}, NV = {robot.velocity_count}): "
            "every output is built except the MATLAB derivation script (--matlab writes its +package only)")


def solve_floating(robot: Robot, argument: str, flags: dict[str, bool], out: Path, template_dir: Path | None,
                   quiet: bool, echo: Callable[[str], None], progress: Callable[[str], None],
                   tests: bool = False) -> None:
    """Write the outputs the flags ask for (the code targets by kind, ``--tests`` the NumPy
    module's checks, the sheets and the JSON), or, with none, print the equations
    (``render_floating_terminal``)."""
    from .. import derive
    from .output import write_all
    from .solve import target_files

    if not quiet:
        echo(floating_note(robot))
    flags = dict(flags)
    digits = flags.pop("digits", None)   # --digits: the sheet's numbers
    refused = [problem(f"--{flag.replace('_', '-')}", f"--{flag.replace('_', '-')}: {NOT_BUILT}")
               for flag, wanted in flags.items() if wanted and flag not in built()]
    if refused:
        raise InputError(refused)
    derivation = derive(robot, progress)   # M(q) regular at the defaults; the programs, never Lagrange's
    if not any(flags.get(flag) for flag in built()):   # no output flag: print the equations
        import typer

        from ..render.terminal import render_floating_terminal

        typer.echo(render_floating_terminal(derivation, digits), nl=False)
        return
    made, failures, stale = target_files(derivation, {kind for kind, wanted in flags.items() if wanted}, template_dir,
                                         progress, out, tests)
    files = {out / name: data for name, data in made.items()}
    removed = [out / name for name in stale]   # the extension built: an earlier failure's compiler log
    from .floating_outputs import SHEET_KINDS, failure_text, floating_sheet_files

    sheets, failure = floating_sheet_files(derivation, {k for k in SHEET_KINDS if flags.get(k)}, template_dir, digits,
                                           progress)
    files |= {out / name: data for name, data in sheets.items()}
    if failure is not None:
        failures.append(failure_text(out, robot.name, failure))
    if flags.get("pdf"):   # an earlier failure's log, or an earlier PDF beside a new sheet (as solve_outputs)
        from ..render.pdf import stale_beside

        stale, said = stale_beside(out, robot.name, made=out / f"{robot.name}.pdf" in files)
        removed += stale
        failures[-1:] = [failures[-1] + said] if said else failures[-1:]
    removed = [path for path in removed if os.path.lexists(path)]
    write_all(files, remove=removed)
    if not quiet:
        for path in files:
            echo(f"wrote {path}")
        for path in removed:
            echo(f"removed {path}")
    for message in failures:   # the extension the compiler rejected, the PDF LaTeX did not make
        echo(f"dynderive: {message}")   # (the other outputs are written)
    if failures:
        import typer

        raise typer.Exit(1)


def floating_outputs(robot: Robot, source: str, kinds: tuple[str, ...], template_dir: str | None,
                     ) -> tuple[dict[str, bytes], Exception | None]:
    """``build``'s outputs of a floating-base robot (its modules, sheet and JSON dump) and the
    PDF's failure, if any; any other kind refused."""
    from .. import derive
    from .solve import target_files

    refused = [kind for kind in kinds if kind not in ("floating_base", *built()) and not kind.startswith("digits:")]
    if refused:
        from ..render.targets import COLUMNS

        flags = ", ".join(target.flag for target in COLUMNS)
        raise InputError(problem(source, f"{', '.join(refused)}: {NOT_BUILT}; build writes its code ({flags}), "
                                         "sheets and JSON"))
    derivation = derive(robot)
    files, _, _ = target_files(derivation, kinds, template_dir)
    from .floating_outputs import floating_sheet_files

    digits = next((int(kind.split(":")[1]) for kind in kinds if kind.startswith("digits:")), None)   # --digits
    sheets, failure = floating_sheet_files(derivation, kinds, template_dir, digits)
    return files | sheets, failure   # no TeX, or LaTeX failed: the other outputs are still made
