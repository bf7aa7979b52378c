"""Linearization of the equations of motion about a state: ``xdot = A dx + B du`` with
``x = (q, qd)``.

Two routes. ``inverse_dynamics_derivatives_program`` differentiates the Newton-Euler
program line by line (forward mode, one pass per coordinate and per velocity), so the
generated ``linearize`` of any robot size gets ``dtau/dq`` and ``dtau/dqd`` as straight-line
code, and then ``qdd``'s derivatives by one solve with M:

    M dqdd/dx = dY/dx - dtau/dx(q, qd, qdd)      (tau = M qdd + C qd + N, Newton-Euler)

as Pinocchio's ``computeABADerivatives`` does. ``symbolic_linearization`` gives A and B of a
small robot in closed form over its parameters (the cart-pole about upright), from the
manipulator form's quantities, for the terminal, JSON and LaTeX of ``dynderive linearize``.
"""

from __future__ import annotations

from collections.abc import Mapping
from itertools import combinations
from typing import Any

import sympy
from sympy.polys.constructor import construct_domain
from sympy.polys.matrices import DomainMatrix
from sympy.polys.polyerrors import ExactQuotientFailed

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .exact_fast import diff, jacobian, matmul
from .program import Program
from .recursive import _carry, _forward, _newton_euler
from .tidy import is_small, tidy
from .tree import Tree


def inverse_dynamics_derivatives_program(robot: Robot, table: SymbolTable, tree: Tree | None = None) -> Program:
    """``dtau/dq`` then ``dtau/dqd`` (each n x n, row i = tau_i, column k = the variable),
    row by row, of ``tau = M qdd + C qd + N`` (armature and springs included; damping and
    friction are added by the module). ``dtau/dq`` is along each velocity column's tangent of
    the configuration (``Tree.tangent_seeds``: ``q_k`` itself for a scalar joint, the tangent
    of ``integrate(q, e_k h)`` for a quaternion's, Pinocchio's convention in
    ``computeABADerivatives``)."""
    tree = tree or Tree(robot, table)
    program = tree.program
    tau = _newton_euler(tree, table.qd, table.qdd)
    trig = {expr: name for name, expr in tree.trig}
    lines = [(name, expr, expr.free_symbols) for name, expr in program.lines]
    n = tree.size
    seeds = tree.tangent_seeds() + [{rate: sympy.Integer(1)} for rate in table.qd]
    by_variable: list[list[sympy.Expr]] = []
    partials: dict[tuple[sympy.Expr, sympy.Symbol], sympy.Expr] = {}
    for seed in seeds:
        tangent = dict(seed)
        _carry(program, tangent, trig, lines, partials)
        by_variable.append([program.let(_forward(t, tangent, trig)) for t in tau])
    # row by row: d tau_i / d q_k, then d tau_i / d qd_k
    outputs = [by_variable[k][i] for i in range(n) for k in range(n)]
    outputs += [by_variable[n + k][i] for i in range(n) for k in range(n)]
    program.outputs = outputs
    return program


def loop_linearization_terms(quantities: dict[str, sympy.Matrix],
                             table: SymbolTable) -> tuple[sympy.Matrix, sympy.Matrix]:
    """What ``linearize`` of a closed-loop robot needs beyond Newton-Euler's derivatives, for
    every target: the loop force's ``d(A_g^T lambda_g)/dq`` at fixed multipliers (n x n) and
    the constraint acceleration's ``d(A_g qdd + Adot_g qd)/dq`` at fixed qdd (k x n);
    ``d(Adot_g qd)/dqd`` is ``2 Adot_g`` (``A_g`` is a Hessian's rows)."""
    coordinates = list(table.q)
    A, Adot = quantities["A_g"], quantities["Adot_g"]
    force = jacobian(matmul(A.T, quantities["lambda_g"]), coordinates)
    acceleration = jacobian(matmul(A, sympy.Matrix(table.qdd)) + matmul(Adot, sympy.Matrix(table.qd)), coordinates)
    return force, acceleration


