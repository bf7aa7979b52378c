"""Closed kinematic loops: the constraints of loop-closing joints on the generalized
coordinates, their multipliers, and the reduced form on the independent coordinates.

A loop joint between links P and C holds when its two frames (``origin`` on P,
``child_origin`` on C) meet as its type allows:

* planar revolute: the frame origins coincide (2 rows);
* planar prismatic: no offset across the axis, no relative rotation (2 rows);
* 3-D spherical: the origins coincide (3 rows); revolute: and the axes stay aligned (5);
  prismatic: no relative rotation and no offset across the axis (5).

The rows ``a_g(q)`` are written from the links' world poses, so ``A_g = da_g/dq`` and
``Adot_g`` follow by differentiation. Rows that are identically zero (a planar loop described
in 3-D) are dropped, with a note; every other row is kept. Rows that are implied by the others
on the constraint manifold (an over-constrained mechanism such as the Bennett linkage: 5 rows
of rank 2) are *not* dropped, because the rows that are implied at one configuration are not
the same everywhere: the rank ``r`` of ``A_g`` on the manifold is recorded instead, the
mobility is ``n - r``, and the generated code solves with the rank-``r`` row space of ``A_g``
at each state. The mechanism is assembled at the default parameters (Levenberg-Marquardt from a
few starts, then the dependent coordinates solved to 40 digits with mpmath, so the written
configuration has the same bytes on every machine): a loop that cannot close is bad input. The
independent coordinates are the file's ``independent`` list, or chosen: actuated coordinates
first, then those whose dependent block of ``A_g`` is best conditioned at the assembled
configuration. With ``qd = R_g qd_i``, ``R_g = P [I; -A_d^-1 A_i]``, the reduced equations are
``R_g^T`` times the multiplier form, in which ``A_g^T lambda_g`` drops out (derived symbolically
only when no row is redundant).
"""

from __future__ import annotations

import itertools
import math
import random
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy

from ..errors import InputError, Problem
from ..model.joint_kinds import joint_kind
from ..model.robot import LoopJoint, Robot
from ..model.symbols import SymbolTable
from .exact_fast import factor_terms, jacobian, matmul
from .joint_variables import unit
from .lagrange import constraint_jacobian_dot
from .planar import rotated
from .rotations import rpy_matrix
from .tidy import count_ops, fewest_operations, fold_constants, is_small, quick_tidy, tidy, trig_linear

#: Singular values of A_g below this fraction of the largest are zero (the rank on the manifold,
#: at configurations assembled to ``ASSEMBLY_TOLERANCE``).
RANK_TOLERANCE = 1e-7
#: Decimal places of the independent coordinates of the default assembly: the float solver's
#: last digits (which depend on the NumPy build) never reach an output.
ASSEMBLY_DECIMALS = 6
#: Largest residual |a_g| accepted as assembled.
ASSEMBLY_TOLERANCE = 1e-10
#: The reduced form is derived symbolically only for at most this many loop constraints, with
#: entries of A_g small enough that the inverse of the dependent block stays readable.
REDUCED_ROWS = 3
REDUCED_NODES = 400


@dataclass
class LoopModel:
    """Everything the derivation, the renderers and the generated code need of the loops."""

    constraints: sympy.Matrix                 # a_g(q), k x 1
    jacobian: sympy.Matrix                    # A_g, k x n
    jacobian_dot: sympy.Matrix                # Adot_g, k x n
    multipliers: list[sympy.Symbol]           # lambda_g1..k
    rows: list[tuple[str, str]]               # (loop joint, what the row says)
    row_indices: list[int]                    # which rows of ``loop_rows`` were kept
    rank: int                                 # rank of A_g on the constraint manifold
    independent: list[int]                    # coordinate indices kept independent
    dependent: list[int]
    assembled: list[float] | None             # a configuration on a_g = 0 at the defaults
    notes: list[str] = field(default_factory=list)
    reduced: dict[str, sympy.Matrix] = field(default_factory=dict)   # R_g, M_r, C_r, N_r, Y_r, EOM_r

    @property
    def mobility(self) -> int:
        """Degrees of freedom of the closed mechanism: coordinates minus independent constraints."""
        return len(self.independent)

    @property
    def redundant(self) -> bool:
        """Whether some rows are implied by the others on the manifold (over-constrained)."""
        return self.rank < self.constraints.shape[0]


