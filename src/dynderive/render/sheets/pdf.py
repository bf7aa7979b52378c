"""Compile a LaTeX sheet to PDF bytes with latexmk, reproducibly and without shell escape."""

from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from ...errors import LatexError, ToolMissingError

#: Fixed date for reproducible PDFs (2000-01-01T00:00:00Z).
SOURCE_DATE_EPOCH = "946684800"
#: The Debian/Ubuntu packages of the TeX that ``--pdf`` needs (TikZ: texlive-pictures); the
#: sample CI workflow, ``.ci/run`` and docs/install.md install the same (a test checks).
TEX_PACKAGES = "latexmk texlive-latex-base texlive-latex-recommended texlive-fonts-recommended texlive-pictures"


def latex_engine_available() -> bool:
    return shutil.which("latexmk") is not None and shutil.which("pdflatex") is not None


@functools.lru_cache(maxsize=1)
def tikz_available() -> bool:
    """Whether TeX finds TikZ (Debian's texlive-pictures), which the sheets' drawings use."""
    if shutil.which("kpsewhich") is None:
        return False
    found = subprocess.run(["kpsewhich", "tikz.sty"], capture_output=True, text=True, stdin=subprocess.DEVNULL)
    return found.returncode == 0 and bool(found.stdout.strip())


def compile_pdf_report(tex: str, jobname: str = "sheet", timeout: float = 300) -> tuple[bytes, int, list[float]]:
    """PDF bytes of ``tex``, with the page count and the widths (pt) of overfull lines that
    pdflatex's last pass logged (``build`` reports them). Works in a private temporary
    directory; writes nothing else."""
    if not latex_engine_available():
        raise ToolMissingError(
            f"--pdf needs latexmk and pdflatex, which are not installed (Debian/Ubuntu: "
            f"apt-get install {TEX_PACKAGES}); --latex alone writes the .tex file")
    if "\\usepackage{tikz}" in tex and not tikz_available():
        raise ToolMissingError(
            "--pdf: the sheet's drawing needs TikZ, which TeX does not find (Debian/Ubuntu: apt-get install "
            "texlive-pictures); --latex alone writes the .tex file")
    env = dict(os.environ, SOURCE_DATE_EPOCH=SOURCE_DATE_EPOCH, FORCE_SOURCE_DATE="1",
               openout_any="p", shell_escape="f")
    with tempfile.TemporaryDirectory(prefix="dynderive-tex-") as work:
        source = Path(work) / f"{jobname}.tex"
        source.write_text(tex, encoding="utf-8")
        command = ["latexmk", "-pdf", "-interaction=nonstopmode", "-halt-on-error",
                   "-no-shell-escape", "-quiet", f"-jobname={jobname}", source.name]
        log_file = Path(work) / f"{jobname}.log"
        try:
            result = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True,
                                    timeout=timeout, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired as exc:
            raise LatexError(f"LaTeX did not finish within {timeout:.0f} s",
                             _read(log_file) or _text(exc.stdout) + _text(exc.stderr)) from None
        pdf = Path(work) / f"{jobname}.pdf"
        text = _read(log_file)
        if result.returncode != 0 or not pdf.is_file():
            log = text or result.stdout + result.stderr
            raise LatexError(_first_error(log), log)
        return pdf.read_bytes(), *read_log(text, jobname)


def _read(path: Path) -> str:
    return path.read_text(errors="replace") if path.is_file() else ""


def _text(output: str | bytes | None) -> str:
    return output.decode(errors="replace") if isinstance(output, bytes) else output or ""


def read_log(log: str, jobname: str) -> tuple[int, list[float]]:
    """Pages written and overfull line widths (pt) from a pdflatex log."""
    pages = re.search(rf"Output written on {re.escape(jobname)}\.pdf \((\d+) pages?", log)
    overfull = [float(w) for w in re.findall(r"Overfull \\hbox \(([\d.]+)pt too wide\)", log)]
    return (int(pages.group(1)) if pages else 0), overfull


def _first_error(log: str) -> str:
    """The log's first error line (``! Double subscript.``) and where TeX was in the .tex
    (the ``l.123`` line that follows it): ``Double subscript. (line 123)``."""
    lines = log.splitlines()
    for k, line in enumerate(lines):
        if line.startswith("!"):
            where = next((m.group(1) for m in map(re.compile(r"l\.(\d+)\b").match, lines[k + 1:k + 30]) if m), None)
            return line[1:].strip() + (f" (line {where})" if where else "")
    return "no error line in the log"


def failure_outputs(name: str, tex: str, error: LatexError) -> dict[str, bytes]:
    """What a sheet that LaTeX could not compile leaves beside the other outputs, by file name:
    its source and LaTeX's log."""
    return {f"{name}.tex": tex.encode(), f"{name}.log": error.log.encode()}


def stale_beside(folder: Path, name: str, made: bool) -> tuple[list[Path], str]:
    """What a run that asked for ``name``'s PDF leaves no longer true in ``folder``, to remove
    with its outputs: once the PDF is made, the log of an earlier failure (``<name>.log``);
    once it could not be, an earlier PDF (it would disagree with the new ``.tex``). And the
    words the failure's message ends with ("" when nothing is removed or the PDF was made)."""
    log, pdf = folder / f"{name}.log", folder / f"{name}.pdf"
    if made:
        return [log], ""
    if os.path.lexists(pdf):
        return [pdf], f"; {pdf} from an earlier run was removed (it would not match the new sheet)"
    return [], ""


def failure_message(folder: Path, name: str, error: LatexError) -> str:
    """One line: which sheet failed, TeX's first error, and where its log is."""
    return f"LaTeX failed to compile {folder / (name + '.tex')}: {error.detail}; the log is {folder / (name + '.log')}"

