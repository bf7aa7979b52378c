"""The context of the Python modules' shared templates (``dynamics.py.j2``,
``dynamics_manifold.py.j2``), which the NumPy, JAX and CasADi targets render: the robot's
names and sizes, its explicit expressions and its engine programs as printed functions."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import sympy
from sympy.printing.numpy import NumPyPrinter

from ...derivation import Derivation
from ...model.array_program import Call
from .. import api
from ..encode import Code, python_literal
from .array_program import ArrayPrinter
from .conventions import conventions, notes, robot_kind
from .functions import Argument, ExpressionFunction, ProgramFunction, expression_function, program_function
from .printer import _Printer

#: Quantities that stay matrices even with one column (a 1-DOF robot's M is 1 x 1).
MATRICES = {"M_g", "C_g", "M_m", "C_m", "A_m", "Adot_m", "H"}


def _common_context(derivation: Derivation) -> dict[str, Any]:
    """The variables of every module: the robot, its parameters, efforts, frames, the
    regressor's parameter vector, whether it is dissipative, what the bodies take besides q,
    qd, qdd and u."""
    from ..._version import __version__

    robot, identification = derivation.robot, derivation.parameter_vector
    parameters = [{"name": p.name, "default": None if p.value is None else python_literal(float(p.value)),
                   "unit": p.unit, "description": p.description} for p in robot.parameters]
    keywords = [p["name"] if p["default"] is None else f"{p['name']}={p['default']}" for p in parameters]
    forward = derivation.programs.get("forward_dynamics")
    effort_matrix = _effort_matrix(derivation)
    size = api.sizes(derivation) | ({"NQ": "NQ", "NV": "NV"} if robot.floating else {})
    return {
        # each function's first docstring line, from the API table (a floating robot's sizes as NQ, NV)
        "doc": {f.name: Code(api.python_doc(f.name, size, batch=f.name != "parameter_vector")) for f in api.API},
        "params_keywords": ("*, " + ", ".join(keywords)) if keywords else "",
        "params_pass": ", ".join(f"{p['name']}={p['name']}" for p in parameters),
        "generator": f"dynderive {__version__}",
        "source": Path(robot.source).name,
        "robot": {"name": robot.name, "title": robot.title},
        "parameters": parameters,
        "efforts": list(robot.efforts),
        "efforts_tuple": _tuple(robot.efforts),
        "dissipative": robot.dissipative,
        "frames": [{"name": f.name, "body": f"_frame{i}"} for i, f in enumerate(robot.frames)],
        "frames_tuple": _tuple(tuple(f.name for f in robot.frames)),
        "centroidal": not robot.planar,   # centre of mass and centroidal momentum: 3-D robots
        # the frames held by contacts by default (``contacts:``) and their kinds (dynamics_contacts.py.j2)
        "contacts_tuple": _tuple(tuple(c.frame for c in robot.contacts)),
        "contact_kinds": Code("{" + ", ".join(f"{python_literal(c.frame)}: {python_literal(c.kind)}"
                                             for c in robot.contacts) + "}"),
        # the forward-dynamics body takes F - J^T w where its program says so (damping, friction, frames)
        "forward_extra": forward is not None and bool(forward.extra_inputs),
        "parameter_vector_tuple": _tuple(tuple(p.name for p in identification)),
        "parameter_count": len(identification),
        "regressor_sign": bool(derivation.programs["regressor"].extra_inputs),
        # NQ and NV (equal for a robot of vector-space joints), and the words on q and qd
        "nq": len(derivation.symbols.q),
        "nv": len(derivation.symbols.qd),
        "velocities_tuple": _tuple(tuple(str(s) for s in derivation.symbols.qd)),
        "effort_columns": python_literal(robot.effort_columns()),
        "robot_kind": robot_kind(robot),
        "conventions": Code(conventions(robot, derivation.symbols)),
        "notes": {name: Code(text) for name, text in notes(robot, derivation.symbols).items()},
        # dY/du as a Python literal (linearize's B), and its nonzero entries (row, column, value)
        "effort_matrix": Code(repr(tuple(map(tuple, effort_matrix)))),
        "effort_entries": [(i, k, Code(repr(value))) for i, row in enumerate(effort_matrix)
                           for k, value in enumerate(row) if value],
    }


def _effort_matrix(derivation: Derivation) -> list[list[float]]:
    """dY/du (NV x NU), rows of numbers: 1 at each effort's velocity column (or a mimic's
    multiplier), taken at q = 0 as linearize's input matrix B takes it."""
    if not derivation.symbols.efforts:   # no effort: NV empty rows
        return [[] for _ in derivation.symbols.qd]
    at_zero = {symbol: 0 for symbol in derivation.symbols.q}
    return [[float(entry) for entry in row] for row in derivation.effort_jacobian.subs(at_zero).tolist()]


