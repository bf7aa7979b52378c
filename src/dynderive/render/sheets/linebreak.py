"""Long expressions broken into display lines at sums and products, without breqn.

breqn's ``dmath*`` breaks a display only at top-level relations and sums, and only where
LaTeX can see them: a long product, a fraction with a long denominator or a sum inside
``\\left( ... \\right)`` sticks out of the margin (the mass-spring-damper's maximal Lagrange
steps by 143 pt). Here the expression tree itself is cut: a sum wider than the line into its
terms, a product into its factors (a long denominator becomes a factor ``(...)^{-1}``), a
parenthesized sum into its terms with ``\\right.`` / ``\\left.`` closing and reopening the
parentheses at the line's ends; pieces that fit are printed whole by the same printer, so a
sum that is split only at the top reads as it would unbroken. Lines are filled greedily by
the estimated widths, so the result is deterministic.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import sympy
from sympy.printing.latex import LatexPrinter


@dataclass(frozen=True)
class _Piece:
    """Printed text of estimated ``width``; ``depth`` +1 opens a parenthesis, -1 closes one."""

    text: str
    width: float
    depth: int = 0


@dataclass(frozen=True)
class _Break:
    """Where a line may end: ``inline`` joins the neighbours on one line, ``start`` begins
    the next line when it ends here."""

    inline: str
    start: str
    width: float
    #: a term too wide for one line starts a line of its own (it is broken inside anyway)
    force: bool = False


#: Estimated widths (math glyphs) of the delimiters and joiners.
_PAREN, _SIGN, _THIN = 0.8, 2.2, 0.3


class LineBreaker:
    """Splits expressions printed by ``latex`` into lines of at most ``budget`` glyphs as
    estimated by ``width``; ``order`` is the printer's term order (as ``sympy.latex``)."""

    def __init__(self, latex: Callable[[sympy.Basic], str], width: Callable[[sympy.Basic], float],
                 order: str | None = None, numbers: Any = None):
        self.latex, self.width = latex, width
        #: sums and products with their numbers as the printer shows them (``render.numbers.Numbers``:
        #: ``add`` and ``mul``), None: as they are
        self.numbers = numbers
        self._printer = LatexPrinter({"order": order})

    def lines(self, expr: sympy.Basic, budget: float) -> list[str]:
        """``expr`` as LaTeX lines: one line (its LaTeX) when it fits ``budget``; else lines
        to be set one below the other, each continuation line starting with its joiner
        (``{}+``, ``{}-`` or ``\\cdot``), parentheses balanced on every line."""
        if self.width(expr) <= budget:
            return [self.latex(expr)]
        return _fill(self._tokens(expr, budget), budget)

    def _tokens(self, expr: sympy.Basic, budget: float) -> list[_Piece | _Break]:
        if self.width(expr) <= budget:
            return [_Piece(self.latex(expr), self.width(expr))]
        if expr.is_Add:
            return self._sum(expr, budget)
        if expr.is_Mul or (expr.is_Pow and expr.exp.is_negative):
            return self._product(expr, budget)
        if expr.is_Pow and expr.base.is_Add and expr.exp.is_Integer:
            return self._parenthesized(expr.base, budget, self.latex(expr.exp))
        return [_Piece(self.latex(expr), self.width(expr))]

    def _sum(self, expr: sympy.Add, budget: float) -> list[_Piece | _Break]:
        shown = self.numbers.add(expr) if self.numbers is not None else expr
        if shown is not expr:   # decimals collected or put in front (their signs)
            return self._tokens(shown, budget)
        out: list[_Piece | _Break] = []
        for i, term in enumerate(self._printer._as_ordered_terms(expr)):
            negative = term.could_extract_minus_sign()
            if i == 0:
                if negative:
                    out.append(_Piece("- ", _SIGN))
            else:
                own_line = self.width(term) > budget
                out.append(_Break(" - ", "{}- ", _SIGN, own_line) if negative
                           else _Break(" + ", "{}+ ", _SIGN, own_line))
            out += self._tokens(-term if negative else term, budget)
        return out

    def _product(self, expr: sympy.Expr, budget: float) -> list[_Piece | _Break]:
        """``expr`` as ``- \\frac{p}{q d} f_1 f_2 ...``, each wide factor split further and a
        denominator factor too wide for the fraction as ``(...)^{-1}`` after it. Short leading
        factors (``- b_{2}``) stay on the line of the first wide one."""
        out: list[_Piece | _Break] = []
        shown = self.numbers.mul(expr) if self.numbers is not None else expr
        if shown is not expr and not shown.is_Mul:   # a decimal folded into a sum, or the whole product
            return self._tokens(shown, budget)
        coefficient, rest = shown.as_coeff_Mul()
        lead = 0.0
        if coefficient.is_negative:
            out.append(_Piece("- ", _SIGN))
            coefficient, lead = -coefficient, _SIGN
        numerator, denominator = sympy.fraction(rest, exact=True)
        above = [f for f in sympy.Mul.make_args(numerator) if f != 1]
        below = [f for f in sympy.Mul.make_args(denominator) if f != 1]
        wide = [] if self.width(sympy.Mul(*below)) <= budget else [f for f in below if self.width(f) > budget / 3]
        p, q = (coefficient.p, coefficient.q) if coefficient.is_Rational else (coefficient, 1)
        narrow = sympy.Mul(sympy.Integer(q), *[f for f in below if f not in wide])
        # (estimated width, tokens of the factor within a budget)
        factors: list[tuple[float, Callable[[float], list[_Piece | _Break]]]] = []
        if narrow != 1 or wide:
            top = self.latex(p)
            text = rf"\frac{{{top}}}{{{self.latex(narrow)}}}" if narrow != 1 else top
            width = max(len(top), self.width(narrow)) + 0.6
            factors.append((width, partial(_whole, _Piece(text, width))))
        elif coefficient != 1 or not above:
            piece = _Piece(self.latex(coefficient), self.width(coefficient))
            factors.append((piece.width, partial(_whole, piece)))
        for f in wide:
            base, exponent = (f.base, -f.exp) if f.is_Pow and f.exp.is_Integer else (f, sympy.Integer(-1))
            power = self.latex(exponent)
            factors.append((self.width(base) + 3.0, partial(self._parenthesized, base, exponent=power)))
        for f in self._ordered_factors(above):
            if f.is_Add:
                factors.append((self.width(f) + 2.0, partial(self._parenthesized, f)))
            elif f.is_Pow and f.base.is_Add and f.exp.is_Integer:
                factors.append((self.width(f) + 2.0, partial(self._power, f)))
            elif self._printer._needs_mul_brackets(f, first=False, last=False):
                piece = _Piece(rf"\left({self.latex(f)}\right)", self.width(f) + 2 * _PAREN)
                factors.append((piece.width, partial(_whole, piece)))
            else:
                factors.append((self.width(f), partial(self._tokens, f)))
        # short factors before the first wide one are glued to it (no break between them)
        glued = 0
        for width, _ in factors:
            if lead + width > budget / 5:
                break
            lead += width + _THIN
            glued += 1
        for i, (_, tokens) in enumerate(factors):
            if i and i > glued:
                out.append(_Break(" ", r"\cdot ", _THIN))
            elif i:
                out.append(_Piece(" ", _THIN))
            out += tokens(budget - lead if i == glued else budget)
        return out

    def _power(self, expr: sympy.Pow, budget: float) -> list[_Piece | _Break]:
        """A sum to a power, split inside its parentheses only when it does not fit."""
        if self.width(expr) + 2.0 > budget:
            return self._parenthesized(expr.base, budget, self.latex(expr.exp))
        return self._tokens(expr, budget)

    def _parenthesized(self, expr: sympy.Basic, budget: float, exponent: str | None = None) -> list[_Piece | _Break]:
        close = r"\right)" + (f"^{{{exponent}}}" if exponent else "")
        return [_Piece(r"\left(", _PAREN, 1), *self._tokens(expr, budget),
                _Piece(close, _PAREN + (1.4 if exponent else 0.0), -1)]

    def _ordered_factors(self, factors: list[sympy.Basic]) -> list[sympy.Basic]:
        """The factors in the order the printer writes them."""
        if self._printer.order in ("old", "none"):
            return factors
        return list(sympy.Mul(*factors, evaluate=False).as_ordered_factors()) if len(factors) > 1 else factors


def _whole(piece: _Piece, budget: float) -> list[_Piece | _Break]:
    """A factor that is never split."""
    return [piece]


def _fill(tokens: list[_Piece | _Break], budget: float) -> list[str]:
    """Pieces set greedily into lines of at most ``budget``; a break is taken only when the
    next piece would not fit. Parentheses open at a line's end are closed there with
    ``\\right.`` and reopened on the next line with ``\\left.``."""
    segments: list[tuple[_Break | None, list[_Piece]]] = [(None, [])]
    for token in tokens:
        if isinstance(token, _Break):
            segments.append((token, []))
        else:
            segments[-1][1].append(token)
    lines: list[str] = []
    text, used, depth = "", 0.0, 0
    for joiner, pieces in segments:
        width = sum(p.width for p in pieces)
        if joiner is None or not used or (not joiner.force and used + joiner.width + width <= budget):
            text += joiner.inline if joiner else ""
            used += (joiner.width if joiner else 0.0) + width
        else:
            lines.append(text + r" \right." * depth)
            text = r"\left. " * depth + joiner.start
            used = joiner.width + width
        for piece in pieces:
            text += piece.text
            depth += piece.depth
    lines.append(text)
    return lines
