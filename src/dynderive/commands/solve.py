"""``dynderive solve``'s output files, in memory: what the command line asked for, made from
one derivation, and the outputs that could not be made (a PDF without LaTeX, a sheet LaTeX
rejects, an extension the compiler rejects) as messages, so that the command writes all the
others at once (``output.write_all``) and then exits 1 naming each failure; and the files the
run makes stale, removed in the same step: an earlier PDF when this one could not be made, the
log of an earlier failure when the PDF or the extension is made.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..derivation import Derivation
from ..errors import LatexError, ToolMissingError


@dataclass(frozen=True)
class Wanted:
    """The output flags of ``solve``."""

    latex: bool = False
    pdf: bool = False
    code: bool = False
    c: bool = False
    c_extension: bool = False
    matlab: bool = False
    jax: bool = False
    json: bool = False
    tests: bool = False
    html: bool = False


def solve_outputs(derivation: Derivation, wanted: Wanted, out: Path, template_dir: Path | None,
                  sections: object, progress: Callable[[str], None],
                  digits: int | None = None) -> tuple[dict[Path, bytes], list[str], list[Path]]:
    """Every requested file by path, one message per output that could not be made (its log,
    if any, is among the files) and the files to remove (``stale_beside``); the sheet's
    numbers to ``digits`` at most (``--digits``)."""
    from ..render.code import render_code
    from ..render.json import render_json
    from ..render.latex import render_latex

    name = derivation.robot.name
    files: dict[Path, bytes] = {}
    failures: list[str] = []
    removed: list[Path] = []
    c_files = None
    if wanted.c:   # first: a robot the C target refuses stops the run before any work or output
        from ..render.c import render_c

        progress("generating C")
        c_files = render_c(derivation, template_dir)
        files[out / f"{name}_dynamics.h"] = c_files[0].encode()
        files[out / f"{name}_dynamics.c"] = c_files[1].encode()
    if wanted.matlab:   # next: a robot whose names MATLAB refuses stops the run before more work
        from ..render.matlab import render_matlab

        progress("generating MATLAB")
        files |= {out / path: text.encode() for path, text in render_matlab(derivation, template_dir).items()}
        from ..render.matlab_script import render_matlab_script

        files[out / f"{name}_derivation.m"] = render_matlab_script(derivation, template_dir).encode()
    if wanted.jax:
        from ..render.jax import render_jax

        progress("generating JAX")
        files[out / f"{name}_dynamics_jax.py"] = render_jax(derivation, template_dir).encode()
    if wanted.c_extension:
        from .compile import ExtensionCompileError, build_extension
        from .compile import failure_message as build_failure
        from .compile import failure_outputs as build_logs

        try:
            filename, data = build_extension(derivation, template_dir, c_files=c_files, progress=progress)
            files[out / filename] = data
            removed.append(out / f"{name}_dynamics_c.log")   # an earlier failure's
        except ExtensionCompileError as exc:   # the other outputs are still written, with the compiler's log
            files |= {out / log: text for log, text in build_logs(name, exc).items()}
            failures.append(build_failure(out, name, exc))
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
    if wanted.code:
        progress("generating code")
        files[out / f"{name}_dynamics.py"] = render_code(derivation, template_dir).encode()
        if wanted.tests:
            from ..render.code import render_code_tests

            files[out / f"test_{name}_dynamics.py"] = render_code_tests(derivation, template_dir).encode()
    if wanted.json:
        files[out / f"{name}.json"] = render_json(derivation).encode()
    return files, failures, removed
