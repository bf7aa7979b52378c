"""Safe parsing of the expressions written in robot files.

Expressions are parsed with Python's ``ast`` and rebuilt node by node from a whitelist:
numbers, declared names, ``+ - * / **`` (``^`` means power too), unary signs and calls of a
few elementary functions. Nothing is ever ``eval``'d or ``sympify``'d from raw text, and
resource attacks (``9**9**9``, deep nesting, huge strings) are refused before any work.

Every node is checked as soon as it is built, bottom-up, so the innermost offending
sub-expression is the one reported: values that are not finite (``log(0)``), not real
(``acos(2)``) or outside the range of a double (``10**400``, ``exp(1000)``), and powers of
symbolic expressions above ``MAX_SYMBOLIC_EXPONENT`` however they are written
(``(m**12)**12``, ``m*m*...*m``). Constant values are computed bottom-up with 15 digits, each
step bounded by the range of a double, so no check can run away.

>>> import sympy
>>> parse_expression("m*l**2/12", {"m": sympy.Symbol("m"), "l": sympy.Symbol("l")})
l**2*m/12
"""

from __future__ import annotations

import ast
import math
import operator
import re
import sys
from collections.abc import Mapping
from decimal import Decimal, InvalidOperation

import sympy

from .naming import did_you_mean
from .size import expanded_terms

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
#: Terms an expression may expand to (``model.size``): ``(a+b+c+d+e+f+h+i+j+k)**12``, 30
#: characters, has 293 930 and would hold the derivation for many minutes; physical
#: expressions have a handful.
MAX_EXPANDED_TERMS = 100
#: Levels of nesting of an expression's syntax tree (a chain ``a + b - c`` or ``a*b/c`` is one
#: level, whatever its length); deeper trees would exhaust Python's recursion.
MAX_NESTING = 100

#: Digits of the numeric checks (constants, values at the parameter defaults).
DIGITS = 15
#: The largest size of a number written in a robot file (MuJoCo's ``mjMAXVAL`` too): a length of
#: 1e200 is a double, but its square in the mass matrix is not.
LARGEST = 1e10
_DOUBLE_MAX = sympy.Integer(int(sys.float_info.max))
_DOUBLE_TINY = sympy.Rational(sys.float_info.min)  # exact: the smallest normal double
_LOG10_MAX = math.log10(sys.float_info.max)
_LOG10_TINY = math.log10(sys.float_info.min)
_NON_FINITE = {sympy.zoo: "infinite", sympy.oo: "infinite", -sympy.oo: "infinite", sympy.nan: "undefined"}


#: MATLAB's element-wise operators (``.^ .* ./``), hinted at when an expression does not parse
#: (``2.*x`` parses: a decimal point, then a product).
_MATLAB_OPERATOR = re.compile(r"\.\s*[\^*/]")


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
        number = sympy.Integer(text)
        if abs(number) > _DOUBLE_MAX:
            raise ExpressionError(f"number is out of the range of a double ({_about(number)})")
        return number
    if isinstance(text, float):
        return _number(repr(text), 0)
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression or a number, got {kind(text)}")
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
    lead = len(source) - len(source.lstrip())
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        offset = max((exc.offset or 1) - 1, 0) + lead
        matlab = _MATLAB_OPERATOR.search(text)
        if matlab is not None:   # l.^2, m.*g: MATLAB's element-wise operators
            raise ExpressionError(f"malformed expression: '{matlab.group()}' is MATLAB's element-wise operator; "
                                  "write ** (or ^) for powers, * and / for products and quotients",
                                  matlab.start()) from None
        raise ExpressionError(f"malformed expression: {exc.msg}", offset) from None
    except (RecursionError, MemoryError, ValueError):
        raise ExpressionError("expression is too complex") from None
    builder = _Builder(symbols, lead, source.strip())
    deep = _too_deep(tree.body)
    if deep is not None:
        raise builder.fail(deep, f"expression is nested too deeply (more than {MAX_NESTING} levels)")
    try:
        return builder.build(tree.body)
    except (RecursionError, MemoryError):
        raise ExpressionError("expression is nested too deeply") from None


