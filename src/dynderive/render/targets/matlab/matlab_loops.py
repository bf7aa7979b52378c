"""The MATLAB/Octave target's closed loops: ``loop_constraints``, ``loop_jacobian``,
``loop_jacobian_dot`` (the NumPy module's expressions, printed), and ``forward_dynamics``,
``loop_forces`` and ``linearize`` solving the NumPy module's constrained system

    [M  -A^T] [qdd   ]   [Y - C qd - N - F                     ]
    [A    0 ] [lambda] = [-Adot qd - 2 alpha A qd - beta^2 a(q)]

with MATLAB's ``\\`` (``alpha`` and ``beta`` are fields of the parameters struct, default 0).
Over-constrained loops (the rows of A have rank r < NC on the constraints) use, as the NumPy
module does, the r left singular vectors U_r of A with the largest singular values and the
multipliers of least norm ``lambda = U_r lambda_r``.
"""

from __future__ import annotations

from typing import Any

from ....derivation import Derivation
from ...codegen.constrained import loop_sizes
from .matlab_print import (
    MFunction,
    Names,
    expression_body,
    help_line,
    linearize_rhs,
    matrix_targets,
    program_body,
    prologue,
    vector_targets,
)
from .matlab_program import statements


def _solve_function(derivation: Derivation) -> MFunction:
    """The local function ``loop_solve(q, qd, u, p, alpha, beta)`` -> [qdd, lam]: the engine's
    program (``Derivation.loop_solve``) printed."""
    return MFunction("loop_solve", "[qdd, lam]", ["q", "qd", "u", "p", "alpha", "beta"],
                     ["LOOP_SOLVE  The constrained system at one state (alpha, beta: Baumgarte gains)."],
                     statements(derivation.loop_solve.steps, derivation.robot.name, len(derivation.symbols.qd)))


#: Singular values of the loop Jacobian of a robot with quaternions in q below this fraction of
#: the largest are zero (the NumPy module's LOOP_RANK_TOLERANCE).
TOLERANCE = "1e-7"


def row_space_shim() -> MFunction:
    """The shim of the engine's ``RowSpaceSolve``."""
    return MFunction(
        "row_space_solve", "[x, lambda]", ["M", "Aj", "b", "target", "r"],
        ["ROW_SPACE_SOLVE  x and lambda with M x = b + Aj' lambda and Aj x = target in the row space of Aj: its",
         "   rows (r = their number), else U_r' Aj with U_r the r left singular vectors of Aj with the largest",
         f"   singular values (r [] : those above {TOLERANCE} of the largest, at this state); lambda = U_r lambda_r,",
         "   the multipliers of least norm; by the Schur complement."],
        ["Ur = eye(size(Aj, 1));", "if isempty(r) || r < size(Aj, 1)", "    [Ub, Sb, ~] = svd(Aj);",
         "    if isempty(r)", "        values = diag(Sb);", f"        r = sum(values > {TOLERANCE} * values(1));", "    end",
         "    Ur = Ub(:, 1:r);", "    Aj = Ur' * Aj;", "    target = Ur' * target;", "end",
         "free = M \\ b;", "MiJt = M \\ Aj';", "reduced = (Aj * MiJt) \\ (target - Aj * free);",
         "x = free + MiJt * reduced;", "lambda = Ur * reduced;"])


def loop_functions(derivation: Derivation, names: Names) -> list[MFunction]:
    """The loop functions, and the constrained forward dynamics and linearize (a robot with
    quaternions in q: its loops' rows on the tree's twists, linearize on the tangent space)."""
    quantities = derivation.quantities
    if derivation.robot.floating:
        return [*_tangent_rows(derivation, names), *_solved(derivation, len(derivation.loop_programs.rows), None),
                _linearize(derivation, names), _tangent_assemble(derivation)]
    n, k, r = loop_sizes(derivation)
    return [
        MFunction("loop_constraints", "a", ["q", "p"],
                  [help_line(derivation, "loop_constraints")],
                  [*prologue(derivation, ["q"], 2), f"a = zeros({k}, 1);",
                   *expression_body(names, list(quantities["a_g"]), vector_targets("a", k))]),
        MFunction("loop_jacobian", "A", ["q", "p"],
                  [help_line(derivation, "loop_jacobian")],
                  [*prologue(derivation, ["q"], 2), f"A = zeros({k}, {n});",
                   *expression_body(names, list(quantities["A_g"]), matrix_targets("A", k, n))]),
        MFunction("loop_jacobian_dot", "Adot", ["q", "qd", "p"],
                  [help_line(derivation, "loop_jacobian_dot")],
                  [*prologue(derivation, ["q", "qd"], 3), f"Adot = zeros({k}, {n});",
                   *expression_body(names, list(quantities["Adot_g"]), matrix_targets("Adot", k, n))]),
        *_solved(derivation, k, r),
        _linearize(derivation, names),
        *_reduced(derivation),
    ]


