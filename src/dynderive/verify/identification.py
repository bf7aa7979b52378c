"""Base parameters of the regressor: which combinations of ``pi`` the torques determine.

``Y(q, qd, qdd) pi = tau`` does not determine ``pi`` itself: some columns of ``Y`` are zero
at every state (a mass on a joint axis moves nothing), and some are combinations of others
at every state (a link's mass shifts into its parent's first moment and inertia). The base
parameters are ``pi_base = pi_b + beta pi_d``, with ``Y = Y_b [1 beta]`` up to the order of
the columns, so that ``Y pi = Y_b pi_base``.

Found numerically (Gautier's method, 1991): ``Y`` stacked at random states (fixed seed), its
columns scaled to unit norm, the rank from a QR decomposition with column pivoting
(``scipy.linalg.qr(pivoting=True)``); the base columns are then the first columns, in the
order of ``PARAMETER_VECTOR``, that are independent of those before them (a QR without
pivoting, the same threshold), so each link keeps its own parameters and a later link's
dependent ones group into an earlier link's, as in the textbooks (``Izz1 + m2 l1**2``). The
coefficients ``beta`` come from least squares, and are rounded to clean rationals where they
are within 1e-9 of one. Where the robot has symbolic geometry, each coefficient is also
recognised as a polynomial of degree at most 2 in the parameters of the joint origins and
axes, fitted on the same states at randomly scaled parameter values and accepted only if it
fits every set to 1e-8 with rational coefficients.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..model.robot import Robot

#: Singular-value threshold, relative to the largest scaled column's: below it, dependent.
RANK_TOLERANCE = 1e-8


@dataclass
class Grouping:
    """One base parameter: the kept parameter plus ``coefficient * dependent`` terms."""

    name: str                                   # the kept parameter
    value: float                                # pi_base at the given parameter values
    terms: list[tuple[str, float, sympy.Expr | None]] = field(default_factory=list)

    @property
    def text(self) -> str:
        """``Izz_link1 + l**2*m_link2``: symbolic coefficients where recognised, else numbers."""
        parts = [self.name]
        for name, number, symbolic in self.terms:
            text = f"{number:.10g}" if symbolic is None else (f"({symbolic})" if symbolic.is_Add else str(symbolic))
            sign = "-" if text.startswith("-") else "+"
            text = text.lstrip("-")
            parts.append(f"{sign} {name}" if text == "1" else f"{sign} {text}*{name}")
        return " ".join(parts)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "grouping": self.text, "value": json_number(self.value),
                "terms": [{"parameter": name, "coefficient": json_number(number),
                           "symbolic": None if symbolic is None else str(symbolic)}
                          for name, number, symbolic in self.terms]}


@dataclass
class BaseParameters:
    names: tuple[str, ...]          # PARAMETER_VECTOR
    values: np.ndarray              # pi at the given parameter values
    rank: int
    base: list[int]                 # indices of the kept columns
    dependent: list[int]            # indices of the columns grouped into them
    unidentifiable: list[int]       # zero columns
    beta: np.ndarray                # (rank, len(dependent)): Y[:, dependent] = Y[:, base] @ beta
    groupings: list[Grouping]
    states: int

    @property
    def base_values(self) -> np.ndarray:
        """``pi_base = pi_b + beta pi_d``."""
        return self.values[self.base] + self.beta @ self.values[self.dependent]

    def as_dict(self) -> dict[str, Any]:
        return {"parameters": [{"name": n, "value": json_number(v)} for n, v in zip(self.names, self.values)],
                "rank": self.rank, "states": self.states, "base": [g.as_dict() for g in self.groupings],
                "unidentifiable": [self.names[i] for i in self.unidentifiable]}


def json_number(value: float) -> float | None:
    """``value`` for JSON: null where it is not finite (JSON has no NaN or Infinity)."""
    number = float(value)
    return number if np.isfinite(number) else None


def fewest_states(robot: Robot) -> int:
    """The fewest random states ``base_parameters`` accepts: one per entry of ``pi``. Each
    joint's row of ``Y`` adds at most one direction per state, and the first joint's row alone
    can span as many directions as there are base parameters, so fewer states can make the
    rank come out too small (and below ``len(pi) / n`` the stacked ``Y`` has fewer rows than
    columns)."""
    from ..mechanics.regressor import parameter_vector
    from ..model.symbols import SymbolTable

    return len(parameter_vector(robot, SymbolTable.for_robot(robot)))


def random_states(n: int, count: int, seed: int, module: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` states (q, qd, qdd) from a fixed seed: angles over a full turn, rates normal.
    With the generated ``module`` of a floating-base robot (it has ``integrate``), ``n`` is its
    number of velocities and the configurations are ``integrate(neutral, v)`` for v uniform over
    a full turn in every entry: positions within pi, rotations of every size and axis."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (count, n))
    if module is not None and hasattr(module, "integrate"):
        q = module.integrate(module.neutral_configuration(), q)
    return q, rng.normal(size=(count, n)), rng.normal(size=(count, n))


def _stack(module: Any, states: tuple[np.ndarray, ...], values: dict[str, float]) -> np.ndarray:
    Y = module.regressor(*states, **values)
    return Y.reshape(-1, Y.shape[-1])


def base_parameters(derivation: Derivation, module: Any, values: dict[str, float], states: int | None = None,
                    seed: int = 0) -> BaseParameters:
    """The base parameters of ``derivation``'s robot at the parameter ``values``, from
    ``module.regressor`` (the generated module) at random states."""
    from scipy.linalg import qr

    names = tuple(module.PARAMETER_VECTOR)
    size, n = len(names), len(derivation.symbols.qd)
    count = states or max(100, 4 * size)
    sample = random_states(n, count, seed, module)
    W = _stack(module, sample, values)
    norms = np.linalg.norm(W, axis=0)
    zero = [int(i) for i in np.flatnonzero(norms <= 1e-12 * max(norms.max(), 1.0))]
    live = [i for i in range(size) if i not in zero]
    scaled = W[:, live] / norms[live]
    R, pivots = qr(scaled, mode="r", pivoting=True)
    pivoted = np.abs(np.diag(R))
    rank = int(np.sum(pivoted > RANK_TOLERANCE * pivoted[0])) if live else 0
    ordered = np.abs(np.diag(qr(scaled, mode="r")[0]))
    base = [live[k] for k in range(len(live)) if ordered[k] > RANK_TOLERANCE]
    if len(base) != rank:   # a borderline column: trust the pivoted choice, kept in vector order
        base = sorted(live[k] for k in pivots[:rank])
    dependent = [i for i in live if i not in base]
    beta = _clean(_solve(W, base, dependent))
    symbolic = _recognise(derivation, module, sample, values, base, dependent, beta)
    pi = np.asarray(module.parameter_vector(**values), dtype=float)
    result = BaseParameters(names, pi, rank, base, dependent, zero, beta, [], count)
    result.groupings = [
        Grouping(names[b], float(result.base_values[r]),
                 [(names[d], float(beta[r, c]), symbolic.get((r, c))) for c, d in enumerate(dependent) if beta[r, c] != 0])
        for r, b in enumerate(base)]
    return result


def _solve(W: np.ndarray, base: list[int], dependent: list[int]) -> np.ndarray:
    if not dependent:
        return np.zeros((len(base), 0))
    return np.linalg.lstsq(W[:, base], W[:, dependent], rcond=None)[0]


def _clean(beta: np.ndarray) -> np.ndarray:
    """Entries within 1e-9 of a rational with a denominator up to 1000 become that rational;
    entries below 1e-10 (relative to the largest) become zero."""
    scale = max(float(np.abs(beta).max()) if beta.size else 0.0, 1.0)
    out = beta.copy()
    for index, value in np.ndenumerate(beta):
        if abs(value) < 1e-10 * scale:
            out[index] = 0.0
            continue
        fraction = Fraction(float(value)).limit_denominator(1000)
        if abs(float(fraction) - value) <= 1e-9 * max(1.0, abs(value)):
            out[index] = float(fraction)
    return out


def _geometry(derivation: Derivation) -> list[sympy.Symbol]:
    """The parameters that place the joints (origins, axes): what ``beta`` can depend on."""
    table, found = derivation.symbols, set()
    for joint in derivation.robot.joints:
        for text in [*joint.origin, *(joint.axis or ())]:
            found |= table.expr(text).free_symbols
    return sorted(found & set(table.parameters.values()), key=str)


def _recognise(derivation: Derivation, module: Any, sample: tuple[np.ndarray, ...], values: dict[str, float],
               base: list[int], dependent: list[int], beta: np.ndarray) -> dict[tuple[int, int], sympy.Expr]:
    """Nonzero entries of ``beta`` as polynomials (degree <= 2, rational coefficients) in the
    geometric parameters, fitted at randomly scaled parameter values; {} where none fits."""
    geometry = [s for s in _geometry(derivation) if values.get(str(s)) is not None]
    if not geometry or not dependent or len(geometry) > 6:
        return {}
    monomials = [sympy.Integer(1)] + [sympy.Mul(*c) for d in (1, 2)
                                      for c in itertools.combinations_with_replacement(geometry, d)]
    rng = np.random.default_rng(12345)
    rows, betas = [], []
    few = tuple(a[:max(20, len(base))] for a in sample)
    for k in range(len(monomials) + 4):
        trial = dict(values) if k == 0 else {
            name: (v * rng.uniform(0.6, 1.6) if v else rng.uniform(0.5, 1.5)) for name, v in values.items()}
        with np.errstate(all="ignore"):
            W = _stack(module, few if k else sample, trial)
            if not np.all(np.isfinite(W)):
                return {}
            betas.append(beta if k == 0 else _solve(W, base, dependent))
        point = {s: trial[str(s)] for s in geometry}
        rows.append([float(m.subs(point)) for m in monomials])
    A, found = np.array(rows), {}
    for (r, c), value in np.ndenumerate(beta):
        if value == 0:
            continue
        b = np.array([entry[r, c] for entry in betas])
        coefficients = np.linalg.lstsq(A, b, rcond=None)[0]
        exact = [Fraction(float(x)).limit_denominator(1000) for x in coefficients]
        rounded = np.array([float(x) for x in exact])
        if np.max(np.abs(A @ rounded - b)) > 1e-8 * max(1.0, float(np.abs(b).max())):
            continue
        found[(r, c)] = sympy.Add(*(sympy.Rational(x.numerator, x.denominator) * m for x, m in zip(exact, monomials)))
    return found


__all__ = ["BaseParameters", "Grouping", "base_parameters", "fewest_states", "json_number", "random_states"]
