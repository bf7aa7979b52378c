"""``<name>_derivation.m``: a MATLAB script that carries out the derivation with the Symbolic
Math Toolbox (Octave: the ``symbolic`` package), step by step in the order of the sheet and
under the reference's names (``T_g, V_g, L_g, Y_g, EOM_g1, M_g, C_g, N_g, EOM_g2``, then
``a_m, A_m, Adot_m, T_m, V_m, L_m, Y_m, EOM_m1, M_m, C_m, N_m, EOM_m2, lambdaVec, h, H,
EOM_g3``), ending with the checks the engine proves.

Only the inputs are printed from the engine: the links' centre-of-mass positions and
orientations (the kinematics), their generalized inertias, the applied forces, the loop and
maximal constraint functions and the frames' poses. Every derivation step (velocities,
energies, Lagrange's equations, Christoffel symbols, the constraint Jacobians, the
multipliers, the change of basis) is a MATLAB operation (``jacobian``, ``diff``, ``subs``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import sympy

from ....derivation import Derivation
from ....errors import Problem
from ...codegen.names import refuse
from ...encode import Code
from ...environment import render
from .matlab_names import matlab_problems
from .matlab_text import matlab_code, matlab_comment, matlab_string

SCRIPT_TEMPLATE = "matlab/derivation.m.j2"

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")


def _names(symbols: Any) -> str:
    return " ".join(str(s) for s in symbols)


def _column(symbols: Any) -> str:
    return "[" + "; ".join(str(s) for s in symbols) + "]"


def _links(derivation: Derivation) -> list[dict[str, Any]]:
    return [{"index": t.index, "name": matlab_comment(t.name), "com": matlab_code(sympy.Matrix(t.com_position)),
             "orientation": matlab_code(t.orientation), "inertia": matlab_code(t.spatial_inertia)}
            for t in derivation.generalized_steps["links"]]


def _drives(derivation: Derivation) -> list[dict[str, Any]]:
    return [{"index": d.coordinate + 1, "coordinate": str(derivation.symbols.q[d.coordinate]),
             "damping": matlab_code(d.damping), "friction": matlab_code(d.friction),
             "stiffness": matlab_code(d.stiffness), "rest": matlab_code(d.rest), "armature": matlab_code(d.armature)}
            for d in derivation.joint_drives]


def _frames(derivation: Derivation, omitted: list[str]) -> list[dict[str, Any]]:
    robot, quantities = derivation.robot, derivation.quantities
    frames = []
    for frame in robot.frames:
        if not _IDENTIFIER.match(frame.name) or len(frame.name) > 50:
            omitted.append(f"frame {frame.name}: its name is not a MATLAB identifier")
            continue
        orientation = quantities[f"theta_{frame.name}"][0, 0] if robot.planar else quantities[f"R_{frame.name}"]
        frames.append({"name": frame.name, "link": matlab_comment(frame.link),
                       "position": matlab_code(quantities[f"p_{frame.name}"]), "orientation": matlab_code(orientation)})
    return frames


def _maximal(derivation: Derivation) -> dict[str, Any]:
    table, q, robot = derivation.symbols, derivation.quantities, derivation.robot
    links = []
    for k, link in enumerate(robot.links):
        x, y, phi = table.qm[3 * k: 3 * k + 3]
        xd, yd, phid = table.qmd[3 * k: 3 * k + 3]
        links.append({"index": k + 1, "mass": matlab_code(table.expr(link.mass)),
                      "inertia": matlab_code(table.expr(link.inertia[0])),
                      "position": f"[{x}; {y}]", "velocity": f"[{xd}; {yd}]", "rate": str(phid)})
    a_m, Y_m = q["a_m"], q["Y_m"]   # the maximal model names the multipliers
    multipliers = table.multipliers
    return {
        "coordinates": _names(table.qm), "velocities": _names(table.qmd), "accelerations": _names(table.qmdd),
        "q_m": _column(table.qm), "qmd": _column(table.qmd), "qmdd": _column(table.qmdd),
        "multipliers": _names(multipliers), "lambda": _column(multipliers),
        "a_m": matlab_code(a_m), "Y_m": matlab_code(Y_m), "links": links,
        "from_file": robot.maximal_constraints is not None,
        "lambdaVec": "lambdaVec" in q,
        "EOM_g3": "EOM_g3" in q,
    }


def _checks(derivation: Derivation, maximal: bool, loops: bool) -> list[dict[str, Any]]:
    """The engine's checks as MATLAB expressions that must be zero (the ones the script derives)."""
    a_on_h, AH = "subs(a_m, q_m, h)", "subs(A_m, q_m, h)*H"
    if loops:
        a_on_h = f"{a_on_h} - [sym(zeros(size(a_m, 1) - size(a_g, 1), 1)); a_g]"
        AH = f"{AH} - [sym(zeros(size(a_m, 1) - size(a_g, 1), numel(q))); A_g]"
    expressions = {"EOM_g1 == EOM_g2": "EOM_g1 - EOM_g2", "a_m(h(q)) == 0": a_on_h,
                   "A_m(h(q)) H(q) == 0": AH, "EOM_m1 == EOM_m2": "EOM_m1 - EOM_m2",
                   "EOM_g3 == EOM_g1": "EOM_g3 - EOM_g1"}
    checks = []
    for check in derivation.checks:
        expression = expressions.get(check.name)
        if check.method == "skipped" or expression is None or (not maximal and check.name not in ("EOM_g1 == EOM_g2",)):
            continue
        checks.append({"name": matlab_comment(check.name), "description": matlab_comment(check.description),
                       "label": matlab_string(check.name), "expression": Code(expression)})
    return checks