def _planar_frame(link: str, kinematics: dict[str, Any], offset: tuple[sympy.Expr, ...]
                  ) -> tuple[sympy.Matrix, sympy.Expr]:
    """World position and angle of the loop frame at ``offset = (x, y, theta)`` on ``link``."""
    if link == "world":
        origin, angle = sympy.Matrix([0, 0]), sympy.Integer(0)
    else:
        kin = kinematics[link]
        origin, angle = kin.joint_origin, kin.angle
    x, y, theta = offset
    return origin + rotated(angle, (x, y)), angle + theta


def _spatial_frame(link: str, kinematics: dict[str, Any], offset: tuple[sympy.Expr, ...],
                   table: SymbolTable, robot: Robot) -> tuple[sympy.Matrix, sympy.Matrix]:
    """World position and rotation of the loop frame at ``offset = (xyz, rpy)`` on ``link``."""
    if link == "world":
        R, origin = sympy.eye(3), sympy.zeros(3, 1)
    else:
        kin = kinematics[link]
        com = sympy.Matrix([table.expr(e) for e in robot.link(link).com])
        R, origin = kin.rotation, kin.com_world - kin.rotation * com
    x, y, z, roll, pitch, yaw = offset
    return origin + R * sympy.Matrix([x, y, z]), R * rpy_matrix(roll, pitch, yaw)


def _normals(axis: tuple[sympy.Expr, ...]) -> tuple[sympy.Matrix, sympy.Matrix]:
    """Two unit vectors perpendicular to the unit ``axis`` and to each other."""
    a = sympy.Matrix(axis)
    first = float(sympy.N(axis[0])) if axis[0].is_number else 0.0
    helper = sympy.Matrix([1, 0, 0]) if abs(first) < 0.9 else sympy.Matrix([0, 1, 0])
    b1 = a.cross(helper)
    b1 = b1 / sympy.sqrt(sum(e**2 for e in b1))
    return b1, a.cross(b1)


def loop_rows(robot: Robot, table: SymbolTable, links: list[Any]) -> list[tuple[str, str, sympy.Expr]]:
    """Every loop constraint row as ``(loop joint, description, expression)``, before
    redundant rows are dropped."""
    kinematics = {kin.name: kin for kin in links}
    rows: list[tuple[str, str, sympy.Expr]] = []
    for loop in robot.loops:
        origin = tuple(table.expr(e) for e in loop.origin)
        child_origin = tuple(table.expr(e) for e in loop.child_origin)
        if robot.planar:
            rows += _planar_rows(loop, kinematics, origin, child_origin, table)
        else:
            rows += _spatial_rows(loop, kinematics, origin, child_origin, table, robot)
    return [(name, what, tidy(expr)) for name, what, expr in rows]


def _frees(loop: LoopJoint) -> tuple[str, str]:
    """What the loop joint lets move between its frames (translation, rotation), from its type."""
    return joint_kind(loop.type).frees or ("all", "all")


def _planar_rows(loop: LoopJoint, kinematics: dict[str, Any], origin: tuple[sympy.Expr, ...],
                 child_origin: tuple[sympy.Expr, ...], table: SymbolTable) -> list[tuple[str, str, sympy.Expr]]:
    p_parent, angle_parent = _planar_frame(loop.parent, kinematics, origin)
    p_child, angle_child = _planar_frame(loop.child, kinematics, child_origin)
    gap = p_child - p_parent
    if _frees(loop) == ("none", "axis"):   # a turn: the frames' origins coincide
        return [(loop.name, f"{axis} of the gap between the loop frames", e) for axis, e in zip("xy", gap)]
    ux, uy = unit(tuple(table.expr(e) for e in loop.axis))
    normal = rotated(angle_parent, (-uy, ux))
    return [(loop.name, "offset across the sliding axis", (normal.T * gap)[0, 0]),
            (loop.name, "relative rotation", angle_child - angle_parent)]


