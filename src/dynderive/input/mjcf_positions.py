"""Where in an MJCF file a compiled element came from.

MuJoCo's model specification keeps the line of each element it read from the main file
(``info``: ``"line N"``; elements from an ``<include>``d file have none); the column is where
that line's ``<tag`` starts. MuJoCo's compile errors name a line too (``compile_problem``).
"""

from __future__ import annotations

import re
from xml.parsers import expat

from ..errors import Problem

_LINE = re.compile(r"\bline (\d+)")
_ELEMENT = re.compile(r"Element (?:name )?'([^']*)'")


def root_tag(text: str) -> str | None:
    """The root element's tag of an XML text, or None when it does not parse that far."""
    parser = expat.ParserCreate()
    found: list[str] = []

    def start(tag: str, _: dict[str, str]) -> None:
        found.append(tag)
        raise StopIteration

    parser.StartElementHandler = start
    try:
        parser.Parse(text, True)
    except (StopIteration, expat.ExpatError):
        pass
    return found[0] if found else None


class Locator:
    """Line and column of elements of one MJCF file's text."""

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self.root = self._first("mujoco")
        self.include = self._first("include", default=None)

    def _first(self, tag: str, default: tuple[int, int] | None = (1, 1)) -> tuple[int, int] | None:
        for number, line in enumerate(self.lines, 1):
            column = line.find(f"<{tag}")
            if column >= 0:
                return number, column + 1
        return default

    def at_line(self, line: int, tag: str | None = None) -> tuple[int, int]:
        """The start of ``<tag`` on ``line`` (the line's first character that is not blank)."""
        if not 1 <= line <= len(self.lines):
            return self.root
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


def compile_problem(message: str, file: str, locator: Locator) -> Problem:
    """MuJoCo's error text as one positioned line: ``MuJoCo: <what> (element ...)``."""
    lines = [line.strip() for line in message.strip().splitlines() if line.strip()]
    what = lines[0] if lines else "the model does not compile"
    for prefix in ("XML Error: ", "Error: "):
        if what.startswith(prefix):
            what = what[len(prefix):]
    rest = " ".join(lines[1:])
    line_match = _LINE.search(rest)
    element = _ELEMENT.search(rest)
    tag = None
    tag_match = re.search(r"Element '([A-Za-z_]+)'", rest)
    if tag_match:
        tag = tag_match.group(1)
    where = locator.at_line(int(line_match.group(1)), tag) if line_match else locator.root
    detail = f" (element '{element.group(1)}')" if element and element.group(1) and not tag_match else ""
    return Problem(file, *where, f"MuJoCo: {what}{detail}")
