"""Which names a robot's symbols may take: none that the generated module uses (its
functions, arguments, ``np``, every Python built-in), none that clash, none that typeset
alike on the sheet; and which names its frames may take: none whose quantities (``J_<frame>``...)
would be one the engine derives (``J_b1``, ``R_g``). Part of validation (``schema.validate``
calls ``check_names`` and ``engine_quantities``, ``frames.read_frames`` calls ``check_frame``)."""

from __future__ import annotations

import builtins
from typing import Any

from ..model.expressions import RESERVED
from ..model.naming import (
    CENTROIDAL_QUANTITIES,
    FRAME_KINDS,
    GENERALIZED_QUANTITIES,
    LOOP_QUANTITIES,
    MAXIMAL_QUANTITIES,
    acceleration_name,
    body_jacobian_name,
    frame_quantity_names,
    latex_name,
    maximal_coordinate_names,
    velocity_name,
)
from ..model.robot import Joint, Link, Parameter
from .free_joints import planar_floating_names

#: Python's built-in names (``float``, ``range``, ``sum``, ``ValueError``...): a robot symbol
#: of that name would shadow them in the generated module. The names ``site`` adds are listed
#: too, so the set does not depend on how Python was started.
PYTHON_BUILTINS = frozenset(name for name in dir(builtins) if not name.startswith("_")) | {
    "copyright", "credits", "exit", "help", "license", "quit"}

#: Argument names of the generated functions, current and planned (DESIGN.md section 6).
API_ARGUMENTS = frozenset({"alpha", "beta", "frame", "wrenches", "q_guess", "friction_smoothing",
                           "contacts", "baumgarte", "anchors", "qd_minus", "restitution"})

#: Public names of the generated module planned in DESIGN.md section 6.
PLANNED_NAMES = frozenset({
    "friction_forces", "loop_constraints", "loop_jacobian", "loop_jacobian_dot", "loop_forces",
    "assemble", "FRAMES", "frame_transform", "frame_jacobian", "frame_jacobian_dot_qd",
    "linearize", "regressor", "PARAMETER_VECTOR", "parameter_vector", "maximal_kinetic_energy",
    "maximal_potential_energy", "generalized_forces", "maximal_forward_dynamics",
    "CONTACTS", "CONTACT_KINDS", "CONTACT_RANK_TOLERANCE", "constrained_forward_dynamics", "impulse_dynamics",
})

#: The generated functions' other arguments and locals, and the modules they use (listed in
#: docs/reference/names.md, which a test holds to this set).
MODULE_LOCALS = frozenset({"np", "numpy", "math", "q", "qd", "qdd", "u", "qm", "qmd", "p", "out", "result",
                           "world", "arrays", "batch"})

#: Names the generated module defines or uses; robot symbols may not take them.
MODULE_NAMES = API_ARGUMENTS | PLANNED_NAMES | PYTHON_BUILTINS | MODULE_LOCALS | frozenset({
    "PARAMETERS", "COORDINATES", "EFFORTS", "MAXIMAL_COORDINATES", "mass_matrix",
    "coriolis_matrix", "gravity_vector", "inverse_dynamics", "forward_dynamics",
    "kinetic_energy", "potential_energy", "generalized_forces", "maximal_mass_matrix",
    "maximal_coriolis_matrix", "maximal_gravity_vector", "maximal_efforts", "constraints",
    "constraint_jacobian", "constraint_jacobian_dot", "constraint_forces", "to_maximal",
    "to_maximal_jacobian", "maximal_forward_dynamics",
    "LOOPS", "INDEPENDENT_COORDINATES", "ASSEMBLED_CONFIGURATION", "reduced_basis", "reduced_forward_dynamics",
    "maximal_friction_forces",
})


