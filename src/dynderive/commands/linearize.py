"""``dynderive linearize``: A and B of ``xdot = A dx + B du`` about an operating point.

Small robots get A and B in closed form over their parameters (``mechanics.linearization.
symbolic_linearization``), and their values at the parameters' defaults from the generated
``linearize``, which must agree (the output says so). Large robots and closed loops get the
numbers only, and so does a small robot at a point where the closed form's entries are too
large to read (with a note).

Floating-base robots (a quaternion in ``q``) get the numbers of their generated module's
``linearize`` on the tangent space (A is 2 NV x 2 NV); entries of ``q`` that ``--at`` does not
give are the neutral configuration's, and a quaternion given off the unit sphere is normalized
with a note.

``--at`` lists ``KEY=VALUES`` items separated by commas: ``q``, ``qd`` and ``u`` take a vector
(the values that follow, up to the next ``KEY=``), a coordinate, velocity or effort name one
value: ``--at q=0,pi`` or ``--at theta=pi,F=0``. Values are numbers or whitelisted
expressions of numbers (``pi/2``, ``atan2(1, 1)``: commas inside a call's parentheses do not
separate items); whatever is not given is 0. ``u=equilibrium`` asks for the efforts that hold
the state (``qdd = 0``), where the actuation allows it.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..errors import InputError, Problem
from ..model.expressions import ExpressionError
from ..model.robot import Robot
from ..verify.motions import allowed_velocity
from .options import real_number, split_top_level

_KEY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=(.*)$", re.S)


def _problem(message: str) -> Problem:
    return Problem("--at", 1, 1, message)


def parse_at(texts: list[str], coordinates: list[str], velocities: list[str],
             efforts: list[str]) -> tuple[dict[str, list[float]], set[tuple[str, int]], bool]:
    """``{"q": [...], "qd": [...], "u": [...]}`` from the ``--at`` texts, which entries
    were given (``("q", 0)``, ...), and whether ``u=equilibrium`` asks for the efforts that
    hold the state; raises InputError."""
    names = {"q": coordinates, "qd": velocities, "u": efforts}
    values = {key: [0.0] * len(entries) for key, entries in names.items()}
    # the entries each key sets: a name one, q, qd and u all theirs (they win over a name)
    slots = {name: [(key, i)] for key, entries in names.items() for i, name in enumerate(entries)}
    slots |= {key: [(key, i) for i in range(len(entries))] for key, entries in names.items()}
    problems: list[Problem] = []
    given: set[tuple[str, int]] = set()
    items: list[tuple[str, list[str]]] = []
    equilibrium = False
    for text in texts:
        for part in split_top_level(text):
            match = _KEY.match(part)
            if match:
                items.append((match.group(1), [match.group(2)]))
            elif items:
                items[-1][1].append(part)
            else:
                problems.append(_problem(f"expected KEY=VALUE (KEY: q, qd, u or a coordinate, velocity or effort name), "
                                         f"got {part.strip()!r}"))
    for key, parts in items:
        if key == "u" and [p.strip() for p in parts] == ["equilibrium"]:
            equilibrium = True
            continue
        numbers = []
        for part in parts:
            try:
                number = real_number(part.strip())
            except (ExpressionError, TypeError, ValueError) as exc:
                problems.append(_problem(f"{key}: {exc}"))
                break
            if number is None:
                problems.append(_problem(f"{key}: {part.strip()!r} is not a finite real number"))
                break
            numbers.append(number)
        else:
            if key in slots and len(numbers) != len(slots[key]):
                wanted = f"{len(slots[key])} values" if key in names else "one value"
                problems.append(_problem(f"{key}: expected {wanted}, got {len(numbers)}"))
            elif key in slots:
                for (vector, index), number in zip(slots[key], numbers):
                    values[vector][index] = number
                given.update(slots[key])
            else:
                known = ", ".join(["q", "qd", "u", *coordinates, *velocities, *efforts])
                problems.append(_problem(f"unknown name {key!r} (known: {known})"))
    if equilibrium and any(vector == "u" for vector, _ in given):
        problems.append(_problem("u=equilibrium chooses every effort: give no other value of u"))
    if problems:
        raise InputError(problems)
    return values, given, equilibrium


def equilibrium_efforts(module: Any, at: dict[str, list[float]], values: dict[str, float]) -> tuple[list[float], str | None]:
    """The efforts that hold the state ``at`` (``qdd = 0``; with ``qd = 0`` an equilibrium),
    and a note when the actuation cannot: then the least-squares choice. ``qdd`` is affine in
    ``u`` (``M qdd = B u - ...``; with loops the constrained solve), so one call per effort
    gives it exactly."""
    q, qd = (np.array(at[k], dtype=float) for k in ("q", "qd"))
    size = len(module.EFFORTS)
    with np.errstate(all="ignore"):
        free = module.forward_dynamics(q, qd, np.zeros(size), **values)
        G = np.array([module.forward_dynamics(q, qd, e, **values) - free for e in np.eye(size)]).reshape(size, -1).T
    u = np.linalg.lstsq(G, -free, rcond=None)[0] if size else np.zeros(0)
    left = free + G @ u
    if np.max(np.abs(left), initial=0.0) <= 1e-9 * max(1.0, float(np.max(np.abs(free), initial=0.0))):
        return [float(v) for v in u], None
    held = "no efforts" if not size else "the efforts"
    return [float(v) for v in u], (f"u=equilibrium: {held} cannot hold this state (the actuation does not reach "
                                   f"every coordinate); u is the least-squares choice, leaving qdd = {_vector(left)}")


def equilibrium_note(module: Any, at: dict[str, list[float]], values: dict[str, float]) -> str | None:
    """A note when the operating point is not an equilibrium: the velocities are not zero, or
    the efforts do not hold the state (``qdd`` not 0)."""
    q, qd, u = (np.array(at[k], dtype=float) for k in ("q", "qd", "u"))
    with np.errstate(all="ignore"):
        qdd = module.forward_dynamics(q, qd, u, **values)
    moving = bool(np.any(qd))
    if not moving and np.max(np.abs(qdd), initial=0.0) <= 1e-9:
        return None
    why = "qd is not 0" if moving else "the efforts do not hold the state"
    advice = "" if moving else "; --at u=equilibrium gives the efforts that do, where the actuation allows"
    return f"the operating point is not an equilibrium ({why}): qdd = {_vector(qdd)} there{advice}"


def _vector(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in np.asarray(values, dtype=float).reshape(-1)) + "]"


def on_the_loops(module: Any, at: dict[str, list[float]], given: set[tuple[str, int]],
                 values: dict[str, float]) -> tuple[dict[str, list[float]], list[str]]:
    """A closed-loop robot's operating point on its constraints: the independent coordinates
    as given (else those of the default assembly), the others assembled; the independent
    velocities as given, the others those the loops allow. Returns it with notes on what was
    changed. A robot with quaternions in q keeps no reduced form: ``_on_tangent_loops``."""
    if not hasattr(module, "INDEPENDENT_COORDINATES"):
        return _on_tangent_loops(module, at, given, values)
    independent = [module.COORDINATES.index(c) for c in module.INDEPENDENT_COORDINATES]
    guess = np.array(module.ASSEMBLED_CONFIGURATION, dtype=float)
    chosen = [i for i in independent if ("q", i) in given]
    guess[chosen] = np.array(at["q"], dtype=float)[chosen]
    try:
        q = module.assemble(guess, **values)
    except (ValueError, np.linalg.LinAlgError):
        raise InputError(_problem("the loops cannot be closed with " + ", ".join(
            f"{module.COORDINATES[i]} = {guess[i]:g}" for i in independent))) from None
    qd = module.reduced_basis(q, **values) @ np.array([at["qd"][i] for i in independent])
    notes = [f"{module.COORDINATES[i]} = {q[i]:.6g} follows from the loops (given {at['q'][i]:g})"
             for i in range(len(q)) if ("q", i) in given and i not in independent and abs(q[i] - at["q"][i]) > 1e-9]
    notes += [f"{module.COORDINATES[i]}' = {qd[i]:.6g} follows from the loops (given {at['qd'][i]:g})"
              for i in range(len(q)) if ("qd", i) in given and i not in independent and abs(qd[i] - at["qd"][i]) > 1e-9]
    return {"q": [float(v) for v in q], "qd": [float(v) for v in qd], "u": list(at["u"])}, notes


def _on_tangent_loops(module: Any, at: dict[str, list[float]], given: set[tuple[str, int]],
                      values: dict[str, float]) -> tuple[dict[str, list[float]], list[str]]:
    """The operating point of closed loops on a robot with quaternions in q: the configuration
    assembled from the one given (the module's Gauss-Newton steps of least norm, so it moves the
    least it can), the velocity projected onto the motions the loops allow (the least change)."""
    try:
        q = module.assemble(np.array(at["q"], dtype=float), **values)
    except (ValueError, np.linalg.LinAlgError):
        raise InputError(_problem("the loops cannot be closed near the configuration given")) from None
    given_qd = np.array(at["qd"], dtype=float)
    qd = allowed_velocity(module, q, given_qd, values)
    notes = [f"{module.COORDINATES[i]} = {q[i]:.6g} follows from the loops (given {at['q'][i]:g})"
             for i in range(len(q)) if ("q", i) in given and abs(q[i] - at["q"][i]) > 1e-9]
    notes += [f"{module.VELOCITIES[i]} = {qd[i]:.6g} follows from the loops (given {given_qd[i]:g})"
              for i in range(len(qd)) if abs(qd[i] - given_qd[i]) > 1e-9]
    return {"q": [float(v) for v in q], "qd": [float(v) for v in qd], "u": list(at["u"])}, notes


def linearization(derivation: Derivation, module: Any, at: dict[str, list[float]], values: dict[str, float],
                  equilibrium: bool = False) -> dict[str, Any]:
    """A and B at the point ``at``: symbolic (small robots) and numeric (every robot), with
    the largest difference between the two routes at the parameters' ``values``; ``skipped``
    says why a small robot has no closed form at this point (its entries too large). With
    ``equilibrium`` the closed form takes the efforts that hold the state over the parameters
    (where they are unique), not their numbers at ``values``."""
    q, qd, u = (np.array(at[k], dtype=float) for k in ("q", "qd", "u"))
    A, B = module.linearize(q, qd, u, **values)
    result: dict[str, Any] = {"A_numeric": A, "B_numeric": B, "symbolic": None, "skipped": None}
    if derivation.intermediate_form or derivation.robot.loops or derivation.robot.floating:
        return result
    from ..mechanics.linearization import NoClosedForm, symbolic_linearization

    table = derivation.symbols
    point = {s: sympy.nsimplify(v, [sympy.pi], rational=False) if v else sympy.Integer(0)
             for s, v in zip([*table.q, *table.qd, *table.efforts.values()], [*at["q"], *at["qd"], *at["u"]])}
    if equilibrium:
        point |= _holding_efforts(derivation, point)
    try:
        A_sym, B_sym, qdd0 = symbolic_linearization(derivation.quantities, table, point)
    except NoClosedForm as why:
        result["skipped"] = str(why)
        return result
    numbers = {table.parameters[name]: value for name, value in values.items()}
    numbers |= {table.parameters[p.name]: p.value for p in derivation.robot.parameters
                if p.value is not None and p.name not in values}

    def evaluate(matrix: sympy.Matrix) -> np.ndarray:
        return np.array(matrix.xreplace(numbers).evalf(), dtype=float) if matrix.shape[1] else np.zeros(matrix.shape)

    agreement = max(float(np.max(np.abs(evaluate(A_sym) - A), initial=0.0)),
                    float(np.max(np.abs(evaluate(B_sym) - B), initial=0.0)))
    result["symbolic"] = {"A": A_sym, "B": B_sym, "qdd": qdd0, "agreement": agreement}
    return result


def _holding_efforts(derivation: Derivation, point: dict[sympy.Symbol, sympy.Expr]) -> dict[sympy.Symbol, sympy.Expr]:
    """The efforts that hold the state in ``point`` in closed form (``Y = C qd + N + F`` at
    ``qdd = 0``, linear in u), or {} when they are not unique or do not exist (then the
    numbers stand)."""
    from ..mechanics.tidy import tidy

    table, quantities = derivation.symbols, derivation.quantities
    efforts, n = list(table.efforts.values()), len(table.q)
    F = quantities.get("F_g", sympy.zeros(n, 1))
    state = {s: v for s, v in point.items() if s in set(table.q) | set(table.qd)}
    residual = (quantities["Y_g"] - quantities["C_g"] * sympy.Matrix(table.qd) - quantities["N_g"] - F).xreplace(state)
    solutions = list(sympy.linsolve(list(residual), efforts)) if efforts else []
    if len(solutions) != 1 or any(e.free_symbols & set(efforts) for e in solutions[0]):
        return {}
    return {u: tidy(sympy.cancel(e)) for u, e in zip(efforts, solutions[0])}


def _numbers(matrix: np.ndarray) -> list[list[float]]:
    return [[float(f"{v:.12g}") for v in row] for row in np.asarray(matrix)]


def render_linearization(derivation: Derivation, at: dict[str, list[float]], values: dict[str, float],
                         result: dict[str, Any], kind: str) -> str:
    """The result as terminal text, JSON (``kind`` "json") or a LaTeX document ("latex")."""
    import json

    from ..render.sheets.latex import Formatter

    robot = derivation.robot
    symbolic = result["symbolic"]
    A, B = result["A_numeric"], result["B_numeric"]
    given = ", ".join(f"{name}={value:g}" for name, value in values.items())
    if kind == "json":
        from ..render.sheets.json import quantity_entry

        fmt = Formatter.of(derivation, exact=True)   # JSON: exact numbers
        document: dict[str, Any] = {
            "robot": robot.name, "state": {"coordinates": [str(s) for s in derivation.symbols.q],
                                           **({"velocities": [str(s) for s in derivation.symbols.qd]}
                                              if robot.floating else {}), **at},
            "method": "symbolic" if symbolic else "numeric",
            "parameters": values, "A_numeric": _numbers(A), "B_numeric": _numbers(B),
        }
        if symbolic:
            document["A"] = quantity_entry(symbolic["A"], fmt, "xdot = A dx + B du, x = (q, qd)")
            document["B"] = quantity_entry(symbolic["B"], fmt, "input matrix")
            document["agreement"] = symbolic["agreement"]
        return json.dumps(document, indent=2) + "\n"
    if kind == "latex":
        from ..render.encode import escape_tex
        from ..render.environment import render

        fmt = Formatter.of(derivation)
        table = derivation.symbols

        def numeric(matrix: np.ndarray) -> str:
            rows = [" & ".join(f"{v:.6g}" for v in row) for row in np.asarray(matrix)]
            return r"\begin{bmatrix}" + r" \\ ".join(rows) + r"\end{bmatrix}"

        def vector(values_: list[float]) -> str:
            return fmt(sympy.Matrix([sympy.nsimplify(v, [sympy.pi], rational=False) if v else 0 for v in values_]).T)

        context = {
            "generator": "dynderive", "source": escape_tex(robot.source.rsplit("/", 1)[-1]),
            "title": escape_tex(robot.title), "q": fmt(sympy.Matrix(table.q).T),
            "dissipative": robot.dissipative, "q0": vector(at["q"]), "qd0": vector(at["qd"]), "u0": vector(at["u"]),
            "qdd0": fmt(symbolic["qdd"].T) if symbolic else numeric(np.zeros((1, len(table.qd)))),
            "tangent_space": robot.floating,   # quaternions: perturbed by integrate, NV entries
            "qd": fmt(sympy.Matrix(table.qd).T), "nq": len(table.q), "nv": len(table.qd),
            "A": fmt(symbolic["A"]) if symbolic else numeric(A), "B": fmt(symbolic["B"]) if symbolic else numeric(B),
            "values": escape_tex(given) if symbolic else "", "A_numeric": numeric(A), "B_numeric": numeric(B),
        }
        return render("latex", "linearization.tex.j2", context, None)
    from ..render.encode import terminal_text

    lines = [f"{terminal_text(robot.title)} ({robot.name}): linearized about q = {at['q']}, qd = {at['qd']}, u = {at['u']}",
             f"x = (dq, qd) on the tangent space (q perturbed as integrate(q, dq), dq of NV = {len(at['qd'])} entries), "
             "xdot = A dx + B du" if robot.floating else "x = (q, qd), xdot = A dx + B du", ""]
    if symbolic:
        for label, value in (("A", symbolic["A"]), ("B", symbolic["B"])):
            lines += [f"{label} =", sympy.pretty(value, use_unicode=True, wrap_line=False), ""]
        lines.append(f"At {given or 'the defaults'} (closed form and generated linearize agree to "
                     f"{symbolic['agreement']:.1e}):")
    else:
        why = ("not built for floating-base robots" if robot.floating else "it has closed loops" if robot.loops
               else result.get("skipped") or "this robot is too large")
        lines.append(f"At {given or 'the defaults'} (from the generated linearize; closed form skipped: {why}):")
    with np.printoptions(precision=6, suppress=True, linewidth=120):
        lines += ["A =", str(np.asarray(A)), "B =", str(np.asarray(B)), ""]
    return "\n".join(lines)


def on_the_manifold(robot: Robot, module: Any, q: list[float], given: set[tuple[str, int]]) -> tuple[list[float], list[str]]:
    """A floating-base robot's configuration from ``--at``: the neutral configuration's entries
    where none is given, each quaternion normalized (with a note when it was not unit); a zero
    quaternion is refused."""
    q = [value if ("q", i) in given else float(neutral) for i, (value, neutral)
         in enumerate(zip(q, module.neutral_configuration()))]
    notes, problems = [], []
    for joint, start in zip((j for j in robot.joints if j.multi), robot.quaternion_starts):
        quaternion = np.array(q[start:start + 4])
        norm = float(np.linalg.norm(quaternion))
        if norm < 1e-12:
            problems.append(_problem(f"joint {joint.name!r}: its quaternion (qx, qy, qz, qw) is zero; give a unit quaternion"))
        elif abs(norm - 1.0) > 1e-12:
            q[start:start + 4] = [float(v) for v in quaternion / norm]
            notes.append(f"joint {joint.name!r}: its quaternion (norm {norm:.6g}) normalized to "
                         f"{_vector(quaternion / norm)}")
    if problems:
        raise InputError(problems)
    return q, notes
