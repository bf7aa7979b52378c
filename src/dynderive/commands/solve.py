"""``dynderive solve``'s output files, in memory: what the command line asked for, made from
one derivation, and the outputs that could not be made (a PDF without LaTeX, a sheet LaTeX
rejects, an extension the compiler rejects) as messages, so that the command writes all the
others at once (``output.write_all``) and then exits 1 naming each failure; and the files the
run makes stale, removed in the same step: an earlier PDF when this one could not be made, the
log of an earlier failure when the PDF or the extension is made.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path

from ..derivation import Derivation
from ..errors import LatexError, ToolMissingError


@dataclass(frozen=True)
class Wanted:
    """The output flags of ``solve``; ``targets``: the code targets asked for, by ``build``
    kind (``render/targets``: ``code``, ``c``, ``c_extension``, ...)."""

    latex: bool = False
    pdf: bool = False
    json: bool = False
    tests: bool = False
    html: bool = False
    targets: frozenset[str] = frozenset()


def target_files(derivation: Derivation, kinds: Collection[str], template_dir: str | Path | None,
                 progress: Callable[[str], None] = lambda stage: None, folder: Path | None = None,
                 tests: bool = False) -> tuple[dict[str, bytes], list[str], list[str]]:
    """The files of the code targets among ``kinds`` by name, in the registry's order (a
    target that refuses the robot stops the run before the later ones' work), for a fixed or
    a floating base; ``tests``: the NumPy module's checks too. With ``folder`` (``solve``), a
    target that could not be made (the extension a compiler rejected) leaves its log and a
    message (the other outputs are still written) and one that was made names the files of an
    earlier failure it makes stale; without, its error stops the robot (``build``)."""
    from ..render.targets import TARGETS, resolve

    name = derivation.robot.name
    files: dict[str, bytes] = {}
    failures: list[str] = []
    stale: list[str] = []
    for target in TARGETS:
        if target.kind not in kinds:
            continue
        if target.progress:
            progress(target.progress + (" (floating base)" if derivation.robot.floating else ""))
        try:
            files |= target.files(derivation, template_dir, files, tests=tests, progress=progress)
        except Exception as exc:
            if folder is None or target.failure is None:
                raise
            logs, message = resolve(target.failure)(exc, folder, name)   # raises what is not its failure
            files |= logs
            failures.append(message)
        else:
            stale += [pattern.format(name) for pattern in target.stale]
    return files, failures, stale


def solve_outputs(derivation: Derivation, wanted: Wanted, out: Path, template_dir: Path | None,
                  sections: object, progress: Callable[[str], None],
                  digits: int | None = None) -> tuple[dict[Path, bytes], list[str], list[Path]]:
    """Every requested file by path, one message per output that could not be made (its log,
    if any, is among the files) and the files to remove (``stale_beside``); the sheet's
    numbers to ``digits`` at most (``--digits``)."""
    from ..render.json import render_json
    from ..render.latex import render_latex

    name = derivation.robot.name
    made, failures, stale = target_files(derivation, wanted.targets, template_dir, progress, out, wanted.tests)
    files = {out / path: data for path, data in made.items()}
    removed = [out / path for path in stale]
    tex = None
    if wanted.latex or wanted.pdf:
        progress("rendering LaTeX")
        tex = render_latex(derivation, template_dir, sections, digits)
    if wanted.latex:
        files[out / f"{name}.tex"] = tex.encode()  # type: ignore[union-attr]
    if wanted.pdf:
        from ..render.pdf import compile_pdf, failure_message, failure_outputs, stale_beside

        progress("compiling PDF")
        try:
            files[out / f"{name}.pdf"] = compile_pdf(tex, name)  # type: ignore[arg-type]
        except ToolMissingError as exc:   # the other outputs are still worth writing
            failures.append(f"{out / (name + '.pdf')} skipped: {exc}")
        except LatexError as exc:   # so are they, with the .tex and LaTeX's log to look at
            files |= {out / log: text for log, text in failure_outputs(name, tex, exc).items()}  # type: ignore[arg-type]
            failures.append(failure_message(out, name, exc))
        stale, said = stale_beside(out, name, made=out / f"{name}.pdf" in files)
        removed += stale
        if said:
            failures[-1] += said
    if wanted.html:
        from ..render.html import render_html

        progress("rendering HTML")
        files[out / f"{name}.html"] = render_html(derivation, template_dir, sections, digits).encode()
    if wanted.json:
        files[out / f"{name}.json"] = render_json(derivation).encode()
    return files, failures, removed