def _spatial_rows(loop: LoopJoint, kinematics: dict[str, Any], origin: tuple[sympy.Expr, ...],
                  child_origin: tuple[sympy.Expr, ...], table: SymbolTable,
                  robot: Robot) -> list[tuple[str, str, sympy.Expr]]:
    p_parent, R_parent = _spatial_frame(loop.parent, kinematics, origin, table, robot)
    p_child, R_child = _spatial_frame(loop.child, kinematics, child_origin, table, robot)
    rows: list[tuple[str, str, sympy.Expr]] = []
    translation, rotation = _frees(loop)
    if translation == "none":
        gap = p_child - p_parent
        rows += [(loop.name, f"{axis} of the gap between the loop frames", gap[i]) for i, axis in enumerate("xyz")]
    if rotation == "all":
        return rows
    axis = unit(tuple(table.expr(e) for e in loop.axis))
    b1, b2 = _normals(axis)   # type: ignore[arg-type]
    if rotation == "axis":
        a_world = R_parent * sympy.Matrix(axis)
        rows += [(loop.name, "axis alignment (first normal)", (a_world.T * R_child * b1)[0, 0]),
                 (loop.name, "axis alignment (second normal)", (a_world.T * R_child * b2)[0, 0])]
        return rows
    relative = R_parent.T * R_child
    rows += [(loop.name, f"relative rotation about {axis}", relative[k, j] - relative[j, k])
             for axis, (k, j) in zip("xyz", ((2, 1), (0, 2), (1, 0)))]
    offset = R_parent.T * (p_child - p_parent)
    rows += [(loop.name, "offset across the sliding axis (first normal)", (b1.T * offset)[0, 0]),
             (loop.name, "offset across the sliding axis (second normal)", (b2.T * offset)[0, 0])]
    return rows


class _Numeric:
    """``a_g`` and ``A_g`` as NumPy functions of q at the default parameters."""

    def __init__(self, a: sympy.Matrix, A: sympy.Matrix, table: SymbolTable, defaults: dict[sympy.Symbol, float]):
        values = {s: sympy.Float(v) for s, v in defaults.items()}
        self.a = sympy.lambdify([table.q], fold_constants(a.xreplace(values)), "numpy")
        self.A = sympy.lambdify([table.q], fold_constants(A.xreplace(values)), "numpy")

    def residual(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.a(q), dtype=float).reshape(-1)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.A(q), dtype=float).reshape(-1, len(q))


def assemble(numeric: _Numeric, start: np.ndarray, fixed: list[int] | None = None,
             iterations: int = 60) -> np.ndarray | None:
    """A configuration near ``start`` with ``a_g = 0`` (Levenberg-Marquardt on the free
    coordinates; ``fixed`` coordinates keep their values), or None if it does not converge."""
    q = np.array(start, dtype=float)
    free = [i for i in range(len(q)) if not fixed or i not in fixed]
    damping = 1e-6
    for _ in range(iterations):
        r = numeric.residual(q)
        if not np.all(np.isfinite(r)):
            return None
        if np.max(np.abs(r), initial=0.0) < ASSEMBLY_TOLERANCE:
            return q
        J = numeric.jacobian(q)[:, free]
        step = np.linalg.solve(J.T @ J + damping * np.eye(len(free)), -J.T @ r)
        trial = q.copy()
        trial[free] += step
        if np.linalg.norm(numeric.residual(trial)) < np.linalg.norm(r):
            q, damping = trial, max(damping / 10, 1e-12)
        else:
            damping *= 10
            if damping > 1e8:
                return None
    return q if np.max(np.abs(numeric.residual(q)), initial=0.0) < ASSEMBLY_TOLERANCE else None