def matlab_script_context(derivation: Derivation) -> dict[str, Any]:
    """What the script's template needs, every value printed or encoded already."""
    robot, table, quantities = derivation.robot, derivation.symbols, derivation.quantities
    omitted: list[str] = []
    large = derivation.intermediate_form
    drives = _drives(derivation) if not large else []
    loops = bool(robot.loops)
    maximal = robot.planar and not large and not drives
    if robot.planar and not maximal:
        omitted.append("the maximal-coordinate problem (a_m ... EOM_g3): "
                       + ("the robot is too large to expand" if large else
                          "its drive terms act through each joint's coordinate in maximal coordinates, "
                          "which this script does not write out; the sheet and the JSON have it"))
    if large:
        omitted.append(f"T_g, L_g, Lagrange's equations EOM_g1, M_g, C_g and EOM_g2: this robot "
                       f"({len(table.q)} coordinates) is too large to expand symbolically; the numeric "
                       "package and the generated modules compute them by recursive algorithms")
    if loops:
        omitted.append("the reduced form of the closed loops (R_g, M_r, C_r, N_r): the multiplier form "
                       "(EOM_g1, EOM_g2 with A_g.'*lambda_g) is derived instead")
    if maximal and "lambdaVec" not in quantities:
        omitted.append("lambdaVec in closed form: at this size it is not formed symbolically (the numeric "
                       "package evaluates it)")
    if large and robot.frames:
        omitted.append("the frames' poses and Jacobians (too large to expand)")
    frames = _frames(derivation, omitted) if robot.frames and not large else []
    parameters = [{"name": p.name, "comment": matlab_comment(
        ", ".join(x for x in (p.description, f"default {float(p.value)!r}" if p.value is not None else "",
                              p.unit) if x))} for p in robot.parameters]
    context: dict[str, Any] = {
        "name": robot.name, "title": matlab_comment(robot.title), "source": matlab_comment(Path(robot.source).name),
        "planar": robot.planar, "large": large, "n": len(table.q),
        "coordinates": _names(table.q), "velocities": _names(table.qd), "accelerations": _names(table.qdd),
        "q": _column(table.q), "qd": _column(table.qd), "qdd": _column(table.qdd),
        "parameters": parameters, "efforts": _names(table.efforts.values()),
        "gravity": matlab_code(sympy.Matrix([table.expr(e) for e in robot.gravity])),
        "links": _links(derivation) if not large else [],
        "drives": drives,
        "armature": any(d.armature != 0 for d in derivation.joint_drives) if drives else False,
        "dissipative": "F_g" in quantities and not large,
        "Y_g": matlab_code(quantities["Y_g"]),
        "loops": None, "frames": frames, "maximal": _maximal(derivation) if maximal else None,
        "omitted": [matlab_comment(o) for o in omitted],
    }
    if large:
        context["large_links"] = [{"index": k + 1, "name": matlab_comment(t.name), "com": matlab_code(t.com_world),
                                   "mass": matlab_code(table.expr(link.mass))}
                                  for k, (t, link) in enumerate(zip(derivation.link_kinematics, robot.links))]
    if loops:
        context["loops"] = {"a_g": matlab_code(quantities["a_g"]), "multipliers": _names(quantities["lambda_g"]),
                            "lambda": _column(quantities["lambda_g"])}
    context["checks"] = _checks(derivation, maximal, loops) if not large else []
    return context


#: A line of the script that assigns variables: ``x = ...``, ``x(i, j) = ...``, ``[a, b] = ...``,
#: ``for k = ...``.
_ASSIGNMENT = re.compile(r"^\s*(?:for\s+)?(\[[A-Za-z0-9_,\s~]*\]|[A-Za-z]\w*)\s*(?:\([^=]*\))?\s*=(?!=)")


def _clashes(derivation: Derivation, text: str) -> list[Problem]:
    """The robot's own names (parameters, coordinates, velocities, efforts: the script's
    ``syms``) that the script also assigns (``h``, ``H``, ``gvec``, ``n_``...), each at its
    place in the robot file: such a symbol would be overwritten mid-derivation."""
    assigned: set[str] = set()
    for line in text.splitlines():
        match = _ASSIGNMENT.match(line)
        if match:
            assigned |= set(re.findall(r"[A-Za-z]\w*", match.group(1)))
    robot, table = derivation.robot, derivation.symbols
    where = {p.name: robot.positions.get(f"parameter:{p.name}", (1, 1)) for p in robot.parameters}
    joints = [j for j in robot.joints if j.owns]
    for symbols in (table.q, table.qd, table.qdd):
        where |= {str(s): robot.positions.get(f"joint:{j.name}", (1, 1)) for s, j in zip(symbols, joints)}
    where |= {str(s): robot.positions.get("joints", (1, 1)) for s in table.efforts.values() if str(s) not in where}
    return [Problem(robot.source, *where[name], f"--matlab: '{name}' is also a variable of the derivation script "
                    f"(<name>_derivation.m assigns {name}), which would overwrite the symbol; rename it")
            for name in sorted(where) if name in assigned]


def render_matlab_script(derivation: Derivation, template_dir: str | Path | None = None) -> str:
    """The text of ``<name>_derivation.m`` (nothing written); ``InputError`` when a name of the
    robot cannot be a MATLAB name or is a variable the script assigns."""
    refuse(matlab_problems(derivation.robot))
    text = render("code", SCRIPT_TEMPLATE, matlab_script_context(derivation), template_dir)
    refuse(_clashes(derivation, text))
    return text
