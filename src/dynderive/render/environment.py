"""One strict Jinja environment per output kind, looking in a user directory first.

``.tex`` templates use LaTeX-safe delimiters (``\\VAR{x}``, ``\\BLOCK{for ...}``,
``\\#{comment}``) so LaTeX's own braces and ``%`` need no escaping; other templates use
Jinja's defaults. ``StrictUndefined`` turns any missing variable into an error.
"""

from __future__ import annotations

import os
from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2
import jinja2.bccache
import markupsafe

from .encode import Code, docstring, escape_tex, is_plain, python_literal, tex_unit

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


class _BytecodeCache(jinja2.FileSystemBytecodeCache):
    """Jinja's cache of compiled templates (in its per-user temporary folder; each entry
    checked against its template's source, written atomically): compiling the sheet and the
    module's templates costs 0.3 s, every run. A cache that cannot be written is skipped."""

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            super().load_bytecode(bucket)
        except Exception:   # unreadable or corrupt (any unpickling error): compile afresh
            bucket.reset()

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            super().dump_bytecode(bucket)
        except OSError:
            pass


def _bytecode_cache() -> jinja2.BytecodeCache | None:
    if os.environ.get("DYNDERIVE_NO_TEMPLATE_CACHE"):
        return None
    try:
        return _BytecodeCache(pattern="dynderive-%s.cache")
    except (OSError, RuntimeError):   # no safe per-user folder
        return None


@lru_cache(maxsize=16)
def environment(kind: str, template_dir: str | None = None) -> jinja2.Environment:
    """The environment for ``kind`` ("latex" or "code"); ``template_dir`` overrides by file name."""
    search = [str(template_dir)] if template_dir else []
    search.append(str(builtin_templates_dir()))
    options: dict[str, object] = dict(LATEX_DELIMITERS) if kind == "latex" else {"finalize": _python_source}
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(search),
        undefined=jinja2.StrictUndefined,
        autoescape=False,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        bytecode_cache=_bytecode_cache(),
        **options,  # type: ignore[arg-type]
    )
    env.filters.update({"docstring": docstring, "py": python_literal, "tex": escape_tex, "tex_unit": tex_unit})
    return env


def _python_source(value: object) -> object:
    """What a code template prints: encoded text (``Code``), numbers, or text that holds
    nothing that could change the program; anything else is a template bug (free text
    printed without ``|docstring`` or ``|py``), refused before a module is written."""
    if isinstance(value, (Code, markupsafe.Markup)) or value is None or isinstance(value, (bool, int, float)):
        return value
    text = str(value)
    if not is_plain(text):
        raise TemplateEncodingError(f"a code template printed text that is not encoded for Python: {text[:60]!r} "
                                    "(use the |docstring or |py filter)")
    return value


class TemplateEncodingError(ValueError):
    """A code template printed free text without encoding it."""


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