def _program_lines(derivation: Derivation, xp: str, array_printer: type[ArrayPrinter]) -> dict[str, Any]:
    """The engine's array programs as Python lines over ``xp``: each contact program's parts
    (``contact_lines``, none without contact dynamics) and the loops' solve (``loop_lines``)."""

    def call(step: Call) -> str:
        if step.function == "effort_map":
            return f'{xp}.einsum("ij,...j->...i", _effort_map, u)'
        if step.function == "inverse_dynamics":
            return (f"inverse_dynamics(q, qd, {xp}.zeros_like(qd), wrenches, friction_smoothing=friction_smoothing, "
                    "**_parameters)")
        return f"{step.function}({', '.join({'frame': '_frame'}.get(a, a) for a in step.arguments)}, **_parameters)"

    printer = array_printer(xp, call)
    loops = derivation.loop_solve
    return {"loop_lines": [] if loops is None else [Code(line) for line in printer.statements(loops.steps)],
            "contact_lines": {program.name: {"anchors": program.anchors, **{part: [Code(line) for line in printer.statements(
                getattr(program, part), "anchors" if part == "finish" else "_anchor")] for part in
                ("setup", "contact", "point", "surface", "finish")}} for program in derivation.contact_programs or ()}}


def code_context(derivation: Derivation, printer: NumPyPrinter | None = None, xp: str = "np",
                 array_printer: type[ArrayPrinter] = ArrayPrinter) -> dict[str, Any]:
    """Every variable the code template can use (documented in docs/templates.md); ``printer``
    prints the expression functions (default: NumPy's, ``np.sin``; the JAX target passes its own),
    ``array_printer`` the engine's array programs over the module's array namespace ``xp``.
    A robot with quaternions in ``q`` (``robot.floating``) takes ``_tangent_context``."""
    return _code_context(derivation, printer) | _program_lines(derivation, xp, array_printer)