def _reduced(derivation: Derivation) -> list[MFunction]:
    """``reduced_basis``, ``reduced_forward_dynamics`` and ``assemble`` of a robot of vector-space
    joints, as the NumPy module's (its independent coordinates; over-constrained rows in their
    row space of the loops' rank; Newton's steps on the dependent coordinates, at most 0.5)."""
    model, name = derivation.loop_model, derivation.robot.name
    n, nu, m = len(derivation.symbols.q), len(derivation.symbols.efforts), len(model.independent)
    independent = "[" + " ".join(str(i + 1) for i in model.independent) + "]"
    dependent = "[" + " ".join(str(i + 1) for i in model.dependent) + "]"
    space = ["[Ub, ~, ~] = svd(Aj);", f"Ur = Ub(:, 1:{model.rank});", "Aj = Ur' * Aj;"] if model.redundant else []
    names = ", ".join(derivation.robot.coordinates[i] for i in model.independent)
    return [
        MFunction("reduced_basis", "R", ["q", "p"],
                  [help_line(derivation, "reduced_basis"), "",
                   f"   qd = R qd_i with qd_i the velocities of ({names}); R = P [I; -A_d^-1 A_i], A_g R = 0."],
                  [*prologue(derivation, ["q"], 2), f"Aj = {name}.loop_jacobian(q, p);", *space,
                   f"R = zeros({n}, {m});", f"R({independent}, :) = eye({m});",
                   f"R({dependent}, :) = -(Aj(:, {dependent}) \\ Aj(:, {independent}));"]),
        MFunction("reduced_forward_dynamics", "qdd", ["q", "qd", "u", "p"],
                  [help_line(derivation, "reduced_forward_dynamics"), "",
                   "   qdd = R qdd_i + s, s the dependent accelerations A_g qdd + Adot_g qd = 0 requires, and",
                   "   (R' M R) qdd_i = R' (Y - C qd - N - M s): equals forward_dynamics with alpha = beta = 0 on the",
                   "   constraints. u may be [] (no effort)."],
                  [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
                   f"Aj = {name}.loop_jacobian(q, p);", f"drift = {name}.loop_jacobian_dot(q, qd, p) * qd;",
                   *([*space, "drift = Ur' * drift;"] if model.redundant else []),
                   f"R = {name}.reduced_basis(q, p);", f"s = zeros({n}, 1);",
                   f"s({dependent}) = -(Aj(:, {dependent}) \\ drift);", f"M = {name}.mass_matrix(q, p);",
                   f"rhs = {name}.generalized_forces(q, u, p) - {name}.inverse_dynamics(q, qd, zeros({n}, 1), p) "
                   "- M * s;",
                   "qdd = R * ((R' * M * R) \\ (R' * rhs)) + s;"]),
        MFunction("assemble", "q", ["q_guess", "p"],
                  [help_line(derivation, "assemble"), "",
                   f"   Newton's steps on the dependent coordinates, keeping ({names}), each at most 0.5 in its",
                   "   largest entry, at most 100; an error where |a_g(q)| >= 1e-9 after them."],
                  _newton(derivation, [f"jac = {name}.loop_jacobian(q, p);", f"jac = jac(:, {dependent});",
                                       "S = jac' * jac;"], len(model.dependent), "S \\ (jac' * a)",
                          f"q({dependent}) = q({dependent}) - x;",
                          "for these independent coordinates from this guess")),
    ]