def assemblies(numeric: _Numeric, robot: Robot) -> list[np.ndarray]:
    """The assembled configurations reached from a few deterministic starts (angles wrapped to
    (-pi, pi]), the one nearest ``q = 0`` first: the branch the sheet and ``assemble`` use."""
    n = len(robot.coordinates)
    revolute = [angle for j in robot.joints if j.owns for angle in j.kind.angle_entries]
    rng = random.Random(15)
    starts = [np.zeros(n), np.array([0.3 * (-1) ** i for i in range(n)]), np.array([-0.3 * (-1) ** i for i in range(n)])]
    starts += [np.array([rng.uniform(-math.pi, math.pi) for _ in range(n)]) for _ in range(9)]
    found = [q for q in (assemble(numeric, start) for start in starts) if q is not None]
    wrapped = [np.array([math.remainder(x, 2 * math.pi) if r else x for x, r in zip(q, revolute)])
               for q in found]
    return sorted(wrapped, key=lambda q: float(np.linalg.norm(q)))


def _rank(J: np.ndarray) -> int:
    """The rank of ``J``: its singular values above RANK_TOLERANCE times the largest."""
    sigma = np.linalg.svd(J, compute_uv=False) if J.size else np.zeros(0)
    return int(np.sum(sigma > RANK_TOLERANCE * max(float(sigma[0]) if len(sigma) else 0.0, 1e-300)))


def _neighbours(numeric: _Numeric, q: np.ndarray) -> list[np.ndarray]:
    """Configurations near ``q`` on its branch: each coordinate in turn moved by +-0.1 and held
    there while the others are assembled (moves of all coordinates at once would fall back
    into a singular ``q``, which attracts the least-squares solver)."""
    found = []
    for j in range(len(q)):
        for step in (0.1, -0.1):
            start = q.copy()
            start[j] += step
            moved = assemble(numeric, start, fixed=[j])
            if moved is not None and np.linalg.norm(moved - q) < 1.0:
                found.append(moved)
    return found


def _regular(J: np.ndarray, rank: int) -> bool:
    """Whether ``J`` has rank ``rank``, well away from a lower one."""
    sigma = np.linalg.svd(J, compute_uv=False)
    return _rank(J) == rank and (rank == 0 or sigma[rank - 1] > 1e-6 * sigma[0])


def _manifold_rank(numeric: _Numeric, q: np.ndarray) -> int:
    """The rank of A_g on the constraint manifold at ``q``'s branch: the most common rank at
    configurations assembled near ``q`` (fewest rows on a tie). Not just the rank at ``q``,
    which may be a singular configuration (a parallelogram folded flat), nor the largest, which
    a point assembled to 1e-10 beside a bifurcation, or a rigid crossed branch, would raise."""
    ranks = [_rank(numeric.jacobian(m)) for m in _neighbours(numeric, q)] or [_rank(numeric.jacobian(q))]
    return min(set(ranks), key=lambda r: (-ranks.count(r), r))


def _vanishing_rows(numeric: _Numeric, n: int) -> list[int]:
    """Rows that are zero with their gradient at random configurations: identically zero,
    though not simplified to 0 (a planar loop in 3-D: the axes stay parallel by construction)."""
    rng = np.random.default_rng(15)
    points = [rng.uniform(-math.pi, math.pi, n) for _ in range(3)]
    values = [np.abs(numeric.residual(q)) for q in points]
    slopes = [np.max(np.abs(numeric.jacobian(q)), axis=1, initial=0.0) for q in points]
    scale = max(1.0, *(float(np.max(v, initial=0.0)) for v in values + slopes))
    return [i for i in range(len(values[0]))
            if all(v[i] < 1e-12 * scale and g[i] < 1e-12 * scale for v, g in zip(values, slopes))]