def _code_context(derivation: Derivation, printer: NumPyPrinter | None = None) -> dict[str, Any]:
    if derivation.robot.floating:
        return _tangent_context(derivation)
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    printer = printer or _Printer({"fully_qualified_modules": True, "strict": False})
    params = set(table.parameters.values())
    n, size = len(table.q), api.sizes(derivation)
    q = Argument("q", table.q, f"joint coordinates {tuple(robot.coordinates)}, shape (..., {n})")
    qd = Argument("qd", table.qd, f"joint velocities, shape (..., {n})")
    u = Argument("u", list(table.efforts.values()), f"efforts {tuple(robot.efforts)}, shape (..., {len(table.efforts)})")
    structured = derivation.structured_code
    functions = _expression_functions(derivation, q, qd, u, printer, params, structured)
    programs = _programs(derivation, q, qd, u) + _drive_bodies(derivation) + _configuration_bodies(derivation)
    if robot.loops:
        for name, args, quantity in [("loop_constraints", [q], "a_g"), ("loop_jacobian", [q], "A_g"),
                                     ("loop_jacobian_dot", [q, qd], "Adot_g")]:
            functions.append(expression_function(name, api.python_doc(name, size), args, quantities[quantity],
                                                 printer, params,
                                                 matrix_result=quantity != "a_g"))
        functions += _loop_derivatives(derivation, q, qd, printer, params)
    maximal = robot.planar
    if maximal:
        m = len(table.qm)
        qm = Argument("qm", table.qm, f"maximal coordinates (x, y, phi of each link's COM frame), shape (..., {m})")
        qmd = Argument("qmd", table.qmd, f"maximal velocities, shape (..., {m})")
        specs = [("maximal_mass_matrix", [qm], "M_m"), ("maximal_coriolis_matrix", [qm, qmd], "C_m"),
                 ("maximal_gravity_vector", [qm], "N_m"), ("maximal_efforts", [qm, u], "Y_m"),
                 ("constraints", [qm], "a_m"), ("constraint_jacobian", [qm], "A_m"),
                 ("constraint_jacobian_dot", [qm, qmd], "Adot_m"), ("maximal_kinetic_energy", [qm, qmd], "T_m"),
                 ("maximal_potential_energy", [qm], "V_m"), ("to_maximal", [q], "h"),
                 ("to_maximal_jacobian", [q], "H")]
        if robot.dissipative:
            specs.append(("maximal_friction_forces", [qm, qmd], "F_m"))
        for name, args, quantity in specs:
            functions.append(expression_function(name, api.python_doc(name, size), args, quantities[quantity],
                                                 printer, params, matrix_result=quantity in MATRICES))
    identification = derivation.parameter_vector
    functions.append(expression_function(
        "parameter_vector", api.python_doc("parameter_vector", size, batch=False),
        [], sympy.Matrix([p.value for p in identification]), printer, params))
    context = _common_context(derivation) | {
        "coordinates": list(robot.coordinates),
        "coordinates_tuple": _tuple(robot.coordinates),
        "q_doc": Code(f"joint coordinates {_tuple(robot.coordinates)}"),
        "dof": n,
        "nq_text": n,
        "nv_text": n,
        "functions": functions,
        "structured": structured,
        "coriolis_doc": Code("From the Christoffel symbols of M: C_ij = 1/2 sum_k (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) "
                             "qd_k,\n    with dM/dq_k from the composite-rigid-body algorithm differentiated line by line."),
        "maximal_dissipative": robot.planar and robot.dissipative,
        "programs": programs,
        "frame_size": 3 if robot.planar else 4,
        "twist_size": 3 if robot.planar else 6,
        "maximal": maximal,
        "maximal_coordinates_tuple": _tuple(tuple(str(s) for s in table.qm)),
        "maximal_size": len(table.qm),
        "constraint_count": quantities["a_m"].shape[0] if maximal else 0,
        "loops": bool(robot.loops),
        # the loops' solve partitions q into independent and dependent coordinates (dynamics_loops.py.j2)
        "loop_partition": bool(robot.loops),
        "contact_rows_doc": Code(" (the\n    loops' rank plus the contacts' rows, taken as independent)"),
        "loop_count": quantities["a_g"].shape[0] if robot.loops else 0,
        "loop_rank": derivation.loop_model.rank if robot.loops else 0,
        "redundant_loops": bool(robot.loops) and derivation.loop_model.redundant,
        "loops_tuple": _tuple(tuple(lp.name for lp in robot.loops)),
        "independent_tuple": _tuple(tuple(robot.coordinates[i] for i in derivation.loop_model.independent))
        if robot.loops else Code("()"),
        "dependent_list": Code(repr(derivation.loop_model.dependent)) if robot.loops else Code("[]"),
        "independent_list": Code(repr(derivation.loop_model.independent)) if robot.loops else Code("[]"),
        "independent_count": len(derivation.loop_model.independent) if robot.loops else 0,
        "assembled_tuple": python_literal(tuple(derivation.loop_model.assembled or ()))
        if robot.loops else Code("()"),
    }
    # the loops' constants: the joints closing them, the coordinates kept independent, a guess for assemble
    context["loop_constants"] = [
        Code("#: The loop-closing joints, and the coordinates kept independent (the others follow from them)."),
        Code(f"LOOPS = {context['loops_tuple']}"), Code(f"INDEPENDENT_COORDINATES = {context['independent_tuple']}"),
        Code("#: A configuration on the loop constraints at the default parameters (a guess for ``assemble``)."),
        Code(f"ASSEMBLED_CONFIGURATION = {context['assembled_tuple']}")]
    return context


