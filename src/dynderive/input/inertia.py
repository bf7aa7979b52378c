"""Physical checks of 3-D inertias (about the centre of mass), shared by the robot-file
validator and the URDF reader, with a tolerance for rounding.

A symmetric inertia with principal moments ``a <= b <= c`` is physical when ``a >= 0`` and
``a + b >= c`` (the other two triangle inequalities follow). Files exported from CAD or
copied by hand miss this by rounding; Pinocchio loads them as they are, Drake swaps in a
sphere with a warning. Here (README, "3-D robots and URDF"):

- the *violation* is ``max(0, -a, c - max(a, 0) - max(b, 0))``; the inertia's *size* is the
  sum of its absolute principal moments (its trace when it is physical); the robot's *scale* is the
  largest size among its links' inertias;
- a violation within ``SILENT`` times the largest absolute moment, or 1e-12 kg m^2 if that is
  more, is the arithmetic's rounding: accepted as written, without a note (the check's only
  tolerance before the rounding tolerance came);
- within the *tolerance* ``max(ROUNDING * size, FLOOR * scale)`` it is accepted with a
  ``note:`` and corrected (only raised, never lowered, so ``M(q)`` stays positive definite
  and grows by at most the correction): negative moments are raised to 0, then the two
  smaller moments are raised by half of ``c - a - b`` each, about the same principal axes;
- beyond the tolerance it is refused, with the violation and the tolerance in the message,
  except a triangle violation in a URDF file (``impossible``): the tensor is still positive
  semi-definite, so it is kept as written with a note, as Pinocchio reads it (allegro's
  fingers, romeo's shoulders miss by 1 to 80 %); a robot file's own numbers stay strict;
- a link welded to the world (by fixed joints only) never enters the dynamics: whatever is
  wrong with its inertia is a note, never an error.

``ROUNDING`` covers values printed with six significant digits (the default of C++ streams
and ``printf("%g")``, which many exporters use): each moment is then off by up to 5e-6 of
itself, so a body on the triangle's edge (a flat plate) misses it by up to 5e-6 of its
trace. ``FLOOR`` lets a tiny placeholder inertia (``1e-6`` kg m^2 on a contact frame) miss
by its own size, which is a millionth of the robot's and below anything the dynamics show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import sympy

from ..model.robot import Joint, Link

#: Violations up to this fraction of the largest moment (or 1 kg m^2) are arithmetic rounding (silent).
SILENT = 1e-12
#: Violations up to this fraction of the inertia's own size are rounding (noted, corrected).
ROUNDING = 1e-5
#: ... or up to this fraction of the robot's scale (its largest inertia size).
FLOOR = 1e-6


@dataclass(frozen=True)
class Verdict:
    """What to do with one inertia: refuse it (``error``), or note (``note``) and use
    ``tensor`` (the corrected tensor, or the given one when nothing is corrected)."""

    error: str | None
    note: str | None
    tensor: np.ndarray
    impossible: bool = False   # a triangle violation beyond the tolerance, kept as written


def moments(tensor: np.ndarray) -> np.ndarray | None:
    """Principal moments in ascending order, or None when they are not finite."""
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvalsh(tensor)
    return eig if bool(np.all(np.isfinite(eig))) else None


def size(tensor: np.ndarray) -> float:
    """The sum of the absolute principal moments (0 when they are not finite)."""
    eig = moments(tensor)
    return 0.0 if eig is None else float(np.sum(np.abs(eig)))


def tolerance(tensor: np.ndarray, scale: float) -> float:
    """The rounding tolerance of an inertia in a robot of the given scale."""
    return max(ROUNDING * size(tensor), FLOOR * scale)


#: Principal moments come from an eigensolver whose last bits differ between CPUs and BLAS
#: builds (a few ``eps`` of the largest moment); digits below this fraction of the largest
#: moment are not printed, so a note reads the same on any machine.
SHOWN = 1e-12


def _num(x: float, top: float) -> str:
    """``x`` with six significant digits at most, none below ``SHOWN * top`` (the rounding
    of the eigensolver on a tensor whose largest moment is ``top``): 0 when ``x`` is smaller."""
    quantum = SHOWN * top
    if not math.isfinite(x) or quantum <= 0:
        return f"{x:g}"
    if abs(x) <= quantum:
        return "0"
    digits = min(6, max(1, math.floor(math.log10(abs(x))) - math.floor(math.log10(quantum))))
    return f"{x:.{digits}g}"


def _g(values: np.ndarray | list[float], top: float) -> str:
    return ", ".join(_num(float(x), top) for x in values)


def judge(tensor: np.ndarray, scale: float, welded: bool, correct: bool = True, impossible: bool = False) -> Verdict:
    """The verdict on a symmetric 3 x 3 inertia; ``welded``: the link is welded to the world;
    ``correct``: a violation within the tolerance is corrected (else kept, with a note);
    ``impossible``: a triangle violation beyond the tolerance is kept as written, with a note
    (URDF files, as Pinocchio reads them: the tensor is still positive semi-definite, so M(q)
    stays positive definite); moments negative beyond the tolerance are still refused.

    Messages come without the link's label (callers prefix ``link 'x' inertia: ``).
    """
    eig = moments(tensor)
    if eig is None:
        problem = "inertia is too large"
        return Verdict(None if welded else problem, _ignored(problem) if welded else None, tensor)
    a, b, c = (float(x) for x in eig)
    gap = c - max(a, 0.0) - max(b, 0.0)
    violation = max(0.0, -a, gap)
    top = float(np.max(np.abs(eig)))
    silent = SILENT * max(1.0, top)
    if violation <= silent:
        return Verdict(None, None, tensor)
    if a < -silent:
        problem, amount = f"inertia is not positive semi-definite (smallest principal moment {_num(a, top)}", ")"
    else:
        problem, amount = f"principal moments {_g(eig, top)} violate the triangle inequality", f" by {_num(gap, top)}"
    if welded:
        return Verdict(None, _ignored(problem + amount.rstrip()), tensor)
    tol = tolerance(tensor, scale)
    if impossible and gap > tol and -a <= tol:
        return _impossible(tensor, eig, gap, tol, silent)
    if violation > tol:
        ending = f"; rounding tolerance {tol:g})" if amount == ")" else f"{amount} (rounding tolerance {tol:g})"
        return Verdict(problem + ending, None, tensor)
    if not correct:
        return Verdict(None, f"{problem}{amount}, within the rounding tolerance {tol:g}: kept as written "
                       "(its entries depend on parameters)", tensor)
    raised = np.maximum(eig, 0.0)
    if raised[2] > raised[0] + raised[1]:
        raised[:2] += (raised[2] - raised[0] - raised[1]) / 2
    corrected = _rebuilt(tensor, raised)
    note = (f"{problem}{amount}, within the rounding tolerance {tol:g}: corrected, principal moments "
            f"raised by {_g(raised - eig, top)}")
    return Verdict(None, note, corrected)


def _impossible(tensor: np.ndarray, eig: np.ndarray, gap: float, tol: float, silent: float) -> Verdict:
    """A triangle violation beyond the tolerance, kept as written (negative moments within the
    tolerance still raised to 0, so the tensor stays positive semi-definite)."""
    top = float(np.max(np.abs(eig)))
    note = (f"principal moments {_g(eig, top)} violate the triangle inequality by {_num(gap, top)}, beyond the rounding "
            f"tolerance {tol:g}: physically impossible, but kept as written (as Pinocchio does)")
    if eig[0] >= -silent:
        return Verdict(None, note, tensor, impossible=True)
    return Verdict(None, f"{note}; negative moments raised to 0", _rebuilt(tensor, np.maximum(eig, 0.0)), True)


def _rebuilt(tensor: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """The tensor with these principal moments about its own principal axes (symmetric)."""
    with np.errstate(all="ignore"):
        _, axes = np.linalg.eigh(tensor)
    rebuilt = axes @ np.diag(moments) @ axes.T
    return (rebuilt + rebuilt.T) / 2


def _ignored(problem: str) -> str:
    return f"{problem}; ignored: the link is welded to the world, so its inertia never enters the dynamics"


def asymmetry(upper: float, lower: float, tol: float, where: tuple[int, int]) -> tuple[str | None, str | None]:
    """(error, note) for a 3 x 3 inertia whose entries ``[r][c]`` (``upper``) and ``[c][r]``
    (``lower``) differ: within ``tol`` both are taken as their mean."""
    r, c = where
    gap = abs(upper - lower)
    if gap > tol or not math.isfinite(gap):
        return (f"not symmetric (entry [{c}][{r}] differs from [{r}][{c}] by {gap:g}; rounding "
                f"tolerance {tol:g})"), None
    return None, (f"entries [{r}][{c}] and [{c}][{r}] differ by {gap:g}, within the rounding tolerance "
                  f"{tol:g}: both taken as {(upper + lower) / 2!r}")


def inertia_entries(tensor: np.ndarray) -> tuple[float | int, ...]:
    """``(ixx, iyy, izz, ixy, ixz, iyz)`` of a computed tensor, entries below 1e-15 of the
    largest (rounding noise of the products that made them) written as 0."""
    values = [float(tensor[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    top = max(abs(x) for x in values)
    return tuple(0 if abs(x) <= 1e-15 * top else x for x in values)


@dataclass(frozen=True)
class Written:
    """A link's 3-D inertia as a robot file writes it, kept for the checks that need the
    whole robot (its scale, its welds): where it is, its tensor at the parameter defaults
    (None when some entry has no value), whether every entry is a constant (no parameter:
    then a correction may replace it), and the off-diagonal pairs of a 3 x 3 form that differ
    (``(r, c, entry [r][c], entry [c][r])``, the values of constants, else None), and the
    parameters its entries use (one with a negative default is reported at its value, once)."""

    path: tuple[Any, ...]
    tensor: np.ndarray | None
    constant: bool
    pairs: tuple[tuple[int, int, float | None, float | None], ...] = ()
    symbols: frozenset[sympy.Symbol] = frozenset()


def from_entries(ixx: Any, iyy: Any, izz: Any, ixy: Any, ixz: Any, iyz: Any) -> np.ndarray:
    """The symmetric 3 x 3 tensor of the six entries of an inertia."""
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


#: Position of the entry ``[r][c]`` (``r < c``) in ``(ixx, iyy, izz, ixy, ixz, iyz)``.
_FLAT = {(0, 1): 3, (0, 2): 4, (1, 2): 5}


def read(v: Any, value: Any, path: tuple[Any, ...], planar: bool,
         symbols: dict[str, sympy.Expr]) -> tuple[tuple[Any, ...], Written | None]:
    """A link's inertia entries as written (``v``: the validator), and for a 3-D link what
    ``check_links`` needs to judge them once the whole robot is read."""
    if planar:
        if isinstance(value, list):
            v.report(path, "a planar link takes one scalar inertia about the COM")
            return (0,), None
        expr = v.expression(value, path, symbols)
        number = v.numeric(expr)
        if number is not None and number < 0:
            v.negative_value(expr, path, number, "must not be negative")
        return (value,), None
    pairs = []
    if isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value):
        rows = value
        if any(len(r) != 3 for r in rows):
            v.report(path, "a 3x3 inertia needs three rows of three entries")
            return (0,) * 6, None
        flat = [rows[0][0], rows[1][1], rows[2][2], rows[0][1], rows[0][2], rows[1][2]]
        exprs = [v.expression(rows[r][c], path + (r, c), symbols) for r in range(3) for c in range(3)]
        for (r, c) in ((0, 1), (0, 2), (1, 2)):
            a, b = exprs[3 * r + c], exprs[3 * c + r]
            if a is not None and b is not None and sympy.expand(a - b) != 0:
                pairs.append((r, c, None if a.free_symbols else v.numeric(a),
                              None if b.free_symbols else v.numeric(b)))
        used = [exprs[0], exprs[4], exprs[8], exprs[1], exprs[2], exprs[5]]
    else:
        entries = v.vector(value, path, (6,), symbols)
        if entries is None:
            return (0,) * 6, None
        flat, used = list(value), entries
    values = [v.numeric(e) for e in used]
    tensor = from_entries(*values) if all(x is not None for x in values) else None
    constant = all(e is not None and not e.free_symbols for e in used)
    symbols = frozenset().union(*(e.free_symbols for e in used if e is not None))
    return tuple(flat), Written(path, tensor, constant, tuple(pairs), symbols)


def check_links(v: Any, links: list[Link], joints: list[Joint], written: list[Written | None]) -> list[Link]:
    """The robot file's links with their inertias judged (``v``: the validator, for errors
    and positions): refused beyond the tolerance, corrected within it when every entry is a
    number (a note says so), kept as written when some entry is an expression."""
    moved = moved_links({j.child: (j.parent, j.moves) for j in joints})
    scale = max((size(w.tensor) for w in written if w is not None and w.tensor is not None), default=0.0)
    result = []
    for link, w in zip(links, written):
        if w is None or w.path[:2] in v.doc.impossible_inertias:   # judged by the URDF reader
            result.append(link)
            continue
        label, welded = v.label(w.path), link.name not in moved
        entries, tensor = list(link.inertia), w.tensor
        for r, c, upper, lower in w.pairs:
            where = w.path + (c, r)
            if welded:
                v.note(where, _ignored(f"{label}: not symmetric (entry [{c}][{r}] differs from [{r}][{c}])"))
            elif tensor is None or upper is None or lower is None:
                v.error(where, f"{label}: not symmetric (entry [{c}][{r}] differs from [{r}][{c}])")
            else:
                mean = (upper + lower) / 2
                tensor = tensor.copy()
                tensor[r, c] = tensor[c, r] = mean
                error, note = asymmetry(upper, lower, tolerance(tensor, scale), (r, c))
                if error is not None:
                    v.error(where, f"{label}: {error}")
                    tensor = None
                else:
                    v.note(where, f"{label}: {note}")
                    entries[_FLAT[(r, c)]] = mean
        if tensor is not None and w.symbols & v.negative_defaults:
            tensor = None   # a parameter's negative default, reported at the parameter
        if tensor is not None:
            verdict = judge(tensor, scale, welded, correct=w.constant)
            if verdict.error is not None:
                v.report(w.path, verdict.error)
            if verdict.note is not None:
                v.note(w.path, f"{label}: {verdict.note}")
            if verdict.tensor is not tensor:
                entries = list(inertia_entries(verdict.tensor))
        result.append(replace(link, inertia=tuple(entries)))
    return result


def moved_links(parents: dict[str, tuple[str, bool]]) -> set[str]:
    """Links below a moving joint (``parents``: each link's parent link and whether the joint
    between them moves); the others are welded to the world (to the root, in a valid tree).
    Linear time; lenient with a broken tree, which is reported on its own."""
    moved: dict[str, bool] = {}
    for name in parents:
        chain: list[str] = []
        current, answer = name, None
        while answer is None:
            if current in moved:
                answer = moved[current]
            elif current not in parents or current in chain:  # a root, or a cycle
                answer = False
            else:
                chain.append(current)
                current, moves = parents[current]
                if moves:
                    answer = True
        moved.update(dict.fromkeys(chain, answer))
    return {name for name, yes in moved.items() if yes}
