"""PyYAML's syntax errors told in words a student understands.

PyYAML reports what its parser expected (``expected <block end>, but found '?'``); a student
needs to hear what is wrong with the line (``this line is indented differently from the lines
before it (its siblings at column 5)``). ``student_problem`` recognises the common mistakes
(a line indented too little or too much, a key without ``:``, a missing space after ``:``,
a tab, a list mixed with keys) from the error and the text, and gives the position where the
fix is needed; anything else keeps PyYAML's wording.
"""

from __future__ import annotations

import re

import yaml

from ..errors import Problem

#: A line whose key is glued to its value by a ``:`` without a space, e.g. ``mass:m``.
_GLUED = re.compile(r"^\s*(?:-\s+)*([A-Za-z_][\w.-]*):(?=[^\s:])")

_KEY_OR_ITEM = (yaml.KeyToken, yaml.BlockEntryToken)


def student_problem(exc: yaml.MarkedYAMLError, text: str, file: str) -> Problem | None:
    """A positioned problem in student wording for a common syntax error, or None."""
    mark = exc.problem_mark
    if mark is None:
        return None
    problem, lines = exc.problem or "", text.splitlines()
    line, column = mark.line + 1, mark.column + 1
    if "'\\t'" in problem and "cannot start any token" in problem:
        return _tab(lines, line, column, file)
    if problem.startswith("could not find expected ':'") and exc.context_mark is not None:
        return _missing_colon(lines, exc.context_mark.line + 1, exc.context_mark.column + 1, file)
    if problem == "mapping values are not allowed here":
        return _colon_not_allowed(text, lines, line, column, file)
    if problem.startswith("expected <block end>, but found"):
        return _block_end(text, line, column, problem, file)
    return None


def _tab(lines: list[str], line: int, column: int, file: str) -> Problem:
    text = lines[line - 1] if line <= len(lines) else ""
    if text[:column - 1].strip(" ") == "":
        return Problem(file, line, column, "this line is indented with a tab: YAML indentation must "
                                           "use spaces")
    return Problem(file, line, column, "a tab cannot stand here in YAML: use spaces")


def _missing_colon(lines: list[str], line: int, column: int, file: str) -> Problem:
    text = lines[line - 1] if line <= len(lines) else ""
    glued = _GLUED.match(text)
    if glued is not None:
        return _glued_problem(file, line, glued)
    return Problem(file, line, column, "this line has no ':' after its key (each line of a mapping "
                                       "is written 'key: value')")


def _glued_problem(file: str, line: int, glued: re.Match) -> Problem:
    return Problem(file, line, glued.end(1) + 1,
                   f"put a space after the ':' of '{glued.group(1)}:' (without it YAML reads "
                   "the key and its value as one word)")


def _colon_not_allowed(text: str, lines: list[str], line: int, column: int, file: str) -> Problem | None:
    """``key: value`` where YAML is still reading a value: a line indented more than the one
    before it (its text continues that value), a previous key glued to its value, or a second
    ``': '`` on one line."""
    content = lines[line - 1] if line <= len(lines) else ""
    start = len(content) - len(content.lstrip(" ")) + 1
    before = content[start - 1:column - 1]
    previous = _previous_content_line(lines, line)
    if previous is not None:
        glued = _GLUED.match(lines[previous - 1])
        if glued is not None and ": " not in lines[previous - 1] and not before.startswith("-"):
            return _glued_problem(file, previous, glued)
    if ":" in before or before.startswith(("-", "[", "{", "'", '"')):
        return Problem(file, line, column, "a second ': ' on this line: a value that contains ': ' "
                                           "must be quoted, or the key belongs on a line of its own")
    opened = _open_columns(text, line)
    if opened and start > opened[-1][0]:
        return Problem(file, line, start, "this line is indented more than the line before it "
                                          f"(its siblings at column {opened[-1][0]})")
    return None


def _block_end(text: str, line: int, column: int, problem: str, file: str) -> Problem | None:
    """The parser wanted a block to end: the line's indentation matches no open block, or a
    list item and a ``key: value`` line share one indentation."""
    opened = _open_columns(text, line)
    if not opened:
        return None
    columns = [c for c, _ in opened]
    deeper = [c for c in columns if c > column]
    found_item = problem.endswith("'-'")
    if column not in columns:
        sibling = deeper[0] if deeper else columns[-1]
        return Problem(file, line, column, "this line is indented differently from the lines before "
                                           f"it (its siblings at column {sibling})")
    kind = dict(opened)[column]
    if (found_item and kind == "key") or (not found_item and kind == "item"):
        if deeper and not found_item:
            return Problem(file, line, column, "this line is indented differently from the lines "
                                               f"before it (its siblings at column {deeper[0]})")
        return Problem(file, line, column, "list items ('- ...') and 'key: value' lines cannot be "
                                           f"mixed at one indentation (column {column})")
    return None


def _previous_content_line(lines: list[str], line: int) -> int | None:
    for number in range(line - 1, 0, -1):
        stripped = lines[number - 1].strip()
        if stripped and not stripped.startswith("#"):
            return number
    return None


def _open_columns(text: str, line: int) -> list[tuple[int, str]]:
    """The block collections still open where ``line`` starts, outermost first, as (column,
    "key" or "item"): read from PyYAML's tokens before that line (keys and list dashes outside
    brackets), so comments, quoted and block scalars do not count."""
    starts: list[tuple[int, int, str]] = []
    scanner = yaml.SafeLoader(text)
    flow = 0
    try:
        while scanner.check_token():
            token = scanner.get_token()
            if token.start_mark.line + 1 >= line:
                break
            if isinstance(token, (yaml.FlowSequenceStartToken, yaml.FlowMappingStartToken)):
                flow += 1
            elif isinstance(token, (yaml.FlowSequenceEndToken, yaml.FlowMappingEndToken)):
                flow = max(0, flow - 1)
            elif flow == 0 and isinstance(token, _KEY_OR_ITEM):
                kind = "key" if isinstance(token, yaml.KeyToken) else "item"
                starts.append((token.start_mark.line + 1, token.start_mark.column + 1, kind))
    except yaml.YAMLError:
        pass
    finally:
        scanner.dispose()
    opened: list[tuple[int, str]] = []
    limit = None
    for number in sorted({n for n, _, _ in starts}, reverse=True):
        on_line = sorted((c, k) for n, c, k in starts if n == number)
        for column, kind in on_line:
            if (limit is None or column < limit) and all(c != column for c, _ in opened):
                opened.append((column, kind))
        limit = on_line[0][0] if limit is None else min(limit, on_line[0][0])
        if limit == 1:
            break
    return sorted(opened)
