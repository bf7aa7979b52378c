"""Where in an MJCF file a compiled element came from.

MuJoCo's model specification keeps the line of each element it read from the main file
(``info``: ``"line N"``; elements from an ``<include>``d file have line 0); the column is where
that line's ``<tag`` starts. MuJoCo's compile errors name a line too (``compile_problem``); an
error in an included file is placed in that file when MuJoCo's message or the element's name
shows where it is, else at the ``<include>``.
"""

from __future__ import annotations

import re
from pathlib import Path
from xml.parsers import expat

from ..errors import Problem

_LINE = re.compile(r"\bline (\d+)")
_TAG = re.compile(r"Element '([A-Za-z_]+)'")
_NAME = re.compile(r"Element name '([^']*)'")
_ATTRIBUTE = re.compile(r"attribute:? '([^']+)'")
#: TinyXML's parse errors: ``Error=XML_ERROR_MISMATCHED_ELEMENT ... Line number=3: XMLElement name=body``.
_PARSE = re.compile(r"Error=XML_ERROR_(\w+).*?Line number=(\d+)(?:: XMLElement name=(\S+))?", re.S)
_INCLUDE = re.compile(r"Include error: '(.*)'\s*Element 'include', line (\d+)", re.S)
#: Deepest ``<include>`` nesting followed when looking for an element, and the largest file read.
MAX_INCLUDE_DEPTH = 8
MAX_INCLUDED_BYTES = 2_000_000


def root_tag(text: str) -> str | None:
    """The root element's tag of an XML text, or None when it does not parse that far."""
    found = _elements(text, stop_after=1)
    return found[0][0] if found else None


def _elements(text: str, stop_after: int | None = None) -> list[tuple[str, dict[str, str], int]]:
    """``(tag, attributes, line)`` of the text's elements in document order, as far as the text
    is well-formed XML."""
    parser = expat.ParserCreate()
    found: list[tuple[str, dict[str, str], int]] = []

    def start(tag: str, attributes: dict[str, str]) -> None:
        found.append((tag, attributes, parser.CurrentLineNumber))
        if stop_after is not None and len(found) >= stop_after:
            raise StopIteration

    parser.StartElementHandler = start
    try:
        parser.Parse(text, True)
    except (StopIteration, expat.ExpatError, ValueError):
        pass
    return found


class Locator:
    """Line and column of elements of one MJCF file's text (``path``: where the file is, for
    its ``<include>``s, which MuJoCo reads relative to the main file's folder)."""

    def __init__(self, text: str, path: str | Path | None = None, base: Path | None = None):
        self.lines = text.splitlines()
        self.path = None if path is None else Path(path)
        self.base = base if base is not None else (self.path.parent if self.path is not None else Path("."))
        self.elements = _elements(text)
        self.root = self.at_line(self.elements[0][2], self.elements[0][0]) if self.elements else (1, 1)
        self.include = self._first("include", default=None)

    def model_name(self) -> str | None:
        """``<mujoco model="...">`` as written (None when the file does not name its model)."""
        if not self.elements or self.elements[0][0] != "mujoco":
            return None
        return self.elements[0][1].get("model") or None

    def _first(self, tag: str, default: tuple[int, int] | None = (1, 1)) -> tuple[int, int] | None:
        line = next((line for name, _, line in self.elements if name == tag), None)
        if line is not None:
            return self.at_line(line, tag)
        for number, text in enumerate(self.lines, 1):
            column = text.find(f"<{tag}")
            if column >= 0:
                return number, column + 1
        return default

    def at_line(self, line: int, tag: str | None = None) -> tuple[int, int]:
        """The start of ``<tag`` on ``line`` (the line's first character that is not blank)."""
        if not 1 <= line <= len(self.lines):
            return getattr(self, "root", (1, 1))
        text = self.lines[line - 1]
        column = text.find(f"<{tag}") if tag else -1
        if column < 0:
            column = len(text) - len(text.lstrip())
        return line, column + 1

    def of(self, element: object, tag: str) -> tuple[int, int]:
        """Where a specification element (``mujoco.MjsBody``, ``MjsJoint``...) was written: its
        line in the main file, or the ``<include>`` that brought it, or the root element."""
        match = _LINE.search(getattr(element, "info", "") or "")
        if match and int(match.group(1)) > 0:
            return self.at_line(int(match.group(1)), tag)
        return self.include or self.root

    def included(self, line: int | None = None) -> list[tuple[Path, int]]:
        """The files this one's ``<include>`` elements name (the one at ``line`` only), with the
        line of each ``<include>``."""
        return [(self.base / attributes["file"], at) for tag, attributes, at in self.elements
                if tag == "include" and "file" in attributes and (line is None or at == line)]

    def find(self, wanted, depth: int = 0, seen: set[Path] | None = None
             ) -> list[tuple[Path, tuple[int, int], int]]:
        """Elements of the included files (followed ``MAX_INCLUDE_DEPTH`` deep) for which
        ``wanted(tag, attributes)`` holds: (file, position, line of the main file's ``<include>``)."""
        seen = set() if seen is None else seen
        hits: list[tuple[Path, tuple[int, int], int]] = []
        if depth >= MAX_INCLUDE_DEPTH:
            return hits
        for file, at in self.included():
            inner = _locator_of(file, self.base, seen)
            if inner is None:
                continue
            for tag, attributes, line in inner.elements:
                if wanted(tag, attributes):
                    hits.append((file, inner.at_line(line, tag), at))
            hits += [(f, where, at) for f, where, _ in inner.find(wanted, depth + 1, seen)]
        return hits


