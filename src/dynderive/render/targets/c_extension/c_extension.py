"""The CPython binding of the C target (``solve --c-extension``): the C source of the module
``<name>_dynamics_c``, which wraps ``<name>_dynamics.c`` in the NumPy module's API.

The binding is driven by one table (``bindings``): each row names a Python function, the C
function it calls, its array inputs and their sizes, its outputs and their shapes, and what
the C function's return value means. The template (``templates/c/extension.c.j2``) turns each
row into a small kernel that calls the C function for one state and an entry of a spec table
that one generic dispatcher reads: argument parsing (positional or keyword, the robot's
parameters and ``friction_smoothing`` as keywords), shape checks with the NumPy module's
messages, broadcasting of the batch dimensions, and the batch loop in C (without the GIL).
Adding a C function to the module is one row (``c_binding.Binding``). A robot with
quaternions (a floating or spherical joint) takes ``q`` of NQ entries and ``qd``, ``qdd`` of NV,
has no ``generalized_forces`` and adds the configuration maps (``neutral_configuration``,
``integrate``, ``difference``, ``configuration_rate``).

Free text reaches the binding only as encoded C string literals (``c_string``): names of
coordinates, efforts, frames and regressor parameters; parameter names are C identifiers
(``c_names.c_problems``). Nothing is compiled here (``compile.py`` beside it does that).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ....derivation import Derivation
from ...encode import Code, python_literal
from ...environment import render
from ..c.c_binding import Binding
from ..c.c_loops import loop_context
from ..c.c_names import c_problems, refuse
from ..c.c_print import double_literal

TEMPLATE = "c/extension.c.j2"


def module_name(robot_name: str) -> str:
    """The extension's import name."""
    return f"{robot_name}_dynamics_c"


def c_string(text: str) -> Code:
    """``text`` as a C string literal of printable ASCII: its UTF-8 bytes, with ``\\``, ``"``
    and ``?`` (trigraphs) escaped and every other byte as a three-digit octal escape (which,
    unlike ``\\x``, cannot swallow the characters after it)."""
    out = []
    for byte in text.encode("utf-8"):
        char = chr(byte)
        if char in '\\"?':
            out.append("\\" + char)
        elif 0x20 <= byte < 0x7F:
            out.append(char)
        else:
            out.append(f"\\{byte:03o}")
    return Code('"' + "".join(out) + '"')


