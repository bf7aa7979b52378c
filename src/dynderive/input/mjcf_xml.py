"""An MJCF file and the files it includes, read as plain XML before MuJoCo reads them.

MuJoCo's XML reader trusts its input: it expands DTDs and entities, opens whatever an
``<include>`` or an asset's ``file`` names (a FIFO blocks it for ever), stops at 499 nested
elements with a bare ``XML parse error 18``, and takes ``nan``, ``inf`` or ``1e200`` as numbers
(printing a ``WARNING:`` and writing ``MUJOCO_LOG.TXT`` for a NaN). This pass refuses all of
that, each problem at its element or attribute (``FILE:LINE:COL``), with the same hardened
expat check the URDF reader uses (``urdf_xml.refuse_declarations``). XML that is not
well-formed is left to MuJoCo, whose message names the line.
"""

from __future__ import annotations

import math
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path
from xml.parsers import expat

from ..errors import InputError, Problem
from .loader import read_text
from .mjcf_positions import MAX_INCLUDE_DEPTH
from .urdf_xml import refuse_declarations

#: The deepest element nesting MuJoCo's XML reader (TinyXML2) accepts in one file.
MAX_NESTING = 499
#: The largest size of a position, orientation, inertia or drive term: MuJoCo's ``mjMAXVAL``,
#: beyond which its own checks call a value huge. Products of such numbers (``m * l**2``) then
#: stay far inside the range of a double, which the generated code and the checks compute in.
LARGEST = 1e10
#: Attributes that hold only numbers and that the equations read (directly, or through the
#: inertia MuJoCo infers from geoms): each word finite and at most ``LARGEST`` in size.
MEASURES = frozenset({
    "pos", "quat", "axisangle", "euler", "xyaxes", "zaxis", "fromto", "axis", "size", "mass",
    "density", "diaginertia", "fullinertia", "ref", "springref", "stiffness", "damping",
    "armature", "frictionloss", "gear", "gravity", "anchor", "polycoef", "relpose",
})
#: Attributes that hold names, never numbers (a body may be called ``inf``).
_NAMING = frozenset({"name", "class", "childclass", "model", "prefix"})
_NON_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass(frozen=True)
class _Start:
    """One start tag: its tag, attributes, position and byte offset in the file."""

    tag: str
    attributes: dict[str, str]
    line: int
    column: int
    offset: int


class _Refused(Exception):
    def __init__(self, problem: Problem):
        self.problem = problem


class _File:
    """One file of the model: its start tags, and where in it an attribute is written."""

    def __init__(self, text: str, file: str, note: str = ""):
        self.text, self.file, self.note = text, file, note
        self.raw = text.encode("utf-8")
        self.starts: list[_Start] = []
        parser = expat.ParserCreate()
        depth = 0

        def start(tag: str, attributes: dict[str, str]) -> None:
            nonlocal depth
            depth += 1
            here = _Start(tag, attributes, parser.CurrentLineNumber, parser.CurrentColumnNumber + 1,
                          parser.CurrentByteIndex)
            if depth > MAX_NESTING:
                raise _Refused(self.problem(here.line, here.column, f"<{tag}>: elements nested more than "
                                            f"{MAX_NESTING} deep (the most MuJoCo's XML reader accepts)"))
            self.starts.append(here)

        def end(_: str) -> None:
            nonlocal depth
            depth -= 1

        parser.StartElementHandler, parser.EndElementHandler = start, end
        refuse_declarations(parser, "MJCF")
        try:
            parser.Parse(text, True)
        except expat.ExpatError:
            pass   # not well-formed: MuJoCo says where
        except ValueError as exc:   # a DTD or an entity: at its line, as the URDF reader says it
            raise _Refused(self.problem(parser.CurrentLineNumber, 1, str(exc))) from None

    def problem(self, line: int, column: int, message: str) -> Problem:
        return Problem(self.file, line, column, message + self.note)

    def attribute_at(self, element: _Start, name: str) -> tuple[int, int]:
        """Line and column of ``name=`` in ``element``'s start tag (the tag's own if not found)."""
        found = re.compile(rb"\s(" + re.escape(name.encode()) + rb")\s*=").search(self.raw, element.offset)
        if found is None:
            return element.line, element.column
        before = self.raw[:found.start(1)]
        line = before.count(b"\n") + 1
        return line, len(before[before.rfind(b"\n") + 1:].decode("utf-8", errors="replace")) + 1