#: Operators whose left-nested chains are built in a loop: ``+ -`` and ``* /``.
_FAMILY = {ast.Add: "sum", ast.Sub: "sum", ast.Mult: "product", ast.Div: "product"}
#: Operators built without a check of their own (``/`` and ``**`` have theirs).
_ARITHMETIC = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul}


def _chained(parent: ast.AST, child: ast.AST) -> bool:
    return (isinstance(parent, ast.BinOp) and child is parent.left and isinstance(child, ast.BinOp)
            and type(child.op) in _FAMILY and _FAMILY[type(child.op)] == _FAMILY.get(type(parent.op)))


def _too_deep(tree: ast.AST) -> ast.AST | None:
    """The first node nested deeper than ``MAX_NESTING`` (measured without recursion), or None."""
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            return node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.expr):
                stack.append((child, depth if _chained(node, child) else depth + 1))
    return None


class NotFiniteError(ValueError):
    """A numeric value is infinite, undefined or beyond the range of a double."""

    def __init__(self, reason: str, value: sympy.Expr | None = None):
        super().__init__(reason)
        self.reason = reason
        self.value = value


class Evaluator:
    """Numeric values of SymPy expressions, computed bottom-up with ``DIGITS`` digits.

    Each sub-expression is evaluated from its arguments' values and refused
    (``NotFiniteError``) as soon as it is infinite, undefined or larger than a double, so
    ``exp(exp(exp(m)))`` stops at the first overflow instead of building a number with
    astronomically many digits. ``values`` maps symbols to numbers (e.g. parameter defaults);
    an expression with a symbol not in ``values`` has no value (``None``).
    """

    def __init__(self, values: Mapping[sympy.Symbol, sympy.Expr] | None = None):
        self.values = dict(values or {})
        self.memo: dict[sympy.Expr, sympy.Expr] = {}

    def __call__(self, expr: sympy.Expr) -> sympy.Expr | None:
        if expr.free_symbols - set(self.values):
            return None
        memo = self.memo
        stack: list[tuple[sympy.Expr, bool]] = [(expr, False)]
        while stack:
            node, ready = stack.pop()
            if node in memo:
                continue
            if node in self.values:
                memo[node] = self._checked(sympy.sympify(self.values[node]))
            elif ready or not node.args:
                value = node.func(*(memo[a] for a in node.args)) if node.args else node
                try:
                    value = value.evalf(DIGITS, maxn=4 * DIGITS)
                except (ValueError, TypeError, ArithmeticError, RecursionError):
                    return None
                if not value.is_number:
                    return None
                memo[node] = self._checked(value)
            else:
                stack.append((node, True))
                stack.extend((a, False) for a in node.args if a not in memo)
        return memo[expr]

    @staticmethod
    def _checked(value: sympy.Expr) -> sympy.Expr:
        if value in _NON_FINITE or value.has(*_NON_FINITE):
            raise NotFiniteError("undefined" if value.has(sympy.nan) else "infinite", value)
        real, imag = value.as_real_imag()
        if abs(real) > _DOUBLE_MAX or abs(imag) > _DOUBLE_MAX:
            raise NotFiniteError("out of range", value)
        return value


def imaginary_part(value: sympy.Expr) -> float:
    """The imaginary part of a numeric value, 0 when negligible next to the real part."""
    real, imag = (float(abs(x)) for x in value.as_real_imag())
    return 0.0 if imag <= 1e-12 * max(1.0, real) else float(sympy.im(value))


def describe_number(value: sympy.Expr) -> str:
    """A short text for a (maybe complex) value: ``-1``, ``1.31696i``, ``1 + 1.73205i``."""
    real, imag = (float(x) for x in value.as_real_imag())
    if imag == 0:
        return f"{real:g}"
    if real == 0:
        return f"{imag:g}i"
    return f"{real:g} {'+' if imag > 0 else '-'} {abs(imag):g}i"


def _about(value: sympy.Expr) -> str:
    """``about 1.97e+434`` for a number too large or too small for a double."""
    magnitude = sympy.Float(abs(value), DIGITS)
    return _about_log10(float(sympy.log(magnitude, 10).evalf(DIGITS)))


def _about_log10(log10: float) -> str:
    if abs(log10) >= 100_000:  # exp(exp(100)): the exponent itself is huge
        return f"about 10**{log10:.3g}"
    exponent = math.floor(log10)
    return f"about {10 ** (log10 - exponent):.3g}e{exponent:+d}"