def derive_loops(robot: Robot, table: SymbolTable, links: list[Any]) -> LoopModel:
    """The loop constraints of ``robot`` without identically zero rows, their rank on the
    manifold, the assembly at the default parameters and the choice of independent coordinates."""
    n = len(table.q)
    every = loop_rows(robot, table, links)
    nonzero = [i for i, row in enumerate(every) if row[2] != 0]
    notes: list[str] = []
    where = robot.positions.get("loops", (1, 1))
    complete = all(p.value is not None for p in robot.parameters)
    values = table.defaults(robot) if complete else {s: 1.0 for s in table.parameters.values()}

    def numeric_of(indices: list[int]) -> tuple[sympy.Matrix, sympy.Matrix, _Numeric]:
        a = sympy.Matrix([every[i][2] for i in indices]) if indices else sympy.zeros(0, 1)
        A = jacobian(a, table.q) if indices else sympy.zeros(0, n)
        return a, A, _Numeric(a, A, table, values)

    a, A, numeric = numeric_of(nonzero)
    vanishing = set(_vanishing_rows(numeric, n)) if nonzero else set()
    if vanishing:
        nonzero = [i for k, i in enumerate(nonzero) if k not in vanishing]
        a, A, numeric = numeric_of(nonzero)
    dropped = "; ".join(f"{name}: {what}" for i, (name, what, _) in enumerate(every) if i not in nonzero)
    if dropped:
        count = len(every) - len(nonzero)
        notes.append(f"{robot.source}:{where[0]}:{where[1]}: note: {count} loop constraint "
                     f"{'rows are' if count != 1 else 'row is'} identically zero and "
                     f"{'were' if count != 1 else 'was'} dropped: {dropped}")
    rows = [every[i] for i in nonzero]
    if not rows:   # a loop joint on a tree joint's own axis: nothing to close
        message = (f"loops: every loop constraint row is identically zero ({dropped}), so the loops "
                   "constrain nothing: remove them, or move the loop joint off the tree joint's axis")
        raise InputError(Problem(robot.source, where[0], where[1], message))
    found = assemblies(numeric, robot)
    if not found:
        if complete:
            first = robot.loops[0]
            line, column = robot.positions.get(f"loop:{first.name}", where)
            raise InputError(Problem(robot.source, line, column, f"loops[0] '{first.name}': the mechanism cannot "
                                     "be assembled at the default parameters (the loop constraints have no "
                                     "solution near any tried configuration: check lengths and origins)"))
        default = np.random.default_rng(15).uniform(-1, 1, n)
        rank = _rank(numeric.jacobian(default))
    else:
        rank = _manifold_rank(numeric, found[0])
        # the default: the nearest q = 0 where the rows have their full rank on the manifold (a
        # singular configuration, such as a parallelogram folded flat, makes a poor default:
        # the coordinates there are only assembled to the square root of the tolerance)
        default = next((q for q in found if _regular(numeric.jacobian(q), rank)), found[0])
    k = len(rows)
    if rank >= n:
        raise InputError(Problem(robot.source, where[0], where[1], f"loops: the loop joints impose {rank} independent "
                                 f"constraints on {n} coordinates, which leaves no degree of freedom"))
    if rank < k:
        notes.append(f"{robot.source}:{where[0]}:{where[1]}: note: the {k} loop constraint rows have rank {rank} on "
                     f"the constraint manifold: the mechanism is over-constrained (mobility {n - rank}, where "
                     f"counting rows would give {n - k}); every row is kept, and the generated code solves with "
                     "their row space at each state")
    A = A.applyfunc(_tidy_entry)
    Adot = constraint_jacobian_dot(A, table.q, table.qd).applyfunc(_tidy_entry)
    independent = _independent(robot, numeric.jacobian(default), n, rank, notes)
    dependent = [i for i in range(n) if i not in independent]
    assembled = _exact_assembly(a, A, table, values, default, independent, dependent) if found else None
    multipliers = [sympy.Symbol(f"lambda_g{i}") for i in range(1, k + 1)]
    model = LoopModel(a, A, Adot, multipliers, [(r[0], r[1]) for r in rows], nonzero, rank,
                      independent, dependent, assembled, notes)
    if assembled is not None:   # the rows as lambdified above (same values as the defaults when complete)
        _singular_partition(robot, model, numeric, notes)
    return model


