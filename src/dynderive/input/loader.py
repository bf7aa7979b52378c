"""Read robot files into plain Python data, remembering where every value stands.

The loader is one of only two modules that touch files (the other is the CLI). It turns a
YAML document into ``SourceDocument``: the plain data (dicts, lists, scalars) plus a map from
each value's path, e.g. ``("links", 1, "mass")``, to its 1-based ``(line, column)``, so that
the validator can point at the exact spot of a problem long after parsing.
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from ..errors import InputError, Problem
from .yaml_messages import student_problem

Path_ = tuple[Any, ...]

#: Longest robot file we read; protects against megabyte-sized junk.
MAX_FILE_BYTES = 2_000_000
#: Most values a document may expand to (YAML aliases can expand exponentially).
MAX_VALUES = 50_000
#: Deepest nesting of YAML collections (a robot file needs about 5 levels).
MAX_YAML_DEPTH = 100
#: The suffixes of robot files.
ROBOT_SUFFIXES = (".yaml", ".yml", ".urdf", ".xml")


@dataclass
class SourceDocument:
    """Parsed file contents with positions.

    ``positions[path]`` is where the value at ``path`` starts; ``key_positions[path]`` is
    where the key naming it starts (for "unknown key" errors); ``scalar_style[path]`` tells
    whether a scalar was written in quotes (so expression errors can point inside the string).
    """

    file: str
    data: Any
    positions: dict[Path_, tuple[int, int]] = field(default_factory=dict)
    key_positions: dict[Path_, tuple[int, int]] = field(default_factory=dict)
    scalar_style: dict[Path_, str | None] = field(default_factory=dict)
    #: Names for item paths in messages, e.g. ``("joints", 1) -> "joint 'elbow'"`` (URDF).
    labels: dict[Path_, str] = field(default_factory=dict)
    #: Scalars written over several lines (column offsets inside them are not meaningful).
    multiline: set[Path_] = field(default_factory=set)
    #: Remarks about input that was accepted but changed or ignored (e.g. URDF ``<mimic>`` on
    #: a fixed joint), shown by the CLI as ``note:`` lines.
    notes: list[str] = field(default_factory=list)
    #: Links (``("links", i)``) whose inertia the reader kept as written although it is not
    #: physical (a URDF inertia missing the triangle inequality, with a note): not judged again.
    impossible_inertias: set[Path_] = field(default_factory=set)
    #: The most significant digits of a number the source wrote (URDF; None: count the data's).
    digits: int | None = None
    #: Parameters whose values were replaced by the command line's (``--param``): a problem
    #: they cause is reported where they are used, not at the file's default.
    replaced: set[str] = field(default_factory=set)

    def where(self, path: Path_, key: bool = False) -> tuple[int, int]:
        """Position of ``path``, falling back to the nearest enclosing value."""
        table = self.key_positions if key else self.positions
        probe = tuple(path)
        while probe:
            if probe in table:
                return table[probe]
            if probe in self.positions:
                return self.positions[probe]
            probe = probe[:-1]
        return self.positions.get((), (1, 1))

    def problem(self, path: Path_, message: str, key: bool = False, offset: int = 0) -> Problem:
        line, column = self.where(path, key)
        return Problem(self.file, line, column + offset, message)

    def note(self, where: tuple[int, int], message: str) -> None:
        """Add a ``note:`` line at ``where`` (``LINE, COL``) to ``notes``."""
        self.notes.append(f"{self.file}:{where[0]}:{where[1]}: note: {message}")


def bundled_robots_dir() -> Path:
    """Directory of the robots shipped with dynderive (inside the wheel, or the checkout)."""
    packaged = resources.files("dynderive") / "robots"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[3] / "robots"


def bundled_robot_names() -> list[str]:
    """The bundled robots' names (their files' stems), sorted."""
    return sorted(p.stem for p in bundled_robots_dir().glob("*") if p.suffix in ROBOT_SUFFIXES)


def resolve_robot_path(robot: str | Path) -> Path:
    """A path as given, or the file of a bundled robot called ``robot``."""
    path = Path(robot)
    if path.exists() or path.suffix in ROBOT_SUFFIXES or len(path.parts) > 1:
        if not os.path.lexists(path) and path.suffix in ROBOT_SUFFIXES and path.stem in bundled_robot_names():
            raise InputError(Problem(str(robot), 1, 1, f"no such file; `{path.stem}` is a bundled robot: give "
                                     f"its name alone (`{path.stem}`), or run `dynderive copy {path.stem}` to "
                                     "get its file to edit"))
        return path
    for suffix in ROBOT_SUFFIXES:
        candidate = bundled_robots_dir() / f"{robot}{suffix}"
        if candidate.is_file():
            return candidate
    raise InputError(Problem(str(robot), 1, 1, "no such file, and no bundled robot of that name "
                             f"(bundled: {', '.join(bundled_robot_names())})"))


_FILE_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
               (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def read_text(path: Path) -> str:
    """The UTF-8 text of a regular file of at most ``MAX_FILE_BYTES`` bytes.

    The file is ``stat``-ed before it is opened: opening a FIFO blocks until a writer comes,
    and a device such as ``/dev/zero`` (or a symlink to it) never ends. It is opened without
    blocking, checked again, and read up to ``MAX_FILE_BYTES + 1`` bytes whatever its size said.
    """
    display = str(path)
    try:
        info = os.stat(path)
        if stat.S_ISDIR(info.st_mode):
            raise InputError(Problem(display, 1, 1, "is a directory, not a robot file"))
        if not stat.S_ISREG(info.st_mode):
            what = next((name for test, name in _FILE_KINDS if test(info.st_mode)),
                        "not a file with contents")
            raise InputError(Problem(display, 1, 1, f"not a regular file ({what})"))
        if info.st_size > MAX_FILE_BYTES:
            raise InputError(Problem(display, 1, 1, f"file is larger than {MAX_FILE_BYTES} bytes"))
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
        with os.fdopen(descriptor, "rb") as handle:
            if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):  # replaced since the stat
                raise InputError(Problem(display, 1, 1, "not a regular file"))
            raw = handle.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise InputError(Problem(display, 1, 1, "no such file")) from None
    except IsADirectoryError:
        raise InputError(Problem(display, 1, 1, "is a directory, not a robot file")) from None
    except OSError as exc:
        raise InputError(Problem(display, 1, 1, f"cannot read file: {exc.strerror}")) from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(Problem(display, 1, 1, f"file is larger than {MAX_FILE_BYTES} bytes"))
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise InputError(Problem(display, line, column, "file is not valid UTF-8")) from None


class _Composer(yaml.SafeLoader):
    """Safe loader used only to compose nodes; values are built by ``_build``.

    Plain scalars in decimal notation with an exponent (``1e-3``, ``2E5``, ``1.5e3``) are
    numbers, as in YAML 1.2 and as users mean them: YAML 1.1, which PyYAML follows, reads them
    as text unless they have a dot and a signed exponent. Quoted, they stay text.

    Nesting deeper than ``MAX_YAML_DEPTH`` stops the composition at once (``_Refused``): PyYAML's
    parser slows down with depth, and 500 levels of ``[`` took seconds before Python's
    recursion limit ended them."""

    depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_YAML_DEPTH:
                raise _Refused(self.peek_event().start_mark, "YAML nesting is too deep")
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


class _Refused(Exception):
    """A document beyond a limit (``MAX_YAML_DEPTH``, ``MAX_VALUES``), refused where it shows."""

    def __init__(self, mark: yaml.Mark, message: str):
        self.where, self.message = _mark(mark), message


_Composer.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def parse_yaml(text: str, file: str) -> SourceDocument:
    """Parse YAML text, keeping positions and rejecting duplicate keys."""
    deep = _flow_too_deep(text, MAX_YAML_DEPTH)
    if deep is not None:
        raise InputError(Problem(file, *deep, "YAML nesting is too deep"))
    document = SourceDocument(file=file, data=None, positions={(): (1, 1)})   # (1, 1): an empty file
    problems: list[Problem] = []
    try:
        loader = _Composer(text)
        try:
            node = loader.get_single_node()
        finally:
            loader.dispose()
        if node is not None:
            document.data = _build(node, (), document, problems, _Composer(""), [0])
    except yaml.MarkedYAMLError as exc:
        raise InputError(student_problem(exc, text, file) or _syntax_problem(exc, file)) from None
    except yaml.reader.ReaderError as exc:
        line, column = _yaml_position(text, exc.position)
        character = exc.character if isinstance(exc.character, str) else chr(exc.character or 0)
        raise InputError(Problem(file, line, column, f"YAML syntax error: character U+{ord(character):04X} "
                                 "is not allowed in YAML")) from None
    except yaml.YAMLError as exc:  # pragma: no cover - defensive, PyYAML marks nearly all
        raise InputError(Problem(file, 1, 1, f"YAML syntax error: {exc}")) from None
    except _Refused as exc:
        raise InputError(Problem(file, *exc.where, exc.message)) from None
    except RecursionError:   # building a self-referencing alias (&a [*a]); composing stops at the limit
        raise InputError(Problem(file, 1, 1, "YAML nesting is too deep")) from None
    if problems:
        raise InputError(problems)
    return document


def _yaml_position(text: str, index: int) -> tuple[int, int]:
    """1-based (line, column) of ``text[index]`` with YAML's line breaks (CR LF, CR, LF, NEL, LS, PS)."""
    line, start, i = 1, 0, 0
    while i < index:
        char = text[i]
        if char in "\r\n\x85\u2028\u2029":
            if char == "\r" and i + 1 < len(text) and text[i + 1] == "\n":
                i += 1
            line, start = line + 1, i + 1
        i += 1
    return line, index - start + 1


def _flow_too_deep(text: str, limit: int) -> tuple[int, int] | None:
    """Where a run of brackets nested deeper than ``limit`` opens, found in one pass before
    parsing (PyYAML's scanner looks ahead over every open bracket: 1000 of them take seconds),
    or None. Brackets in comments and quoted scalars do not count."""
    depth, line, column, start = 0, 1, 0, (1, 1)
    quote, previous, i = "", "\n", 0
    while i < len(text):
        char = text[i]
        i += 1
        column += 1
        if char == "\n":
            line, column = line + 1, 0
        elif quote:
            if char == quote:
                if quote == "'" and text[i:i + 1] == "'":   # '' inside single quotes
                    i, column = i + 1, column + 1
                else:
                    quote = ""
            elif char == "\\" and quote == '"':
                i, column = i + 1, column + 1
        elif char in "'\"" and previous in " \t\n[{,:-?":
            quote = char
        elif char == "#" and previous in " \t\n":
            end = text.find("\n", i)
            column += (len(text) if end < 0 else end) - i
            i = len(text) if end < 0 else end
        elif char in "[{":
            if depth == 0:
                start = (line, column)
            depth += 1
            if depth > limit:
                return start
        elif char in "]}" and depth:
            depth -= 1
        previous = char
    return None


def _syntax_problem(exc: yaml.MarkedYAMLError, file: str) -> Problem:
    """PyYAML's error at its position; an unclosed quote or bracket points at where it opened."""
    what = exc.problem or exc.context or "invalid YAML"
    mark = exc.problem_mark or exc.context_mark
    context = (exc.context or "").replace("while scanning ", "").replace("while parsing ", "")
    opened = exc.context_mark
    if opened is not None and context and exc.problem_mark is not None and opened.line != exc.problem_mark.line:
        if "quoted scalar" in context:
            quote = opened.buffer[opened.pointer] if opened.buffer else '"'
            return Problem(file, *_mark(opened), f"YAML syntax error: '{quote}' was never closed")
        if "flow sequence" in context or "flow mapping" in context:
            bracket = "[" if "sequence" in context else "{"
            return Problem(file, *_mark(opened), f"YAML syntax error: '{bracket}' was never closed "
                           f"({what} at line {exc.problem_mark.line + 1})")
    return Problem(file, *(_mark(mark) if mark else (1, 1)), f"YAML syntax error: {what}")


def _mark(mark: yaml.Mark) -> tuple[int, int]:
    return mark.line + 1, mark.column + 1


_PLAIN_TAGS = {"tag:yaml.org,2002:seq", "tag:yaml.org,2002:map"}


def _build(node: yaml.Node, path: Path_, doc: SourceDocument, problems: list[Problem],
           constructor: yaml.SafeLoader, count: list[int]) -> Any:
    count[0] += 1
    if count[0] > MAX_VALUES:
        raise _Refused(node.start_mark, f"document expands to more than {MAX_VALUES} values (YAML aliases?)")
    doc.positions[path] = _mark(node.start_mark)
    if not isinstance(node, yaml.ScalarNode) and node.tag not in _PLAIN_TAGS:
        problems.append(Problem(doc.file, *_mark(node.start_mark), "invalid value: could not determine a "
                                f"constructor for the tag '{node.tag}'"))
        return None
    if isinstance(node, yaml.MappingNode):
        result: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                problems.append(Problem(doc.file, *_mark(key_node.start_mark),
                                        "mapping keys must be plain names"))
                continue
            key = _construct(key_node, doc, problems, constructor)
            if not isinstance(key, str):
                key = str(key_node.value)
            if key in result:
                first = doc.key_positions[path + (key,)]
                problems.append(Problem(doc.file, *_mark(key_node.start_mark),
                                        f"duplicate key '{key}' (first given at line {first[0]})"))
                continue
            doc.key_positions[path + (key,)] = _mark(key_node.start_mark)
            result[key] = _build(value_node, path + (key,), doc, problems, constructor, count)
        return result
    if isinstance(node, yaml.SequenceNode):
        return [_build(item, path + (i,), doc, problems, constructor, count)
                for i, item in enumerate(node.value)]
    doc.scalar_style[path] = node.style
    if node.start_mark.line != node.end_mark.line:
        doc.multiline.add(path)
    return _construct(node, doc, problems, constructor)


def _construct(node: yaml.Node, doc: SourceDocument, problems: list[Problem],
               constructor: yaml.SafeLoader) -> Any:
    """A scalar's value; a bad tag or a tagged value that does not parse is a positioned problem."""
    try:
        return constructor.construct_object(node)
    except yaml.constructor.ConstructorError as exc:
        message = exc.problem or "cannot be constructed"
    except (ValueError, KeyError, TypeError, OverflowError) as exc:
        message = f"{node.tag.rsplit(':', 1)[-1]} value {node.value!r} does not parse ({type(exc).__name__})"
    problems.append(Problem(doc.file, *_mark(node.start_mark), f"invalid value: {message}"))
    return None


def load_document(path: Path) -> SourceDocument:
    """Read and parse one YAML robot file."""
    return parse_yaml(read_text(path), str(path))
