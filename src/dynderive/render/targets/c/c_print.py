"""One C function's parts (``CFunction``) and the casts that mark arguments used; the
expressions are printed by ``codegen/c_syntax.py``."""

from __future__ import annotations

from dataclasses import dataclass, field

from ...codegen.names import c_comment
from ...encode import Code


@dataclass
class CFunction:
    """One generated function: its prototype (without ``;``), a one-line comment, its body."""

    prototype: str
    comment: str
    body: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.prototype = Code(self.prototype)
        self.comment = c_comment(self.comment)
        self.body = [Code(line) for line in self.body]


def void(*arguments: str) -> list[str]:
    """Casts that mark every argument used (``-Wextra -Werror``: a constant M reads no ``q``)."""
    return [f"(void){a};" for a in arguments]