#: Entries of A_g and Adot_g up to this many nodes get the full ``tidy``; larger ones (3-D
#: loops written through every link's pose) the cheap expansion, which costs a fraction.
TIDY_NODES = 45


def _tidy_entry(expr: sympy.Expr) -> sympy.Expr:
    return tidy(expr) if is_small(expr, TIDY_NODES) else quick_tidy(expr)


def _exact_assembly(a: sympy.Matrix, A: sympy.Matrix, table: SymbolTable, values: dict[sympy.Symbol, float],
                    q: np.ndarray, independent: list[int], dependent: list[int]) -> list[float]:
    """The default assembly with the same bytes on every machine: the independent coordinates
    of the float solution rounded to ``ASSEMBLY_DECIMALS`` places, the dependent ones solved by
    Gauss-Newton over every row in 40-digit arithmetic (mpmath, the same on every platform)
    and rounded to doubles. Falls back to the float solution where that does not converge."""
    import mpmath

    parameters = sorted(values, key=str)
    arguments = [table.q, parameters]
    residual = sympy.lambdify(arguments, a, "mpmath")
    jacobian = sympy.lambdify(arguments, A.extract(list(range(A.shape[0])), dependent), "mpmath")
    with mpmath.workdps(40):
        point = [mpmath.mpf(float(x)) for x in q]
        for i in independent:
            point[i] = mpmath.mpf(round(float(q[i]), ASSEMBLY_DECIMALS))
        numbers = [mpmath.mpf(values[s]) for s in parameters]
        for _ in range(40):
            r = mpmath.matrix(residual(point, numbers))
            J = mpmath.matrix(jacobian(point, numbers))
            try:
                step = mpmath.lu_solve(J.T * J, J.T * r)
            except ZeroDivisionError:   # a singular dependent block: keep the float solution
                return [float(x) for x in q]
            for row, i in enumerate(dependent):
                point[i] -= step[row]
            if mpmath.norm(step) < mpmath.mpf(10) ** -34:
                break
        closed = mpmath.norm(mpmath.matrix(residual(point, numbers))) < mpmath.mpf(10) ** -30
    if not closed:
        return [float(x) for x in q]
    # an exact zero comes out of the iteration as a few units of 1e-40: write it as 0
    return [float(x) if abs(x) > 1e-30 else 0.0 for x in point]


def _independent(robot: Robot, J: np.ndarray, n: int, k: int, notes: list[str]) -> list[int]:
    """Indices of the independent coordinates: the file's, or chosen (actuated first, then
    the best-conditioned dependent block at the assembled configuration)."""
    names = list(robot.coordinates)
    if robot.independent is not None:
        chosen = [names.index(c) for c in robot.independent]
        line, column = robot.positions.get("independent", (1, 1))
        if len(chosen) != n - k:
            plural = "s" * (n - k != 1)
            raise InputError(Problem(robot.source, line, column, f"independent: the mechanism has {n - k} degree{plural} "
                                     f"of freedom ({n} coordinates, {k} independent loop constraint{'s' * (k != 1)}), so "
                                     f"{n - k} independent coordinate{plural} {'are' if plural else 'is'} needed, "
                                     f"got {len(chosen)}"))
        dependent = [i for i in range(n) if i not in chosen]
        if np.linalg.svd(J[:, dependent], compute_uv=False)[-1] < 1e-9 * max(1.0, float(np.max(np.abs(J)))):
            raise InputError(Problem(robot.source, line, column, "independent: with these independent coordinates "
                                     "the dependent ones are not determined at the default configuration (the "
                                     "dependent block of A_g is singular there)"))
        return sorted(chosen)
    actuated = {i for i, joint in enumerate(j for j in robot.joints if j.moves) if joint.effort}
    best: tuple[Any, ...] | None = None
    combos = itertools.combinations(range(n), k) if math.comb(n, k) <= 5000 else [tuple(range(n - k, n))]
    for dependent in combos:
        sigma = np.linalg.svd(J[:, list(dependent)], compute_uv=False)
        score = (len(actuated & set(dependent)), -sigma[-1] / max(sigma[0], 1e-300))
        if best is None or score < best[0]:
            best = (score, dependent)
    assert best is not None
    return [i for i in range(n) if i not in best[1]]


