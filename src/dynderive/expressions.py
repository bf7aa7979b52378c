"""Safe parsing of the expressions written in robot files.

Expressions are parsed with Python's ``ast`` and rebuilt node by node from a whitelist:
numbers, declared names, ``+ - * / **`` (``^`` means power too), unary signs and calls of a
few elementary functions. Nothing is ever ``eval``'d or ``sympify``'d from raw text, and
resource attacks (``9**9**9``, deep nesting, huge strings) are refused before any work.

>>> import sympy
>>> parse_expression("m*l**2/12", {"m": sympy.Symbol("m"), "l": sympy.Symbol("l")})
l**2*m/12
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping
from decimal import Decimal, InvalidOperation

import sympy

#: Functions an expression may call, by name.
FUNCTIONS: dict[str, object] = {
    "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan,
    "asin": sympy.asin, "acos": sympy.acos, "atan": sympy.atan, "atan2": sympy.atan2,
    "sinh": sympy.sinh, "cosh": sympy.cosh, "tanh": sympy.tanh,
    "sqrt": sympy.sqrt, "exp": sympy.exp, "log": sympy.log, "abs": sympy.Abs,
}
#: Named constants.
CONSTANTS: dict[str, sympy.Expr] = {"pi": sympy.pi, "E": sympy.E}
#: Names a robot file may not use for its own symbols.
RESERVED = frozenset(FUNCTIONS) | frozenset(CONSTANTS)

MAX_LENGTH = 1000
MAX_DEPTH = 60
MAX_EXPONENT = 1000
#: ``(m + l)**999`` would stall the derivation; physics needs small powers of symbols.
MAX_SYMBOLIC_EXPONENT = 12


class ExpressionError(ValueError):
    """An expression is malformed or not allowed; ``offset`` is the 0-based column in it."""

    def __init__(self, message: str, offset: int = 0):
        super().__init__(message)
        self.offset = offset


def parse_expression(text: object, symbols: Mapping[str, sympy.Expr]) -> sympy.Expr:
    """Parse ``text`` (a string or a YAML number) into a SymPy expression over ``symbols``.

    Decimal literals become exact rationals (``0.1`` -> ``1/10``) so results are exact and
    deterministic.
    """
    if isinstance(text, bool):
        raise ExpressionError("expected an expression or a number, got a boolean")
    if isinstance(text, int):
        return sympy.Integer(text)
    if isinstance(text, float):
        return _number(repr(text), 0)
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression or a number, got {_kind(text)}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression is longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ExpressionError("expression is empty")
    depth = 0
    for index, char in enumerate(text):
        depth += char in "([{"
        depth -= char in ")]}"
        if depth > MAX_DEPTH:
            raise ExpressionError(f"expression is nested more than {MAX_DEPTH} levels deep", index)
    source = text.replace("^", "**")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        offset = max((exc.offset or 1) - 1, 0) + (len(source) - len(source.lstrip()))
        raise ExpressionError(f"malformed expression: {exc.msg}", offset) from None
    except (RecursionError, MemoryError, ValueError):
        raise ExpressionError("expression is too complex") from None
    lead = len(source) - len(source.lstrip())
    return _Builder(symbols, lead, source.strip()).build(tree.body)


def _kind(value: object) -> str:
    return {list: "a list", dict: "a mapping", type(None): "nothing"}.get(type(value), type(value).__name__)


def _number(literal: str, offset: int) -> sympy.Expr:
    try:
        value = Decimal(literal)
    except InvalidOperation:
        raise ExpressionError(f"invalid number {literal!r}", offset) from None
    if not value.is_finite():
        raise ExpressionError(f"number {literal!r} is not finite", offset)
    sign, digits, exponent = value.as_tuple()
    if abs(int(exponent)) > 300:
        raise ExpressionError(f"number {literal!r} is out of range", offset)
    return sympy.Rational(str(value)) if int(exponent) < 0 else sympy.Integer(int(value))


class _Builder:
    def __init__(self, symbols: Mapping[str, sympy.Expr], lead: int, source: str = ""):
        self.symbols = symbols
        self.lead = lead
        self.source = source

    def fail(self, node: ast.AST, message: str) -> ExpressionError:
        # ast offsets count UTF-8 bytes; positions count characters
        offset = getattr(node, "col_offset", 0)
        characters = len(self.source.encode("utf-8")[:offset].decode("utf-8", errors="ignore"))
        return ExpressionError(message, characters + self.lead)

    def build(self, node: ast.AST) -> sympy.Expr:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise self.fail(node, f"only numbers are allowed as constants, not {node.value!r}")
            if isinstance(node.value, float) and not math.isfinite(node.value):
                raise self.fail(node, f"number '{ast.get_source_segment(self.source, node) or node.value}' "
                                "is out of range")
            return _number(repr(node.value) if isinstance(node.value, float) else str(node.value),
                           node.col_offset + self.lead)
        if isinstance(node, ast.Name):
            if node.id in self.symbols:
                return self.symbols[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            if node.id in FUNCTIONS:
                raise self.fail(node, f"function '{node.id}' must be called, e.g. {node.id}(x)")
            raise self.fail(node, f"undeclared symbol '{node.id}'" + self._suggest(node.id))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = self.build(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            return self._binary(node)
        if isinstance(node, ast.Call):
            return self._call(node)
        raise self.fail(node, f"not allowed in an expression: {_describe(node)}")

    def _binary(self, node: ast.BinOp) -> sympy.Expr:
        left, right = self.build(node.left), self.build(node.right)
        op = node.op
        if isinstance(op, ast.Add):
            return left + right
        if isinstance(op, ast.Sub):
            return left - right
        if isinstance(op, ast.Mult):
            return left * right
        if isinstance(op, ast.Div):
            if right == 0:
                raise self.fail(node, "division by zero")
            return left / right
        if isinstance(op, ast.Pow):
            if right.is_Number and abs(right) > MAX_EXPONENT:
                raise self.fail(node, f"exponent {right} is too large (limit {MAX_EXPONENT})")
            if not left.is_Number and not (right.is_Number and abs(right) <= MAX_SYMBOLIC_EXPONENT):
                raise self.fail(node, "powers of symbolic expressions need a number exponent of at most "
                                f"{MAX_SYMBOLIC_EXPONENT} (got {right})")
            if left == 0 and right.is_Number and right.is_negative:
                raise self.fail(node, "division by zero")
            return left**right
        raise self.fail(node, f"operator not allowed: {_describe(op)}")

    def _call(self, node: ast.Call) -> sympy.Expr:
        if not isinstance(node.func, ast.Name):
            raise self.fail(node, "only calls of plain function names are allowed "
                            f"({', '.join(sorted(FUNCTIONS))})")
        name = node.func.id
        if name not in FUNCTIONS:
            raise self.fail(node, f"unknown function '{name}' (allowed: "
                            f"{', '.join(sorted(FUNCTIONS))})")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(node, f"'{name}' takes plain positional arguments only")
        arity = 2 if name == "atan2" else 1
        if len(node.args) != arity:
            raise self.fail(node, f"'{name}' takes {arity} argument{'s' * (arity > 1)}, "
                            f"got {len(node.args)}")
        args = [self.build(a) for a in node.args]
        return FUNCTIONS[name](*args)  # type: ignore[operator]

    def _suggest(self, name: str) -> str:
        import difflib

        close = difflib.get_close_matches(name, list(self.symbols) + list(RESERVED), n=1)
        return f" (did you mean '{close[0]}'?)" if close else ""


def _describe(node: ast.AST) -> str:
    names = {
        "Attribute": "attribute access", "Subscript": "subscripts", "Lambda": "lambdas",
        "ListComp": "comprehensions", "SetComp": "comprehensions", "DictComp": "comprehensions",
        "GeneratorExp": "comprehensions", "JoinedStr": "f-strings", "Compare": "comparisons",
        "BoolOp": "boolean operators", "IfExp": "conditional expressions", "List": "lists",
        "Tuple": "tuples", "Dict": "mappings", "Set": "sets", "NamedExpr": "assignments",
        "Await": "await", "Yield": "yield", "Starred": "starred arguments",
        "FloorDiv": "'//'", "Mod": "'%'", "MatMult": "'@'", "BitAnd": "'&'", "BitOr": "'|'",
        "LShift": "'<<'", "RShift": "'>>'",
    }
    return names.get(type(node).__name__, type(node).__name__)