def _newton(derivation: Derivation, normal: list[str], size: int, step: str, update: str, failure: str) -> list[str]:
    """``assemble``'s body, the NumPy module's ``_newton``: at most 100 steps until every |a(q)| <
    1e-12, each ``x = step`` (``normal``'s lines set S, regularized by 1e-14 (1 + trace S), of
    ``size``), at most 0.5 in its largest entry, then ``update``; an error ``failure`` where
    |a(q)| >= 1e-9 after them."""
    name = derivation.robot.name
    return [*prologue(derivation, ["q_guess"], 2), "q = q_guess;", "for k = 1:100",
            f"    a = {name}.loop_constraints(q, p);", "    if all(abs(a) < 1e-12)", "        return;", "    end",
            *(f"    {line}" for line in normal), f"    S = S + 1e-14 * (1 + trace(S)) * eye({size});",
            f"    x = {step};", "    top = max(abs(x));", "    if top > 0.5", "        x = x * (0.5 / top);", "    end",
            f"    {update}", "end", f"if ~all(abs({name}.loop_constraints(q, p)) < 1e-9)",
            f"    error('assemble: the loop constraints could not be solved {failure}');", "end"]


def _tangent_rows(derivation: Derivation, names: Names) -> list[MFunction]:
    """A robot with quaternions in q: the loops' rows, their Jacobian on the velocities and
    Adot qd, each its program printed (``Derivation.loop_programs``)."""
    programs, n = derivation.loop_programs, len(derivation.symbols.qd)
    k = len(programs.rows)
    return [
        MFunction("loop_constraints", "a", ["q", "p"], [help_line(derivation, "loop_constraints")],
                  [*prologue(derivation, ["q"], 2), f"a = zeros({k}, 1);",
                   *program_body(names, programs.constraints, vector_targets("a", k))]),
        MFunction("loop_jacobian", "A", ["q", "p"], [help_line(derivation, "loop_jacobian")],
                  [*prologue(derivation, ["q"], 2), f"A = zeros({k}, {n});",
                   *program_body(names, programs.jacobian, matrix_targets("A", k, n))]),
        MFunction("loop_jacobian_dot_qd", "a", ["q", "qd", "p"], [help_line(derivation, "loop_jacobian_dot_qd")],
                  [*prologue(derivation, ["q", "qd"], 3), f"a = zeros({k}, 1);",
                   *program_body(names, programs.jacobian_dot_qd, vector_targets("a", k))]),
    ]


def _tangent_assemble(derivation: Derivation) -> MFunction:
    """``assemble`` of a robot with quaternions in q: the NumPy module's Gauss-Newton steps of least
    norm on the tangent space through the package's ``integrate``, with its limits and messages."""
    name, k = derivation.robot.name, len(derivation.loop_programs.rows)
    return MFunction(
        "assemble", "q", ["q_guess", "p"],
        [help_line(derivation, "assemble"), "",
         "   At most 100 Gauss-Newton steps of least norm on the tangent space, q <- integrate(q, -A' (A A')^-1 a),",
         "   each at most 0.5 in its largest entry; an error where |a(q)| >= 1e-9 after them."],
        _newton(derivation, [f"Aj = {name}.loop_jacobian(q, p);", "S = Aj * Aj';"], k, "-Aj' * (S \\ a)",
                f"q = {name}.integrate(q, x);", "from this guess"))


def _solved(derivation: Derivation, k: int, r: int | None) -> list[MFunction]:
    """forward_dynamics and loop_forces: the local loop_solve, the engine's program, for ``k``
    rows of rank ``r`` (None: found at each state)."""
    n, nu = len(derivation.symbols.qd), len(derivation.symbols.efforts)
    if r is None:
        least = (f" Rows implied by the others at the state (singular values below {TOLERANCE} of the largest) are "
                 "left out: the multipliers of least norm.")
    elif r < k:
        least = f" The {k} rows of A_g have rank {r} (over-constrained): the multipliers of least norm."
    else:
        least = ""
    optional_u = {"u": f"zeros({nu}, 1)"}
    return [
        MFunction("forward_dynamics", "qdd", ["q", "qd", "u", "p"],
                  [f"FORWARD_DYNAMICS  Accelerations qdd of the closed-loop mechanism, {n} x 1, from", "",
                   "   [M, -A'; A, 0] [qdd; lambda] = [tau - h; -Adot qd - 2 alpha A qd - beta^2 a(q)]", "",
                   "   (alpha = p.alpha, beta = p.beta: Baumgarte gains, 0 = none); start from a state on the",
                   "   constraints (A qd = 0). u may be [] (no effort)." + least],
                  [*prologue(derivation, ["q", "qd"], 4, optional_u),
                   "qdd = loop_solve(q, qd, u, p, p.alpha, p.beta);"], [_solve_function(derivation), row_space_shim()]),
        MFunction("loop_forces", "lambda", ["q", "qd", "u", "p"],
                  [help_line(derivation, "loop_forces") + least],
                  [*prologue(derivation, ["q", "qd"], 4, optional_u),
                   "[qdd, lambda] = loop_solve(q, qd, u, p, 0, 0);"], [_solve_function(derivation), row_space_shim()]),
    ]