def symbolic_linearization(quantities: Mapping[str, sympy.Matrix], table: SymbolTable,
                           point: dict[sympy.Symbol, sympy.Expr]) -> tuple[sympy.Matrix, sympy.Matrix, sympy.Matrix]:
    """``(A, B, qdd0)`` at ``point`` (values of q, qd, u), over the parameters, from the
    manipulator form ``M qdd + C qd + N + F = Y``; raises ``NoClosedForm`` when an entry
    has more than ``CLOSED_FORM_TERMS`` terms or M is singular there.

    Everything is taken at the point first (M, the forces and the residual's partials), then
    the solves with M are exact polynomial arithmetic over the parameters: ``qdd0 = adj(M) f /
    det M`` and ``M^-1 dr/dx = adj(M) dr/dx / det M``, each entry's common factors found by
    dividing it exactly by det M's irreducible factors (the only ones a denominator has). The
    residual's partial in ``q_k`` at ``qdd0`` is ``dM/dq_k qdd0 + d(C qd + N + F - Y)/dq_k``.
    Inverting M symbolically and cancelling every product with greatest common divisors (the
    textbook route) grows past minutes on a three-link arm.

    Coulomb friction's ``sign(qd)`` is taken as constant (its slope is zero away from
    qd = 0, and no stiction is modelled at 0).
    """
    n = len(table.q)
    M, C, N, Y = quantities["M_g"], quantities["C_g"], quantities["N_g"], quantities["Y_g"]
    F = quantities.get("F_g", sympy.zeros(n, 1))
    signs = {s: sympy.Dummy("sign") for s in F.atoms(sympy.sign)}
    rest = C * sympy.Matrix(table.qd) + N + F.xreplace(signs) - Y
    efforts = list(table.efforts.values())
    state = {s: v for s, v in point.items() if s in set(table.q) | set(table.qd) | set(efforts)}
    back = {d: s.xreplace(state) for s, d in signs.items()}

    def at(matrix: sympy.Matrix) -> sympy.Matrix:
        return matrix.xreplace(state).xreplace(back)

    def partials(variables: list[sympy.Symbol]) -> sympy.Matrix:
        """``d rest / d variables`` at the point, the other variables put in first."""
        others = {s: v for s, v in state.items() if s not in set(variables)}
        return at(jacobian(rest.xreplace(others), variables))

    pieces = [at(M), -at(rest), *[at(M.applyfunc(lambda e, c=c: diff(e, c))) for c in table.q],
              partials(list(table.q)), partials(list(table.qd)),
              at(jacobian(Y, efforts)) if efforts else sympy.zeros(n, 0)]
    if not is_small(sympy.Tuple(*(e for piece in pieces for e in piece)), INPUT_NODES):
        raise NoClosedForm(f"the mass matrix and forces at this point are too large for a closed form "
                           f"(over {INPUT_NODES} operations)")
    exact = _Exact(pieces)
    M0, forces, *mass_slopes, rest_q, rest_qd, d_u = exact.matrices
    det, adjugate = exact.inverse_parts(M0)
    accelerations = adjugate * forces                       # det M qdd0
    qdd0 = exact.quotient(accelerations, 1)
    # det M times the residual's partial in q at qdd0, column by column
    d_q = DomainMatrix.hstack(*[slope * accelerations for slope in mass_slopes]) + rest_q * det
    A_q = exact.quotient(-(adjugate * d_q), 2)
    A_qd = exact.quotient(-(adjugate * rest_qd), 1)
    B_u = exact.quotient(adjugate * d_u, 1)
    A = sympy.Matrix.vstack(sympy.Matrix.hstack(sympy.zeros(n, n), sympy.eye(n)), sympy.Matrix.hstack(A_q, A_qd))
    B = sympy.Matrix.vstack(sympy.zeros(n, len(efforts)), B_u)
    return A, B, qdd0


