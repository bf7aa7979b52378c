"""The NumPy module of a floating-base robot: ``mass_matrix``, ``coriolis_matrix``,
``gravity_vector``, ``inverse_dynamics``, ``forward_dynamics``, ``linearize``, ``regressor``
from the programs of ``mechanics/floating.py`` and ``floating_derivatives.py``, and
``NQ``, ``NV``, ``neutral_configuration``, ``integrate``, ``difference`` (Pinocchio's
conventions; also the module of a fixed-base robot with spherical joints), with the fixed-base
module's ``friction_forces`` (damping and Coulomb friction of the scalar joints, zero on the
floating and spherical joints' rows) and ``wrenches=`` (``sum J_f^T w_f`` over frames, world
axes, moment about the frame's origin) in ``inverse_dynamics`` and ``forward_dynamics``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import sympy

from ....derivation import Derivation
from ...encode import Code, python_literal
from ...python_module import render_module, render_test_module
from .code import Argument, program_function

TEMPLATE = "floating_dynamics.py.j2"
TEST_TEMPLATE = "floating_dynamics_test.py.j2"



def floating_context(derivation: Derivation) -> dict[str, Any]:
    """Every variable the floating-base module template uses."""
    from ...._version import __version__

    robot, table = derivation.robot, derivation.symbols
    nq, nv = len(table.q), len(table.qd)
    q = Argument("q", table.q, f"coordinates, shape (..., {nq})")
    qd = Argument("qd", table.qd, f"velocities, shape (..., {nv})")
    qdd = Argument("qdd", table.qdd, f"accelerations, shape (..., {nv})")
    u = Argument("u", list(table.efforts.values()), f"efforts, shape (..., {len(table.efforts)})")
    programs = derivation.programs   # the free-flyer programs (mechanics/floating.py)
    forward_args = [q, qd, u]
    if programs["forward_dynamics"].extra_inputs:   # damping, friction, frames: F - J^T w from the module
        forward_args.append(Argument("_friction", programs["forward_dynamics"].extra_inputs,
                                     f"friction_forces minus the frames' J^T w, shape (..., {nv})"))
    regressor_args = [q, qd, qdd]
    if programs["regressor"].extra_inputs:   # Coulomb friction's columns: sign(qd) or tanh(qd / eps)
        regressor_args.append(Argument("_sign", programs["regressor"].extra_inputs,
                                       f"sign(qd) or tanh(qd / eps), shape (..., {nv})"))
    specs = {
        "mass_matrix": ("_mass_matrix_body", "M(q), row by row: composite-rigid-body algorithm.", [q]),
        "gravity": ("_gravity_body", "N(q): Newton-Euler at rest.", [q]),
        "potential": ("_potential_body", "V(q): gravity along the tree, and the springs.", [q]),
        "inverse_dynamics": ("_inverse_dynamics_body", "M qdd + C qd + N: recursive Newton-Euler.", [q, qd, qdd]),
        "forward_dynamics": ("_forward_dynamics_body", "qdd: CRBA, Newton-Euler and an L^T D L solve of "
                             "M qdd = Y - C qd - N - F + sum J^T w.", forward_args),
        "coriolis": ("_coriolis_body", "C(q, qd), row by row: Pinocchio's computeCoriolisMatrix.", [q, qd]),
        "inverse_dynamics_derivatives": ("_inverse_dynamics_derivatives_body", "dtau/dq (along integrate), then "
                                         "dtau/dqd, row by row: Newton-Euler differentiated line by line.",
                                         [q, qd, qdd]),
        "regressor": ("_regressor_body", "Y(q, qd, qdd) with Y pi = inverse_dynamics, row by row.", regressor_args),
    }
    bodies = [program_function(*specs[key], program) for key, program in programs.items()]
    identification = derivation.parameter_vector
    bodies.append(program_function("_parameter_vector_body", "The parameter vector pi of regressor.", [],
                                   SimpleNamespace(lines=[], outputs=[p.value for p in identification])))
    if robot.dissipative:   # F = b qd + fc sign(qd): the coefficients per velocity column (0 on a quaternion's)
        for name, what in (("damping", "Viscous damping b"), ("friction", "Coulomb friction fc")):
            values = [sympy.Integer(0)] * nv
            for drive in derivation.joint_drives:
                values[drive.coordinate] = getattr(drive, name)
            bodies.append(program_function(f"_{name}_coefficients_body", f"{what} of each velocity entry.", [],
                                           SimpleNamespace(lines=[], outputs=values)))
    for index, (name, pose, jacobian, bias) in enumerate(derivation.frame_programs):
        bodies += [program_function(f"_frame{index}_transform_body", f"Pose of frame {name!r} (homogeneous, row by row).",
                                    [q], pose),
                   program_function(f"_frame{index}_jacobian_body", f"World-aligned Jacobian of frame {name!r}, "
                                    "row by row.", [q], jacobian),
                   program_function(f"_frame{index}_jacobian_dot_qd_body", f"Jdot qd of frame {name!r}, world axes.",
                                    [q, qd], bias)]
    where_q, where_v = robot.offsets()
    floating = [j.name for j in robot.joints if j.type == "floating"]
    spherical = [j.name for j in robot.joints if j.type == "spherical"]
    scalar = [j.name for j in robot.joints if j.owns and not j.multi]
    parameters = [{"name": p.name, "default": None if p.value is None else python_literal(float(p.value)),
                   "unit": p.unit, "description": p.description} for p in robot.parameters]
    return {
        "generator": f"dynderive {__version__}",
        "source": Path(robot.source).name,
        "robot": {"name": robot.name, "title": robot.title},
        "parameters": parameters,
        "coordinates_tuple": python_literal(tuple(str(s) for s in table.q)),
        "velocities_tuple": python_literal(tuple(str(s) for s in table.qd)),
        "efforts": list(robot.efforts),
        "efforts_tuple": python_literal(tuple(robot.efforts)),
        "nq": nq,
        "nv": nv,
        "floating_offsets": python_literal(tuple((where_q[n], where_v[n]) for n in floating)),
        "spherical_offsets": python_literal(tuple((where_q[n], where_v[n]) for n in spherical)),
        "spherical": bool(spherical),
        "floating_base": robot.floating_base,
        "scalar_q": Code(repr([where_q[n] for n in scalar])),
        "scalar_v": Code(repr([where_v[n] for n in scalar])),
        "effort_columns": python_literal(robot.effort_columns()),
        "programs": bodies,
        "frames": [{"name": f.name, "body": f"_frame{i}"} for i, f in enumerate(robot.frames)],
        "frames_tuple": python_literal(tuple(f.name for f in robot.frames)),
        "parameter_vector_tuple": python_literal(tuple(p.name for p in identification)),
        "parameter_count": len(identification),
        "dissipative": robot.dissipative,
        "forward_extra": bool(programs["forward_dynamics"].extra_inputs),
        "regressor_sign": bool(programs["regressor"].extra_inputs),
    }


def render_floating_code_tests(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The pytest file of property checks of a floating-base robot's module (``--tests``)."""
    return render_test_module(derivation, TEST_TEMPLATE, template_dir)


def render_floating_code(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The module's text, checked as ``render_code`` checks a fixed-base robot's."""
    return render_module(derivation, TEMPLATE, floating_context(derivation), template_dir)
