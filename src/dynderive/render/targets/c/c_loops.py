"""The C target's closed loops and external wrenches (``solve --c``).

Closed loops: ``loop_constraints``, ``loop_jacobian``, ``loop_jacobian_dot`` (the NumPy
module's expressions, printed), and ``forward_dynamics``, ``forward_dynamics_wrenches`` and
``loop_forces`` solving the NumPy module's constrained system

    [M  -A^T] [qdd   ]   [Y - C qd - N (- F + sum J^T w)     ]
    [A    0 ] [lambda] = [-Adot qd - 2 alpha A qd - beta^2 a ]

by its Schur complement: M = L D L^T unrolled (the open tree's M, positive definite), then
``X = M^-1 [rhs, A^T]``, ``S = A M^-1 A^T`` (L D L^T again), ``lambda = S^-1 (bottom - A X_0)``,
``qdd = X_0 + M^-1 A^T lambda``. Over-constrained loops (the rows of A have rank r < NC on the
constraints) use, as the NumPy module does, the r largest directions U_r of A's row space at
the state (``c_solve.row_space_lines``: one-sided Jacobi rotations, an SVD's left singular
vectors) and the multipliers of least norm ``lambda = U_r lambda_r``. The Baumgarte gains
``alpha`` and ``beta`` are members of the parameters struct of a loop robot (after
``friction_smoothing``, default 0), as ``friction_smoothing`` is. Returns 0; 1 if M is not
positive definite; 2 if ``S`` is singular (a pivot not above 1e-12 of its diagonal entry: the
loop rows are dependent beyond the rank at this configuration); outputs untouched unless 0.
``linearize`` of a loop robot solves the same system for its columns (the NumPy module's).
``reduced_basis`` and ``reduced_forward_dynamics`` solve the dependent block by Gaussian
elimination with partial pivoting (``numpy.linalg.solve``'s); ``assemble`` is the NumPy
module's Newton iteration (1 where it raises).

External wrenches (every robot, floating-base ones included, NV = their velocity size): ``inverse_dynamics_wrenches`` and
``forward_dynamics_wrenches`` take ``wrenches``, NFRAMES x 6 (planar x 3) row-major, one per
frame in FRAMES order, entering as ``sum_f J_f^T w_f`` (the NumPy module's
``_external_forces``); NULL means none. A robot without frames takes NULL (nothing is read).

This module knows nothing of ``c.py``: what it needs of it comes in a ``CKit``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from itertools import count
from math import prod
from typing import Any

from ....derivation import Derivation
from ....model.array_program import Call, Let, RowSpaceSolve
from ...codegen.constrained import BAUMGARTE, loop_sizes
from ...codegen.names import c_comment
from ...encode import Code
from .c_program import assignment, c_name, call_line, flat_index
from .c_solve import LOOP_RANK_TOLERANCE, dense, gauss_lines, ldl_factor, ldl_solve, row_space_lines


@dataclass
class CKit:
    """What the loop and wrench functions need of the C target (``c.py`` builds it)."""

    start: str                                    # the line that sets P (p or the defaults)
    pp: str                                       # the parameters argument's declaration
    function: Callable[[str, str, list[str]], Any]   # CFunction(prototype, comment, body)
    expressions: Callable[..., list[str]]         # (values, targets, extra names) -> C lines
    program: Callable[..., list[str]]             # (program, targets, extra names) -> C lines
    mass_pattern: list[list[bool]]                # entries of L that can be nonzero (M's, fill-in)
    friction_slope: Callable[[], list[str]]       # ``R[...] -= dF/dqd`` lines of linearize


def _sizes(derivation: Derivation) -> tuple[int, int, int]:
    """(NV, NC, the rank the solve takes): a robot with quaternions in q (its loops rows on the
    tree's twists) finds the rank at each state, so its solve sizes are NC."""
    n, k, rank = loop_sizes(derivation)
    return n, k, k if rank is None else rank


def loop_context(derivation: Derivation) -> dict[str, Any]:
    """The header's loop count and the struct members a loop robot adds (alpha, beta)."""
    if not derivation.robot.loops:
        return {"nc": 0, "members": []}
    return {"nc": _sizes(derivation)[1], "members": [
        {"name": name, "default": Code(default), "comment": c_comment(comment)} for name, default, comment in BAUMGARTE]}


def _block(printer: Callable[..., list[str]], *arguments: Any) -> list[str]:
    """The lines of one printed expression or program inside ``{ }``: their temporaries
    ``t0, t1, ...`` are local to it (a function prints several)."""
    return ["{", *("    " + line for line in printer(*arguments)), "}"]


def function_name(function: Any) -> str:
    """``<robot>_<function>`` of a CFunction's prototype."""
    return str(function.prototype).split("(")[0].split()[-1]


def amend(derivation: Derivation, kit: CKit, functions: list[Any]) -> list[Any]:
    """``functions`` with the wrench variants after inverse and forward dynamics, and for a loop
    robot its forward dynamics and linearize replaced by the constrained ones and the loop
    functions added."""
    name, loops = derivation.robot.name, bool(derivation.robot.loops)
    tangent = loops and derivation.robot.floating   # quaternions in q: the loops' rows on the tree's twists
    result = []
    for function in functions:
        which = function_name(function)[len(name) + 1:]
        if loops and which == "forward_dynamics":
            function = kit.function(
                f"int {name}_forward_dynamics(const double *q, const double *qd, const double *u, {kit.pp}, "
                "double *qdd)", "qdd of the closed-loop mechanism: forward_dynamics_wrenches with no wrench.",
                [f"return {name}_forward_dynamics_wrenches(q, qd, u, 0, p, qdd);"])
        elif loops and which == "linearize":
            function = _loop_linearize(derivation, kit)
        result.append(function)
        if which == "inverse_dynamics":
            result.append(_inverse_wrenches(derivation, kit))
        elif which == "forward_dynamics":
            result.append(_loop_forward(derivation, kit) if loops else _tree_forward_wrenches(derivation, kit))
    if loops:
        result += _tangent_loop_functions(derivation, kit) if tangent else _loop_functions(derivation, kit)
    return result


def _inverse_wrenches(derivation: Derivation, kit: CKit) -> Any:
    name, n = derivation.robot.name, len(derivation.symbols.qd)
    frames, twist = len(derivation.robot.frames), 3 if derivation.robot.planar else 6
    body = [f"{name}_inverse_dynamics(q, qd, qdd, p, tau);"]
    if frames:
        body += ["if (wrenches) {", f"    double J[{twist * n}];",
                 f"    for (int f = 0; f < {frames}; ++f) {{",
                 f"        (void){name}_frame_jacobian(q, f, p, J);",
                 f"        for (int j = 0; j < {n}; ++j) {{",
                 f"            for (int i = 0; i < {twist}; ++i) tau[j] -= J[i * {n} + j]*wrenches[f * {twist} + i];",
                 "        }", "    }", "}"]
    else:
        body.append("(void)wrenches;   /* no frames: no wrench */")
    return kit.function(
        f"void {name}_inverse_dynamics_wrenches(const double *q, const double *qd, const double *qdd, "
        f"const double *wrenches, {kit.pp}, double *tau)",
        f"inverse_dynamics - sum_f J_f^T w_f: wrenches NFRAMES x {twist} row-major, "
        f"{'(fx, fy, n)' if twist == 3 else '(fx, fy, fz, nx, ny, nz)'} per frame in world axes (moment about the "
        "frame's origin), or NULL for none.", body)


def _applied(derivation: Derivation, kit: CKit, target: str, wrenches: str) -> list[str]:
    """``target = Y_g(u) - (C qd + N + F - sum J^T w)`` and M (``M``), as locals."""
    name, n = derivation.robot.name, len(derivation.symbols.qd)
    lines = [kit.start, "(void)P;", "(void)u;", f"double M[{n * n}];", f"double b[{n}];", f"double {target}[{n}];",
             f"const double zero[{n}] = {{0.0}};", f"{name}_mass_matrix(q, p, M);",
             f"{name}_inverse_dynamics_wrenches(q, qd, zero, {wrenches}, p, b);   /* C qd + N + F - sum J^T w */"]
    if len(derivation.symbols.q) != n:   # quaternions: each effort at its velocity column (no symbolic Y_g)
        columns = dict(zip(derivation.robot.effort_columns(), range(len(derivation.robot.efforts))))
        lines += [f"{target}[{i}] = {f'u[{columns[i]}]' if i in columns else '0.0'};" for i in range(n)]
    else:
        lines += _block(kit.expressions, list(derivation.quantities["Y_g"]), [f"{target}[{i}]" for i in range(n)])
    return lines + [f"{target}[{i}] -= b[{i}];" for i in range(n)]


def _tree_forward_wrenches(derivation: Derivation, kit: CKit) -> Any:
    name, n = derivation.robot.name, len(derivation.symbols.qd)
    prototype = (f"int {name}_forward_dynamics_wrenches(const double *q, const double *qd, const double *u, "
                 f"const double *wrenches, {kit.pp}, double *qdd)")
    comment = ("forward_dynamics with wrenches (as inverse_dynamics_wrenches; NULL: none): M qdd = Y_g(u) - C qd "
               "- N - F + sum_f J_f^T w_f; returns 0, or 1 (qdd untouched) if M is not positive definite.")
    if not derivation.robot.frames:
        return kit.function(prototype, comment, ["(void)wrenches;   /* no frames: no wrench */",
                                                 f"return {name}_forward_dynamics(q, qd, u, p, qdd);"])
    lines = [f"if (!wrenches) return {name}_forward_dynamics(q, qd, u, p, qdd);",
             *_applied(derivation, kit, "r", "wrenches")]
    lines += ldl_factor(lambda i, j: f"M[{i * n + j}]", n, kit.mass_pattern, "m", "return 1;")
    lines += ldl_solve(n, kit.mass_pattern, "m", [f"r[{i}]" for i in range(n)])
    return kit.function(prototype, comment, lines + [f"qdd[{i}] = mx{i};" for i in range(n)] + ["return 0;"])


def _constraint_rows(derivation: Derivation, bottom: str | None, columns: int,
                     jacobian: str = "Aj") -> tuple[list[str], str, str | None]:
    """Lines that give the rows the solve uses: the loop Jacobian ``Aj`` itself, or
    (over-constrained) ``Ar = U_r^T Aj`` with ``U_r`` (``Ur``) from the row space, and ``bottom``
    (NC x columns) projected to ``<bottom>_r``; returns (lines, rows array, bottom array)."""
    n, k, rank = _sizes(derivation)
    if derivation.robot.floating:
        return _rows_kept(n, k, bottom, jacobian, columns)
    if rank == k:
        return [], jacobian, bottom
    lines = row_space_lines(k, n, rank, jacobian, "Ar", "Ur", "return 2;")
    if bottom is None:
        return lines + ["(void)Ur;"], "Ar", None
    lines += [f"double {bottom}_r[{rank * columns}];",
              f"for (int m = 0; m < {rank}; ++m) {{", f"    for (int c = 0; c < {columns}; ++c) {{",
              "        double sum = 0.0;",
              f"        for (int i = 0; i < {k}; ++i) sum += Ur[i * {rank} + m]*{bottom}[i * {columns} + c];",
              f"        {bottom}_r[m * {columns} + c] = sum;", "    }", "}"]
    return lines, "Ar", f"{bottom}_r"


def _schur(derivation: Derivation, kit: CKit, rows: str, mass: str = "M") -> list[str]:
    """M = L D L^T (``return 1`` if not positive definite), ``W = M^-1 rows^T`` and
    ``S = rows W`` = L D L^T (``return 2`` if singular)."""
    n, _, r = _sizes(derivation)
    lines = ldl_factor(lambda i, j: f"{mass}[{i * n + j}]", n, kit.mass_pattern, "m", "return 1;")
    lines += [f"double W[{n * r}];   /* M^-1 rows^T */", f"for (int j = 0; j < {r}; ++j) {{"]
    lines += ["    " + line for line in ldl_solve(n, kit.mass_pattern, "m", [f"{rows}[j * {n} + {i}]" for i in range(n)])]
    lines += [f"    W[{i} * {r} + j] = mx{i};" for i in range(n)] + ["}"]
    lines += [f"double S[{r * r}];", f"for (int i = 0; i < {r}; ++i) {{", "    for (int j = 0; j <= i; ++j) {",
              "        double sum = 0.0;", f"        for (int c = 0; c < {n}; ++c) sum += {rows}[i * {n} + c]*W[c * {r} + j];",
              f"        S[i * {r} + j] = sum;", "    }", "}"]
    if derivation.robot.floating:   # the rows left out: S's diagonal 1, their multipliers 0
        lines += [f"for (int m = 0; m < {r}; ++m) {{", f"    if (!kept_[m]) S[m * {r} + m] = 1.0;", "}"]
    return lines + ldl_factor(lambda i, j: f"S[{i * r + j}]", r, dense(r), "s", "return 2;", relative=True)


def _schur_column(derivation: Derivation, kit: CKit, top: str, rows: str, bottom: str, columns: int,
                  column: str) -> list[str]:
    """For the column ``column`` of the right-hand side [top; bottom] (n x columns, rank x
    columns): ``a<i>`` and ``sx<m>`` solving ``M a - rows^T s = top, rows a = bottom``."""
    n, _, r = _sizes(derivation)
    lines = ldl_solve(n, kit.mass_pattern, "m", [f"{top}[{i * columns} + {column}]" for i in range(n)])
    lines += [f"const double g{m} = {bottom}[{m * columns} + {column}]"
              + "".join(f" - {rows}[{m * n + i}]*mx{i}" for i in range(n)) + ";" for m in range(r)]
    lines += ldl_solve(r, dense(r), "s", [f"g{m}" for m in range(r)])
    return lines + [f"const double a{i} = mx{i}" + "".join(f" + W[{i * r + m}]*sx{m}" for m in range(r)) + ";"
                    for i in range(n)]


def _multipliers(derivation: Derivation, target: str) -> list[str]:
    n, k, r = _sizes(derivation)
    if r == k and not derivation.robot.floating:
        return [f"{target}[{i}] = sx{i};" for i in range(k)]
    return [f"{target}[{i}] = " + " + ".join(f"Ur[{i * r + m}]*sx{m}" for m in range(r)) + ";" for i in range(k)]


def _loop_solve(derivation: Derivation, kit: CKit, wrenches: str, baumgarte: bool,
                qdd: str | None, multipliers: str | None) -> list[str]:
    """The engine's loop solve (``Derivation.loop_solve``) at one state, its calls and values
    printed as the contact programs' (``c_program.py``) and its ``RowSpaceSolve`` by the shim
    below; stores qdd and lambda in the arrays named. ``baumgarte``: the gains from the struct
    (else 0, as loop_forces and linearize take them)."""
    program, name = derivation.loop_solve, derivation.robot.name
    n = len(derivation.symbols.qd)
    fresh = count()
    gains = ("P->alpha", "P->beta") if baumgarte else ("0.0", "0.0")
    lines = [kit.start, "(void)P;", "(void)u;",
             f"const double zeros[{max(n, len(derivation.symbols.efforts))}] = {{0.0}};",
             f"const double alpha = {gains[0]}, beta = {gains[1]};"]
    for step in program.steps:
        if isinstance(step, Call):
            lines.append(f"double {c_name(step.output)}[{prod(step.shape)}];")
            if step.function == "inverse_dynamics":
                lines.append(f"{name}_inverse_dynamics_wrenches(q, qd, zeros, {wrenches}, p, {c_name(step.output)});")
            else:
                lines += call_line(derivation, step, n)
        elif isinstance(step, Let):
            target, columns = c_name(step.name), step.value.shape[1] if len(step.value.shape) == 2 else None
            lines += [f"double {target}[{prod(step.value.shape)}];",
                      *assignment(lambda i, j, t=target, c=columns: f"{t}[{flat_index(i, c, j)}]", step.value, n, fresh)]
        else:
            lines += _row_space_solve(derivation, kit, step, fresh, qdd, multipliers)
    return lines


def _row_space_solve(derivation: Derivation, kit: CKit, step: RowSpaceSolve, fresh: Iterator[int],
                     qdd: str | None, multipliers: str | None) -> list[str]:
    """The shim of ``RowSpaceSolve``: ``f`` = b and ``e`` = target, the rows in the row space
    (``_constraint_rows``), M and the Schur complement factored, one column solved."""
    n, k, _ = _sizes(derivation)
    lines = [f"double f[{n}];", *assignment(lambda i, j: f"f[{i}]", step.b, n, fresh),
             f"double e[{k}];", *assignment(lambda i, j: f"e[{i}]", step.target, n, fresh)]
    rows_lines, rows, bottom = _constraint_rows(derivation, "e", 1, c_name(step.jacobian))
    lines += rows_lines + _schur(derivation, kit, rows, c_name(step.mass))
    lines += _schur_column(derivation, kit, "f", rows, bottom, 1, "0")
    lines += [f"{qdd}[{i}] = a{i};" for i in range(n)] if qdd else [f"(void)a{i};" for i in range(n)]
    return lines + (_multipliers(derivation, multipliers) if multipliers else [])


def _loop_forward(derivation: Derivation, kit: CKit) -> Any:
    name = derivation.robot.name
    return kit.function(
        f"int {name}_forward_dynamics_wrenches(const double *q, const double *qd, const double *u, "
        f"const double *wrenches, {kit.pp}, double *qdd)",
        "qdd of the closed-loop mechanism: [M -A^T; A 0] [qdd; lambda] = [Y - C qd - N - F + sum J^T w; -Adot qd "
        "- 2 alpha A qd - beta^2 a(q)] (alpha, beta: struct members); wrenches as inverse_dynamics_wrenches (NULL: "
        "none); returns 0, 1 if M is not positive definite, 2 if the loop rows are singular (qdd untouched).",
        _loop_solve(derivation, kit, "wrenches", True, "qdd", None) + ["return 0;"])


def _loop_functions(derivation: Derivation, kit: CKit) -> list[Any]:
    name, quantities = derivation.robot.name, derivation.quantities
    n, k, r = _sizes(derivation)
    rows = (f" The {k} rows have rank {r} on the constraints (over-constrained): the multipliers of least norm."
            if r < k else "")
    return [
        kit.function(f"void {name}_loop_constraints(const double *q, {kit.pp}, double *a)",
                     f"Loop constraints a_g(q), {k} entries (zero when the loops are closed).",
                     [kit.start, "(void)q;", "(void)P;",
                      *_block(kit.expressions, list(quantities["a_g"]), [f"a[{i}]" for i in range(k)])]),
        kit.function(f"void {name}_loop_jacobian(const double *q, {kit.pp}, double *A)",
                     f"Loop constraint Jacobian A_g(q) = da_g/dq, {k} x {n}, row-major.",
                     [kit.start, "(void)q;", "(void)P;",
                      *_block(kit.expressions, list(quantities["A_g"]), [f"A[{i}]" for i in range(k * n)])]),
        kit.function(f"void {name}_loop_jacobian_dot(const double *q, const double *qd, {kit.pp}, double *Adot)",
                     f"Its time derivative Adot_g(q, qd), {k} x {n}, row-major.",
                     [kit.start, "(void)q;", "(void)qd;", "(void)P;",
                      *_block(kit.expressions, list(quantities["Adot_g"]), [f"Adot[{i}]" for i in range(k * n)])]),
        kit.function(f"int {name}_loop_forces(const double *q, const double *qd, const double *u, {kit.pp}, "
                     "double *lambda)",
                     f"Loop multipliers lambda_g, {k} entries: A_g^T lambda_g is the generalized force of the loop "
                     f"joints (forward_dynamics' system with alpha = beta = 0, no wrench).{rows} Returns as "
                     "forward_dynamics (lambda untouched unless 0).",
                     [f"return {name}_loop_forces_wrenches(q, qd, u, 0, p, lambda);"]),
        kit.function(f"int {name}_loop_forces_wrenches(const double *q, const double *qd, const double *u, "
                     f"const double *wrenches, {kit.pp}, double *lambda)",
                     "loop_forces with wrenches as inverse_dynamics_wrenches (NULL: none).",
                     _loop_solve(derivation, kit, "wrenches", False, None, "lambda") + ["return 0;"]),
        *_reduced_functions(derivation, kit),
    ]


def _partition(derivation: Derivation, rows: str, extra: str | None) -> list[str]:
    """``Dd`` (the dependent columns of ``rows``, r x r) and ``Di`` (its independent columns,
    and the column ``extra`` when given: r x (m + 1)), then ``Di = Dd^-1 Di`` (``return 2``
    when Dd is singular, as ``numpy.linalg.solve`` raises)."""
    loops = derivation.loop_model
    n, _, r = _sizes(derivation)
    m = len(loops.independent)
    width = m + (1 if extra else 0)
    lines = [f"double Dd[{r * r}];", f"double Di[{r * width}];"]
    for a in range(r):
        lines += [f"Dd[{a * r + b}] = {rows}[{a * n + j}];" for b, j in enumerate(loops.dependent)]
        lines += [f"Di[{a * width + b}] = {rows}[{a * n + j}];" for b, j in enumerate(loops.independent)]
        if extra:
            lines.append(f"Di[{a * width + m}] = {extra}[{a}];")
    return lines + gauss_lines(r, "Dd", "Di", width, "return 2;")


def _basis(derivation: Derivation, target: str, width: int) -> list[str]:
    """``target`` (n x m) = R_g: the identity on the independent rows, -Dd^-1 Di on the others."""
    loops = derivation.loop_model
    m = len(loops.independent)
    lines = []
    for b, i in enumerate(loops.independent):
        lines += [f"{target}[{i * m + c}] = {1.0 if b == c else 0.0};" for c in range(m)]
    for a, i in enumerate(loops.dependent):
        lines += [f"{target}[{i * m + c}] = -Di[{a * width + c}];" for c in range(m)]
    return lines


def _reduced_functions(derivation: Derivation, kit: CKit) -> list[Any]:
    """reduced_basis, reduced_forward_dynamics and assemble, as the NumPy module's."""
    name, loops = derivation.robot.name, derivation.loop_model
    n, k, r = _sizes(derivation)
    m, independent = len(loops.independent), ", ".join(derivation.robot.coordinates[i] for i in loops.independent)
    jacobian = [f"double Aj[{k * n}];", f"{name}_loop_jacobian(q, p, Aj);"]
    rows_lines, rows, _ = _constraint_rows(derivation, None, 1)
    basis = [kit.start, "(void)P;", *jacobian, *rows_lines, *_partition(derivation, rows, None),
             *_basis(derivation, "R", m), "return 0;"]
    drift = [f"double Ad[{k * n}];", f"double e[{k}];", f"{name}_loop_jacobian_dot(q, qd, p, Ad);",
             *(f"e[{i}] = " + " + ".join(f"Ad[{i * n + j}]*qd[{j}]" for j in range(n)) + ";" for i in range(k))]
    rows_lines, rows, bottom = _constraint_rows(derivation, "e", 1)
    reduced = [*_applied(derivation, kit, "f", "0"), *jacobian, *drift, *rows_lines,
               *_partition(derivation, rows, bottom), f"double Rb[{n * m}];", f"double sh[{n}];",
               *_basis(derivation, "Rb", m + 1), *(f"sh[{i}] = 0.0;" for i in loops.independent),
               *(f"sh[{i}] = -Di[{a * (m + 1) + m}];" for a, i in enumerate(loops.dependent)),
               *(f"f[{i}] -= " + " + ".join(f"M[{i * n + j}]*sh[{j}]" for j in range(n)) + ";" for i in range(n)),
               f"double Mr[{m * m}];", f"double g[{m}];",
               f"for (int r1 = 0; r1 < {m}; ++r1) {{", "    g[r1] = 0.0;",
               f"    for (int i = 0; i < {n}; ++i) g[r1] += Rb[i * {m} + r1]*f[i];",
               f"    for (int r2 = 0; r2 < {m}; ++r2) {{", "        double sum = 0.0;",
               f"        for (int i = 0; i < {n}; ++i) {{",
               f"            for (int j = 0; j < {n}; ++j) sum += Rb[i * {m} + r1]*M[i * {n} + j]*Rb[j * {m} + r2];",
               "        }", f"        Mr[r1 * {m} + r2] = sum;", "    }", "}",
               *ldl_factor(lambda i, j: f"Mr[{i * m + j}]", m, dense(m), "r", "return 1;"),
               *ldl_solve(m, dense(m), "r", [f"g[{c}]" for c in range(m)]),
               *(f"qdd[{i}] = " + "".join(f"Rb[{i * m + c}]*rx{c} + " for c in range(m)) + f"sh[{i}];"
                 for i in range(n)), "return 0;"]
    dependent = loops.dependent
    d = len(dependent)
    assemble = [f"double x[{n}];", f"double a[{k}];", f"double Aj[{k * n}];",
                f"for (int i = 0; i < {n}; ++i) x[i] = q_guess[i];",
                "for (int iteration = 0; iteration < 100; ++iteration) {   /* Newton, steps limited to 0.5 */",
                "    int closed = 1;", f"    {name}_loop_constraints(x, p, a);",
                f"    for (int i = 0; i < {k}; ++i) closed = closed && fabs(a[i]) < 1e-12;",
                "    if (closed) {", f"        for (int i = 0; i < {n}; ++i) q[i] = x[i];", "        return 0;", "    }",
                f"    {name}_loop_jacobian(x, p, Aj);", f"    double Nm[{d * d}];", f"    double h[{d}];",
                "    double trace = 0.0;"]
    for a, i in enumerate(dependent):
        assemble.append(f"    h[{a}] = " + " + ".join(f"Aj[{row * n + i}]*a[{row}]" for row in range(k)) + ";")
        for b, j in enumerate(dependent):
            assemble.append(f"    Nm[{a * d + b}] = " + " + ".join(f"Aj[{row * n + i}]*Aj[{row * n + j}]"
                                                                for row in range(k)) + ";")
        assemble.append(f"    trace += Nm[{a * d + a}];")
    assemble += [f"    Nm[{a * d + a}] += 1e-14*(1.0 + trace);" for a in range(d)]
    assemble += ["    " + line for line in ldl_factor(lambda i, j: f"Nm[{i * d + j}]", d, dense(d), "n", "return 1;")]
    assemble += ["    " + line for line in ldl_solve(d, dense(d), "n", [f"h[{a}]" for a in range(d)])]
    assemble += ["    double size = 0.0;", *(f"    size = fmax(size, fabs(nx{a}));" for a in range(d)),
                 "    const double scale = fmin(1.0, 0.5 / fmax(size, 1e-300));",
                 *(f"    x[{i}] -= nx{a}*scale;" for a, i in enumerate(dependent)), "}",
                 f"{name}_loop_constraints(x, p, a);",
                 f"for (int i = 0; i < {k}; ++i) {{", "    if (!(fabs(a[i]) < 1e-9)) return 1;", "}",
                 f"for (int i = 0; i < {n}; ++i) q[i] = x[i];", "return 0;"]
    return [
        kit.function(f"int {name}_reduced_basis(const double *q, {kit.pp}, double *R)",
                     f"R_g(q), {n} x {m}, row-major: the motions the loops allow, qd = R_g qd_i with qd_i the "
                     f"velocities of {independent}; returns 0, or 2 (R untouched) where the dependent block of A_g "
                     "is singular.", basis),
        kit.function(f"int {name}_reduced_forward_dynamics(const double *q, const double *qd, const double *u, "
                     f"{kit.pp}, double *qdd)",
                     "qdd by the reduced form R_g^T M R_g qdd_i = R_g^T (Y - C qd - N - F - M s), qdd = R_g qdd_i + s "
                     "(no multipliers; forward_dynamics with alpha = beta = 0 on the constraints); returns 0, 1 if "
                     "R_g^T M R_g is not positive definite, 2 as reduced_basis (qdd untouched).", reduced),
        kit.function(f"int {name}_assemble(const double *q_guess, {kit.pp}, double *q)",
                     f"The configuration on a_g(q) = 0 nearest q_guess by Newton's method (at most 100 steps, each "
                     f"at most 0.5), keeping {independent}; returns 0, or 1 (q untouched) where it does not "
                     "converge (the NumPy module raises ValueError).", assemble),
    ]


def _loop_linearize(derivation: Derivation, kit: CKit) -> Any:
    """The NumPy module's linearize of a loop robot: [M -A^T; A 0] [dqdd/dx; dlambda/dx] =
    [dY/dx - dtau/dx + d(A^T lambda)/dx; -d(A qdd + Adot qd)/dx] at the state's qdd and lambda
    (one constrained solve with alpha = beta = 0 and no wrench, in a block of its own)."""
    table = derivation.symbols
    n, k, r = _sizes(derivation)
    nu = len(table.efforts)
    width = 2 * n + nu
    lines = [f"double qdd[{n}];", f"double lambda[{k}];", "{",
             *("    " + line for line in _loop_solve(derivation, kit, "0", False, "qdd", "lambda")), "}",
             kit.start, "(void)P;", f"double D[{2 * n * n}];", f"double R[{n * width}];", f"double E[{k * width}];"]
    extra = {s: f"qdd[{i}]" for i, s in enumerate(table.qdd)}
    lines += _block(kit.program, derivation.programs["inverse_dynamics_derivatives"], [f"D[{i}]" for i in range(2 * n * n)],
                         extra)
    lines += [f"for (int i = 0; i < {n}; ++i) {{",
              f"    for (int c = 0; c < {2 * n}; ++c) R[i * {width} + c] = -D[(c / {n}) * {n * n} + i * {n} + c % {n}];",
              "}"]
    lines += kit.friction_slope()
    if nu:
        lines += _block(kit.expressions, list(derivation.effort_jacobian), [f"R[{i * width + 2 * n + c}]" for i in range(n) for c in range(nu)])
    name = derivation.robot.name
    force_at = [f"K[{i}]" for i in range(n * n)]
    acceleration_at = [f"E[{i * width + j}]" for i in range(k) for j in range(n)]
    if derivation.robot.floating:   # the loops' terms on the tangent space: the engine's programs
        terms = derivation.loop_linearization_programs
        multipliers = {s: f"lambda[{i}]" for i, s in enumerate(terms.multipliers)}
        force = _block(kit.program, terms.force, force_at, multipliers)
        acceleration = _block(kit.program, terms.acceleration, acceleration_at, extra)
        rate = [f"double Ad[{k * n}];", *_block(kit.program, terms.rate, [f"Ad[{i}]" for i in range(k * n)])]
        stored = [f"E[{i * width + n + j}] = -Ad[{i * n + j}];" for i in range(k) for j in range(n)]
    else:   # d(Adot qd)/dqd = 2 Adot: A_g is a Hessian's rows
        force_terms, acceleration_terms = derivation.loop_linearization
        multipliers = {s: f"lambda[{i}]" for i, s in enumerate(table.loop_multipliers)}
        force = _block(kit.expressions, list(force_terms), force_at, multipliers)
        acceleration = _block(kit.expressions, list(acceleration_terms), acceleration_at, extra)
        rate = [f"double Ad[{k * n}];", f"{name}_loop_jacobian_dot(q, qd, p, Ad);"]
        stored = [f"E[{i * width + n + j}] = -2.0*Ad[{i * n + j}];" for i in range(k) for j in range(n)]
    lines += [f"double K[{n * n}];", *force, *(f"R[{i * width + j}] += K[{i * n + j}];" for i in range(n) for j in range(n))]
    lines += [*rate, f"for (int i = 0; i < {k * width}; ++i) E[i] = 0.0;", *acceleration,
              *(f"E[{i * width + j}] = -E[{i * width + j}];" for i in range(k) for j in range(n)), *stored,
              f"double M[{n * n}];", f"double Aj[{k * n}];", f"{name}_mass_matrix(q, p, M);",
              f"{name}_loop_jacobian(q, p, Aj);"]
    rows_lines, rows, bottom = _constraint_rows(derivation, "E", width)
    lines += rows_lines + _schur(derivation, kit, rows)
    lines += [f"for (int i = 0; i < {4 * n * n}; ++i) A[i] = 0.0;", *(f"A[{i * 2 * n + n + i}] = 1.0;" for i in range(n)),
              *([f"for (int i = 0; i < {2 * n * nu}; ++i) B[i] = 0.0;"] if nu else ["(void)B;"]),
              f"for (int c = 0; c < {width}; ++c) {{"]
    lines += ["    " + line for line in _schur_column(derivation, kit, "R", rows, bottom, width, "c")]
    lines += [f"    if (c < {2 * n}) {{", *(f"        A[{(n + i) * 2 * n} + c] = a{i};" for i in range(n))]
    if nu:
        lines += ["    } else {", *(f"        B[{(n + i) * nu} + c - {2 * n}] = a{i};" for i in range(n))]
    lines += ["    }", "}", "return 0;"]
    return kit.function(
        f"int {name}_linearize(const double *q, const double *qd, const double *u, {kit.pp}, double *A, double *B)",
        f"(A, B) of xdot = A dx + B du about x = (q, qd) and u: A {2 * n} x {2 * n}, B {2 * n} x {nu}, row-major; the "
        "constrained solve [M -A_g^T; A_g 0] [dqdd/dx; dlambda/dx] = [dY/dx - dtau/dx + d(A_g^T lambda)/dx; "
        "-d(A_g qdd + Adot_g qd)/dx] at the state's qdd and lambda (alpha = beta = 0 and no wrench, as the NumPy "
        "module); returns 0, or 1 or 2 as forward_dynamics (A, B untouched).", lines)


def _rows_kept(n: int, k: int, bottom: str | None, jacobian: str = "Aj",
               columns: int = 1) -> tuple[list[str], str, str | None]:
    """A floating-base robot's rows in the row space of ``Aj`` at this state (the NumPy module's):
    ``Ar = U^T Aj`` and ``Ur`` from the one-sided Jacobi SVD, the rows whose singular value is
    above LOOP_RANK_TOLERANCE of the largest kept (``kept_``), the others zeroed; ``bottom``
    (NC x ``columns``) projected to ``<bottom>_r`` (zero on the rows left out)."""
    lines = row_space_lines(k, n, k, jacobian, "Ar", "Ur", "return 2;")
    lines += [f"int kept_[{k}];", "double top_ = 0.0;",
              f"for (int m = 0; m < {k}; ++m) {{", "    double norm = 0.0;",
              f"    for (int c = 0; c < {n}; ++c) norm += Ar[m * {n} + c]*Ar[m * {n} + c];",
              "    norm = sqrt(norm);", "    if (m == 0) top_ = norm;",
              f"    kept_[m] = norm > {LOOP_RANK_TOLERANCE}*top_;",
              f"    if (!kept_[m]) for (int c = 0; c < {n}; ++c) Ar[m * {n} + c] = 0.0;", "}"]
    if bottom is None:
        return lines + ["(void)Ur;"], "Ar", None
    lines += [f"double {bottom}_r[{k * columns}];", f"for (int m = 0; m < {k}; ++m) {{",
              f"    for (int c = 0; c < {columns}; ++c) {{", "        double sum = 0.0;",
              f"        for (int i = 0; i < {k}; ++i) sum += Ur[i * {k} + m]*{bottom}[i * {columns} + c];",
              f"        {bottom}_r[m * {columns} + c] = kept_[m] ? sum : 0.0;", "    }", "}"]
    return lines, "Ar", f"{bottom}_r"


def _tangent_loop_functions(derivation: Derivation, kit: CKit) -> list[Any]:
    """A robot with quaternions in q: its loops' rows (``Derivation.loop_programs``) printed,
    ``loop_forces`` as the fixed base's, and ``assemble``: Gauss-Newton steps of least norm on the
    tangent space, ``q <- integrate(q, -A^T (A A^T)^-1 a)`` (damped, each at most 0.5), as the
    NumPy module's."""
    name, programs = derivation.robot.name, derivation.loop_programs
    n, k, _ = _sizes(derivation)
    nq = len(derivation.symbols.q)
    assemble = [f"double x[{nq}];", f"double y[{nq}];", f"double a[{k}];", f"double Aj[{k * n}];",
                f"double step[{n}];",
                f"for (int i = 0; i < {nq}; ++i) x[i] = q_guess[i];",
                "for (int iteration = 0; iteration < 100; ++iteration) {   /* Gauss-Newton, steps limited to 0.5 */",
                "    int closed = 1;", f"    {name}_loop_constraints(x, p, a);",
                f"    for (int i = 0; i < {k}; ++i) closed = closed && fabs(a[i]) < 1e-12;",
                "    if (closed) {", f"        for (int i = 0; i < {nq}; ++i) q[i] = x[i];", "        return 0;", "    }",
                f"    {name}_loop_jacobian(x, p, Aj);", f"    double Nm[{k * k}];", "    double trace = 0.0;",
                f"    for (int i = 0; i < {k}; ++i) {{", f"        for (int j = 0; j < {k}; ++j) {{",
                "            double sum = 0.0;",
                f"            for (int c = 0; c < {n}; ++c) sum += Aj[i * {n} + c]*Aj[j * {n} + c];",
                f"            Nm[i * {k} + j] = sum;", "        }", f"        trace += Nm[i * {k} + i];", "    }",
                f"    for (int i = 0; i < {k}; ++i) Nm[i * {k} + i] += 1e-14*(1.0 + trace);"]
    assemble += ["    " + line for line in ldl_factor(lambda i, j: f"Nm[{i * k + j}]", k, dense(k), "n", "return 1;")]
    assemble += ["    " + line for line in ldl_solve(k, dense(k), "n", [f"a[{i}]" for i in range(k)])]
    assemble += ["    double size = 0.0;",
                 *(f"    step[{c}] = -(" + " + ".join(f"Aj[{i * n + c}]*nx{i}" for i in range(k)) + ");"
                   for c in range(n)),
                 f"    for (int c = 0; c < {n}; ++c) size = fmax(size, fabs(step[c]));",
                 "    const double scale = fmin(1.0, 0.5 / fmax(size, 1e-300));",
                 f"    for (int c = 0; c < {n}; ++c) step[c] *= scale;",
                 f"    {name}_integrate(x, step, 1.0, y);",
                 f"    for (int i = 0; i < {nq}; ++i) x[i] = y[i];", "}",
                 f"{name}_loop_constraints(x, p, a);",
                 f"for (int i = 0; i < {k}; ++i) {{", "    if (!(fabs(a[i]) < 1e-9)) return 1;", "}",
                 f"for (int i = 0; i < {nq}; ++i) q[i] = x[i];", "return 0;"]
    return [
        kit.function(f"void {name}_loop_constraints(const double *q, {kit.pp}, double *a)",
                     f"Loop constraints a(q), {k} entries (zero when the loops are closed): per loop joint the gap "
                     "between its frames' origins in world axes, and the alignment rows of revolute and prismatic ones.",
                     [kit.start, "(void)q;", "(void)P;",
                      *_block(kit.program, programs.constraints, [f"a[{i}]" for i in range(k)])]),
        kit.function(f"void {name}_loop_jacobian(const double *q, {kit.pp}, double *A)",
                     f"Loop Jacobian A(q), {k} x {n}, row-major: the rate of loop_constraints is A qd (the loop "
                     "frames' Jacobians differenced).",
                     [kit.start, "(void)q;", "(void)P;",
                      *_block(kit.program, programs.jacobian, [f"A[{i}]" for i in range(k * n)])]),
        kit.function(f"void {name}_loop_jacobian_dot_qd(const double *q, const double *qd, {kit.pp}, double *a)",
                     f"Adot qd, {k} entries: the loop rows' acceleration at qdd = 0.",
                     [kit.start, "(void)q;", "(void)qd;", "(void)P;",
                      *_block(kit.program, programs.jacobian_dot_qd, [f"a[{i}]" for i in range(k)])]),
        kit.function(f"int {name}_loop_forces(const double *q, const double *qd, const double *u, {kit.pp}, "
                     "double *lambda)",
                     f"Loop multipliers lambda, {k} entries: A^T lambda is the generalized force of the loop joints "
                     "(forward_dynamics' system with alpha = beta = 0, no wrench); rows implied by the others at this "
                     "state take the multipliers of least norm. Returns as forward_dynamics (lambda untouched unless 0).",
                     [f"return {name}_loop_forces_wrenches(q, qd, u, 0, p, lambda);"]),
        kit.function(f"int {name}_loop_forces_wrenches(const double *q, const double *qd, const double *u, "
                     f"const double *wrenches, {kit.pp}, double *lambda)",
                     "loop_forces with wrenches as inverse_dynamics_wrenches (NULL: none).",
                     _loop_solve(derivation, kit, "wrenches", False, None, "lambda") + ["return 0;"]),
        kit.function(f"int {name}_assemble(const double *q_guess, {kit.pp}, double *q)",
                     f"A configuration on a(q) = 0 near q_guess ({nq} entries): at most 100 Gauss-Newton steps of "
                     "least norm on the tangent space, q <- integrate(q, -A^T (A A^T)^-1 a), each at most 0.5; returns "
                     "0, or 1 (q untouched) where it does not converge (the NumPy module raises ValueError).", assemble),
    ]