def _expression_functions(derivation: Derivation, q: Argument, qd: Argument, u: Argument,
                          printer: _Printer, params: set[sympy.Symbol],
                          structured: bool) -> list[ExpressionFunction]:
    """Functions printed as explicit expressions: Y_g and V_g always; M, C, N and T_g for
    planar robots (short, readable beside the sheet). A 3-D robot's M, C, N are programs
    (``_programs``): their explicit entries are far too large to print for a 6-7 DOF arm."""
    quantities, size = derivation.quantities, api.sizes(derivation)
    explicit = [] if structured else [("mass_matrix", [q], "M_g"), ("coriolis_matrix", [q, qd], "C_g"),
                                      ("gravity_vector", [q], "N_g")]
    explicit.append(("generalized_forces", [q, u], "Y_g"))
    if not structured:
        explicit += [("kinetic_energy", [q, qd], "T_g"), ("potential_energy", [q], "V_g")]
    functions = [expression_function(name, api.python_doc(name, size), args, quantities[quantity], printer, params,
                                     matrix_result=quantity in MATRICES) for name, args, quantity in explicit]
    return functions


def _loop_derivatives(derivation: Derivation, q: Argument, qd: Argument, printer: _Printer,
                      params: set[sympy.Symbol]) -> list[ExpressionFunction]:
    """What ``linearize`` of a closed-loop robot needs beyond Newton-Euler's derivatives: the
    loop force's ``d(A_g^T lambda_g)/dq`` at fixed multipliers and the constraint
    acceleration's ``d(A_g qdd + Adot_g qd)/dq`` at fixed qdd (``d(Adot_g qd)/dqd`` is
    ``2 Adot_g``: ``A_g`` is a Hessian's rows)."""
    table, quantities = derivation.symbols, derivation.quantities
    n, k = len(table.q), quantities["a_g"].shape[0]
    qdd = Argument("qdd", table.qdd, f"joint accelerations, shape (..., {n})")
    multipliers = Argument("_multipliers", table.loop_multipliers, f"loop multipliers lambda_g, shape (..., {k})")
    force, acceleration = derivation.loop_linearization
    return [
        expression_function("_loop_force_jacobian", f"d(A_g^T lambda_g)/dq at fixed lambda_g, shape (..., {n}, {n}).",
                            [q, multipliers], force, printer, params, matrix_result=True),
        expression_function("_loop_acceleration_jacobian", "d(A_g qdd + Adot_g qd)/dq at fixed qdd, "
                            f"shape (..., {k}, {n}).", [q, qd, qdd], acceleration, printer, params, matrix_result=True),
    ]


