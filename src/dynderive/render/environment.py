"""One strict, sandboxed Jinja environment per output kind, looking in a user directory first.

``.tex`` templates use LaTeX-safe delimiters (``\\VAR{x}``, ``\\BLOCK{for ...}``,
``\\#{comment}``) so LaTeX's own braces and ``%`` need no escaping; other templates use
Jinja's defaults. ``StrictUndefined`` turns any missing variable into an error.

Templates are shared (a course hands them around), so they run in Jinja's sandbox and may
call nothing but their own macros, Jinja's globals and the methods of plain data (strings,
lists, dictionaries, numbers): no attribute that starts with ``_`` (``lipsum.__globals__``),
no method of a SymPy or NumPy object (``subs("...")`` would evaluate text), and no ``*`` or
``**`` that builds a huge value. A template that breaks a rule, has a syntax error or fails
while rendering is bad input: ``TemplateProblem`` at the template's file and line (exit 2).
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import traceback
from collections.abc import Callable, Sequence
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import jinja2
import jinja2.bccache
import markupsafe
from jinja2 import meta
from jinja2.sandbox import SandboxedEnvironment, SecurityError

from ..errors import InputError, Problem
from .codegen.names import c_comment
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

#: The largest string or list a template's ``*`` may build, and the largest ``**`` (in bits).
MAX_REPEAT = 10_000_000
MAX_POWER_BITS = 100_000


def builtin_templates_dir() -> Path:
    """The shared templates shipped with dynderive (the sheets and what several Python targets
    render; inside the wheel, or the checkout's ``templates/``)."""
    packaged = resources.files("dynderive") / "templates"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[3] / "templates"


def target_templates_dir() -> Path:
    """The folder of the code targets (``render/targets/``): a target's own templates live in
    its folder, named by it (``c/dynamics.c.j2`` is ``render/targets/c/dynamics.c.j2``)."""
    return Path(__file__).resolve().parent / "targets"


def builtin_template_dirs() -> tuple[Path, ...]:
    """Where the built-in templates are found, in order: the shared ones, then the targets'."""
    return builtin_templates_dir(), target_templates_dir()


class TemplateSandbox(SandboxedEnvironment):
    """Jinja's sandbox, with calls limited to what a template needs (see the module's docstring)."""

    intercepted_binops = frozenset({"*", "**"})

    #: Types whose methods a template may call (exact types: a NumPy float is a ``float``
    #: subclass whose ``dump`` writes files).
    SAFE_OWNERS = frozenset({str, bytes, int, float, bool, list, tuple, dict, set, frozenset, range,
                             type({}.keys()), type({}.values()), type({}.items()), Code, markupsafe.Markup,
                             jinja2.runtime.LoopContext, jinja2.utils.Cycler, jinja2.utils.Joiner})

    def is_safe_callable(self, obj: object) -> bool:
        if not super().is_safe_callable(obj):
            return False
        if isinstance(obj, (jinja2.runtime.Macro, jinja2.runtime.BlockReference, jinja2.runtime.LoopContext)):
            return True
        if any(obj is value for value in self.globals.values()) or getattr(obj, "_sandboxed_format", False):
            return True
        owner = getattr(obj, "__self__", None)
        return owner is not None and type(owner) in self.SAFE_OWNERS

    def wrap_str_format(self, value: object) -> Callable[..., str] | None:
        wrapped = super().wrap_str_format(value)   # str.format, made to refuse "{0.__class__}"
        if wrapped is not None:
            wrapped._sandboxed_format = True  # type: ignore[attr-defined]
        return wrapped

    def call_binop(self, context: jinja2.runtime.Context, operator: str, left: object, right: object) -> object:
        if operator == "**" and _integers(left, right) and abs(left) > 1 and right > 0:  # type: ignore[operator, arg-type]
            if right * math.log2(abs(left)) > MAX_POWER_BITS:  # type: ignore[operator, arg-type]
                raise SecurityError(f"{left} ** {right} is too large for a template")
        if operator == "*":
            for value, count in ((left, right), (right, left)):
                if isinstance(value, (str, list, tuple)) and _integers(count) and len(value) * count > MAX_REPEAT:  # type: ignore[operator]
                    raise SecurityError(f"repeating a {type(value).__name__} {count} times is too large for a template")
        return super().call_binop(context, operator, left, right)


def _integers(*values: object) -> bool:
    return all(isinstance(v, int) and not isinstance(v, bool) for v in values)


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
        with contextlib.suppress(OSError):
            super().dump_bytecode(bucket)


def _bytecode_cache() -> jinja2.BytecodeCache | None:
    if os.environ.get("DYNDERIVE_NO_TEMPLATE_CACHE"):
        return None
    try:
        return _BytecodeCache(pattern="dynderive-%s.cache")
    except (OSError, RuntimeError):   # no safe per-user folder
        return None


@lru_cache(maxsize=16)
def environment(kind: str, template_dir: str | None = None) -> jinja2.Environment:
    """The environment for ``kind`` ("latex", "html" or "code"); ``template_dir`` overrides by
    file name. HTML templates autoescape: only Markup (MathML, SVG) is printed as it is."""
    search = [str(template_dir)] if template_dir else []
    search += [str(path) for path in builtin_template_dirs()]
    options: dict[str, object] = (dict(LATEX_DELIMITERS) if kind == "latex" else {} if kind == "html"
                                  else {"finalize": _python_source})
    env = TemplateSandbox(
        loader=jinja2.FileSystemLoader(search),
        undefined=jinja2.StrictUndefined,
        autoescape=kind == "html",
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        bytecode_cache=_bytecode_cache(),
        **options,  # type: ignore[arg-type]
    )
    env.filters.update({"docstring": docstring, "py": python_literal, "tex": escape_tex, "tex_unit": tex_unit,
                        "c_comment": c_comment})
    return env


def _python_source(value: object) -> object:
    """What a code template prints: encoded text (``Code``), numbers, or text that holds
    nothing that could change the program; anything else is a template bug (free text
    printed without ``|docstring`` or ``|py``), refused before a module is written."""
    if value is None or isinstance(value, (Code, markupsafe.Markup, bool, int, float)) \
            or is_plain(str(value)):
        return value
    raise TemplateEncodingError("a code template printed text that is not encoded for Python: "
                                f"{str(value)[:60]!r} (use the |docstring or |py filter)")


class TemplateEncodingError(ValueError):
    """A code template printed free text without encoding it."""


class TemplateProblem(InputError):
    """A user's template is at fault (exit 2): every robot rendered with it would fail alike."""


def kind_of(name: str) -> str:
    """The environment a template is rendered in, by its file name."""
    return "latex" if name.endswith(".tex.j2") else "html" if name.endswith(".html.j2") else "code"


def render(kind: str, name: str, context: dict[str, object], template_dir: str | Path | None) -> str:
    """``name`` rendered with ``context``; a failure in a template of ``template_dir`` is the
    user's (``InputError`` at its file and line), one in a built-in template is ours."""
    env = environment(kind, str(template_dir) if template_dir else None)
    try:
        return env.get_template(name).render(**context)
    except jinja2.TemplateSyntaxError as exc:
        if template_dir is None or not _is_user_file(exc.filename, template_dir):
            raise
        raise TemplateProblem(Problem(exc.filename or name, exc.lineno or 1, 1, f"template syntax error: {exc.message}")) from None
    except Exception as exc:
        where = _user_frame(exc, template_dir)
        if where is None:
            raise
        file, line = where
        message = exc.message if isinstance(exc, jinja2.TemplateError) and exc.message else str(exc)
        if isinstance(exc, SecurityError):
            message = f"refused by the template sandbox: {message}"
        elif isinstance(exc, jinja2.TemplateNotFound):
            message = f"template not found: {exc.name}"
        elif not isinstance(exc, (jinja2.TemplateError, TemplateEncodingError)):
            message = f"{type(exc).__name__}: {message}"
        raise TemplateProblem(Problem(file, line, _column(file, line, exc), f"template error: {message}")) from None


def _is_user_file(filename: str | None, template_dir: str | Path) -> bool:
    if not filename:
        return False
    return Path(filename).resolve().is_relative_to(Path(template_dir).resolve())


def _user_frame(exc: BaseException, template_dir: str | Path | None) -> tuple[str, int] | None:
    """The innermost line of a user template in ``exc``'s traceback (Jinja rewrites the
    traceback so that a template's frames carry its file name and line)."""
    if template_dir is None:
        return None
    found = None
    for frame in traceback.extract_tb(exc.__traceback__):
        if frame.filename.endswith(".j2") and frame.lineno and _is_user_file(frame.filename, template_dir):
            found = (frame.filename, frame.lineno)
    return found


def _column(file: str, line: int, exc: BaseException) -> int:
    """The column of the refused attribute or missing name on the template's line, else 1."""
    match = re.search(r"'([A-Za-z_][A-Za-z_0-9]*)'", str(exc))
    try:
        text = Path(file).read_text(encoding="utf-8").split("\n")[line - 1]
    except (OSError, UnicodeDecodeError, IndexError):
        return 1
    position = text.find(match.group(1)) if match else -1
    return position + 1 if position >= 0 else len(text) - len(text.lstrip()) + 1


def templates_in_use(names: list[str], template_dir: str | Path | None) -> list[tuple[str, Path]]:
    """The templates that ``names`` load (their ``{% include %}``, ``{% extends %}`` and
    ``{% import %}``, recursively), as (name, file), for build hashes. A reference by a
    variable (not a string) could be any file: then every file in ``template_dir`` counts."""
    directory = str(template_dir) if template_dir else None
    found: dict[tuple[str, str], Path] = {}
    todo = [(kind_of(name), name) for name in names]
    dynamic = False
    while todo:
        kind, name = todo.pop()
        if (kind, name) in found:
            continue
        env = environment(kind, directory)
        try:
            source, filename, _ = env.loader.get_source(env, name)  # type: ignore[union-attr]
        except (jinja2.TemplateNotFound, OSError, UnicodeDecodeError):
            continue   # rendering will report it
        found[(kind, name)] = Path(filename)  # type: ignore[arg-type]
        try:
            references = _references(kind, directory, source)
        except jinja2.TemplateSyntaxError:
            continue   # rendering will report it
        dynamic |= None in references
        todo += [(kind, reference) for reference in references if reference is not None]
    used = {(name, path) for (_, name), path in found.items()}
    if dynamic and directory:
        base = Path(directory)
        used |= {(p.relative_to(base).as_posix(), p) for p in base.rglob("*") if p.is_file()}
    return sorted(used)


@lru_cache(maxsize=64)
def _references(kind: str, directory: str | None, source: str) -> tuple[str | None, ...]:
    """The templates ``source`` names (``None``: one named by a variable); parsed once per text."""
    return tuple(meta.find_referenced_templates(environment(kind, directory).parse(source)))


def locate_output_line(names: list[str], template_dir: str | Path | None, text: str) -> tuple[str, int, int] | None:
    """Where in the user's templates (those of ``template_dir`` that ``names`` load) the output
    line ``text`` most likely comes from: the line whose literal text, with its ``{{ }}`` and
    ``{% %}`` parts as wildcards, matches it best (file, line, column); ``None`` when no user
    template is in use."""
    if template_dir is None:
        return None
    user = [path for _, path in templates_in_use(names, template_dir) if _is_user_file(str(path), template_dir)]
    if not user:
        return None
    target = text.strip()
    best: tuple[int, str, int, int] | None = None
    for path in user:
        try:
            lines = path.read_text(encoding="utf-8").split("\n")
        except (OSError, UnicodeDecodeError):
            continue
        for number, line in enumerate(lines, 1):
            parts = _TAG.split(line.strip())
            literal = sum(len(p.strip()) for p in parts[::2])
            if literal == 0 or (best is not None and literal <= best[0]):
                continue
            pattern = ".*".join(re.escape(p) for p in parts[::2])
            if target and re.fullmatch(pattern, target, re.DOTALL):
                best = (literal, str(path), number, len(line) - len(line.lstrip()) + 1)
    if best is None:   # the main template if it is the user's, else the first of theirs it loads
        main = [p for p in user if p.name == Path(names[0]).name]
        return str((main or user)[0]), 1, 1
    return best[1], best[2], best[3]


_TAG = re.compile(r"(\{\{.*?\}\}|\{%.*?%\}|\{#.*?#\})")


def template_fault(error: Exception, line: int | None, text: str, name: str,
                   template_dir: str | Path | None) -> TemplateProblem | None:
    """``error`` in the output ``text`` of template ``name`` (at its ``line``, if known) as bad
    input at the line of the user's template that made it; ``None`` when only built-in
    templates are in use (then it is an internal error)."""
    lines = text.split("\n")
    line = line if line is not None and 1 <= line <= len(lines) else None
    where = locate_output_line([name], template_dir, lines[line - 1] if line else "")
    if where is None:
        return None
    file, row, column = where
    shown = f" (line {line} of the output: {lines[line - 1].strip()[:60]!r})" if line else ""
    return TemplateProblem(Problem(file, row, column, f"template error: {error}{shown}"))


class LazyList(Sequence):
    """A template variable's list, made on first use (its length known before): the sheet's
    context offers quantities a custom template may show and the default one does not."""

    def __init__(self, size: int, make: Callable[[], list[Any]]):
        self._size, self._make, self._items = size, make, None

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: Any) -> Any:
        if self._items is None:
            self._items = self._make()
        return self._items[index]
