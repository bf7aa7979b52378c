"""``Derivation``: every named quantity of a robot's equations of motion, the straight-line
programs of the recursive algorithms, and the checks.

The engine's only output. Renderers read it; they never call into ``mechanics`` themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import sympy

from .mechanics.planar import planar_kinematics
from .mechanics.recursive import Program, build_programs
from .mechanics.regularity import check_mass_matrix
from .mechanics.tidy import Check, check_zero, is_small, tidy
from .model.robot import Robot
from .model.symbols import SymbolTable

#: What each quantity is, for the sheet, the terminal and the JSON consumers.
DESCRIPTIONS = {
    "T_g": "kinetic energy (generalized coordinates)",
    "V_g": "potential energy (generalized coordinates)",
    "L_g": "Lagrangian T_g - V_g",
    "Y_g": "applied generalized forces",
    "EOM_g1": "equations of motion from Lagrange's equations (= 0)",
    "M_g": "mass matrix",
    "C_g": "Coriolis matrix (Christoffel symbols)",
    "N_g": "gravity vector dV/dq",
    "EOM_g2": "equations of motion M qdd + C qd + N + F - Y (= 0)",
    "D_g": "Rayleigh dissipation function 1/2 sum b_i qd_i^2",
    "F_g": "dissipative generalized forces dD/dqd + fc sign(qd) (damping and friction)",
    "D_m": "Rayleigh dissipation function in maximal coordinates",
    "F_m": "dissipative forces in maximal coordinates",
}

Progress = Callable[[str], None]


@dataclass
class Derivation:
    """Named SymPy quantities (DESIGN.md section 4), intermediate steps and checks.

    >>> d = derive(load_robot("rp_arm"))          # doctest: +SKIP
    >>> d["N_g"]                                   # doctest: +SKIP
    Matrix([[g*m*(l + q2)*cos(q1)], [g*m*sin(q1)]])
    """

    robot: Robot
    symbols: SymbolTable
    quantities: dict[str, Any]
    steps: dict[str, Any] = field(default_factory=dict)
    checks: list[Check] = field(default_factory=list)
    #: Remarks about the derivation (dropped redundant loop rows, singular partitions).
    notes: list[str] = field(default_factory=list)
    _programs: dict[str, Program] | None = field(default=None, repr=False, compare=False)

    @property
    def programs(self) -> dict[str, Program]:
        """Straight-line programs of the recursive algorithms (``mechanics/recursive.py``), by
        what they compute: ``inverse_dynamics`` and ``forward_dynamics`` for every robot, and
        ``mass_matrix``, ``coriolis``, ``gravity`` for 3-D robots (a planar robot's explicit
        M, C, N are short and read like the sheet). Built once, on first use: a run that
        writes only a sheet never pays for them."""
        if self._programs is None:
            self._programs = build_programs(self.robot, self.symbols, list(self.quantities["Y_g"]))
        return self._programs

    def keys(self) -> list[str]:
        """The names of the quantities, in derivation order (``d.keys()``, as for a dict)."""
        return list(self.quantities)

    def _repr_latex_(self) -> str:
        """The equations of motion in a notebook: the manipulator form, and M, C, N where they
        are short enough to read."""
        names = self.symbols.latex_names()
        parts = [r"M(q)\,\ddot q + C(q, \dot q)\,\dot q + N(q) = \Upsilon"]
        for label, key in (("M", "M_g"), ("C", "C_g"), ("N", "N_g")):
            value = self.quantities[key]
            if is_small(sympy.Tuple(*value), 60 * len(value)):
                parts.append(f"{label} = " + sympy.latex(value, symbol_names=names, mat_delim="["))
            else:
                parts.append(rf"{label}:\ \text{{{value.shape[0]} $\times$ {value.shape[1]}, too large to show}}")
        return rf"$\displaystyle \text{{{_latex_text(self.robot.title)}}}:\quad " + r",\quad ".join(parts) + "$"

    def __getitem__(self, name: str) -> Any:
        try:
            return self.quantities[name]
        except KeyError:
            raise KeyError(f"no quantity {name!r}; available: {', '.join(self.quantities)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.quantities

    def __iter__(self) -> Iterator[str]:
        return iter(self.quantities)

    @property
    def all_checks_passed(self) -> bool:
        return all(c.passed for c in self.checks if not c.skipped)


def derive(robot: Robot, progress: Progress | None = None) -> Derivation:
    """Derive every quantity of ``robot`` and run the built-in consistency checks."""
    from .mechanics.generalized import derive_generalized

    report = progress or (lambda stage: None)
    table = SymbolTable.for_robot(robot)
    check_mass_matrix(robot, table)
    report("kinematics")
    if robot.planar:
        links: list[Any] = planar_kinematics(robot, table)
    else:
        from .mechanics.spatial import spatial_kinematics

        links = spatial_kinematics(robot, table)
    report("energies")
    quantities, steps = derive_generalized(robot, table, links, report)
    derivation = Derivation(robot, table, quantities, {"generalized": steps, "kinematics": links})
    loop_force = None
    if robot.loops:
        report("loop constraints")
        loop_force = _add_loops(derivation, links)
    if robot.planar:
        from .mechanics.maximal import derive_maximal

        report("maximal coordinates")
        loops = derivation.steps.get("loops")
        maximal, maximal_steps = derive_maximal(robot, table, links, steps, steps["links"],
                                                loops.row_indices if loops else None, loop_force)
        quantities.update(maximal)
        derivation.steps["maximal"] = maximal_steps
    report("checks")
    derivation.checks.extend(run_checks(derivation))
    return derivation


def _add_loops(derivation: Derivation, links: list[Any]) -> sympy.Matrix:
    """Loop constraints, multipliers and the reduced form (``mechanics/loops.py``); the
    multiplier form ``- A_g^T lambda_g`` joins EOM_g1 and EOM_g2. Returns that force."""
    from .mechanics.loops import derive_loops, reduced_form

    robot, table, q = derivation.robot, derivation.symbols, derivation.quantities
    model = derive_loops(robot, table, links)
    table.loop_multipliers = model.multipliers
    force = (model.jacobian.T * sympy.Matrix(model.multipliers))
    q.update({"a_g": model.constraints, "A_g": model.jacobian, "Adot_g": model.jacobian_dot,
              "lambda_g": sympy.Matrix(model.multipliers)})
    if "EOM_g1" in q:
        q["EOM_g1"] = (q["EOM_g1"] - force).applyfunc(tidy)
    q["EOM_g2"] = (q["EOM_g2"] - force).applyfunc(tidy)
    q.update(reduced_form(model, table, q["M_g"], q["C_g"], q["N_g"], q["Y_g"]))
    derivation.steps["loops"] = model
    derivation.notes.extend(model.notes)
    return force


def run_checks(derivation: Derivation) -> list[Check]:
    """The engine's consistency checks (DESIGN.md section 4), each proven or tested."""
    q, table = derivation.quantities, derivation.symbols
    symbols = table.all_symbols()
    if "EOM_g1" in q:
        checks = [check_zero(
            "EOM_g1 == EOM_g2", "Lagrange's equations (EOM_g1) equal the manipulator form (EOM_g2)",
            sympy.Matrix(q["EOM_g1"]) - q["EOM_g2"], symbols)]
    else:
        checks = [Check("EOM_g1 == EOM_g2", "Lagrange's equations (EOM_g1) were not derived "
                        "symbolically: this 3-D robot is too large (see `dynderive check`)", False,
                        "skipped", float("nan"))]
    loops = derivation.steps.get("loops")
    if loops is not None and "R_g" in q:
        checks.append(check_zero("A_g R_g == 0", "A_g R_g = 0: the reduced velocities qd = R_g qd_i satisfy the "
                                 "loop constraints", q["A_g"] * q["R_g"], symbols))
    if "maximal" not in derivation.steps:
        return checks
    steps = derivation.steps["maximal"]
    a_on_h, AH = steps["a_on_h"], steps["AH"]
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
        check_zero("EOM_g3 == EOM_g1", "the maximal model mapped through H (EOM_g3) equals EOM_g1",
                   q["EOM_g3"] - q["EOM_g1"], symbols),
    ]
    return checks


def _latex_text(text: str) -> str:
    """Free text inside ``\\text{}`` (a notebook cell): LaTeX specials written literally."""
    specials = {"\\": r"\textbackslash{}", "{": r"\{", "}": r"\}", "&": r"\&", "#": r"\#", "%": r"\%", "$": r"\$",
                "_": r"\_", "^": r"\^{}", "~": r"\~{}"}
    return "".join(specials.get(c, c) for c in text if c.isprintable())