def _out_of_range(value: sympy.Expr) -> bool:
    """Whether a real number is too large for a double, or non-zero and below its normal range."""
    magnitude = abs(value)
    return bool(magnitude > _DOUBLE_MAX or (magnitude != 0 and magnitude < _DOUBLE_TINY))


def kind(value: object, empty: bool = False) -> str:
    """What a parsed YAML value is, in words: ``a list``, ``text``; ``empty``: ``an empty list``."""
    if value is None:
        return "nothing"
    if empty and value in ([], {}):
        return f"an empty {'list' if value == [] else 'mapping'}"
    return {bool: "a boolean", int: "a number", float: "a number", str: "text", list: "a list",
            dict: "a mapping"}.get(type(value), type(value).__name__)


def _number(literal: str, offset: int) -> sympy.Expr:
    try:
        value = Decimal(literal)
    except InvalidOperation:
        raise ExpressionError(f"invalid number {literal!r}", offset) from None
    if not value.is_finite():
        raise ExpressionError(f"number {literal!r} is not finite", offset)
    sign, digits, exponent = value.as_tuple()
    if abs(int(exponent)) > 300 or abs(value) > LARGEST:
        raise ExpressionError(f"number {literal!r} is out of range (a robot's numbers are at most 1e10 in size: "
                              "products of them must stay within a double)", offset)
    return sympy.Rational(str(value)) if int(exponent) < 0 else sympy.Integer(int(value))