def _programs(derivation: Derivation, q: Argument, qd: Argument, u: Argument) -> list[ProgramFunction]:
    """The straight-line programs the derivation holds (``Derivation.programs``), printed:
    inverse and forward dynamics and the regressor for every robot, M, C, N for 3-D robots."""
    n = len(derivation.symbols.q)
    qdd = Argument("qdd", derivation.symbols.qdd, f"joint accelerations, shape (..., {n})")
    effort_args = [q, qd, u]
    forward = derivation.programs.get("forward_dynamics")
    if forward is not None and forward.extra_inputs:   # damping, friction: F_g computed outside the body
        opposing = "dissipative forces F_g" if derivation.robot.dissipative else "no dissipative force"
        external = " minus the external forces J^T w" if derivation.robot.frames else ""
        effort_args.append(Argument("_friction", forward.extra_inputs, f"{opposing}{external}, shape (..., {n})"))
    regressor = derivation.programs["regressor"]
    regressor_args = [q, qd, qdd]
    if regressor.extra_inputs:   # Coulomb friction: sign(qd) (or its smoothed form) computed outside the body
        regressor_args.append(Argument("_sign", regressor.extra_inputs, f"sign(qd) or tanh(qd / eps), shape (..., {n})"))
    specs = {
        "mass_matrix": ("_mass_matrix_body", "M(q), row by row: composite-rigid-body algorithm.", [q]),
        "coriolis": ("_coriolis_body", "C(q, qd), row by row: Christoffel symbols of the differentiated CRBA.", [q, qd]),
        "gravity": ("_gravity_body", "N(q): Newton-Euler at rest.", [q]),
        "potential": ("_potential_body", "V(q): gravity along the tree, and the springs.", [q]),
        "inverse_dynamics": ("_inverse_dynamics_body", "M qdd + C qd + N: recursive Newton-Euler.", [q, qd, qdd]),
        "inverse_dynamics_derivatives": ("_inverse_dynamics_derivatives_body",
                                         "dtau/dq, then dtau/dqd, row by row: Newton-Euler differentiated line by line.",
                                         [q, qd, qdd]),
        "forward_dynamics": ("_forward_dynamics_body",
                             "qdd: CRBA, Newton-Euler and an LDL^T solve of M qdd = Y - C qd - N"
                             + (" - F" if derivation.robot.dissipative else "")
                             + (" + J^T w." if derivation.robot.frames else "."), effort_args),
        "regressor": ("_regressor_body", "Y(q, qd, qdd) with Y pi = M qdd + C qd + N (+ F), row by row: each joint's "
                      "axis carried down the tree, dotted with each link's force per unit parameter.", regressor_args),
    }
    functions = [program_function(*specs[key], program) for key, program in derivation.programs.items()]
    for index, frame in enumerate(derivation.frame_programs):
        name, pose, jacobian, bias = frame
        functions += [
            program_function(f"_frame{index}_transform_body", f"Pose of frame {name!r} (homogeneous, row by row).",
                             [q], pose),
            program_function(f"_frame{index}_jacobian_body", f"World-frame Jacobian of frame {name!r}, row by row.",
                             [q], jacobian),
            program_function(f"_frame{index}_jacobian_dot_qd_body", f"Jdot qd of frame {name!r}.", [q, qd], bias),
        ]
    if derivation.centroidal_programs is not None:
        arguments = {"total_mass": [], "center_of_mass": [q], "center_of_mass_jacobian": [q],
                     "centroidal_momentum_matrix": [q], "centroidal_inertia": [q]}
        for name, program in derivation.centroidal_programs._asdict().items():
            functions.append(program_function(f"_{name}_body", f"{name}: centroidal.py's program, row by row.",
                                              arguments.get(name, [q, qd]), program))
    return functions


def _drive_bodies(derivation: Derivation) -> list[ProgramFunction]:
    """The drives' coefficients as bodies of the parameters alone: ``F = b qd + fc sign(qd)``
    per velocity entry (0 where no drive acts: a quaternion joint's entries), none without drives."""
    bodies = []
    if derivation.robot.dissipative:
        for name in ("damping", "friction"):
            values = [sympy.Integer(0)] * len(derivation.symbols.qd)
            for drive in derivation.joint_drives:
                values[drive.coordinate] = getattr(drive, name)
            bodies.append(program_function(f"_{name}_coefficients_body", f"{name}_coefficients, entry by entry.", [],
                                           SimpleNamespace(lines=[], outputs=values)))
    return bodies


def _configuration_bodies(derivation: Derivation) -> list[ProgramFunction]:
    """The configuration maps (``Derivation.configuration_programs``: neutral, integrate,
    difference, rate) as bodies, joint by joint from the joint types: every robot has them
    (a vector-space joint's are ``q + v dt`` and ``q1 - q0``)."""
    bodies = []
    for name, map_ in derivation.configuration_programs.items():
        # private argument names (q aside, reserved): a joint of a robot without quaternions may be called v or dt
        arguments = [Argument(a if a == "q" else f"_{a}", symbols, a) for a, symbols in map_.arguments.items()]
        bodies.append(program_function(f"_{name}_body", f"{name}: the joint types' map, joint by joint.",
                                       arguments, map_.program))
        bodies[-1].keywords = False
    return bodies


