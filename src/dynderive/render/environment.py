"""One strict Jinja environment per output kind, looking in a user directory first.

``.tex`` templates use LaTeX-safe delimiters (``\\VAR{x}``, ``\\BLOCK{for ...}``,
``\\#{comment}``) so LaTeX's own braces and ``%`` need no escaping; other templates use
Jinja's defaults. ``StrictUndefined`` turns any missing variable into an error.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2

LATEX_DELIMITERS = {
    "block_start_string": r"\BLOCK{",
    "block_end_string": "}",
    "variable_start_string": r"\VAR{",
    "variable_end_string": "}",
    "comment_start_string": r"\#{",
    "comment_end_string": "}",
    "line_statement_prefix": "%%",
    "line_comment_prefix": "%#",
}


def builtin_templates_dir() -> Path:
    """The templates shipped with dynderive (inside the wheel, or the checkout's ``templates/``)."""
    packaged = resources.files("dynderive") / "templates"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[3] / "templates"


@lru_cache(maxsize=16)
def environment(kind: str, template_dir: str | None = None) -> jinja2.Environment:
    """The environment for ``kind`` ("latex" or "code"); ``template_dir`` overrides by file name."""
    search = [str(template_dir)] if template_dir else []
    search.append(str(builtin_templates_dir()))
    options = dict(LATEX_DELIMITERS) if kind == "latex" else {}
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(search),
        undefined=jinja2.StrictUndefined,
        autoescape=False,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        **options,  # type: ignore[arg-type]
    )
    return env


def render(kind: str, name: str, context: dict[str, object], template_dir: str | Path | None) -> str:
    env = environment(kind, str(template_dir) if template_dir else None)
    return env.get_template(name).render(**context)


def templates_in_use(names: list[str], template_dir: str | Path | None) -> list[Path]:
    """Files that would be loaded for ``names`` (including included ones), for build hashes."""
    found = []
    for name in names:
        for base in ([Path(template_dir)] if template_dir else []) + [builtin_templates_dir()]:
            if (base / name).is_file():
                found.append(base / name)
                break
    return found