#: Most terms an entry of the closed form may have (numerator and denominator, expanded):
#: beyond it no one reads the formula, and printing it takes longer than deriving it.
CLOSED_FORM_TERMS = 200


#: Most operations (expression nodes) the mass matrix, the forces and their partials at the
#: point may have together before the exact solve is tried: a full-precision 3-D arm's reach
#: hundreds of thousands, whose polynomial ring then takes minutes to build (the bundled
#: planar and small arms' stay under 300).
INPUT_NODES = 20_000


#: Entries up to this many terms are put in ``sympy.cancel``'s normal form.
CANCEL_TERMS = 60


class NoClosedForm(Exception):
    """The closed form is not given at this point: why, in a few words (an entry too large to
    read, the mass matrix singular)."""


class _Exact:
    """Matrices of expressions as polynomials over one ring: every subexpression that is not a
    polynomial operation (``cos(3/10)``, ``sqrt(2)``, ``pi``, ``1/l``, a function of a parameter,
    a float) becomes a generator, so the arithmetic is exact and fast (not SymPy's expression
    domain), and substituting the subexpressions back gives the expressions."""

    def __init__(self, matrices: list[sympy.Matrix]):
        self.generators: dict[sympy.Basic, sympy.Dummy] = {}
        replaced = [self._polynomial(sympy.sympify(e)) for matrix in matrices for e in matrix]
        self.back = {dummy: expr for expr, dummy in self.generators.items()}
        self.ring, elements = construct_domain(replaced)
        self.factors: list[tuple[Any, int]] = []
        self.matrices, position = [], 0
        for matrix in matrices:
            rows, cols = matrix.shape
            flat = elements[position:position + rows * cols]
            position += rows * cols
            self.matrices.append(DomainMatrix([flat[r * cols:(r + 1) * cols] for r in range(rows)],
                                              (rows, cols), self.ring))

    def _polynomial(self, expr: sympy.Basic) -> sympy.Basic:
        if expr.is_Symbol or expr.is_Rational:
            return expr
        if expr.is_Add or expr.is_Mul:
            return expr.func(*[self._polynomial(a) for a in expr.args])
        if expr.is_Pow and expr.exp.is_Integer:
            base = self._polynomial(expr.base) if expr.exp > 0 else self._generator(1 / expr.base)
            return base ** abs(expr.exp)
        return self._generator(expr)

    def _generator(self, expr: sympy.Basic) -> sympy.Dummy:
        if expr not in self.generators:
            self.generators[expr] = sympy.Dummy(f"g{len(self.generators)}")
        return self.generators[expr]

    def inverse_parts(self, matrix: DomainMatrix) -> tuple[Any, DomainMatrix]:
        """``(det, adjugate)`` of a square matrix by cofactors (``_minors``: exact products only,
        no divisions, which are what make fraction-free elimination slow over many
        generators), and ``det`` taken as the denominator that ``quotient`` divides by (its
        irreducible factors with their multiplicities). Raises ``NoClosedForm`` when the
        matrix is singular or its determinant too large to be read as a denominator."""
        ring, n = self.ring, matrix.shape[0]
        entries = matrix.to_list()
        det = _minors(entries, range(n), ring)[frozenset(range(n))]
        if det == ring.zero:
            raise NoClosedForm("the mass matrix is singular at this point")
        if _terms(det) > CLOSED_FORM_TERMS:
            raise NoClosedForm(f"det M, the entries' denominator, would have {_terms(det)} terms at this point "
                               f"(more than {CLOSED_FORM_TERMS})")
        adjugate = [[ring.zero] * n for _ in range(n)]
        for row in range(n):   # adj[j][row] = (-1)^(row+j) det(M without row and column j)
            minors = _minors(entries, [r for r in range(n) if r != row], ring)
            for column in range(n):
                minor = minors[frozenset(c for c in range(n) if c != column)]
                adjugate[column][row] = -minor if (row + column) % 2 else minor
        self.det = det
        if ring.is_PolynomialRing:
            self.coefficient, self.factors = det.factor_list()
        else:
            self.coefficient, self.factors = det, []
        return det, DomainMatrix(adjugate, (n, n), ring)

    def quotient(self, numerators: DomainMatrix, power: int) -> sympy.Matrix:
        """``numerators / det**power`` entry by entry, cancelled and tidied, as expressions."""
        reduced = [self._reduced(e, power) for row in numerators.to_list() for e in row]
        largest = max((_terms(p) + _terms(q) for p, q in reduced), default=0)
        if largest > CLOSED_FORM_TERMS:
            raise NoClosedForm(f"an entry would have {largest} terms at this point (more than {CLOSED_FORM_TERMS})")
        rows, cols = numerators.shape
        return sympy.Matrix(rows, cols, [tidy(self._expression(p, q)) for p, q in reduced])

    def _expression(self, numerator: Any, denominator: Any) -> sympy.Expr:
        """``numerator / denominator`` (without common factors) as an expression: small ones
        in ``sympy.cancel``'s normal form, larger ones with the integer contents and the sign
        taken out directly (``cancel`` would search for common factors again, which costs
        seconds on an entry of a hundred terms over twenty generators)."""
        ring, to_sympy = self.ring, self.ring.to_sympy
        if not ring.is_PolynomialRing or _terms(numerator) + _terms(denominator) <= CANCEL_TERMS:
            return sympy.cancel((to_sympy(numerator) / to_sympy(denominator)).xreplace(self.back))
        coefficients = ring.domain
        top, numerator = numerator.primitive()
        bottom, denominator = denominator.primitive()
        if coefficients.is_negative(denominator.LC):
            bottom, denominator = -bottom, -denominator
        scale = coefficients.to_sympy(coefficients.quo(top, bottom))
        return (scale * to_sympy(numerator) / to_sympy(denominator)).xreplace(self.back)

    def _reduced(self, numerator: Any, power: int) -> tuple[Any, Any]:
        """``numerator / det**power`` as a numerator and denominator without common factors:
        the denominator's factors are det's, so exact division by each finds them all."""
        ring = self.ring
        if numerator == ring.zero:
            return ring.zero, ring.one
        if not ring.is_PolynomialRing:
            return numerator, self.det ** power
        denominator = self.coefficient ** power
        for factor, multiplicity in self.factors:
            left = multiplicity * power
            while left:
                quotient = _exact_quotient(numerator, factor)
                if quotient is None:
                    break
                numerator, left = quotient, left - 1
            denominator *= factor ** left
        return numerator, ring.one * denominator