def check_mjcf_files(path: Path, text: str, file: str) -> None:
    """Refuse what MuJoCo's reader should not be given, in the file and its includes: DTDs and
    entities, nesting deeper than ``MAX_NESTING``, included or asset files that are not regular
    files (a FIFO, a device), numbers that are not finite or larger than ``LARGEST``. Every
    problem is reported, positioned, at once."""
    problems: list[Problem] = []
    _check(_read(text, file, "", problems), path.parent, problems, {path.resolve()}, 0)
    if problems:
        raise InputError(problems)


def _read(text: str, file: str, note: str, problems: list[Problem]) -> _File | None:
    try:
        return _File(text, file, note)
    except _Refused as refused:
        problems.append(refused.problem)
        return None


def _check(source: _File | None, base: Path, problems: list[Problem], seen: set[Path], depth: int) -> None:
    if source is None:
        return
    names = {value for s in source.starts for key, value in s.attributes.items() if key in _NAMING}
    folders = _asset_folders(source, base)
    for element in source.starts:
        for name, value in element.attributes.items():
            said = _bad_number(name, value, names)
            if said:
                problems.append(source.problem(*source.attribute_at(element, name),
                                               f'<{element.tag} {name}="{_short(value)}">: {said}'))
            elif name.startswith("file") and value:
                candidates = [base / value] if element.tag == "include" else [folder / value for folder in folders]
                kind = next((k for k in map(_not_regular, candidates) if k), None)
                if kind:
                    problems.append(source.problem(*source.attribute_at(element, name),
                                                   f'<{element.tag} {name}="{_short(value)}">: not a regular '
                                                   f"file ({kind})"))
                elif element.tag == "include" and name == "file":
                    _include(source, element, base / value, base, problems, seen, depth)


def _include(source: _File, element: _Start, target: Path, base: Path, problems: list[Problem],
             seen: set[Path], depth: int) -> None:
    """Check an included file (read safely: ``loader.read_text``) as the main one."""
    try:
        key = target.resolve()
        if key in seen or depth >= MAX_INCLUDE_DEPTH or not target.exists():
            return   # a cycle, too deep, or missing: MuJoCo says so
        text = read_text(target)
    except InputError as exc:
        problems.append(source.problem(*source.attribute_at(element, "file"),
                                       f'<include file="{_short(element.attributes["file"])}">: '
                                       f"{exc.problems[0].message}"))
        return
    except OSError:
        return
    note = f" (included from {source.file}:{element.line})"
    _check(_read(text, str(target), note, problems), base, problems, seen | {key}, depth + 1)


def _bad_number(name: str, value: str, names: set[str]) -> str | None:
    """What is wrong with a numeric attribute's words (None for text, or good numbers)."""
    if name in _NAMING or (name not in MEASURES and value in names):   # naming an element 'inf'
        return None
    words = value.split()
    try:
        numbers = [_number(word) for word in words]
    except ValueError:
        return None   # text, not numbers
    for word, number in zip(words, numbers):
        if _NON_FINITE.fullmatch(word):
            return f"'{word}' is not a finite number"
        if not math.isfinite(number):
            return f"{word} is out of the range of a double"
        if name in MEASURES and abs(number) > LARGEST:
            return f"{word} is out of range (numbers here are at most {LARGEST:.0e} in size, MuJoCo's mjMAXVAL)".replace("+", "")
    return None


def _number(word: str) -> float:
    """A word as MuJoCo's reader (``strtod``) takes it: decimal, or hexadecimal (``0x1p700``)."""
    try:
        return float(word)
    except ValueError:
        return float.fromhex(word)


def _asset_folders(source: _File, base: Path) -> list[Path]:
    """Where MuJoCo looks for an asset's file: ``<compiler>``'s folders, then the model's."""
    folders = []
    for element in source.starts:
        if element.tag == "compiler":
            folders += [base / element.attributes[key] for key in ("meshdir", "texturedir", "assetdir")
                        if key in element.attributes]
    return folders + [base]


def _not_regular(path: Path) -> str | None:
    """What a path that exists but is not a regular file is (a FIFO, a device), else None."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode):
        return None
    for test, kind in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder")):
        if test(mode):
            return kind
    return "not a file with contents"


def _short(value: str) -> str:
    return value if len(value) <= 40 else value[:37] + "..."
