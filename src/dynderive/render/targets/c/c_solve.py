"""Dense linear algebra printed as C for one robot's sizes: an ``L D L^T`` factorization
unrolled (with the sparsity the caller knows), its forward and back substitution, and the
row space of a loop Jacobian by one-sided Jacobi rotations (an SVD's left singular vectors).

Every local is named with a prefix the caller chooses, so that two factorizations can live in
one C function (the mass matrix ``m``, the loops' Schur complement ``s``); no local is named
like a function of ``<math.h>`` (``y0``, ``j1``, ``gamma``), which ``-Wshadow`` would refuse.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from ....model.array_program import HELD, Node, RowSpaceSolve, SchurSolve
from .c_program import Elements, c_name

#: A pivot of the loops' Schur complement below this fraction of its diagonal entry means the
#: loop rows are dependent beyond the rank the derivation found (a singular configuration).
RELATIVE_PIVOT = "1e-12"

#: Largest number of Jacobi sweeps (each rotates every pair of rows once); it converges
#: quadratically, in 5 to 10 sweeps for the loop Jacobians of mechanisms.
JACOBI_SWEEPS = 60

#: Singular values of a loop Jacobian found at run time (quaternions in q) below this fraction of
#: the largest are zero: rows left out of its solve (the NumPy module's LOOP_RANK_TOLERANCE).
LOOP_RANK_TOLERANCE = "1e-7"


def ldl_factor(entry: Callable[[int, int], str], n: int, nonzero: list[list[bool]], prefix: str,
               failure: str, relative: bool = False) -> list[str]:
    """``A = L D L^T`` unrolled, with ``entry(i, j)`` the C text of ``A_ij`` (lower triangle
    read): ``<prefix>d<j>`` and ``<prefix>L<i>_<j>``; ``failure`` (a statement) at a pivot
    that is not positive, or (``relative``) not above ``RELATIVE_PIVOT`` times ``A_jj``."""
    lines = []
    for j in range(n):
        terms = "".join(f" - {prefix}L{j}_{k}*{prefix}L{j}_{k}*{prefix}d{k}" for k in range(j) if nonzero[j][k])
        lines.append(f"const double {prefix}d{j} = {entry(j, j)}{terms};")
        bound = f"{RELATIVE_PIVOT}*{entry(j, j)}" if relative else "0.0"
        lines.append(f"if (!({prefix}d{j} > {bound})) {failure}")
        for i in range(j + 1, n):
            if nonzero[i][j]:
                terms = "".join(f" - {prefix}L{i}_{k}*{prefix}L{j}_{k}*{prefix}d{k}" for k in range(j)
                                if nonzero[i][k] and nonzero[j][k])
                lines.append(f"const double {prefix}L{i}_{j} = ({entry(i, j)}{terms}) / {prefix}d{j};")
    return lines


def ldl_solve(n: int, nonzero: list[list[bool]], prefix: str, rhs: list[str]) -> list[str]:
    """``<prefix>x<i>`` solving ``L D L^T x = rhs`` (C expressions) by ``<prefix>w<i>``."""
    lines = []
    for i in range(n):
        terms = "".join(f" - {prefix}L{i}_{k}*{prefix}w{k}" for k in range(i) if nonzero[i][k])
        lines.append(f"const double {prefix}w{i} = {rhs[i]}{terms};")
    for i in reversed(range(n)):
        terms = "".join(f" - {prefix}L{k}_{i}*{prefix}x{k}" for k in range(i + 1, n) if nonzero[k][i])
        lines.append(f"const double {prefix}x{i} = {prefix}w{i} / {prefix}d{i}{terms};")
    return lines


def schur_solve(step: SchurSolve, n: int, nonzero: list[list[bool]], rows: int, fresh: Iterator[int],
                count: str = "count", index: tuple[str, str] = ("a", "b")) -> list[str]:
    """The engine's ``SchurSolve`` over ``count`` stacked rows (capacity ``rows``): M is factored
    in reverse order, P M P = L D L^T unrolled for its sparsity (``nonzero``: L's pattern; P the
    reversal, the leaves first, so a tree's factor has no fill-in; ``return 1`` at a pivot not
    positive); Y = L^-1 P J^T and e = L^-1 P b by forward substitution; S = J M^-1 J^T = Y^T
    D^-1 Y by dense Cholesky loops (``return 2`` at a pivot not above 1e-12 of its diagonal
    entry: redundant contacts); the multipliers S^-1 (target - Y^T D^-1 e); x = P L^-T D^-1 (e +
    Y multipliers), one back substitution. ``index``: the names of S's row and column loops
    (none may be an array of the program)."""
    mass, jacobian, multipliers = c_name(step.mass), c_name(step.jacobian), c_name(step.multipliers)
    a, b = index
    elements = Elements(n, fresh)
    lines = ldl_factor(lambda i, j: f"{mass}[{(n - 1 - i) * n + n - 1 - j}]", n, nonzero, "m", "return 1;")
    lines += [f"double Y[{n * rows}], dinv[{n}], z[{n}];",
              *(f"dinv[{i}] = 1.0 / md{i};" for i in range(n)),
              f"for (int c = 0; c < {count}; ++c) {{",
              *(f"    {line}" for line in _forward(n, nonzero, "w", [f"{jacobian}[c * {n} + {n - 1 - i}]"
                                                                      for i in range(n)])),
              *(f"    Y[{i * rows} + c] = w{i};" for i in range(n)), "}"]
    if step.b is None:
        lines += [f"for (int i = 0; i < {n}; ++i) z[i] = 0.0;"]
    else:
        lines += [*_forward(n, nonzero, "e", [elements.element(step.b, n - 1 - i) for i in range(n)]),
                  *(f"z[{i}] = e{i};" for i in range(n))]
    target = elements.element(step.target, a)
    lines += [
        f"if ({count} > 0) {{   /* S = Y^T D^-1 Y, L L^T in place (lower triangle); the multipliers; z += Y lam */",
        f"    double S[{rows * rows}], lam[{rows}];",
        f"    for (int {a} = 0; {a} < {count}; ++{a}) {{",
        f"        for (int {b} = 0; {b} <= {a}; ++{b}) {{",
        "            double sum = 0.0;",
        f"            for (int i = 0; i < {n}; ++i) sum += Y[i * {rows} + {a}]*dinv[i]*Y[i * {rows} + {b}];",
        f"            S[{a} * {rows} + {b}] = sum;",
        "        }",
        f"        lam[{a}] = {target};",
        *([] if step.b is None else [f"        for (int i = 0; i < {n}; ++i) lam[{a}] -= Y[i * {rows} + {a}]*dinv[i]*z[i];"]),
        "    }",
        f"    for (int j = 0; j < {count}; ++j) {{",
        f"        double pivot = S[j * {rows} + j];",
        f"        for (int k = 0; k < j; ++k) pivot -= S[j * {rows} + k]*S[j * {rows} + k];",
        f"        if (!(pivot > {RELATIVE_PIVOT}*S[j * {rows} + j])) return 2;",
        f"        S[j * {rows} + j] = sqrt(pivot);",
        f"        for (int i = j + 1; i < {count}; ++i) {{",
        f"            double sum = S[i * {rows} + j];",
        f"            for (int k = 0; k < j; ++k) sum -= S[i * {rows} + k]*S[j * {rows} + k];",
        f"            S[i * {rows} + j] = sum / S[j * {rows} + j];",
        "        }",
        "    }",
        f"    for (int i = 0; i < {count}; ++i) {{",
        f"        for (int k = 0; k < i; ++k) lam[i] -= S[i * {rows} + k]*lam[k];",
        f"        lam[i] /= S[i * {rows} + i];",
        "    }",
        f"    for (int i = {count} - 1; i >= 0; --i) {{",
        f"        for (int k = i + 1; k < {count}; ++k) lam[i] -= S[k * {rows} + i]*lam[k];",
        f"        lam[i] /= S[i * {rows} + i];",
        "    }",
        f"    for (int i = 0; i < {n}; ++i) {{",
        f"        for (int c = 0; c < {count}; ++c) z[i] += Y[i * {rows} + c]*lam[c];",
        "    }",
        f"    for (int c = 0; c < {count}; ++c) {multipliers}[c] = lam[c];",
        "}",
        *_back(n, nonzero, "x", "z"),
        *(f"{c_name(step.x)}[{n - 1 - i}] = x{i};" for i in range(n)),
    ]
    return [*elements.lines, *lines] if elements.lines else lines


def stacked_row_space_solve(step: RowSpaceSolve, n: int, nonzero: list[list[bool]], rows: int, loops: int,
                            fresh: Iterator[int]) -> list[str]:
    """The engine's ``RowSpaceSolve`` of a robot with closed loops holding contacts: the loops'
    ``loops`` rows over the contacts' ``count`` (``nr`` rows at run time, capacity ``rows``).
    Rows of full rank (the loops' rank known and equal to their rows): ``schur_solve`` of them
    all. Otherwise their row space (``row_space_lines``, capacity ``rows``): the loops' known
    rank plus the contacts' rows (taken as independent), or (rank None) the directions whose
    singular value is above LOOP_RANK_TOLERANCE of the largest, found at this state; the target
    projected onto them (``U_r^T``), the Schur solve of the ``nk`` rows kept, and the multipliers
    of least norm ``U_r lambda_r`` (the NumPy module's ``_row_space_solve``)."""
    lines = [f"const int nr = {loops} + count;"]
    if step.rank == loops:
        return lines + schur_solve(step, n, nonzero, rows, fresh, count="nr", index=("ra", "rb"))
    known = step.rank is not None
    lines += row_space_lines("nr", n, f"{step.rank} + count" if known else "nr", c_name(step.jacobian), "Jr", "Ur",
                             "return 2;", capacity=rows)
    if known:
        lines.append(f"const int nk = {step.rank} + count;")
    else:   # the rows come in order of their norms (singular values): those kept are the first
        lines += ["int nk = 0;", "double top_ = 0.0;",
                  "for (int m = 0; m < nr; ++m) {", "    double norm = 0.0;",
                  f"    for (int c = 0; c < {n}; ++c) norm += Jr[m * {n} + c]*Jr[m * {n} + c];",
                  "    norm = sqrt(norm);", "    if (m == 0) top_ = norm;",
                  f"    if (norm > {LOOP_RANK_TOLERANCE}*top_) nk = m + 1;", "}"]
    target = Elements(n, fresh).element(step.target, "i")
    lines += [f"double tr[{rows}], lr[{rows}];",
              "for (int m = 0; m < nk; ++m) {   /* U_r^T target */", "    tr[m] = 0.0;",
              f"    for (int i = 0; i < nr; ++i) tr[m] += Ur[i * {rows} + m]*{target};", "}"]
    reduced = SchurSolve(step.x, "lr", step.mass, "Jr", step.b, Node("name", ("tr",), (HELD,)))
    lines += schur_solve(reduced, n, nonzero, rows, fresh, count="nk", index=("ra", "rb"))
    return lines + ["for (int i = 0; i < nr; ++i) {   /* the multipliers of least norm, U_r lambda_r */",
                    f"    {c_name(step.multipliers)}[i] = 0.0;",
                    f"    for (int m = 0; m < nk; ++m) {c_name(step.multipliers)}[i] += Ur[i * {rows} + m]*lr[m];",
                    "}"]


def _forward(n: int, nonzero: list[list[bool]], name: str, rhs: list[str]) -> list[str]:
    """``<name><i>`` solving ``L w = rhs`` (L the unit lower factor ``mL``, forward substitution)."""
    return [f"const double {name}{i} = {rhs[i]}" + "".join(f" - mL{i}_{k}*{name}{k}" for k in range(i) if nonzero[i][k])
            + ";" for i in range(n)]


def _back(n: int, nonzero: list[list[bool]], name: str, rhs: str) -> list[str]:
    """``<name><i>`` solving ``D L^T x = rhs[]`` (back substitution)."""
    return [f"const double {name}{i} = {rhs}[{i}] / md{i}" + "".join(f" - mL{k}_{i}*{name}{k}" for k in range(i + 1, n)
                                                                   if nonzero[k][i]) + ";" for i in reversed(range(n))]


def fill_in(mass: list[list[bool]], n: int) -> list[list[bool]]:
    """Which entries of L can be nonzero: those of M, and the fill-in (L_ij where L_ik and
    L_jk are for some k < j)."""
    nonzero = [[mass[i][j] for j in range(n)] for i in range(n)]
    for j in range(n):
        for i in range(j + 1, n):
            nonzero[i][j] = nonzero[i][j] or any(nonzero[i][k] and nonzero[j][k] for k in range(j))
    return nonzero


def dense(n: int) -> list[list[bool]]:
    """The pattern of a full matrix."""
    return [[True] * n for _ in range(n)]


def row_space_lines(k: int | str, n: int, rank: int | str, jacobian: str, rows: str, space: str, failure: str,
                    capacity: int | None = None) -> list[str]:
    """The ``rank`` largest directions of the row space of the ``k x n`` matrix ``jacobian``
    (a local array), as the NumPy module's ``_row_space`` takes them from an SVD: declares
    ``space`` (``U_r``, ``k x rank``) and ``rows`` (``U_r^T A``, ``rank x n``), row-major.
    ``k`` and ``rank`` may be C expressions known at run time (the loops' rows and the contacts'
    held), their arrays then sized and strided by ``capacity`` rows.

    One-sided Jacobi: rotations of pairs of rows of ``G = A`` until they are orthogonal
    (``G = U^T A = S V^T``, ``U`` accumulated), then the ``rank`` rows of largest norm."""
    cap = k if capacity is None else capacity
    stride = rank if capacity is None else capacity
    assert isinstance(cap, int) and isinstance(stride, int)
    last = k - 1 if isinstance(k, int) else f"{k} - 1"
    count = k * n if isinstance(k, int) else f"{k} * {n}"
    return [
        f"double G_[{cap * n}], U_[{cap * cap}], norm_[{cap}];",
        f"int taken_[{cap}] = {{0}};",
        f"double {rows}[{stride * n}], {space}[{cap * stride}];",
        f"for (int i = 0; i < {count}; ++i) G_[i] = {jacobian}[i];",
        f"for (int i = 0; i < {cap * cap}; ++i) U_[i] = (i % {cap + 1} == 0) ? 1.0 : 0.0;",
        f"for (int sweep = 0; sweep < {JACOBI_SWEEPS}; ++sweep) {{",
        "    int rotated = 0;",
        f"    for (int i = 0; i < {last}; ++i) {{",
        f"        for (int j = i + 1; j < {k}; ++j) {{",
        "            double gii = 0.0, gjj = 0.0, gij = 0.0;",
        f"            for (int c = 0; c < {n}; ++c) {{",
        f"                gii += G_[i * {n} + c]*G_[i * {n} + c];",
        f"                gjj += G_[j * {n} + c]*G_[j * {n} + c];",
        f"                gij += G_[i * {n} + c]*G_[j * {n} + c];",
        "            }",
        "            if (gij != 0.0 && fabs(gij) > 2.220446049250313e-16*sqrt(gii*gjj)) {",
        "                const double zeta = (gjj - gii) / (2.0*gij);",
        "                const double t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta*zeta));",
        "                const double cs = 1.0 / sqrt(1.0 + t*t);",
        "                const double sn = cs*t;",
        f"                for (int c = 0; c < {n}; ++c) {{",
        f"                    const double gi = G_[i * {n} + c], gj = G_[j * {n} + c];",
        f"                    G_[i * {n} + c] = cs*gi - sn*gj;",
        f"                    G_[j * {n} + c] = sn*gi + cs*gj;",
        "                }",
        f"                for (int c = 0; c < {k}; ++c) {{",
        f"                    const double ui = U_[c * {cap} + i], uj = U_[c * {cap} + j];",
        f"                    U_[c * {cap} + i] = cs*ui - sn*uj;",
        f"                    U_[c * {cap} + j] = sn*ui + cs*uj;",
        "                }",
        "                rotated = 1;",
        "            }",
        "        }",
        "    }",
        "    if (!rotated) break;",
        "}",
        f"for (int i = 0; i < {k}; ++i) {{",
        "    norm_[i] = 0.0;",
        f"    for (int c = 0; c < {n}; ++c) norm_[i] += G_[i * {n} + c]*G_[i * {n} + c];",
        "}",
        f"for (int m = 0; m < {rank}; ++m) {{   /* the rows of largest norm (singular value), in order */",
        "    int best = -1;",
        f"    for (int i = 0; i < {k}; ++i) {{",
        "        if (!taken_[i] && (best < 0 || norm_[i] > norm_[best])) best = i;",
        "    }",
        f"    if (best < 0) {failure}",
        "    taken_[best] = 1;",
        f"    for (int c = 0; c < {n}; ++c) {rows}[m * {n} + c] = G_[best * {n} + c];",
        f"    for (int i = 0; i < {k}; ++i) {space}[i * {stride} + m] = U_[i * {cap} + best];",
        "}",
    ]


def gauss_lines(size: int, matrix: str, rhs: str, columns: int, failure: str) -> list[str]:
    """``rhs`` (a local ``size x columns`` array) overwritten by ``matrix^-1 rhs`` (``matrix`` a
    local ``size x size`` array, destroyed): Gaussian elimination with partial pivoting, as
    LAPACK's ``gesv`` behind ``numpy.linalg.solve``; ``failure`` at a zero pivot (singular)."""
    s, c = size, columns
    return [
        f"for (int j = 0; j < {s}; ++j) {{",
        "    int pivot = j;",
        f"    for (int i = j + 1; i < {s}; ++i) {{",
        f"        if (fabs({matrix}[i * {s} + j]) > fabs({matrix}[pivot * {s} + j])) pivot = i;",
        "    }",
        f"    if (!(fabs({matrix}[pivot * {s} + j]) > 0.0)) {failure}",
        "    if (pivot != j) {",
        f"        for (int c = 0; c < {s}; ++c) {{",
        f"            const double swap = {matrix}[j * {s} + c];",
        f"            {matrix}[j * {s} + c] = {matrix}[pivot * {s} + c];",
        f"            {matrix}[pivot * {s} + c] = swap;",
        "        }",
        f"        for (int c = 0; c < {c}; ++c) {{",
        f"            const double swap = {rhs}[j * {c} + c];",
        f"            {rhs}[j * {c} + c] = {rhs}[pivot * {c} + c];",
        f"            {rhs}[pivot * {c} + c] = swap;",
        "        }",
        "    }",
        f"    for (int i = j + 1; i < {s}; ++i) {{",
        f"        const double factor = {matrix}[i * {s} + j] / {matrix}[j * {s} + j];",
        f"        for (int c = j; c < {s}; ++c) {matrix}[i * {s} + c] -= factor*{matrix}[j * {s} + c];",
        f"        for (int c = 0; c < {c}; ++c) {rhs}[i * {c} + c] -= factor*{rhs}[j * {c} + c];",
        "    }",
        "}",
        f"for (int j = {s - 1}; j >= 0; --j) {{",
        f"    for (int c = 0; c < {c}; ++c) {{",
        f"        double sum = {rhs}[j * {c} + c];",
        f"        for (int i = j + 1; i < {s}; ++i) sum -= {matrix}[j * {s} + i]*{rhs}[i * {c} + c];",
        f"        {rhs}[j * {c} + c] = sum / {matrix}[j * {s} + j];",
        "    }",
        "}",
    ]