def check_names(v: Any, parameters: list[Parameter], links: list[Link],
                 joints: list[Joint], planar: bool, loop_rows: int = 0) -> None:
    """Every symbol the derivation creates must be unique, free for the generated code, and
    typeset differently from every other symbol (``l1`` and ``l_1`` both print as l_{1})."""
    owners: dict[str, str] = {}
    typeset: dict[str, tuple[str, str]] = {}  # LaTeX -> (name, owner)
    first: dict[str, str] = {}   # name -> " (first at LINE:COL)" of a name the file gives

    def other(name: str, owner: str) -> str:
        return owner if owner.startswith("the ") else f"'{name}' ({owner})"

    def claim(name: str, owner: str, path: tuple[Any, ...], key: bool = False, dots: int = 0,
              base: str | None = None) -> bool:
        latex = latex_name(base or name, dots)
        if name in MODULE_NAMES:
            why = " (a Python built-in)" if name in PYTHON_BUILTINS else ""
            v.error(path, f"{owner}: name '{name}' is reserved by the generated module{why}", key=key)
        elif name.startswith("_"):
            v.error(path, f"{owner}: name '{name}' starts with '_', which the generated module keeps for "
                    "its own temporaries", key=key)
        elif name in RESERVED:
            v.error(path, f"{owner}: name '{name}' is a built-in function or constant", key=key)
        elif name in owners:
            v.error(path, f"{owner}: name '{name}' clashes with {owners[name]}{first.get(name, '')}", key=key)
        elif latex in typeset:
            earlier, earlier_owner = typeset[latex]
            v.error(path, f"{owner}: name '{name}' is typeset as {latex}, the same as "
                    f"{other(earlier, earlier_owner)}{first.get(earlier, '')}", key=key)
        else:
            owners[name] = owner
            typeset[latex] = (name, owner)
            first[name] = f" (first at {v.at(path, key)})"
            return True
        return False

    def claim_coordinate(name: str, owner: str, label: str, path: tuple[Any, ...]) -> bool:
        """A coordinate and, once it is free, its velocity and acceleration."""
        if not claim(name, owner, path):
            return False
        for dots, (what, derived) in enumerate((("velocity", velocity_name(name)),
                                                 ("acceleration", acceleration_name(name))), start=1):
            claim(derived, f"{label} ({what} '{derived}')", path, dots=dots, base=name)
        return True

    if planar:  # names the maximal-coordinate derivation creates come first
        for name in maximal_coordinate_names(len(links)):
            for dots, derived in enumerate((name, velocity_name(name), acceleration_name(name))):
                owners[derived] = f"the maximal coordinate '{derived}'"
                typeset[latex_name(name, dots)] = (derived, owners[derived])
    multipliers = [(f"lambda{k}", "multiplier") for k in range(1, 3 * len(links) + 1)] if planar else []
    multipliers += [(f"lambda_g{k}", "loop multiplier") for k in range(1, loop_rows + 1)]   # of the loops
    for name, what in multipliers:
        owners[name] = f"the {what} '{name}'"
        typeset[latex_name(name)] = (name, owners[name])
    for p in parameters:
        claim(p.name, f"parameters.{p.name}", ("parameters", p.name), key=True)
    seen_joints: set[str] = set()
    for i, joint in enumerate(joints):
        if not joint.moves or joint.name in seen_joints:  # a duplicate name is reported once, where found
            continue
        seen_joints.add(joint.name)
        path = ("joints", i, "name")
        label = v.label(path)
        if planar and joint.kind.free:   # three coordinates <joint>_x, _y, _theta
            for name in planar_floating_names(joint.name):
                claim_coordinate(name, f"{label} (coordinate '{name}')", label, path)
            continue
        if joint.kind.nq > 1:   # entries <joint>_<suffix>: universal, planar, spherical, floating
            coordinates, velocities, accelerations, _ = joint.kind.names(joint.name)
            for name in coordinates:   # a vector-space joint's rates are named from its coordinates
                if joint.kind.vector_space:
                    claim_coordinate(name, f"{label} (coordinate '{name}')", label, path)
                else:
                    claim(name, f"{label} (coordinate '{name}')", path)
            for name in (*velocities, *accelerations):
                claim(name, f"{label} (coordinate '{name}')", path)
            for name in joint.effort_names:   # e_1, e_2; e_fx ... e_tz
                claim(name, f"joints[{i}].effort ('{name}')", ("joints", i, "effort"))
            continue
        if claim_coordinate(joint.name, label, label, path) and joint.effort:
            claim(joint.effort, f"joints[{i}].effort", ("joints", i, "effort"))


#: A quantity name the engine derives -> (what it is, the path in the file of what brings it, or None).
EngineQuantities = dict[str, tuple[str, "tuple[Any, ...] | None"]]


def engine_quantities(links: list[Link], planar: bool, loops: bool) -> EngineQuantities:
    """The quantity names the engine derives for a robot of these links (in the file's order),
    whether planar and whether with loops: what each is, and where the file brings it in."""
    names: EngineQuantities = {name: ("a quantity of the equations of motion", None) for name in GENERALIZED_QUANTITIES}
    for k, link in enumerate(links, start=1):
        names[body_jacobian_name(k)] = (f"the body Jacobian of link {k} ('{link.name}')", ("links", k - 1, "name"))
    if loops:
        names |= {name: ("a quantity of the loops' equations", ("loops",)) for name in LOOP_QUANTITIES}
    if planar:
        names |= {name: ("a quantity of the maximal-coordinate equations", None) for name in MAXIMAL_QUANTITIES}
    else:
        names |= {name: ("a quantity of the centre of mass", None) for name in CENTROIDAL_QUANTITIES}
    return names


def check_frame(v: Any, name: str, path: tuple[Any, ...], planar: bool, engine: EngineQuantities) -> bool:
    """Refuse a frame name one of whose quantities is a quantity the engine derives (a frame
    ``b1`` would replace link 1's body Jacobian ``J_b1`` in the JSON; a 3-D frame ``g`` would
    be ``R_g``, the loops' reduced basis). False when refused."""
    for quantity in frame_quantity_names(name, planar):
        if quantity in engine:
            what, origin = engine[quantity]
            kind = FRAME_KINDS[quantity.partition("_")[0]]
            where = f" (first at {v.at(origin, key=origin == ('loops',))})" if origin is not None else ""
            v.report(path, f"frame '{name}' would name its {kind} '{quantity}', {what}; "
                     f"rename the frame{where}")
            return False
    return True