def _locator_of(file: Path, base: Path, seen: set[Path]) -> Locator | None:
    """A locator of an included file, or None if it cannot be read (or was read already)."""
    try:
        key = file.resolve()
        if key in seen or not file.is_file() or file.stat().st_size > MAX_INCLUDED_BYTES:
            return None
        seen.add(key)
        return Locator(file.read_text(encoding="utf-8", errors="replace"), file, base)
    except OSError:
        return None


def _clean(text: str) -> str:
    """MuJoCo's message without its ``XML Error:`` / ``Error:`` / ``ParseXML:`` prefixes."""
    text = text.strip()
    changed = True
    while changed:
        changed = False
        for prefix in ("XML Error: ", "Error: ", "ParseXML: "):
            if text.startswith(prefix):
                text, changed = text[len(prefix):].strip(), True
    return text


def compile_problem(message: str, file: str, locator: Locator) -> Problem:
    """MuJoCo's error text as one positioned line: ``MuJoCo: <what> (element ...)``.

    The position is the element MuJoCo names (its line, the column of its ``<tag``); an error
    inside an ``<include>``d file is placed in that file when it can be found there, and says
    which ``<include>`` brought it."""
    message = _clean(message)
    include = _INCLUDE.search(message)
    if include:   # MuJoCo could not read an included file: its own message, placed in that file
        line = int(include.group(2))
        files = locator.included(line)
        where = locator.at_line(line, "include")
        inner = _locator_of(files[0][0], locator.base, set()) if files else None
        if inner is None:
            return Problem(file, *where, f"MuJoCo: in the included file: {_one_line(include.group(1))}")
        problem = compile_problem(include.group(1), str(files[0][0]), inner)
        return Problem(problem.file, problem.line, problem.column,
                       f"{problem.message} (included from {file}:{where[0]})")
    parse = _PARSE.search(message)
    if parse:   # not well-formed XML (TinyXML's words)
        kind, line, tag = parse.group(1).lower().replace("_", " "), int(parse.group(2)), parse.group(3)
        detail = f" (<{tag}>)" if tag else ""
        return Problem(file, *locator.at_line(line, tag), f"MuJoCo: XML parse error: {kind}{detail}")
    lines = [line.strip() for line in message.splitlines() if line.strip()]
    what = lines[0] if lines else "the model does not compile"
    rest = " ".join(lines[1:])
    line_match = _LINE.search(rest)
    tag_match, name_match = _TAG.search(rest), _NAME.search(rest)
    tag = tag_match.group(1) if tag_match else None
    name = name_match.group(1) if name_match else ""
    detail = f" (element '{name}')" if name else f" (<{tag}>)" if tag else ""
    if line_match and int(line_match.group(1)) > 0:
        return Problem(file, *locator.at_line(int(line_match.group(1)), tag), f"MuJoCo: {what}{detail}")
    if line_match and locator.include:   # an element of an included file (MuJoCo says line 0)
        hits = _in_included(locator, what, tag, name)
        if len(hits) == 1:
            found, (line, column), at = hits[0]
            return Problem(str(found), line, column, f"MuJoCo: {what}{detail} (included from {file}:{at})")
        return Problem(file, *locator.include, f"MuJoCo: {what}{detail} (in an included file)")
    return Problem(file, *locator.root, f"MuJoCo: {what}{detail}")


def _in_included(locator: Locator, what: str, tag: str | None, name: str
                 ) -> list[tuple[Path, tuple[int, int], int]]:
    """The elements of included files that MuJoCo's message can be about: the one of that
    name, or the ``<tag>`` that has the attribute the message names."""
    if name:
        return locator.find(lambda t, attributes: attributes.get("name") == name and (tag is None or t == tag))
    attribute = _ATTRIBUTE.search(what)
    if tag and attribute:
        return locator.find(lambda t, attributes: t == tag and attribute.group(1) in attributes)
    return []


def _one_line(text: str) -> str:
    return " ".join(part.strip() for part in text.splitlines() if part.strip())