class _Builder:
    def __init__(self, symbols: Mapping[str, sympy.Expr], lead: int, source: str = ""):
        self.symbols = symbols
        self.lead = lead
        self.source = source
        self.seen: set[sympy.Expr] = set()  # sub-expressions already checked
        self.size_memo: dict[sympy.Basic, tuple[int, int]] = {}  # expanded_terms' counts
        self.evaluate = Evaluator()

    def fail(self, node: ast.AST, message: str) -> ExpressionError:
        # ast offsets count UTF-8 bytes; positions count characters
        offset = getattr(node, "col_offset", 0)
        characters = len(self.source.encode("utf-8")[:offset].decode("utf-8", errors="ignore"))
        return ExpressionError(message, characters + self.lead)

    def refuse(self, node: ast.AST, what: str) -> ExpressionError:
        """``'<node's text>' <what>`` at ``node``, the text cut to 40 characters."""
        text = ast.get_source_segment(self.source, node) or "expression"
        return self.fail(node, f"'{text if len(text) <= 40 else text[:37] + '...'}' {what}")

    def build(self, node: ast.AST) -> sympy.Expr:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise self.fail(node, f"only numbers are allowed as constants, not {node.value!r}")
            if isinstance(node.value, float) and not math.isfinite(node.value):
                raise self.fail(node, f"number '{ast.get_source_segment(self.source, node) or node.value}' "
                                "is out of range")
            return self.checked(node, _number(repr(node.value) if isinstance(node.value, float)
                                              else str(node.value), node.col_offset + self.lead))
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
            return self.checked(node, -operand if isinstance(node.op, ast.USub) else operand)
        if isinstance(node, ast.BinOp):
            return self._binary(node)
        if isinstance(node, ast.Call):
            return self._call(node)
        raise self.fail(node, f"not allowed in an expression: {_describe(node)}")

    def checked(self, node: ast.AST, result: sympy.Expr) -> sympy.Expr:
        """``result`` (built for ``node``) if its new sub-expressions pass the checks of the module."""
        stack = [result]
        while stack:
            expr = stack.pop()
            if expr in self.seen:
                continue
            self.seen.add(expr)
            if expr in _NON_FINITE:
                raise self.refuse(node, f"is {_NON_FINITE[expr]}")
            if expr.is_Number:
                if _out_of_range(expr):
                    raise self.refuse(node, f"is out of the range of a double ({_about(expr)})")
                continue
            if (expr.is_Pow and expr.exp.is_Number and abs(expr.exp) > MAX_SYMBOLIC_EXPONENT
                    and expr.base.free_symbols):
                raise self.refuse(node, f"makes the power {expr}; powers of symbolic expressions are limited "
                                  f"to exponent {MAX_SYMBOLIC_EXPONENT}")
            if not expr.free_symbols:
                self._check_constant(node, expr)
                continue
            stack.extend(expr.args)
        if result.free_symbols and not result.is_Symbol:
            terms = expanded_terms(result, MAX_EXPANDED_TERMS + 1, self.size_memo)
            if terms > MAX_EXPANDED_TERMS:
                raise self.refuse(node, f"expands to up to {expanded_terms(result)} terms (limit "
                                  f"{MAX_EXPANDED_TERMS}): give the value a parameter of its own, or write "
                                  "it with fewer sums inside powers and products")
        return result

    def _check_constant(self, node: ast.AST, expr: sympy.Expr) -> None:
        try:
            value = self.evaluate(expr)
        except NotFiniteError as exc:
            if exc.reason == "out of range":
                about = _about(exc.value)  # type: ignore[arg-type]
                raise self.refuse(node, f"is out of the range of a double ({about})") from None
            raise self.refuse(node, f"is {exc.reason}") from None
        if value is None:
            return
        if imaginary_part(value):
            raise self.refuse(node, f"is not a real number (its value is {describe_number(value)})")
        if _out_of_range(sympy.re(value)):
            raise self.refuse(node, f"is out of the range of a double ({_about(value)})")

    def _binary(self, node: ast.BinOp) -> sympy.Expr:
        # a long chain a + b - c + ... (or a*b/c*...) is built in a loop, not by recursion
        chain = [node]
        while _chained(chain[-1], chain[-1].left):
            chain.append(chain[-1].left)  # type: ignore[arg-type]
        value = self.build(chain[-1].left)
        for link in reversed(chain):
            value = self.checked(link, self._combine(link, value, self.build(link.right)))
        return value

    def _combine(self, node: ast.BinOp, left: sympy.Expr, right: sympy.Expr) -> sympy.Expr:
        op = node.op
        if type(op) in _ARITHMETIC:
            return _ARITHMETIC[type(op)](left, right)
        if isinstance(op, ast.Div):
            if right == 0:
                raise self.fail(node, "division by zero")
            return left / right
        if isinstance(op, ast.Pow):
            if right.is_Number and abs(right) > MAX_EXPONENT:
                raise self.fail(node, f"exponent {right} is too large (limit {MAX_EXPONENT})")
            if left.free_symbols and not (right.is_Number and abs(right) <= MAX_SYMBOLIC_EXPONENT):
                raise self.fail(node, "powers of symbolic expressions need a number exponent of at most "
                                f"{MAX_SYMBOLIC_EXPONENT} (got {right})")
            if left == 0 and right.is_Number and right.is_negative:
                raise self.fail(node, "division by zero")
            if not left.free_symbols and right.is_Number and left != 0:
                # estimate the size before SymPy computes it: (10**999)**999 has 998 001 digits
                base = self.evaluate(left)
                if base is not None and abs(base) != 0:
                    log10 = float(right) * math.log10(float(abs(base)))
                    if log10 > _LOG10_MAX or log10 < _LOG10_TINY:
                        raise self.refuse(node, f"is out of the range of a double ({_about_log10(log10)})")
            return left**right
        raise self.fail(node, f"operator not allowed: {_describe(op)}")

    def _call(self, node: ast.Call) -> sympy.Expr:
        if not isinstance(node.func, ast.Name):
            raise self.fail(node, "only calls of plain function names are allowed "
                            f"({', '.join(sorted(FUNCTIONS))})")
        name = node.func.id
        if name not in FUNCTIONS:
            raise self.fail(node, f"unknown function '{name}' (allowed: {', '.join(sorted(FUNCTIONS))})")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(node, f"'{name}' takes plain positional arguments only")
        arity = 2 if name == "atan2" else 1
        if len(node.args) != arity:
            raise self.fail(node, f"'{name}' takes {arity} argument{'s' * (arity > 1)}, got {len(node.args)}")
        args = [self.build(a) for a in node.args]
        return self.checked(node, FUNCTIONS[name](*args))  # type: ignore[operator]

    def _suggest(self, name: str) -> str:
        return did_you_mean(name, list(self.symbols) + list(RESERVED))


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
