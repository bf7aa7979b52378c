"""The sheet (``--latex``, ``--pdf``, ``--html``) and the JSON dump of a floating-base robot,
for ``solve`` and ``build`` (``commands/floating.py``): file name -> bytes, and the PDF that
could not be made, if any (the other outputs are still written)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..derivation import Derivation
from ..errors import LatexError, ToolMissingError

#: The outputs of this module (``--latex``, ``--pdf``, ``--json``, ``--html``).
SHEET_KINDS = ("latex", "pdf", "json", "html")


def floating_sheet_files(derivation: Derivation, kinds: set[str] | tuple[str, ...], template_dir: str | Path | None,
                         digits: int | None = None, progress: Callable[[str], None] = lambda stage: None,
                         ) -> tuple[dict[str, bytes], LatexError | ToolMissingError | None]:
    """The requested files by name, and the PDF's failure (the ``.tex`` and LaTeX's log are
    then among the files)."""
    name = derivation.robot.name
    files: dict[str, bytes] = {}
    failure: LatexError | ToolMissingError | None = None
    if "latex" in kinds or "pdf" in kinds:
        from ..render.floating_latex import render_floating_latex

        progress("rendering LaTeX (floating base)")
        tex = render_floating_latex(derivation, template_dir, digits)
        if "latex" in kinds:
            files[f"{name}.tex"] = tex.encode()
        if "pdf" in kinds:
            from ..render.pdf import compile_pdf, failure_outputs

            progress("compiling PDF")
            try:
                files[f"{name}.pdf"] = compile_pdf(tex, name)
            except ToolMissingError as exc:
                failure = exc
            except LatexError as exc:
                failure = exc
                files |= failure_outputs(name, tex, exc)
    if "html" in kinds:
        from ..render.html_floating import render_floating_html

        progress("rendering HTML (floating base)")
        files[f"{name}.html"] = render_floating_html(derivation, template_dir, digits).encode()
    if "json" in kinds:
        from ..render.floating_json import render_floating_json

        progress("writing JSON (floating base)")
        files[f"{name}.json"] = render_floating_json(derivation).encode()
    return files, failure


def failure_text(out: Path, name: str, failure: LatexError | ToolMissingError) -> str:
    """``solve``'s line for a PDF that could not be made (as for a fixed-base robot)."""
    if isinstance(failure, LatexError):
        from ..render.pdf import failure_message

        return failure_message(out, name, failure)
    return f"{out / (name + '.pdf')} skipped: {failure}"
