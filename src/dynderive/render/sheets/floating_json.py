"""The JSON dump of a floating-base robot: the fixed-base dump's layout and names
(``render/json.py``) where they apply, in quasi-velocities.

``NQ`` and ``NV``, ``coordinates`` (NQ names), ``velocities`` and ``accelerations`` (NV names)
join the fixed-base keys. A small robot's ``quantities`` (``mechanics/quasi_velocity.py``):
``T_g``, ``V_g``, ``Y_g``, ``M_g``, ``C_g`` (Pinocchio's Coriolis matrix), ``N_g`` (gravity
and springs: not ``dV/dq``, the velocities being quasi-velocities), ``EOM_g2``
(``M vdot + C v + N - Y``), ``Q_g`` (``qdot = Q_g v``) and the body Jacobians ``J_b1, ...``.
A large robot's (the sheet's intermediate-variable form) ``M_g``, ``N_g`` and ``EOM_g2`` over
``intermediates`` ``_w1, _w2, ...``, the lines of the module's programs. No Lagrange's
equations (``EOM_g1``, ``L_g``) and no checks: the quaternion is not a generalized coordinate
of Lagrange's path (``dynderive check`` runs the module's checks).
"""

from __future__ import annotations

import json

import sympy

from ...derivation import Derivation
from .floating_latex import FloatingFormatter, _names_of, dissipative_forces, program_listing
from .json import quantity_entry
from ..printers import RememberingStrPrinter

DESCRIPTIONS = {
    "T_g": "kinetic energy 1/2 v^T M v",
    "V_g": "potential energy (gravity and springs)",
    "Y_g": "applied generalized forces (each effort at its velocity column)",
    "M_g": "mass matrix in the velocity coordinates v (NV x NV)",
    "C_g": "Coriolis matrix (Pinocchio's computeCoriolisMatrix; Mdot - 2 C skew-symmetric)",
    "N_g": "generalized gravity and spring forces (NV)",
    "EOM_g2": "equations of motion M vdot + C v + N + F - Y (= 0)",
    "F_g": "dissipative forces b v + fc sign(v) of the joints' damping and Coulomb friction (NV)",
    "Q_g": "configuration rate: qdot = Q_g v (NQ x NV)",
}


def render_floating_json(derivation: Derivation) -> str:
    robot, table = derivation.robot, derivation.symbols
    steps = derivation.quasi_velocity_steps
    small = steps.sheet is not None
    groups, outputs = ([], {}) if small else program_listing(derivation)
    fmt = FloatingFormatter.of(derivation, exact=True, lines=_names_of(groups))
    printer = RememberingStrPrinter({"order": fmt.order or "lex"})
    nv = len(table.qd)
    values: dict[str, object] = {}
    if small:
        sheet = steps.sheet
        values = {"T_g": sheet.T, "V_g": sheet.V, "Y_g": sheet.Y, "M_g": sheet.M, "C_g": sheet.C, "N_g": sheet.N,
                  "EOM_g2": sheet.EOM, "Q_g": sheet.rate}
        values |= {f"J_b{link.index}": link.jacobian for link in sheet.links}
    else:
        Y = sympy.Matrix(steps.efforts)
        values = {"Y_g": Y, "M_g": sympy.Matrix(nv, nv, outputs["M"]), "N_g": sympy.Matrix(outputs["N"]),
                  "EOM_g2": sympy.Matrix(outputs["tau"]) + dissipative_forces(derivation) - Y}
    if robot.dissipative:
        values["F_g"] = dissipative_forces(derivation)

    def description(name: str) -> str:
        if name.startswith("J_b"):
            link = robot.links[int(name[3:]) - 1].name
            return (f"body Jacobian of link {name[3:]} ({link}): the twist (v, omega) of its centre of mass in "
                    "the link's own axes per velocity coordinate")
        return DESCRIPTIONS[name]

    where_q, where_v = robot.offsets()
    document = {
        "robot": robot.name,
        "floating": True,
        "NQ": len(table.q),
        "NV": nv,
        "coordinates": [str(s) for s in table.q],
        "velocities": [str(s) for s in table.qd],
        "accelerations": [str(s) for s in table.qdd],
        "joints": {j.name: ({"type": j.type, "q": where_q[j.name], "v": where_v[j.name]} if j.owns else
                            {"type": j.type, "mimic": dict(zip(("joint", "multiplier", "offset"), robot.driver(j)))})
                   for j in robot.joints if j.moves},
        "efforts": list(robot.efforts),
        "parameters": {p.name: p.value for p in robot.parameters},
        "degrees_of_freedom": nv,
        "quantities": {name: quantity_entry(value, fmt, description(name), printer) for name, value in values.items()},
        **({"intermediates": {str(name): quantity_entry(value, fmt, printer=printer)
                              for _, lines in groups for name, value in lines}} if groups else {}),
        "checks": [],
    }
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"