def _minors(entries: list[list[Any]], rows: Any, ring: Any) -> dict[frozenset[int], Any]:
    """The determinants of ``entries``' square submatrices on the first ``k`` of ``rows`` and
    every set of ``k`` columns (Laplace along the last row, each smaller minor computed once),
    up to ``k = len(rows)``: ``2^n`` minors of an n x n matrix, n products each."""
    rows = list(rows)
    columns = range(len(entries[0]) if entries else 0)
    minors: dict[frozenset[int], Any] = {frozenset(): ring.one}
    for size, row in enumerate(rows, start=1):
        for chosen in combinations(columns, size):
            total = ring.zero
            for place, column in enumerate(chosen):   # sign of the entry in the minor's last row
                entry = entries[row][column]
                if entry != ring.zero:
                    term = entry * minors[frozenset(chosen) - {column}]
                    total = total + term if (size - 1 - place) % 2 == 0 else total - term
            minors[frozenset(chosen)] = total
    return minors


def _exact_quotient(numerator: Any, factor: Any) -> Any:
    """``numerator / factor`` when ``factor`` divides it, else None."""
    try:
        return numerator.exquo(factor)
    except ExactQuotientFailed:
        return None


def _terms(polynomial: Any) -> int:
    """Terms of a ring's element (1 for a number)."""
    return len(polynomial) if hasattr(polynomial, "terms") else 1