def bindings(derivation: Derivation) -> list[Binding]:
    """The extension's functions, in the order of the NumPy module's API."""
    robot = derivation.robot
    nq, n, nu = len(derivation.symbols.q), len(derivation.symbols.qd), len(derivation.symbols.efforts)
    count = len(derivation.parameter_vector)
    size, twist = (3, 3) if robot.planar else (4, 6)
    dissipative = robot.dissipative
    sign = dissipative and bool(derivation.programs["regressor"].extra_inputs)
    q, qd, qdd, u = ("q", nq), ("qd", n), ("qdd", n), ("u", nu)
    loops = bool(robot.loops)
    forward = (("Accelerations qdd of the closed-loop mechanism from [M -A^T; A 0] [qdd; lambda_g] = [Y - C qd - N - F "
                "+ sum J^T w; -Adot qd - 2 alpha A qd - beta**2 a_g(q)], shape (..., n); alpha, beta: Baumgarte gains "
                "(0: none); u=None: no effort. NaN where the system cannot be solved (M not positive definite, or the "
                "loop rows singular).") if loops else
               ("Accelerations qdd solving M qdd = Y_g(u) - C qd - N - F + sum J^T w, shape (..., n); u=None: no "
                "effort. NaN where M is not positive definite."))
    table = [
        Binding("mass_matrix", "mass_matrix", (q,), ((n, n),), "Mass matrix M_g(q), shape (..., n, n)."),
        Binding("coriolis_matrix", "coriolis_matrix", (q, qd), ((n, n),),
                "Coriolis matrix C_g(q, qd) (Christoffel symbols), shape (..., n, n)."),
        Binding("gravity_vector", "gravity_vector", (q,), ((n,),), "Gravity vector N_g(q) = dV/dq, shape (..., n)."),
        *([] if nq != n else [Binding("generalized_forces", "generalized_forces", (q, u), ((n,),),
                                      "Applied generalized forces Y_g(q, u) of the efforts, shape (..., n).")]),
        Binding("inverse_dynamics", "inverse_dynamics", (q, qd, qdd), ((n,),),
                "Generalized forces Y_g = M qdd + C qd + N + F - sum J^T w, shape (..., n); wrenches: None or "
                "{frame: w} in world axes.", wrenches="inverse_dynamics_wrenches", smoothing=True,
                refuses_negative=dissipative),
        Binding("forward_dynamics", "forward_dynamics", (q, qd, u), ((n,),), forward, returns="status", optional=True,
                wrenches="forward_dynamics_wrenches", smoothing=True, refuses_negative=dissipative,
                members=("alpha", "beta") if loops else ()),
        Binding("kinetic_energy", "kinetic_energy", (q, qd), ((),), "Kinetic energy T_g = 1/2 qd^T M qd, shape (...).",
                returns="value", scalar=derivation.structured_code),
        Binding("potential_energy", "potential_energy", (q,), ((),),
                "Potential energy V_g(q) of gravity and the springs, shape (...).", returns="value"),
        Binding("friction_forces", "friction_forces", (qd,), ((n,),),
                "Dissipative forces F_g = b qd + fc sign(qd) (tanh(qd / friction_smoothing) when it is positive), "
                "shape (..., n).", smoothing=True, refuses_negative=dissipative),
        Binding("linearize", "linearize", (q, qd, u), ((2 * n, 2 * n), (2 * n, nu)),
                "(A, B) of xdot = A dx + B du about x = (q, qd) and u, shapes (..., 2n, 2n) and (..., 2n, nu); NaN "
                "where M is not positive definite.", returns="status", optional=True, smoothing=True,
                refuses_negative=dissipative),
        Binding("regressor", "regressor", (q, qd, qdd), ((n, count),),
                "Regressor Y(q, qd, qdd), shape (..., n, len(PARAMETER_VECTOR)): Y @ parameter_vector() equals "
                "inverse_dynamics(q, qd, qdd).", smoothing=True, refuses_negative=sign),
        Binding("parameter_vector", "parameter_vector", (), ((count,),),
                "The regressor's parameters pi (PARAMETER_VECTOR), shape (len(PARAMETER_VECTOR),)."),
        Binding("frame_transform", "frame_transform", (q,), ((size, size),),
                "Pose of frame (a name of FRAMES) in the world, [[R, p], [0, 1]], shape (..., s, s).",
                returns="status", frame=True),
        Binding("frame_jacobian", "frame_jacobian", (q,), ((twist, n),),
                "World-frame Jacobian of frame (a name of FRAMES): linear rows, then angular, shape (..., t, n).",
                returns="status", frame=True),
        Binding("frame_jacobian_dot_qd", "frame_jacobian_dot_qd", (q, qd), ((twist,),),
                "Jdot(q, qd) qd of frame (a name of FRAMES), shape (..., t).", returns="status", frame=True),
    ]
    return table + (_loop_bindings(derivation) if loops else []) + (_configuration_bindings(nq, n) if nq != n else [])


def _configuration_bindings(nq: int, nv: int) -> list[Binding]:
    """The configuration maps of a robot with quaternions (NQ != NV): no parameters;
    ``integrate``'s ``dt`` a number per state (default 1.0)."""
    q, v = ("q", nq), ("v", nv)
    return [
        Binding("neutral_configuration", "neutral_configuration", (), ((nq,),),
                "The neutral configuration (Pinocchio's neutral): zeros, and identity quaternions, shape (NQ,).",
                parameters=False),
        Binding("integrate", "integrate", (q, v, ("dt", 1)), ((nq,),),
                "The configuration reached from q moving at v for dt (Pinocchio's integrate(q, v dt)), shape "
                "(..., NQ); dt: a number or an array of them (batch dimensions).", parameters=False, number="1.0"),
        Binding("configuration_rate", "configuration_rate", (q, v), ((nq,),),
                "dq/dt of the configuration q moving at velocity v, shape (..., NQ).", parameters=False),
        Binding("difference", "difference", (("q_from", nq), ("q_to", nq)), ((nv,),),
                "The velocity v that integrate turns q_from into q_to in unit time (Pinocchio's difference), shape "
                "(..., NV).", parameters=False),
    ]