def _linearize(derivation: Derivation, names: Names) -> Any:
    """linearize of a loop robot: the constrained solve of the NumPy module's for every column, the
    loops' terms symbolic (vector-space robots) or the engine's programs on the tangent space."""
    table = derivation.symbols
    name = derivation.robot.name
    n, k, r = loop_sizes(derivation)
    nu = len(table.efforts)
    width = 2 * n + nu
    accelerations = names.extended({s: f"qdd0({i + 1})" for i, s in enumerate(table.qdd)})
    if derivation.robot.floating:   # on the tangent space: the engine's programs, the rank found at the state
        terms = derivation.loop_linearization_programs
        multipliers = names.extended({s: f"lambda({i + 1})" for i, s in enumerate(terms.multipliers)})
        force = program_body(multipliers, terms.force, matrix_targets("K", n, n))
        acceleration = program_body(accelerations, terms.acceleration, matrix_targets("G", k, n))
        rate = [f"W = zeros({k}, {n});", *program_body(names, terms.rate, matrix_targets("W", k, n)),
                f"E(:, {n + 1}:{2 * n}) = -W;"]
        rank = "[]"
    else:   # d(Adot qd)/dqd = 2 Adot: A_g is a Hessian's rows
        force_terms, acceleration_terms = derivation.loop_linearization
        multipliers = names.extended({s: f"lambda({i + 1})" for i, s in enumerate(table.loop_multipliers)})
        force = expression_body(multipliers, list(force_terms), matrix_targets("K", n, n))
        acceleration = expression_body(accelerations, list(acceleration_terms), matrix_targets("G", k, n))
        rate = [f"E(:, {n + 1}:{2 * n}) = -2*{name}.loop_jacobian_dot(q, qd, p);"]
        rank = str(r)
    body = [*prologue(derivation, ["q", "qd"], 4, {"u": f"zeros({nu}, 1)"}),
            "[qdd0, lambda] = loop_solve(q, qd, u, p, 0, 0);", *linearize_rhs(derivation, names, "qdd0"),
            f"K = zeros({n}, {n});", *force,
            f"R(:, 1:{n}) = R(:, 1:{n}) + K;",
            f"E = zeros({k}, {width});", f"G = zeros({k}, {n});",
            *acceleration,
            f"E(:, 1:{n}) = -G;", *rate,
            f"M = {name}.mass_matrix(q, p);", f"Aj = {name}.loop_jacobian(q, p);",
            f"X = row_space_solve(M, Aj, R, E, {rank});",
            f"A = [zeros({n}, {n}), eye({n}); X(:, 1:{2 * n})];",
            f"B = [zeros({n}, {nu}); X(:, {2 * n + 1}:end)];"]
    return MFunction(
        "linearize", "[A, B]", ["q", "qd", "u", "p"],
        [help_line(derivation, "linearize"), "",
         "   The constrained solve [M, -A_g'; A_g, 0] [dqdd/dx; dlambda/dx] = [dY/dx - dtau/dx + d(A_g' lambda)/dx;",
         "   -d(A_g qdd + Adot_g qd)/dx] at the state's qdd and lambda (alpha = beta = 0, as the NumPy module).",
         *(["   On the tangent space: q perturbed as integrate(q, dq); the rows' rank found at the state."]
           if derivation.robot.floating else [])],
        body, [_solve_function(derivation), row_space_shim()])
