"""Compile a LaTeX sheet to PDF bytes with latexmk, reproducibly and without shell escape."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import ExternalToolError, ToolMissingError

#: Fixed date for reproducible PDFs (2000-01-01T00:00:00Z).
SOURCE_DATE_EPOCH = "946684800"


def latex_engine_available() -> bool:
    return shutil.which("latexmk") is not None and shutil.which("pdflatex") is not None


def compile_pdf(tex: str, jobname: str = "sheet", timeout: float = 300) -> bytes:
    """PDF bytes of ``tex``. Works in a private temporary directory; writes nothing else."""
    return compile_pdf_report(tex, jobname, timeout)[0]


def compile_pdf_report(tex: str, jobname: str = "sheet", timeout: float = 300) -> tuple[bytes, int, list[float]]:
    """``compile_pdf``, with the page count and the widths (pt) of overfull lines that
    pdflatex's last pass logged (``build`` reports them)."""
    if not latex_engine_available():
        raise ToolMissingError(
            "--pdf needs latexmk and pdflatex, which are not installed (Debian/Ubuntu: "
            "apt-get install latexmk texlive-latex-base texlive-latex-recommended "
            "texlive-fonts-recommended); --latex alone writes the .tex file")
    env = dict(os.environ, SOURCE_DATE_EPOCH=SOURCE_DATE_EPOCH, FORCE_SOURCE_DATE="1",
               openout_any="p", shell_escape="f")
    with tempfile.TemporaryDirectory(prefix="dynderive-tex-") as work:
        source = Path(work) / f"{jobname}.tex"
        source.write_text(tex, encoding="utf-8")
        command = ["latexmk", "-pdf", "-interaction=nonstopmode", "-halt-on-error",
                   "-no-shell-escape", "-quiet", f"-jobname={jobname}", source.name]
        try:
            result = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True,
                                    timeout=timeout, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise ExternalToolError(f"LaTeX did not finish within {timeout:.0f} s") from None
        pdf = Path(work) / f"{jobname}.pdf"
        if result.returncode != 0 or not pdf.is_file():
            log = Path(work) / f"{jobname}.log"
            detail = _first_error(log.read_text(errors="replace") if log.is_file() else result.stdout)
            raise ExternalToolError(f"LaTeX failed to compile the sheet: {detail}")
        log_file = Path(work) / f"{jobname}.log"
        text = log_file.read_text(errors="replace") if log_file.is_file() else ""
        return pdf.read_bytes(), *read_log(text, jobname)


def read_log(log: str, jobname: str) -> tuple[int, list[float]]:
    """Pages written and overfull line widths (pt) from a pdflatex log."""
    pages = re.search(rf"Output written on {re.escape(jobname)}\.pdf \((\d+) pages?", log)
    overfull = [float(w) for w in re.findall(r"Overfull \\hbox \(([\d.]+)pt too wide\)", log)]
    return (int(pages.group(1)) if pages else 0), overfull


def _first_error(log: str) -> str:
    for line in log.splitlines():
        if line.startswith("!"):
            return line[1:].strip()
    return "see the LaTeX log (run pdflatex on the .tex file)"
