"""The XML layer of URDF reading: elements with their positions, parsed by expat with DTDs and
entities refused and unexpanded xacro refused; and the number syntax of URDF attributes.

A xacro file (``<xacro:macro>``, ``<xacro:include>``, ``<xacro:property>``, any element or
attribute in the xacro namespace, ``${...}`` expressions) is not a URDF: read as one it would
silently lose whatever its macros make. It is refused where xacro first shows, saying to run
xacro first. Numbers are XML Schema doubles as URDF parsers read them (``1``, ``-0.5``,
``.5``, ``2.5e-3``), not Python's wider syntax (``1_000``, non-ASCII digits); ``inf`` and
``nan`` are refused (no robot value is infinite).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import Any
from xml.parsers import expat

from ..errors import InputError, Problem

#: A URDF number: optional sign, digits with an optional fraction (or a fraction alone), an
#: optional exponent. ASCII digits only.
NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: XML's white space (Python's ``str.split`` also splits at no-break and other Unicode spaces).
_XML_SPACE = re.compile(r"[ \t\r\n]+")
#: Namespaces xacro is declared with (``xmlns:xacro="http://www.ros.org/wiki/xacro"`` and variants).
_XACRO_URI = re.compile(r"xacro", re.IGNORECASE)


def numbers_in(text: str) -> tuple[list[float], str | None]:
    """The numbers of an attribute separated by XML white space, and the first word that is
    not a URDF number (None if all are)."""
    values = []
    for word in _XML_SPACE.split(text.strip(" \t\r\n")):
        if not word:
            continue
        if not NUMBER.fullmatch(word):
            return values, word
        values.append(float(word))
    return values, None


def _xacro_in(element: _Element, prefixes: set[str]) -> str | None:
    """What in ``element`` is unexpanded xacro (an element or attribute with a xacro prefix, a
    ``${...}`` expression), or None."""
    prefix, colon, _ = element.tag.partition(":")
    if colon and prefix in prefixes:
        return f"<{element.tag}>"
    for name, value in element.attrib.items():
        prefix, colon, _ = name.partition(":")
        if colon and prefix in prefixes:
            return f"<{element.tag} {name}=...>"
        if "${" in value:
            start = value.index("${")
            end = value.find("}", start)
            expression = value[start:end + 1] if 0 <= end < start + 40 else value[start:start + 37] + "..."
            return f"<{element.tag} {name}=...>: unexpanded xacro expression '{expression}'"
    return None


@dataclass
class _Element:
    tag: str
    attrib: dict[str, str]
    line: int
    column: int
    children: list[_Element] = field(default_factory=list)

    @property
    def at(self) -> tuple[int, int]:
        """``(line, column)`` of the element's start tag."""
        return self.line, self.column

    def find(self, tag: str) -> _Element | None:
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag: str) -> list[_Element]:
        return [c for c in self.children if c.tag == tag]


def refuse_declarations(parser: Any, kind: str) -> None:
    """Make an expat ``parser`` stop (``ValueError``) at a DOCTYPE or an entity declaration:
    no robot file needs one, and they are how entity expansion bombs and external entities
    (files read from elsewhere) get in. The URDF and the MJCF readers share this check."""
    def refuse(*_: Any) -> None:
        raise ValueError(f"DTDs and entities are not allowed in {kind} files")

    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse


def _parse_xml(text: str, file: str) -> _Element:
    """Parse XML with expat, keeping each element's line and column; no DTDs or entities."""
    parser = expat.ParserCreate()
    stack: list[_Element] = []
    roots: list[_Element] = []

    xacro = {"xacro"}   # prefixes bound to xacro's namespace

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = _Element(tag, dict(attrs), parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
        xacro.update(name[6:] for name, value in attrs.items() if name.startswith("xmlns:") and _XACRO_URI.search(value))
        found = _xacro_in(element, xacro)
        if found is not None:
            raise InputError(Problem(file, *element.at, f"{found}: this is a xacro file, not a URDF; expand "
                                     f"it first (xacro {PurePath(file).name} > robot.urdf) and read the "
                                     "result"))
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    refuse_declarations(parser, "URDF")
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code)
        raise InputError(Problem(file, exc.lineno, exc.offset + 1, f"malformed XML: {message}")) from None
    except ValueError as exc:
        raise InputError(Problem(file, parser.CurrentLineNumber, 1, str(exc))) from None
    if not roots:
        raise InputError(Problem(file, 1, 1, "empty XML document"))
    return roots[0]
