"""The validator's reporting and generic checks: every problem is collected with its position
(``Validator.error``), and the generic value checks (mappings, identifiers, texts,
expressions at the parameter defaults, vectors) word their messages alike. The robot file's
structure is checked by ``schema``, which drives a ``Validator``.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Iterable, Iterator
from typing import Any

import sympy

from ..errors import Problem
from ..model.expressions import (
    Evaluator,
    ExpressionError,
    NotFiniteError,
    describe_number,
    imaginary_part,
    kind,
    parse_expression,
)
from ..model.naming import did_you_mean
from .loader import SourceDocument

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class Validator:
    """The problems and the generic checks (module docstring) of one parsed robot file."""

    def __init__(self, doc: SourceDocument):
        self.doc = doc
        self.problems: list[Problem] = []
        self.parameters_broken = False
        #: Values at the parameter defaults (set once the parameters are read).
        self.evaluate = Evaluator()
        #: Parameters reported for a negative default (their uses are not reported again).
        self.negative_defaults: set[sympy.Symbol] = set()

    # -- reporting -------------------------------------------------------------------
    def error(self, path: tuple[Any, ...], message: str, key: bool = False, offset: int = 0) -> None:
        self.problems.append(self.doc.problem(path, message, key=key, offset=offset))

    def report(self, path: tuple[Any, ...], message: str, key: bool = False, offset: int = 0) -> None:
        """A problem with the value at ``path``: its label, then ``message``."""
        self.error(path, f"{self.label(path)}: {message}", key=key, offset=offset)

    def negative_value(self, expr: sympy.Expr | None, path: tuple[Any, ...], number: float, rule: str) -> None:
        """Report the value ``number`` of ``expr`` (at ``path``), which breaks ``rule`` by being
        negative. When one parameter with a negative default makes it so (``m3: {value: -0.5}``
        used as a mass), the mistake is that default: it is reported once, at the parameter's
        value, naming its first use; its other uses are not reported again."""
        negative = sorted((s for s in (expr.free_symbols if expr is not None else ())
                           if s in self.evaluate.values and self.evaluate.values[s] < 0), key=str)
        if len(negative) != 1 or str(negative[0]) in self.doc.replaced:   # --param's value: at its use
            self.report(path, f"{rule} (got {number:g})")
            return
        symbol = negative[0]
        if symbol in self.negative_defaults:
            return
        self.negative_defaults.add(symbol)
        where = ("parameters", str(symbol))
        where += ("value",) if where + ("value",) in self.doc.positions else ()
        default = float(self.evaluate.values[symbol])
        use = (f"but it is {self.label(path)} (at {self.at(path)})" if expr == symbol else
               f"and makes {self.label(path)} (at {self.at(path)}) {number:g}")
        self.report(where, f"default value {default:g} is negative, {use}, which {rule}")

    def note(self, path: tuple[Any, ...], message: str) -> None:
        self.doc.note(self.doc.where(path), message)

    def at(self, path: tuple[Any, ...], key: bool = False) -> str:
        """``LINE:COL`` of ``path`` (of its key with ``key``), to point at an earlier value."""
        line, column = self.doc.where(path, key)
        return f"{line}:{column}"

    def label(self, path: tuple[Any, ...]) -> str:
        for cut in range(len(path), 0, -1):  # a source may name its items (URDF: "joint 'elbow'")
            if tuple(path[:cut]) in self.doc.labels:
                rest = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path[cut:])
                return self.doc.labels[tuple(path[:cut])] + (f" {rest[1:]}" if rest else "")
        text = ""
        for part in path:
            text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
        return text or "document"

    # -- generic checks ----------------------------------------------------------------
    def mapping(self, value: Any, path: tuple[Any, ...], allowed: Iterable[str],
                required: Iterable[str] = ()) -> dict[str, Any] | None:
        if not isinstance(value, dict):
            self.report(path, f"expected a mapping, got {kind(value)}")
            return None
        allowed = tuple(allowed)
        for key in value:
            if key not in allowed:
                hint = did_you_mean(str(key), allowed) or f" (allowed: {', '.join(allowed)})"
                self.report(path + (key,), f"unknown key '{key}'{hint}", key=True)
        for key in required:
            if key not in value:
                self.report(path, f"missing required key '{key}'")
        return value

    def named_items(self, top: dict[str, Any], key: str, what: str, allowed: Iterable[str], required: Iterable[str],
                    taken: dict[str, tuple[Any, ...]], clash: str = "duplicate {what} name '{name}'"
                    ) -> Iterator[tuple[int, tuple[Any, ...], dict[str, Any], str | None, bool]]:
        """The mappings of the non-empty list ``top[key]`` (an error if it is something else),
        each as ``(i, path, item, name, new)``: ``name`` its ``name`` if an identifier (a
        ``what`` name), ``new`` whether no entry of ``taken`` (name -> path, updated) has it."""
        raw = top.get(key)
        if key in top and (not isinstance(raw, list) or not raw):
            self.error((key,), f"{key}: expected a non-empty list of {what}s, got {kind(raw, empty=True)}")
            return
        for i, value in enumerate(raw or []):
            path = (key, i)
            item = self.mapping(value, path, allowed, required)
            if item is None:
                continue
            name = self.identifier(item.get("name"), path + ("name",), f"{what} name") if "name" in item else None
            new = name is not None and name not in taken
            if name is not None and not new:
                self.report(path + ("name",), f"{clash.format(what=what, name=name)} "
                            f"(first at {self.at(taken[name])})")
            elif new:
                taken[name] = path + ("name",)   # type: ignore[index]
            yield i, path, item, name, new

    def identifier(self, value: Any, path: tuple[Any, ...], what: str, key: bool = False) -> str | None:
        if not isinstance(value, str) or not IDENTIFIER.match(value):
            self.report(path, f"{what} must be an identifier (letters, digits, '_'), got {value!r}", key=key)
            return None
        if keyword.iskeyword(value):
            self.report(path, f"{what} '{value}' is a Python keyword", key=key)
            return None
        return value

    def text(self, value: Any, path: tuple[Any, ...], default: str = "") -> str:
        if value is None:
            return default
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return str(value)
        if not isinstance(value, str):
            self.report(path, f"expected text, got {kind(value)}")
            return default
        return value

    def expression(self, value: Any, path: tuple[Any, ...], symbols: dict[str, sympy.Expr]) -> sympy.Expr | None:
        try:
            expr = parse_expression(value, symbols)
        except ExpressionError as exc:
            if self.parameters_broken and str(exc).startswith("undeclared symbol"):
                return None  # the broken parameters block is already reported
            offset = 0
            style = self.doc.scalar_style.get(path)
            if isinstance(value, str) and "\n" not in value and path not in self.doc.multiline:
                offset = exc.offset + (1 if style in ("'", '"') else 0)
                if style == '"' and "\\" in value:
                    offset = 0
            self.report(path, str(exc), offset=offset)
            return None
        return expr if self.at_defaults(expr, value, path) else None

    def numeric(self, expr: sympy.Expr | None) -> float | None:
        """Value of ``expr`` at the parameter defaults, or None if it is not a real number."""
        if expr is None:
            return None
        try:
            value = self.evaluate(expr)
        except NotFiniteError:
            return None
        if value is None or imaginary_part(value):
            return None
        return float(sympy.re(value))

    def at_defaults(self, expr: sympy.Expr, value: Any, path: tuple[Any, ...]) -> bool:
        """Refuse an expression that is not finite or not real at the parameter defaults."""
        if not expr.free_symbols or expr.free_symbols - set(self.evaluate.values):
            return True  # a constant (checked by the parser) or not every symbol has a default
        detail = ""
        try:
            number = self.evaluate(expr)
        except NotFiniteError as exc:
            what = "out of the range of a double" if exc.reason == "out of range" else exc.reason
        else:
            if number is None or not imaginary_part(number):
                return True
            what, detail = "not a real number", f" (its value is {describe_number(number)})"
        text = str(value) if len(str(value)) <= 40 else str(value)[:37] + "..."
        names = ", ".join(f"{s} = {float(self.evaluate.values[s]):g}"
                          for s in sorted(expr.free_symbols, key=str))
        self.report(path, f"'{text}' is {what} at the default parameter values {names}{detail}")
        return False

    def vector(self, value: Any, path: tuple[Any, ...], lengths: tuple[int, ...],
               symbols: dict[str, sympy.Expr]) -> list[sympy.Expr | None] | None:
        sizes = " or ".join(str(n) for n in lengths)
        if not isinstance(value, list):
            self.report(path, f"expected a list of {sizes} entries, got {kind(value)}")
            return None
        if len(value) not in lengths:
            self.report(path, f"expected {sizes} entries, got {len(value)}")
            return None
        return [self.expression(v, path + (i,), symbols) for i, v in enumerate(value)]
