"""The CPython binding of the C target (``solve --c-extension``): the C source of the module
``<name>_dynamics_c``, which wraps ``<name>_dynamics.c`` in the NumPy module's API.

The binding is driven by one table (``bindings``): each row names a Python function, the C
function it calls, its array inputs and their sizes, its outputs and their shapes, and what
the C function's return value means. The template (``c_extension/extension.c.j2``) turns each
row into a small kernel that calls the C function for one state and an entry of a spec table
that one generic dispatcher reads: argument parsing (positional or keyword, the robot's
parameters and ``friction_smoothing`` as keywords), shape checks with the NumPy module's
messages, broadcasting of the batch dimensions, and the batch loop in C (without the GIL).
Adding a C function to the module is one row (``binding.Binding``). A robot with
quaternions (a floating or spherical joint) takes ``q`` of NQ entries and ``qd``, ``qdd`` of NV,
has no ``generalized_forces`` and adds the configuration maps (``neutral_configuration``,
``integrate``, ``difference``, ``configuration_rate``). A 3-D robot adds the centre of mass and
centroidal momentum (``total_mass`` ... ``centroidal_inertia``).

Free text reaches the binding only as encoded C string literals (``c_string``): names of
coordinates, efforts, frames and regressor parameters; parameter names are C identifiers
(``codegen/names.c_problems``). Nothing is compiled here (``compile.py`` beside it does that).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ....derivation import Derivation
from ... import api
from ...codegen.constrained import BAUMGARTE
from ...codegen.literals import double_literal
from ...codegen.names import c_problems, refuse
from ...encode import Code, python_literal
from ...environment import render
from .binding import Binding
from .contacts import contact_source

TEMPLATE = "c_extension/extension.c.j2"


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
    """The extension's functions: the API table's (``render/api.py``) that the C target builds
    for this robot, in its order, each with what its C function returns and takes besides."""
    robot = derivation.robot
    size = api.sizes(derivation)
    dissipative, loops, quaternions = robot.dissipative, bool(robot.loops), size["NQ"] != size["NV"]
    smooth = {"smoothing": True, "refuses_negative": dissipative}
    solved = {"returns": "status", "optional": True, **smooth}
    frame = {"returns": "status", "frame": True}
    geometry = {"parameters": False}
    extra: dict[str, dict[str, Any]] = {
        "inverse_dynamics": {"wrenches": "inverse_dynamics_wrenches", **smooth},
        "forward_dynamics": {"wrenches": "forward_dynamics_wrenches", "members": ("alpha", "beta") if loops else (),
                             **solved},
        "kinetic_energy": {"returns": "value", "scalar": derivation.structured_code},
        "potential_energy": {"returns": "value"},
        "friction_forces": smooth,
        "linearize": solved,
        "inverse_dynamics_derivatives": smooth,
        "forward_dynamics_derivatives": solved,
        "regressor": {"smoothing": True,
                      "refuses_negative": dissipative and bool(derivation.programs["regressor"].extra_inputs)},
        "total_mass": {"returns": "value"},
        "frame_transform": frame, "frame_jacobian": frame, "frame_jacobian_dot_qd": frame,
        "loop_forces": {"wrenches": "loop_forces_wrenches", **solved},
        "reduced_basis": {"returns": "status"},
        "reduced_forward_dynamics": solved,
        "assemble": {"returns": "status", "error": "assemble: the loop constraints could not be solved from this guess"
                     if quaternions else "assemble: the loop constraints could not be solved for these "
                     "independent coordinates from this guess"},
        "neutral_configuration": geometry, "integrate": {"number": "1.0", **geometry},
        "configuration_rate": geometry, "difference": geometry,
    }
    groups = {"dynamics", "frames"} | (set() if robot.planar else {"centroidal"}) | \
        ({"loops"} if loops else set()) | ({"configuration"} if quaternions else set())
    # loops on a floating base (rows on the tree's twists): Adot qd, no reduced form
    left_out = ({"loop_jacobian_dot", "reduced_basis", "reduced_forward_dynamics"} if loops and quaternions
                else {"loop_jacobian_dot_qd"})
    table = []
    for function in api.API:
        if function.group not in groups or (quaternions and function.name == "generalized_forces") \
                or function.name in left_out:
            continue
        inputs = tuple((a, 1 if a == "dt" else size[api.ARGUMENT_SIZES[a]]) for a in function.arguments if a != "frame")
        doc = " ".join([api.python_doc(function.name, size, batch=function.name not in ("parameter_vector", "total_mass")),
                        *_notes(function.name, loops)])
        table.append(Binding(function.name, inputs, api.shapes(function.name, size), doc,
                             **extra.get(function.name, {})))
    return table


def _notes(name: str, loops: bool) -> list[str]:
    """What the extension's docstring adds to the table's summary: optional arguments, NaN."""
    unsolved = "NaN where M is not positive definite."
    notes = {
        "inverse_dynamics": ["wrenches: None or {frame: w} in world axes (w: linear, then angular)."],
        "forward_dynamics": ["u=None: no effort;", "wrenches as for inverse_dynamics.", unsolved] if not loops else [
            "With the loops, from [M -A^T; A 0] [qdd; lambda_g] = [Y - C qd - N - F + sum J^T w; -Adot qd - 2 alpha "
            "A qd - beta**2 a_g(q)]; alpha, beta: Baumgarte gains (0: none); u=None: no effort. NaN where the "
            "system cannot be solved (M not positive definite, or the loop rows singular)."],
        "linearize": ["u=None: no effort.", unsolved],
        "forward_dynamics_derivatives": ["u=None: no effort.", unsolved],
        "frame_transform": ["frame: a name of FRAMES."],
        "frame_jacobian": ["frame: a name of FRAMES."],
        "frame_jacobian_dot_qd": ["frame: a name of FRAMES."],
        "loop_forces": ["NaN where it cannot be solved."],
        "reduced_basis": ["NaN where the dependent block of A_g is singular."],
        "reduced_forward_dynamics": ["NaN where it cannot be solved."],
        "assemble": ["Raises ValueError where it does not converge."],
        "integrate": ["dt: a number or an array of them (batch dimensions)."],
        "total_mass": ["Links welded to the world are left out (Pinocchio's universe)."],
        "center_of_mass_acceleration_bias": ["The centre of mass accelerates by center_of_mass_jacobian(q) @ qdd + "
                                             "this."],
        "centroidal_momentum_bias": ["The centroidal momentum changes by centroidal_momentum_matrix(q) @ qdd + this."],
    }
    return notes.get(name, [])


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
        return [f"out[0][0] = {_call(robot_name, binding.name, [*arguments, *p])};", "return 0;"]
    call = _call(robot_name, binding.name, [*arguments, *p, *outputs])
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
    members = [{"name": member, "default": Code(default), "python_default": python_literal(float(default))}
               for member, default, _ in (BAUMGARTE if robot.loops else ())]
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
    loops = derivation.loop_model if robot.loops and not robot.floating else None   # floating: rows on twists
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
        "loops": strings([lp.name for lp in robot.loops]) if robot.loops else None,
        "independent": strings([robot.coordinates[i] for i in loops.independent]) if loops else [],
        "assembled": [Code(double_literal(float(x))) for x in loops.assembled or ()] if loops else [],
        "parameter_vector": strings([p.name for p in derivation.parameter_vector]),
        "functions": functions,
        "max_inputs": max(max(len(b.inputs) for b in table), 1),
        "max_outputs": max(len(b.outputs) for b in table),
        "macro": name.upper(), "contact_source": [c_string(line) for line in contact_source(derivation)],
    }


def render_extension(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The C source of the binding (it includes ``<name>_dynamics.h``), as text."""
    return render("code", TEMPLATE, extension_context(derivation), template_dir)
