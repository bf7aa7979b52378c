"""The engine's consistency checks of a derivation (DESIGN.md section 4): the two forms of the
equations of motion agree, the reduced velocities satisfy the loops, the maximal model maps onto
the generalized one. Each is proven symbolically or, for large robots, tested numerically."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .exact_fast import matmul
from .polynomial import expand
from .tidy import Check, check_zero

if TYPE_CHECKING:
    from .loops import LoopModel
    from .maximal import MaximalSteps


class Derived(Protocol):
    """What the checks read of a derivation (``derivation.Derivation``, a layer after the
    engine's, which the engine cannot name)."""

    robot: Robot
    symbols: SymbolTable
    intermediate_form: bool

    @property
    def quantities(self) -> Mapping[str, Any]: ...

    @property
    def intermediates(self) -> list[tuple[sympy.Symbol, sympy.Expr]]: ...

    @property
    def loop_model(self) -> LoopModel: ...

    @property
    def maximal_steps(self) -> MaximalSteps | None: ...

    def lambdify(self, args: list[Any], value: Any) -> Callable[..., Any]: ...


def run_checks(derivation: Derived) -> list[Check]:
    """The engine's consistency checks (DESIGN.md section 4), each proven or tested."""
    q, table = derivation.quantities, derivation.symbols
    symbols = table.all_symbols()
    if "EOM_g1" in q and derivation.intermediate_form:
        # C_g's names opened one level (its Christoffel sums over the names of dM/dq_k): the
        # velocity terms then cancel exactly, and what remains, Newton-Euler's N_g against the
        # differentiated potential, is compared numerically
        definitions = dict(derivation.intermediates)
        christoffel = {c: definitions[c] for c in q["C_g"] if c in definitions}
        checks = [_zero_over_intermediates(
            derivation, "EOM_g1 == EOM_g2", "Lagrange's equations (EOM_g1, from the differentiated mass-matrix and "
            "potential programs) equal the manipulator form (EOM_g2, Christoffel symbols and Newton-Euler)",
            (sympy.Matrix(q["EOM_g1"]) - q["EOM_g2"]).xreplace(christoffel), q["N_g"])]
    elif "EOM_g1" in q:
        checks = [check_zero(
            "EOM_g1 == EOM_g2", "Lagrange's equations (EOM_g1) equal the manipulator form (EOM_g2)",
            sympy.Matrix(q["EOM_g1"]) - q["EOM_g2"], symbols)]
    else:
        checks = [Check("EOM_g1 == EOM_g2", "Lagrange's equations (EOM_g1) were not derived "
                        f"symbolically: this robot ({len(table.q)} coordinates) is too large (see `dynderive check`)",
                        False, "skipped", float("nan"))]
    loops = derivation.loop_model if derivation.robot.loops else None
    if loops is not None and "R_g" in q:
        checks.append(check_zero("A_g R_g == 0", "A_g R_g = 0: the reduced velocities qd = R_g qd_i satisfy the "
                                 "loop constraints", matmul(q["A_g"], q["R_g"]), symbols))
    if derivation.maximal_steps is None:
        return checks
    on_h = dict(zip(table.qm, q["h"]))
    a_on_h, AH = q["a_m"].xreplace(on_h), matmul(q["A_m"].xreplace(on_h), q["H"])
    if loops is not None:   # the loop rows of a_m become a_g on h(q): compare with them
        tree = a_on_h.shape[0] - loops.constraints.shape[0]
        a_on_h = a_on_h - sympy.Matrix.vstack(sympy.zeros(tree, 1), loops.constraints)
        AH = AH - sympy.Matrix.vstack(sympy.zeros(tree, AH.shape[1]), loops.jacobian)
    tree_note = " (the loop rows give a_g)" if loops is not None else ""
    checks += [
        check_zero("a_m(h(q)) == 0", f"the constraints a_m hold on the change of basis h(q_g){tree_note}",
                   a_on_h, symbols),
        check_zero("A_m(h(q)) H(q) == 0", "A_m(h(q)) H(q) = 0: every generalized motion satisfies the constraints"
                   + (" (the loop rows give A_g)" if loops is not None else ""), AH, symbols),
        check_zero("EOM_m1 == EOM_m2", "constrained Lagrange equations (EOM_m1) equal the manipulator form (EOM_m2)",
                   q["EOM_m1"] - q["EOM_m2"], symbols),
    ]
    if "EOM_g3" in q and "EOM_g1" in q:
        checks.append(check_zero("EOM_g3 == EOM_g1", "the maximal model mapped through H (EOM_g3) equals EOM_g1",
                                 q["EOM_g3"] - q["EOM_g1"], symbols))
    else:
        checks.append(Check("EOM_g3 == EOM_g1", "the maximal model was not mapped through H symbolically: this "
                            f"robot ({len(table.q)} coordinates) is too large (`dynderive check` compares both "
                            "models numerically)", False, "skipped", float("nan")))
    return checks


def _zero_over_intermediates(derivation: Derived, name: str, description: str, difference: sympy.Matrix,
                             reference: sympy.Matrix, states: int = 6, seed: int = 0) -> Check:
    """``difference == 0`` for quantities over a large robot's intermediate variables: the
    entries expanded (equal names cancel; what is left is zero only numerically), then
    evaluated at random states, parameters and efforts with the intermediates computed in
    order, to a tolerance relative to ``reference`` (the size of the terms that remain: for
    EOM_g1 - EOM_g2, the gravity vector)."""
    import numpy as np

    difference = sympy.Matrix(difference).applyfunc(expand)
    if all(e == 0 for e in difference):
        return Check(name, description, True, "symbolic", 0.0)
    table, robot = derivation.symbols, derivation.robot
    inputs = [*table.q, *table.qd, *table.qdd, *table.efforts.values(), *(table.parameters[p.name] for p in robot.parameters)]
    evaluate = derivation.lambdify(inputs, sympy.Matrix.hstack(difference, sympy.Matrix(reference)))
    rng = np.random.default_rng(seed)
    worst, scale = 0.0, 1.0
    for _ in range(states):
        values = [*rng.uniform(-1.5, 1.5, 3 * len(table.q) + len(table.efforts)),
                  *(p.value if p.value is not None else rng.uniform(0.5, 1.5) for p in robot.parameters)]
        result = np.asarray(evaluate(*values), dtype=float).reshape(difference.shape[0], 2)
        worst, scale = max(worst, float(np.max(np.abs(result[:, 0])))), max(scale, float(np.max(np.abs(result[:, 1]))))
    return Check(name, description, worst <= 1e-9 * scale, "numeric", worst)