def _loop_bindings(derivation: Derivation) -> list[Binding]:
    """A closed-loop robot's functions (``render/targets/c/c_loops.py``'s C functions)."""
    n, nu = len(derivation.symbols.q), len(derivation.symbols.efforts)
    k, m = derivation.quantities["a_g"].shape[0], len(derivation.steps["loops"].independent)
    dissipative = derivation.robot.dissipative
    q, qd, u = ("q", n), ("qd", n), ("u", nu)
    return [
        Binding("loop_constraints", "loop_constraints", (q,), ((k,),),
                "Loop constraints a_g(q) (zero when the loops are closed), shape (..., k)."),
        Binding("loop_jacobian", "loop_jacobian", (q,), ((k, n),),
                "Loop constraint Jacobian A_g(q) = da_g/dq, shape (..., k, n)."),
        Binding("loop_jacobian_dot", "loop_jacobian_dot", (q, qd), ((k, n),),
                "Its time derivative Adot_g(q, qd), shape (..., k, n)."),
        Binding("loop_forces", "loop_forces", (q, qd, u), ((k,),),
                "Loop multipliers lambda_g, shape (..., k): A_g^T lambda_g is the generalized force the loop joints "
                "exert (forward_dynamics' system with alpha = beta = 0). NaN where it cannot be solved.",
                returns="status", optional=True, wrenches="loop_forces_wrenches", smoothing=True,
                refuses_negative=dissipative),
        Binding("reduced_basis", "reduced_basis", (q,), ((n, m),),
                "R_g(q), shape (..., n, m): the motions the loops allow, qd = R_g qd_i with qd_i the velocities of "
                "INDEPENDENT_COORDINATES. NaN where the dependent block of A_g is singular.", returns="status"),
        Binding("reduced_forward_dynamics", "reduced_forward_dynamics", (q, qd, u), ((n,),),
                "Accelerations qdd, shape (..., n), by the reduced form R_g^T M R_g qdd_i = R_g^T (Y - C qd - N - F - "
                "M s), qdd = R_g qdd_i + s (forward_dynamics with alpha = beta = 0 on the constraints). NaN where it "
                "cannot be solved.", returns="status", optional=True, smoothing=True, refuses_negative=dissipative),
        Binding("assemble", "assemble", (("q_guess", n),), ((n,),),
                "The configuration on the loop constraints a_g(q) = 0 nearest the guess by Newton's method, keeping "
                "INDEPENDENT_COORDINATES, shape (..., n). Raises ValueError where it does not converge.",
                returns="status", error="assemble: the loop constraints could not be solved for these independent "
                "coordinates from this guess"),
    ]


def _call(prefix: str, function: str, arguments: list[str]) -> str:
    return f"{prefix}_{function}({', '.join(arguments)})"


def _kernel(robot_name: str, binding: Binding) -> list[str]:
    """The C lines of the kernel: the C function called for one state."""
    arguments = [f"in[{i}]" for i in range(len(binding.inputs))] + (["frame"] if binding.frame else [])
    if binding.number is not None:
        arguments[len(binding.inputs) - 1] += "[0]"
    p = ["p"] if binding.parameters else []
    outputs = [f"out[{k}]" for k in range(len(binding.outputs))]
    if binding.returns == "value":
        return [f"out[0][0] = {_call(robot_name, binding.function, [*arguments, *p])};", "return 0;"]
    call = _call(robot_name, binding.function, [*arguments, *p, *outputs])
    if binding.returns == "status":
        return [f"return {call};"]
    return [f"{call};", "return 0;"]


def _wrench_kernel(robot_name: str, binding: Binding) -> list[str]:
    """The kernel with wrenches: the C target's ``<name>_..._wrenches`` called for one state."""
    arguments = [f"in[{i}]" for i in range(len(binding.inputs))]
    call = _call(robot_name, binding.wrenches or "", [*arguments, "w", "p", "out[0]"])
    return [f"return {call};"] if binding.returns == "status" else [f"{call};", "return 0;"]


