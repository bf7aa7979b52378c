"""The generated API, written once: each function's name, its arguments, the shapes of its
results and what it computes.

Every code target prints its functions from this table (the names, the argument order, the
one-line summary) and states the shapes in its own idiom: ``shape (..., 3, 3)`` in Python
docstrings (NumPy, JAX, the C extension), ``3 x 3, row-major`` in C comments, ``3 x 3`` in
MATLAB help. ``verify`` compares the targets function by function over the same table, and
the tests hold every generated NumPy module to it (names, arguments, result shapes), so a
function added here and to one target is missing, visibly, from the others.

Sizes are letters resolved per robot (``sizes``): NQ coordinates, NV velocities, NU efforts,
NP regressor parameters, NC loop constraints, NI independent coordinates of a
loop robot, NM maximal coordinates and NK their constraints (a planar robot), S the side of a
frame's homogeneous matrix and T its twist, 2NV the state, NF the forces of the robot file's
contacts (3 per point contact, 6 per surface contact).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..derivation import Derivation


@dataclass(frozen=True)
class Function:
    """One function of the generated API. ``arguments``: its positional arrays in order
    (``frame``: a frame's name, not an array); ``results``: the shape of each result for one
    state, in size letters; ``pinocchio``: the function of Pinocchio that computes the same
    (the tests compare them); ``group``: which robots have it ("dynamics": every robot,
    "frames": every robot, raising for a name that is no frame, "centroidal": 3-D robots, "loops": closed loops,
    "configuration": a robot with quaternions, "maximal": a planar robot's maximal form,
    "contacts": a 3-D robot)."""

    name: str
    arguments: tuple[str, ...]
    results: tuple[tuple[str, ...], ...]
    summary: str
    group: str = "dynamics"
    pinocchio: str = ""


def _f(name: str, arguments: str, results: str, summary: str, group: str = "dynamics",
       pinocchio: str = "") -> Function:
    """A row from compact text: arguments space-separated, results ``;``-separated shapes."""
    shapes = tuple(tuple(part.split()) for part in results.split(";"))
    return Function(name, tuple(arguments.split()), shapes, summary, group, pinocchio)


#: The API in the NumPy module's order.
API: tuple[Function, ...] = (
    _f("mass_matrix", "q", "NV NV", "Mass matrix M_g(q)", pinocchio="crba"),
    _f("coriolis_matrix", "q qd", "NV NV", "Coriolis matrix C_g(q, qd), dM/dt - 2 C_g skew-symmetric",
       pinocchio="computeCoriolisMatrix"),
    _f("gravity_vector", "q", "NV", "Gravity vector N_g(q), the gradient of V_g", pinocchio="computeGeneralizedGravity"),
    _f("generalized_forces", "q u", "NV", "Applied generalized forces Y_g(q, u) of the efforts"),
    _f("inverse_dynamics", "q qd qdd", "NV", "Generalized forces Y_g = M qdd + C qd + N + F by recursive "
       "Newton-Euler", pinocchio="rnea"),
    _f("forward_dynamics", "q qd u", "NV", "Accelerations qdd solving M qdd = Y_g(u) - C qd - N - F",
       pinocchio="aba"),
    _f("kinetic_energy", "q qd", "", "Kinetic energy T_g = 1/2 qd^T M(q) qd", pinocchio="computeKineticEnergy"),
    _f("potential_energy", "q", "", "Potential energy V_g(q) of gravity and the springs",
       pinocchio="computePotentialEnergy"),
    _f("friction_forces", "qd", "NV", "Dissipative forces F_g = b qd + fc sign(qd) (tanh(qd / friction_smoothing) "
       "when it is positive)"),
    _f("linearize", "q qd u", "2NV 2NV; 2NV NU", "(A, B) of xdot = A dx + B du about x = (q, qd) and u"),
    _f("inverse_dynamics_derivatives", "q qd qdd", "NV NV; NV NV", "(dtau/dq, dtau/dqd) of inverse_dynamics",
       pinocchio="computeRNEADerivatives"),
    _f("forward_dynamics_derivatives", "q qd u", "NV NV; NV NV; NV NU", "(dqdd/dq, dqdd/dqd, dqdd/du) of "
       "forward_dynamics, linearize's lower blocks", pinocchio="computeABADerivatives"),
    _f("regressor", "q qd qdd", "NV NP", "Regressor Y(q, qd, qdd): Y pi equals inverse_dynamics(q, qd, qdd), pi "
       "from parameter_vector"),
    _f("parameter_vector", "", "NP", "The parameter vector pi of regressor (names: PARAMETER_VECTOR)"),
    _f("frame_transform", "q frame", "S S", "Pose of a frame in the world, [[R, p], [0, 1]]", "frames"),
    _f("frame_jacobian", "q frame", "T NV", "World-frame Jacobian of a frame: linear rows, then angular", "frames",
       "getFrameJacobian"),
    _f("frame_jacobian_dot_qd", "q qd frame", "T", "Jdot(q, qd) qd of a frame (its acceleration at qdd = 0)",
       "frames"),
    _f("total_mass", "", "", "Total mass of the moving links", "centroidal", "computeTotalMass"),
    _f("center_of_mass", "q", "3", "Centre of mass of the moving links in the world", "centroidal", "centerOfMass"),
    _f("center_of_mass_velocity", "q qd", "3", "Velocity of the centre of mass in the world", "centroidal",
       "centerOfMass"),
    _f("center_of_mass_jacobian", "q", "3 NV", "Jacobian of the centre of mass: its velocity per velocity",
       "centroidal", "jacobianCenterOfMass"),
    _f("center_of_mass_acceleration_bias", "q qd", "3", "Jdot(q, qd) qd of the centre of mass (its acceleration at "
       "qdd = 0)", "centroidal", "centerOfMass"),
    _f("centroidal_momentum_matrix", "q", "6 NV", "Centroidal momentum matrix A_G(q): linear, then angular "
       "momentum about the centre of mass, world axes", "centroidal", "ccrba"),
    _f("centroidal_momentum", "q qd", "6", "Centroidal momentum h_G = A_G qd: linear, then angular about the centre "
       "of mass", "centroidal", "computeCentroidalMomentum"),
    _f("centroidal_momentum_bias", "q qd", "6", "Adot_G(q, qd) qd, the rate of h_G at qdd = 0", "centroidal",
       "computeCentroidalMomentumTimeVariation"),
    _f("centroidal_inertia", "q", "6 6", "Composite inertia of the moving links about the centre of mass, world "
       "axes: [[m 1, 0], [0, I_G]]", "centroidal", "ccrba"),
    _f("loop_constraints", "q", "NC", "Loop constraints a_g(q) (zero when the loops are closed)", "loops"),
    _f("loop_jacobian", "q", "NC NV", "Loop constraint Jacobian A_g(q) = da_g/dq", "loops"),
    _f("loop_jacobian_dot", "q qd", "NC NV", "Its time derivative Adot_g(q, qd)", "loops"),
    _f("loop_jacobian_dot_qd", "q qd", "NC", "Adot qd, the loop rows' acceleration at qdd = 0 (floating base, spherical "
       "joints: the loops' rows on the tree's twists)", "loops"),
    _f("loop_forces", "q qd u", "NC", "Loop multipliers lambda_g: A_g^T lambda_g is the generalized force the loop "
       "joints exert (forward_dynamics' system with alpha = beta = 0)", "loops"),
    _f("reduced_basis", "q", "NV NI", "R_g(q): the motions the loops allow, qd = R_g qd_i with qd_i the velocities "
       "of INDEPENDENT_COORDINATES", "loops"),
    _f("reduced_forward_dynamics", "q qd u", "NV", "Accelerations qdd by the reduced form R_g^T M R_g qdd_i = R_g^T "
       "(Y - C qd - N - F - M s), qdd = R_g qdd_i + s (forward_dynamics with alpha = beta = 0 on the constraints)",
       "loops"),
    _f("assemble", "q_guess", "NQ", "The configuration on the loop constraints a_g(q) = 0 nearest the guess by "
       "Newton's method, keeping INDEPENDENT_COORDINATES", "loops"),
    _f("neutral_configuration", "", "NQ", "The neutral configuration (Pinocchio's neutral): zeros, and identity "
       "quaternions", "configuration"),
    _f("integrate", "q v dt", "NQ", "The configuration reached from q moving at v for dt (Pinocchio's "
       "integrate(q, v dt))", "configuration"),
    _f("configuration_rate", "q v", "NQ", "dq/dt of the configuration q moving at velocity v", "configuration"),
    _f("difference", "q_from q_to", "NV", "The velocity v that integrate turns q_from into q_to in unit time "
       "(Pinocchio's difference)", "configuration"),
    _f("maximal_mass_matrix", "qm", "NM NM", "Mass matrix M_m(qm) in maximal coordinates", "maximal"),
    _f("maximal_coriolis_matrix", "qm qmd", "NM NM", "Coriolis matrix C_m(qm, qmd)", "maximal"),
    _f("maximal_gravity_vector", "qm", "NM", "Gravity vector N_m(qm)", "maximal"),
    _f("maximal_efforts", "qm u", "NM", "Joint efforts as forces on the links, Y_m(qm, u)", "maximal"),
    _f("constraints", "qm", "NK", "Holonomic constraints a_m(qm) (zero when they hold)", "maximal"),
    _f("constraint_jacobian", "qm", "NK NM", "Constraint Jacobian A_m(qm) = da/dqm", "maximal"),
    _f("constraint_jacobian_dot", "qm qmd", "NK NM", "Time derivative Adot_m(qm, qmd)", "maximal"),
    _f("maximal_kinetic_energy", "qm qmd", "", "Kinetic energy T_m(qm, qmd)", "maximal"),
    _f("maximal_potential_energy", "qm", "", "Potential energy V_m(qm)", "maximal"),
    _f("to_maximal", "q", "NM", "Change of basis qm = h(q)", "maximal"),
    _f("to_maximal_jacobian", "q", "NM NV", "Its Jacobian H(q) = dh/dq (qmd = H qd)", "maximal"),
    _f("maximal_friction_forces", "qm qmd", "NM", "Dissipative forces F_m(qm, qmd) of the joints' damping and "
       "friction on the links (exact sign)", "maximal"),
    _f("constraint_forces", "qm qmd u", "NK", "Multipliers lambda_m of the maximal form's constraints", "maximal"),
    _f("maximal_forward_dynamics", "qm qmd u", "NM", "Constrained accelerations qmdd of the maximal form",
       "maximal"),
    _f("constrained_forward_dynamics", "q qd u", "NV; NF", "(qdd, forces) with the contacts held: [[M, J^T], "
       "[J, 0]] [qdd; -forces] = [tau - h; -gamma]", "contacts", "forwardDynamics"),
    _f("impulse_dynamics", "q qd_minus", "NV; NF", "(qd_plus, impulses) of an impact on the contacts: M (qd_plus "
       "- qd_minus) = J^T impulses, J qd_plus = -restitution J qd_minus", "contacts", "impulseDynamics"),
)
BY_NAME = {function.name: function for function in API}
#: The size of each argument's last axis (``dt``: a number per state; ``frame``: a name).
ARGUMENT_SIZES = {"q": "NQ", "qd": "NV", "qdd": "NV", "u": "NU", "v": "NV", "dt": None, "q_guess": "NQ",
                  "q_from": "NQ", "q_to": "NQ", "qm": "NM", "qmd": "NM", "frame": None,
                  "qd_minus": "NV"}


def group(name: str) -> tuple[str, ...]:
    """The names of one group of the API, in order."""
    return tuple(function.name for function in API if function.group == name)


def sizes(derivation: Derivation) -> dict[str, int]:
    """The size letters of ``derivation``'s robot."""
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    nv = len(table.qd)
    rows = derivation.loop_rows   # (k, rank) with loops
    return {"NQ": len(table.q), "NV": nv, "NU": len(table.efforts), "NP": len(derivation.parameter_vector),
            "NC": rows[0] if rows else 0,
            "NI": len(derivation.loop_model.independent) if robot.loops and not robot.floating else 0,
            "NM": len(table.qm) if robot.planar else 0,
            "NK": quantities["a_m"].shape[0] if robot.planar else 0,
            "S": 3 if robot.planar else 4, "T": 3 if robot.planar else 6, "2NV": 2 * nv, "3": 3, "6": 6,
            "NF": sum(3 if c.kind == "point" else 6 for c in robot.contacts)}


def shapes(name: str, size: dict[str, Any]) -> tuple[tuple[Any, ...], ...]:
    """The shapes of ``name``'s results for one state, in numbers."""
    return tuple(tuple(size[letter] for letter in shape) for shape in BY_NAME[name].results)


def python_doc(name: str, size: dict[str, Any], batch: bool = True) -> str:
    """The summary with its Pinocchio counterpart and its shapes as a Python docstring states
    them: ``shape (..., 3, 3)`` (``batch`` False: no batch axes, as ``parameter_vector``'s;
    ``size`` may hold letters, ``shape (..., NV, NV)``)."""
    texts = []
    for shape in shapes(name, size):
        axes = (["..."] if batch else []) + [str(n) for n in shape]
        texts.append(f"({', '.join(axes)}{',' if len(axes) == 1 and not batch else ''})")
    word = "shape" if len(texts) == 1 else "shapes"
    row = BY_NAME[name]
    counterpart = f" (Pinocchio's ``{row.pinocchio}``)" if row.pinocchio else ""
    return f"{row.summary}{counterpart}, {word} {' and '.join(texts)}."


def described(name: str, size: dict[str, int], vector: str, matrix: str = "") -> str:
    """The summary with its dimensions as a comment states them: ``3 x 3`` and a vector as
    ``vector`` (C: "{n} entries", MATLAB: "{n} x 1"), then ``matrix`` if a result is a matrix
    (C: ", row-major"); no full stop, so a target can go on."""
    results = [shape for shape in shapes(name, size) if shape]
    if not results:
        return BY_NAME[name].summary
    dims = [" x ".join(map(str, shape)) if len(shape) != 1 else vector.format(n=shape[0]) for shape in results]
    return f"{BY_NAME[name].summary}, {' and '.join(dims)}{matrix if any(len(s) > 1 for s in results) else ''}"
