"""Encoders for free text (titles, units, descriptions, file names) per output target.

Text from a robot file never reaches an output as it is: each renderer passes it through
the encoder of its target, so no string can end a Python docstring, start a LaTeX command
or send escape sequences to a terminal, and every string round-trips (the docstring of a
generated module reads back exactly as the robot file wrote it).
"""

from __future__ import annotations

import unicodedata


class Code(str):
    """Text that is already valid in its place in the generated Python module (an
    expression, a literal, an encoded docstring); the code environment prints other strings
    only when they hold nothing that could change the program."""


_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _printed(char: str) -> str:
    """``char`` itself where it is a space or printable and no format, private-use or surrogate
    code point (a bidi control hides what the text says), else its escape (``\\n``, ``\\x00``)."""
    if char == " " or (char.isprintable() and unicodedata.category(char) not in ("Cf", "Co", "Cs")):
        return char
    return _NAMED.get(char) or code_point(char)


def code_point(char: str) -> str:
    """``char`` as ``\\xNN``, ``\\uNNNN`` or ``\\UNNNNNNNN`` text: how every target's encoder
    writes a character it keeps out of its output (a newline in a C or MATLAB comment)."""
    code = ord(char)
    if code < 0x100:
        return f"\\x{code:02x}"
    if code < 0x10000:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"


def docstring(text: object) -> Code:
    """``text`` for the inside of a ``\"\"\"docstring\"\"\"``: backslashes and quotes escaped,
    every non-printable character (newlines, NUL, lone surrogates, bidi controls) written
    as an escape, so the docstring's value is ``text`` exactly."""
    return Code("".join("\\" + char if char in "\\\"'" else _printed(char) for char in str(text)))


def python_literal(value: object) -> Code:
    """A Python literal for a string, number, ``None`` or a tuple of them, with the string
    escapes of ``docstring`` (so the source stays printable ASCII-safe UTF-8)."""
    if value is None or isinstance(value, (bool, int, float)):
        return Code(repr(value))
    if isinstance(value, (tuple, list)):
        items = [python_literal(v) for v in value]
        if isinstance(value, tuple):
            return Code("(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")")
        return Code("[" + ", ".join(items) + "]")
    return Code('"' + docstring(value) + '"')


def is_plain(text: str) -> bool:
    """Whether ``text`` can be printed into Python source as it is: nothing that could end a
    string or a comment, start an escape, or hide in the source (used by the code
    environment's ``finalize`` to refuse free text that a template forgot to encode)."""
    return not any(c in "\\\"'\n\r#" for c in text) and text.isprintable()


_TEX_SPECIALS = {
    "\\": r"\textbackslash{}", "{": r"\{", "}": r"\}", "$": r"\$", "&": r"\&", "#": r"\#",
    "^": r"\textasciicircum{}", "_": r"\_", "~": r"\textasciitilde{}", "%": r"\%",
    "<": r"\textless{}", ">": r"\textgreater{}", "|": r"\textbar{}",
}


def escape_tex(text: object) -> str:
    """Free text for LaTeX: every special character appears literally; line breaks and
    other control characters become spaces; characters outside Latin-1 (which pdfLaTeX
    cannot typeset without extra packages) are written as their code point ``[U+2603]``."""
    out = []
    for char in str(text):
        if char in _TEX_SPECIALS:
            out.append(_TEX_SPECIALS[char])
        elif not char.isprintable() or unicodedata.category(char) in ("Cf", "Co", "Cs"):
            out.append(" ")
        elif ord(char) > 0xFF:
            out.append(f"[U+{ord(char):04X}]")
        elif ord(char) > 0x7E and unicodedata.category(char)[0] not in "LNPS":
            out.append(" ")
        else:
            out.append(char)
    return "".join(out)


def tex_unit(unit: object) -> str:
    """A unit for the sheet, with powers raised: ``m/s^2`` -> ``m/s\\textsuperscript{2}``,
    ``kg*m**2`` -> ``kg\\,m\\textsuperscript{2}``; everything else escaped as free text."""
    import re

    text = str(unit).replace("**", "^")
    parts = re.split(r"\^\(?([+-]?\d+(?:\.\d+)?)\)?", text)
    out = []
    for index, part in enumerate(parts):
        if index % 2:
            out.append(r"\textsuperscript{" + part.replace("-", r"\textminus{}") + "}")
        else:
            out.append(escape_tex(part).replace("*", r"\,"))
    return "".join(out)


def terminal_text(text: object) -> str:
    """Free text for a terminal: control characters (escape sequences!) shown as escapes."""
    return "".join(map(_printed, str(text)))