def _signature(binding: Binding, parameters: list[dict[str, Any]], members: dict[str, Any]) -> str:
    """The Python signature (``__text_signature__``, for ``inspect.signature`` and ``help``);
    ``members``: the struct members' Python defaults by name."""
    positional = [name for name, _ in binding.inputs]
    if binding.optional:
        positional[-1] += "=None"
    if binding.number is not None:
        positional[-1] += f"={binding.number}"
    if binding.frame:
        positional.append("frame")
    if binding.wrenches:
        positional.append("wrenches=None")
    keywords = [f"{member}={members[member]}" for member in binding.members] + \
        (["friction_smoothing=0.0"] if binding.smoothing else []) + \
        [p["name"] if p["default"] is None else f"{p['name']}={p['python_default']}" for p in parameters
         if binding.parameters]
    if keywords:
        positional += ["*", *keywords]
    return f"{binding.name}({', '.join(['$module', *positional])})"


def extension_context(derivation: Derivation) -> dict[str, Any]:
    """Every variable ``extension.c.j2`` uses; the wrench kernels call the C target's
    ``<name>_..._wrenches``, which every robot has."""
    refuse(c_problems(derivation.robot))
    robot = derivation.robot
    name, nq, nv = robot.name, len(derivation.symbols.q), len(derivation.symbols.qd)
    parameters = [{"name": p.name, "c_name": c_string(p.name),
                   "default": None if p.value is None else Code(double_literal(float(p.value))),
                   "python_default": None if p.value is None else python_literal(float(p.value))}
                  for p in robot.parameters]
    table = bindings(derivation)
    members = [{"name": m["name"], "default": m["default"], "python_default": python_literal(float(m["default"]))}
               for m in loop_context(derivation)["members"]]
    python_defaults = {m["name"]: m["python_default"] for m in members}
    functions = []
    for binding in table:
        text = f"{_signature(binding, parameters, python_defaults)}\n--\n\n{binding.doc}"
        functions.append({
            "name": binding.name,
            "c_name": c_string(binding.name),
            "doc": c_string(text),
            "kernel": [Code(line) for line in _kernel(name, binding)],
            "wrench_kernel": [Code(line) for line in _wrench_kernel(name, binding)] if binding.wrenches else [],
            "inputs": [{"name": c_string(n), "size": s} for n, s in binding.inputs],
            "outputs": [{"ndim": len(shape), "dims": list(shape) + [0] * (2 - len(shape))} for shape in binding.outputs],
            "status": int(binding.returns == "status"),
            "error": c_string(binding.error) if binding.error else Code("NULL"),
            "members": sum(1 << [m["name"] for m in members].index(member) for member in binding.members),
            **{flag: int(getattr(binding, flag))
               for flag in ("optional", "frame", "smoothing", "refuses_negative", "scalar", "parameters")},
            "number": int(binding.number is not None),
            "fill": Code(binding.number or "0.0"),
        })
    strings = lambda values: [{"text": c_string(v), "length": len(v.encode("utf-8"))} for v in values]  # noqa: E731
    loops = derivation.steps["loops"] if robot.loops else None
    return {
        "name": name,
        "module": module_name(name),
        "n": nq,
        "velocities": strings([str(s) for s in derivation.symbols.qd]) if nq != nv else None,
        "nu": len(derivation.symbols.efforts),
        "twist": 3 if robot.planar else 6,
        "parameters": parameters,
        "all_defaults": int(all(p["default"] is not None for p in parameters)),
        "coordinates": strings(robot.configuration_names),
        "efforts": strings(robot.efforts),
        "frames": strings([f.name for f in robot.frames]),
        "members": members,
        "loops": strings([lp.name for lp in robot.loops]) if loops else None,
        "independent": strings([robot.coordinates[i] for i in loops.independent]) if loops else [],
        "assembled": [Code(double_literal(float(x))) for x in loops.assembled or ()] if loops else [],
        "parameter_vector": strings([p.name for p in derivation.parameter_vector]),
        "functions": functions,
        "max_inputs": max(max(len(b.inputs) for b in table), 1),
        "max_outputs": max(len(b.outputs) for b in table),
    }


def render_extension(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The C source of the binding (it includes ``<name>_dynamics.h``), as text."""
    return render("code", TEMPLATE, extension_context(derivation), template_dir)