def _singular_partition(robot: Robot, model: LoopModel, numeric: _Numeric, notes: list[str]) -> None:
    """Note configurations (along the independent coordinates) where the dependent block is
    singular, or where the mechanism cannot be assembled: the reduced form breaks down there."""
    assert model.assembled is not None
    q = np.array(model.assembled)
    names = list(robot.coordinates)
    bad: list[str] = []
    rng = np.random.default_rng(15)
    if len(model.independent) == 1:
        points = [[q[model.independent[0]] + t] for t in np.linspace(-math.pi, math.pi, 73)[1:]]
    else:
        points = [list(q[model.independent] + rng.uniform(-1, 1, len(model.independent))) for _ in range(40)]
    current = q.copy()
    for values in points:
        guess = current.copy()
        guess[model.independent] = values
        solved = assemble(numeric, guess, fixed=model.independent, iterations=40)
        label = ", ".join(f"{names[i]} = {v:.3g}" for i, v in zip(model.independent, values))
        if solved is None:
            bad.append(f"{label} (not assembled)")
            continue
        current = solved
        block = numeric.jacobian(solved)[:, model.dependent]
        sigma = np.linalg.svd(block, compute_uv=False)
        if sigma[-1] < 1e-6 * max(sigma[0], 1.0):
            bad.append(label)
    if bad:
        where = robot.positions.get("loops", (1, 1))
        shown = "; ".join(bad[:4]) + (f"; and {len(bad) - 4} more" if len(bad) > 4 else "")
        notes.append(f"{robot.source}:{where[0]}:{where[1]}: note: with independent "
                     f"{', '.join(names[i] for i in model.independent)} the reduced form is singular or the "
                     f"loop does not close near {shown}")


def reduced_form(model: LoopModel, table: SymbolTable, M: sympy.Matrix, C: sympy.Matrix,
                 N: sympy.Matrix, Y: sympy.Matrix) -> dict[str, sympy.Matrix]:
    """``R_g`` and the reduced ``M_r, C_r, N_r, Y_r, EOM_r`` while they stay readable; empty
    otherwise (the generated code solves the multiplier form numerically)."""
    A = model.jacobian
    k = A.shape[0]
    if model.redundant or k > REDUCED_ROWS or not is_small(sympy.Tuple(*A), REDUCED_NODES * A.shape[0] * A.shape[1]):
        return {}
    A_d = A.extract(list(range(k)), model.dependent)
    A_i = A.extract(list(range(k)), model.independent)
    det = tidy(A_d.det(method="berkowitz"))
    if det == 0:
        return {}
    adjugate = matmul(A_d.adjugate(method="berkowitz"), A_i)
    qd_i = sympy.Matrix([table.qd[i] for i in model.independent])
    qdd_i = sympy.Matrix([table.qdd[i] for i in model.independent])
    fourier = factor_terms(trig_linear(det))
    if count_ops(fourier) <= count_ops(det):   # planar loops: det is one sine or cosine of an angle sum
        return _reduced_over_determinant(model, table, fourier, adjugate, (M, C, N, Y), (qd_i, qdd_i))
    m = len(model.independent)
    R = _stacked(model, len(table.q), sympy.S.One, adjugate.applyfunc(lambda e: tidy(-e / det)))
    Rdot = constraint_jacobian_dot(R, table.q, table.qd).applyfunc(tidy)
    M_r = matmul(R.T, M, R).applyfunc(tidy)
    if not is_small(sympy.Tuple(*M_r), 4000 * m * m):
        return {"R_g": R}
    # on the manifold qd = R qd_i: Rdot's qd are written through R as well
    on_manifold = dict(zip(table.qd, matmul(R, qd_i)))
    Rdot = Rdot.xreplace(on_manifold)
    C_r = matmul(R.T, matmul(M, Rdot) + matmul(C.xreplace(on_manifold), R)).applyfunc(tidy)
    N_r = matmul(R.T, N).applyfunc(tidy)
    Y_r = matmul(R.T, Y).applyfunc(tidy)
    EOM_r = (matmul(M_r, qdd_i) + matmul(C_r, qd_i) + N_r - Y_r).applyfunc(tidy)
    return {"R_g": R, "M_r": M_r, "C_r": C_r, "N_r": N_r, "Y_r": Y_r, "EOM_r": EOM_r}


