"""``dynderive solve``'s and ``build``'s output files, in memory, for every robot (a fixed
base, a floating base, spherical or mimic joints): what the command line asked for, made from
one derivation, and the outputs that could not be made (a PDF without LaTeX, a sheet LaTeX
rejects, an extension the compiler rejects) as messages, so that the command writes all the
others at once (``output.write_all``) and then exits 1 naming each failure; and the files the
run makes stale, removed in the same step: an earlier PDF when this one could not be made, the
log of an earlier failure when the PDF or the extension is made.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

from ..derivation import Derivation
from ..errors import LatexError, ToolMissingError
from ..model.robot import Robot


def form_note(robot: Robot) -> str | None:
    """``solve``'s note on the form of ``robot``'s equations: one whose configuration holds
    quaternions (NQ != NV) has every output but the MATLAB derivation script; a large one's
    symbolic quantities are in intermediate-variable form."""
    from ..mechanics.structured import intermediate_form
    from .output import quaternion_kind

    if robot.floating:
        what = "has a floating base" if robot.floating_base else f"has {quaternion_kind(robot)}"
        sizes = f"note: {robot.name} {what} (NQ = {len(robot.configuration_names)}, NV = {robot.velocity_count})"
        if robot.loops:
            return (f"{sizes} and closed loops: the sheets, JSON and every code target but CasADi are built "
                    "(CasADi does not print such loops yet; no reduced form)")
        return f"{sizes}: every output is built except the MATLAB derivation script (--matlab writes its +package only)"
    if intermediate_form(robot):
        return (f"note: {robot.name} has {len(robot.coordinates)} coordinates: M, C, N, the energies and Lagrange's "
                "equations are derived in intermediate-variable form (named sub-expressions)")
    return None


#: The kinds of output that are the sheet (a terminal print reads what they do).
SHEET_KINDS = ("latex", "pdf", "html", "json")


def output_wants(kinds: Collection[str]) -> set[str]:
    """What the outputs of ``kinds`` read from the derivation (``derive``'s ``wants``): the
    sheet's kinds the symbolic quantities, each code target what its entry says."""
    from ..render.targets import TARGETS

    wants = {"sheet"} if set(kinds) & set(SHEET_KINDS) else set()
    return wants | {part for target in TARGETS if target.kind in kinds for part in target.reads}


def target_files(derivation: Derivation, kinds: Collection[str], template_dir: str | Path | None,
                 progress: Callable[[str], None] = lambda stage: None, folder: Path | None = None,
                 tests: bool = False) -> tuple[dict[str, bytes], list[str], list[str]]:
    """The files of the code targets among ``kinds`` by name, in the registry's order (a
    target that refuses the robot stops the run before the later ones' work); ``tests``: the
    NumPy module's checks too. With ``folder`` (``solve``), a target that could not be made
    (the extension a compiler rejected) leaves its log and a message (the other outputs are
    still written) and one that was made names the files of an earlier failure it makes
    stale; without, its error stops the robot (``build``)."""
    from ..render.targets import TARGETS

    name = derivation.robot.name
    files: dict[str, bytes] = {}
    failures: list[str] = []
    stale: list[str] = []
    for target in TARGETS:
        if target.kind not in kinds:
            continue
        if target.progress:
            progress(target.progress)
        try:
            files |= target.files(derivation, template_dir, files, tests=tests, progress=progress)
        except Exception as exc:
            if folder is None or target.failure is None:
                raise
            logs, message = target.failure(exc, folder, name)   # raises what is not its failure
            files |= logs
            failures.append(message)
        else:
            stale += [pattern.format(name) for pattern in target.stale]
    return files, failures, stale


def sheet_files(derivation: Derivation, kinds: Collection[str], template_dir: str | Path | None,
                sections: Any = None, digits: int | None = None,
                progress: Callable[[str], None] = lambda stage: None, sheet: dict[str, float] | None = None,
                ) -> tuple[dict[str, bytes], LatexError | ToolMissingError | None]:
    """The sheet's files among ``kinds`` by name (the ``.tex``, the ``.pdf``, the ``.html``, the
    ``.json``), ``sections`` of it with numbers to ``digits`` significant digits at most, and
    the PDF's failure, if any: LaTeX's (the ``.tex`` and its log are then among the files) or
    a missing TeX. With a PDF, ``sheet`` receives its pages, LaTeX's seconds and the widest
    overfull line (pt)."""
    from ..render.sheets.html import render_html
    from ..render.sheets.json import render_json
    from ..render.sheets.latex import render_latex

    name = derivation.robot.name
    files: dict[str, bytes] = {}
    failure: LatexError | ToolMissingError | None = None
    if "latex" in kinds or "pdf" in kinds:
        progress("rendering LaTeX")
        tex = render_latex(derivation, template_dir, sections, digits)
        if "latex" in kinds:
            files[f"{name}.tex"] = tex.encode()
        if "pdf" in kinds:
            from ..render.sheets import pdf

            progress("compiling PDF")
            start = time.monotonic()
            try:
                files[f"{name}.pdf"], pages, overfull = pdf.compile_pdf_report(tex, name)
            except LatexError as exc:   # the other outputs are still worth writing, with the .tex and the log
                failure = exc
                files |= pdf.failure_outputs(name, tex, exc)
            except ToolMissingError as exc:   # no TeX, no TikZ: so are they
                failure = exc
            else:
                if sheet is not None:
                    sheet.update(pages=pages, seconds=round(time.monotonic() - start, 1),
                                 overfull=max(overfull, default=0.0))
    if "html" in kinds:
        progress("rendering HTML")
        files[f"{name}.html"] = render_html(derivation, template_dir, sections, digits).encode()
    if "json" in kinds:
        files[f"{name}.json"] = render_json(derivation).encode()
    return files, failure


def planned_files(name: str, kinds: Collection[str]) -> list[str]:
    """The names of the files ``kinds`` give robot ``name`` (its sheets' and its code targets'),
    to check the output paths before the derivation."""
    from ..render.targets import TARGETS

    sheets = {"latex": "{}.tex", "pdf": "{}.pdf", "html": "{}.html", "json": "{}.json"}
    patterns = [sheets[kind] for kind in sheets if kind in kinds]
    patterns += [pattern for target in TARGETS if target.kind in kinds for pattern in target.outputs]
    return [pattern.format(name) for pattern in patterns]


def failure_text(folder: Path, name: str, failure: LatexError | ToolMissingError) -> str:
    """The line for a PDF that could not be made into ``folder``."""
    if isinstance(failure, LatexError):
        from ..render.sheets.pdf import failure_message

        return failure_message(folder, name, failure)
    return f"{folder / (name + '.pdf')} skipped: {failure}"


def solve_outputs(derivation: Derivation, kinds: Collection[str], tests: bool, out: Path,
                  template_dir: Path | None, sections: object, progress: Callable[[str], None],
                  digits: int | None = None) -> tuple[dict[Path, bytes], list[str], list[Path]]:
    """Every file of ``kinds`` (``build``'s: ``latex``, ``pdf``, ``html``, ``json`` and the code
    targets') by path, one message per output that could not be made (its log, if any, is among
    the files) and the files to remove (``stale_beside``); ``tests``: the NumPy module's checks
    too; the sheet's numbers to ``digits`` at most (``--digits``)."""
    name = derivation.robot.name
    made, failures, stale = target_files(derivation, kinds, template_dir, progress, out, tests)
    sheets, failure = sheet_files(derivation, kinds, template_dir, sections, digits, progress)
    files = {out / path: data for path, data in (made | sheets).items()}
    removed = [out / path for path in stale]
    if failure is not None:
        failures.append(failure_text(out, name, failure))
    if "pdf" in kinds:
        from ..render.sheets.pdf import stale_beside

        stale_files, said = stale_beside(out, name, made=out / f"{name}.pdf" in files)
        removed += stale_files
        if said:
            failures[-1] += said
    return files, failures, removed