def _tangent_context(derivation: Derivation) -> dict[str, Any]:
    """The variables of the module of a robot with quaternions in ``q`` (floating base,
    spherical joints; Pinocchio's conventions, DESIGN.md section 10): NQ coordinates, NV
    velocities, the free-flyer programs, the parameter vector and the drives' coefficients as
    bodies, and the configuration maps (``Derivation.configuration_programs``) as bodies."""
    robot, table = derivation.robot, derivation.symbols
    nq, nv = len(table.q), len(table.qd)
    q = Argument("q", table.q, f"coordinates, shape (..., {nq})")
    qd = Argument("qd", table.qd, f"velocities, shape (..., {nv})")
    u = Argument("u", list(table.efforts.values()), f"efforts, shape (..., {len(table.efforts)})")
    bodies = _programs(derivation, q, qd, u)
    bodies.append(program_function("_parameter_vector_body", "parameter_vector, entry by entry.", [],
                                   SimpleNamespace(lines=[], outputs=[p.value for p in derivation.parameter_vector])))
    bodies += _drive_bodies(derivation)
    if robot.loops:   # the loops' rows on the tree's twists (Derivation.loop_programs)
        loops = derivation.loop_programs
        for name, what, arguments, program in (
                ("loop_constraints", "a(q): the loops' rows.", [q], loops.constraints),
                ("loop_jacobian", "A(q), row by row: the loop frames' Jacobians differenced.", [q], loops.jacobian),
                ("loop_jacobian_dot_qd", "Adot qd: the rows' forward derivative along the motion.", [q, qd],
                 loops.jacobian_dot_qd)):
            bodies.append(program_function(f"_{name}_body", what, arguments, program))
        # linearize's terms of the loops (Derivation.loop_linearization_programs), on the tangent space
        terms, k = derivation.loop_linearization_programs, len(loops.rows)
        qdd = Argument("qdd", table.qdd, f"accelerations, shape (..., {nv})")
        multipliers = Argument("_multipliers", terms.multipliers, f"loop multipliers lambda, shape (..., {k})")
        for name, what, arguments, program in (
                ("loop_force_jacobian", "d(A^T lambda)/dq at fixed lambda, row by row.", [q, multipliers],
                 terms.force),
                ("loop_acceleration_jacobian", "d(A qdd + Adot qd)/dq at fixed qdd, row by row.", [q, qd, qdd],
                 terms.acceleration),
                ("loop_rate_jacobian", "d(Adot qd)/dqd, row by row.", [q, qd], terms.rate)):
            bodies.append(program_function(f"_{name}_body", what, arguments, program))
    bodies += _configuration_bodies(derivation)
    return _common_context(derivation) | {
        "coordinates_tuple": _tuple(tuple(str(s) for s in table.q)),
        "q_doc": Code("coordinates COORDINATES"),
        "nq_text": Code("NQ"),
        "nv_text": Code("NV"),
        "frame_size": 4,
        "twist_size": 6,
        "programs": bodies,
        "functions": [],
        "structured": True,   # M, C, N and V are programs
        "coriolis_doc": Code("C qd = inverse_dynamics(q, qd, 0) - gravity_vector(q), dM/dt along integrate. C = sum "
                             "over links of\n    J^T (I Jdot + B J), J the link's Jacobian in its own frame and "
                             "B = (v x* I - I v x + (I v) xbar*) / 2."),
        "loops": bool(robot.loops),
        "loop_partition": False,   # the loops are rows on the tree's twists (dynamics_tangent_loops.py.j2)
        "contact_rows_doc": Code("\n    (found at each state)"),
        "loop_count": len(derivation.loop_programs.rows) if robot.loops else 0,
        "loop_rank": Code("None"),   # found at each state
        "loops_tuple": _tuple(tuple(lp.name for lp in robot.loops)),
        # the loops' constants: the joints closing them (their rows are loop_constraints')
        "loop_constants": [Code("#: The loop-closing joints (their rows: loop_constraints)."),
                           Code(f"LOOPS = {_tuple(tuple(lp.name for lp in robot.loops))}")],
        "maximal": False,
    }


def _tuple(names: tuple[str, ...]) -> Code:
    """Python source of a tuple of strings, with double quotes as ruff formats them."""
    return python_literal(tuple(names))