def _stacked(model: LoopModel, n: int, identity: sympy.Expr, dependent: sympy.Matrix) -> sympy.Matrix:
    """The n x m velocity basis: ``identity`` times I on the independent coordinates' rows,
    ``dependent``'s rows on the dependent coordinates' (``R_g``, or ``det R_g``)."""
    R = sympy.zeros(n, len(model.independent))
    for column, i in enumerate(model.independent):
        R[i, column] = identity
    for row, d in enumerate(model.dependent):
        for column in range(R.shape[1]):
            R[d, column] = dependent[row, column]
    return R


def _reduced_over_determinant(model: LoopModel, table: SymbolTable, det: sympy.Expr, adjugate: sympy.Matrix,
                              generalized: tuple[sympy.Matrix, ...],
                              rates: tuple[sympy.Matrix, sympy.Matrix]) -> dict[str, sympy.Matrix]:
    """The reduced form as numerators over powers of ``det = det A_d``, each numerator in
    Fourier form (``trig_linear``): for planar loops ``det`` is one sine of an angle sum
    (``b c sin(q1 + q2 - q3)`` for the four-bar) and the numerators short sums of sines and
    cosines of angle sums, where the quotients expanded together are pages long.

    With ``R = R_n / det`` (``R_n``: ``det`` on the independent rows, ``-adj(A_d) A_i`` on the
    dependent ones) and, on the manifold, ``det qd = R_n qd_i``, the time derivatives are
    ``det Rdot_n = D(R_n)`` and ``det detdot = D(det)`` for ``D(x) = sum_k dx/dq_k (R_n qd_i)_k``,
    so ``M_r = R_n^T M R_n / det^2``, ``N_r = R_n^T N / det``, ``Y_r = R_n^T Y / det`` and
    ``C_r = R_n^T (M (D(R_n) det - R_n D(det)) + C(R_n qd_i) R_n det) / det^4`` (C is linear in qd).
    Common factors of symbols cancel against the determinant's (SymPy's products merge powers).
    """
    (M, C, N, Y), (qd_i, qdd_i) = generalized, rates
    R_n = _stacked(model, len(table.q), det, adjugate.applyfunc(lambda e: fewest_operations(tidy(-e), trig_linear)))
    velocity = matmul(R_n, qd_i)   # det * qd on the manifold

    def over(numerator: sympy.Expr, power: int) -> sympy.Expr:
        return factor_terms(trig_linear(numerator)) / det ** power

    R = R_n.applyfunc(lambda e: over(e, 1))
    M_r = matmul(R_n.T, M, R_n).applyfunc(lambda e: over(e, 2))
    D_R = constraint_jacobian_dot(R_n, table.q, velocity)
    D_det = constraint_jacobian_dot(sympy.Matrix([det]), table.q, velocity)[0]
    inner = matmul(M, D_R * det - R_n * D_det) + matmul(C.xreplace(dict(zip(table.qd, velocity))), R_n) * det
    C_r = matmul(R_n.T, inner).applyfunc(lambda e: over(e, 4))
    N_r = matmul(R_n.T, N).applyfunc(lambda e: over(e, 1))
    Y_r = matmul(R_n.T, Y).applyfunc(lambda e: over(e, 1))
    EOM_r = matmul(M_r, qdd_i) + matmul(C_r, qd_i) + N_r - Y_r
    return {"R_g": R, "M_r": M_r, "C_r": C_r, "N_r": N_r, "Y_r": Y_r, "EOM_r": EOM_r}
