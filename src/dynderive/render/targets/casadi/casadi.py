"""The CasADi target (``solve --casadi``): ``<name>_dynamics_casadi.py``, every function of the
generated API as a ``casadi.Function`` of the same name built with ``casadi.SX`` (DESIGN.md
section 9), for a fixed or a floating base.

The module holds the same straight-line bodies as the JAX module (``code.program_function``:
plain Python whose functions, ``sin``, ``where``..., are the body's parameters), here bound to
``casadi.sin``, ``casadi.if_else``...: run once on the entries of ``casadi.SX`` symbols at import,
each program line becomes one SX node and a value read twice is one node read twice (the
engine's common subexpressions are kept). The explicit expressions (a planar robot's M, C, N,
Y_g, the loop and maximal-coordinate functions, the drives' coefficients) are turned into
such bodies here (``sympy.cse``, then the same printer). The dense solves (``linearize``, the
closed loops' and the maximal form's constrained systems) are ``casadi.solve`` on the SX
matrices.

Free text reaches the module only through the code environment's encoders (``|docstring``,
``|py``), as in the NumPy module; CasADi names every Function by the API's name (frames by
their index: ``frame_transform_0``), never by a robot's text; the rendered module is parsed back
and checked (it imports only ``casadi`` and ``numpy``) before anyone can write or import it.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import sympy

from ....derivation import Derivation
from ....errors import InputError, Problem
from ....mechanics.tidy import fold_constants
from ... import api
from ...codegen.constrained import refuse_floating_loops
from ...codegen.cse import common_subexpressions
from ...codegen.functions import Argument, ProgramFunction, program_function
from ...codegen.python_context import code_context
from ...encode import Code, python_literal
from ...python_module import render_module
from .casadi_program import casadi_program_lines

CASADI_TEMPLATE = "casadi/dynamics.py.j2"
#: Modules the generated CasADi module may import.
CASADI_IMPORTS = frozenset({"casadi", "numpy", "__future__"})
#: Maximal-coordinate functions printed from a quantity: (name, arguments, quantity).
_MAXIMAL = (
    ("maximal_mass_matrix", ("qm",), "M_m"),
    ("maximal_coriolis_matrix", ("qm", "qmd"), "C_m"),
    ("maximal_gravity_vector", ("qm",), "N_m"),
    ("maximal_efforts", ("qm", "u"), "Y_m"),
    ("constraints", ("qm",), "a_m"),
    ("constraint_jacobian", ("qm",), "A_m"),
    ("constraint_jacobian_dot", ("qm", "qmd"), "Adot_m"),
    ("maximal_kinetic_energy", ("qm", "qmd"), "T_m"),
    ("maximal_potential_energy", ("qm",), "V_m"),
    ("to_maximal", ("q",), "h"),
    ("to_maximal_jacobian", ("q",), "H"),
)
_FRICTION = ("maximal_friction_forces", ("qm", "qmd"), "F_m")


def expression_body(name: str, doc: str, arguments: list[Argument], value: Any) -> ProgramFunction:
    """An explicit quantity as a straight-line body: its entries row by row (zeros too),
    common subexpressions eliminated, printed as the engine's programs are (``sign``, which the
    bodies do not call, as its branches: ``casadi.sign`` through ``where``)."""
    matrix = value if isinstance(value, sympy.MatrixBase) else sympy.Matrix([[value]])
    exprs = [fold_constants(entry).replace(sympy.sign, _sign) for entry in matrix]
    temporaries, reduced = common_subexpressions(exprs, "_t")
    return program_function(name, doc, arguments, SimpleNamespace(lines=temporaries, outputs=list(reduced)))


def _sign(x: sympy.Expr) -> sympy.Expr:
    return sympy.Piecewise((1, x > 0), (-1, x < 0), (0, True))


def _explicit_bodies(derivation: Derivation, context: dict[str, Any]) -> list[ProgramFunction]:
    """The bodies the NumPy module prints as expressions (or, for a floating base, already has)."""
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    have = {p.name for p in context["programs"]}
    nv = len(table.qd)
    q = Argument("q", table.q, "coordinates")
    qd = Argument("qd", table.qd, "velocities")
    qdd = Argument("qdd", table.qdd, "accelerations")
    u = Argument("u", list(table.efforts.values()), "efforts")
    bodies = []
    specs = [
        ("_mass_matrix_body", [q], "M_g"),
        ("_coriolis_body", [q, qd], "C_g"),
        ("_gravity_body", [q], "N_g"),
        ("_potential_body", [q], "V_g"),
    ]
    if not robot.floating:
        specs.append(("_generalized_forces_body", [q, u], "Y_g"))
    for name, arguments, quantity in specs:
        if name not in have:
            bodies.append(
                expression_body(name, f"{quantity}, entry by entry.", arguments, quantities[quantity])
            )
    if not robot.floating:
        bodies.append(
            expression_body(
                "_parameter_vector_body",
                "parameter_vector, entry by entry.",
                [],
                sympy.Matrix([p.value for p in derivation.parameter_vector]),
            )
        )
        if robot.dissipative:
            for name in ("damping", "friction"):
                value = [sympy.Integer(0)] * nv
                for drive in derivation.joint_drives:
                    value[drive.coordinate] = getattr(drive, name)
                bodies.append(
                    expression_body(
                        f"_{name}_coefficients_body", f"{name}, entry by entry.", [], sympy.Matrix(value)
                    )
                )
    if robot.loops:
        multipliers = Argument("_multipliers", table.loop_multipliers, "loop multipliers")
        force, acceleration = derivation.loop_linearization
        for name, arguments, value in [
            ("_loop_constraints_body", [q], quantities["a_g"]),
            ("_loop_jacobian_body", [q], quantities["A_g"]),
            ("_loop_jacobian_dot_body", [q, qd], quantities["Adot_g"]),
            ("_loop_force_jacobian_body", [q, multipliers], force),
            ("_loop_acceleration_jacobian_body", [q, qd, qdd], acceleration),
        ]:
            bodies.append(expression_body(name, f"{name[1:-5]}, entry by entry.", arguments, value))
    if robot.planar:
        qm = Argument("qm", table.qm, "maximal coordinates")
        qmd = Argument("qmd", table.qmd, "maximal velocities")
        by_name = {"q": q, "u": u, "qm": qm, "qmd": qmd}
        specs = list(_MAXIMAL) + ([_FRICTION] if robot.dissipative else [])
        for name, arguments, quantity in specs:
            bodies.append(
                expression_body(
                    f"_{name}_body",
                    f"{quantity}, entry by entry.",
                    [by_name[a] for a in arguments],
                    quantities[quantity],
                )
            )
    return bodies


def _maximal_row(derivation: Derivation, spec: tuple[str, tuple[str, ...], str]) -> tuple[Any, ...]:
    """(name, arguments, shape as Python text, result name) of a maximal-coordinate function."""
    name, arguments, quantity = spec
    value = derivation.quantities[quantity]
    shape = tuple(value.shape) if isinstance(value, sympy.MatrixBase) else ()
    return name, arguments, Code(repr(shape)), quantity


def casadi_context(derivation: Derivation) -> dict[str, Any]:
    """The NumPy module's context (``code.code_context``: the parameters, names, the engine's
    programs) with the explicit expressions as bodies too, and the sizes of the module."""
    robot = derivation.robot
    refuse_floating_loops(derivation, "the CasADi target (--casadi)")
    if robot.loops and derivation.loop_model.redundant:
        raise InputError(
            Problem(
                robot.source,
                *robot.positions.get("loops", (1, 1)),
                "--casadi does not build over-constrained loops (their solves take the row space of "
                "the constraint Jacobian at each state, an SVD that casadi.SX has not); the NumPy, C "
                "and JAX modules do",
            )
        )
    context = code_context(derivation)
    explicit = _explicit_bodies(derivation, context)   # in place of the context's bodies of the same name
    context["programs"] = [p for p in context["programs"] if p.name not in {b.name for b in explicit}] + explicit
    size = api.sizes(derivation)
    maximal = (
        [_maximal_row(derivation, spec) for spec in _MAXIMAL + ((_FRICTION,) if robot.dissipative else ())]
        if robot.planar
        else []
    )
    context |= {
        "module": f"{robot.name}_dynamics_casadi",
        "sizes": size,
        "parameter_names": python_literal(tuple(p.name for p in robot.parameters)),
        "parameter_defaults": Code(
            ", ".join("_np.nan" if p["default"] is None else str(p["default"]) for p in context["parameters"])
        ),
        "maximal_functions": maximal,
        "loops": bool(robot.loops),
        "maximal": bool(robot.planar),
        "maximal_dissipative": bool(robot.planar and robot.dissipative),
        "loop_count": size["NC"],
        "constraint_count": size["NK"],
        "maximal_size": size["NM"],
        "shapes": {row[0]: row[2] for row in maximal},
        "independent_list": context.get("independent_list", "[]"),
        "dependent_list": context.get("dependent_list", "[]"),
        "effort_columns": context.get("effort_columns", "()"),
        "api_doc": {f.name: Code(api.described(f.name, size, "{n} x 1")) for f in api.API},
    } | casadi_program_lines(derivation)
    return context


def render_casadi(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The text of ``<name>_dynamics_casadi.py``, checked (it parses, imports only ``casadi`` and
    ``numpy``, and its docstring reads back the robot's title) before it is returned."""
    return render_module(
        derivation, CASADI_TEMPLATE, casadi_context(derivation), template_dir, CASADI_IMPORTS
    )


__all__ = ["CASADI_IMPORTS", "CASADI_TEMPLATE", "casadi_context", "expression_body", "render_casadi"]
