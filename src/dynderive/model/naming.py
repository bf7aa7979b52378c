"""How robot symbols are named and typeset: a leaf module (no dynderive imports).

The schema (which checks names), the symbol table (which creates the symbols) and the
renderers (which typeset them) all derive names here, so that a name the validator accepts
is exactly the symbol the derivation creates and the LaTeX the sheet prints.
"""

from __future__ import annotations

import re

GREEK = {
    "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
    "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
    "omega", "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Upsilon", "Phi", "Psi",
    "Omega",
}


def split_index(name: str) -> tuple[str, str]:
    """``q12`` -> ``("q", "12")``; ``theta`` -> ``("theta", "")``."""
    match = re.fullmatch(r"(.*?)(\d*)", name)
    assert match is not None
    stem, digits = match.group(1), match.group(2)
    return (stem, digits) if stem else (name, "")   # digits only cannot happen (identifiers): kept whole


def velocity_name(name: str) -> str:
    """``q1`` -> ``qd1``; ``phi2`` -> ``phid2``; ``x`` -> ``xd``.

    A name whose stem (the part before its trailing digits) ends in ``d`` gets ``_d`` after
    the whole name instead: ``d`` -> ``d_d``, ``d2`` -> ``d2_d`` (not ``dd``, ``dd2``, which
    read as accelerations of a coordinate without the ``d``)."""
    stem, digits = split_index(name)
    return f"{name}_d" if stem.endswith("d") else f"{stem}d{digits}"


def acceleration_name(name: str) -> str:
    """``q1`` -> ``qdd1``; ``phi2`` -> ``phidd2``; ``x`` -> ``xdd``; ``d2`` -> ``d2_dd``."""
    stem, digits = split_index(name)
    return f"{name}_dd" if stem.endswith("d") else f"{stem}dd{digits}"


def maximal_coordinate_names(link_count: int) -> list[str]:
    """Planar maximal coordinates: ``x<k>, y<k>, phi<k>`` of each link's COM frame."""
    return [f"{v}{k}" for k in range(1, link_count + 1) for v in ("x", "y", "phi")]


#: The engine's own quantity names (DESIGN.md section 4): what each is, by where it comes from.
GENERALIZED_QUANTITIES = ("T_g", "V_g", "L_g", "Y_g", "EOM_g1", "M_g", "C_g", "N_g", "EOM_g2", "D_g", "F_g")
#: Loop constraints and the reduced form (robots with ``loops``).
LOOP_QUANTITIES = ("a_g", "A_g", "Adot_g", "lambda_g", "R_g", "M_r", "C_r", "N_r", "Y_r", "EOM_r")
#: Maximal coordinates (planar robots).
MAXIMAL_QUANTITIES = ("q_m", "a_m", "A_m", "Adot_m", "T_m", "V_m", "L_m", "Y_m", "EOM_m1", "M_m", "C_m",
                      "N_m", "EOM_m2", "D_m", "F_m", "lambdaVec", "h", "H", "EOM_g3")
#: The centre of mass and the centroidal momentum matrix (3-D robots small enough for a step-by-step sheet).
CENTROIDAL_QUANTITIES = ("m_total", "p_G", "J_G", "A_G")
#: What a frame's quantities are, by the prefix of their names.
FRAME_KINDS = {"p": "position", "R": "rotation", "theta": "angle", "J": "Jacobian", "Jdot": "Jacobian's derivative"}


def body_jacobian_name(index: int) -> str:
    """The body Jacobian of the ``index``-th link (1-based, in the file's order): ``J_b1``."""
    return f"J_b{index}"


def body_jacobian_index(name: str, link_count: int) -> int | None:
    """``J_b2`` -> 2 when the robot has at least 2 links; None for any other name."""
    match = re.fullmatch(r"J_b([1-9][0-9]*)", name)
    return int(match.group(1)) if match and int(match.group(1)) <= link_count else None


def frame_quantity_names(frame: str, planar: bool) -> list[str]:
    """The quantities of a named frame: ``p_<f>``, ``theta_<f>`` (planar) or ``R_<f>``, ``J_<f>``, ``Jdot_<f>``."""
    return [f"{kind}_{frame}" for kind in ("p", "theta" if planar else "R", "J", "Jdot")]


def latex_name(name: str, dots: int = 0) -> str:
    """LaTeX for a symbol name, with ``dots`` time derivatives.

    ``latex_name("q1", 1)`` -> ``\\dot{q}_{1}``; ``phi2`` -> ``\\phi_{2}``;
    ``m_link`` -> ``m_{\\mathrm{link}}``; ``lc1`` -> ``\\mathrm{lc}_{1}``.
    """
    head, _, rest = name.partition("_")
    if not head:
        head, rest = name, ""
    stem, digits = (head, "") if rest else split_index(head)
    sub = digits or (rest if rest.isdigit() else (r"\mathrm{" + rest.replace("_", r"\_") + "}" if rest else ""))
    body = f"\\{stem}" if stem in GREEK else (stem if len(stem) == 1 else f"\\mathrm{{{stem}}}")
    if dots:
        body = "\\" + ("dot", "ddot")[dots - 1] + "{" + body + "}"
    return body + (f"_{{{sub}}}" if sub else "")


def closest_name(name: str, candidates) -> str | None:
    """The candidate a misspelt ``name`` most likely means, or None: one that differs only in
    case first (``L3`` -> ``l3``, which difflib alone rates too far apart), then difflib's
    closest match, compared case-insensitively."""
    import difflib

    options = [str(c) for c in candidates]
    same = [c for c in options if c.lower() == name.lower() and c != name]
    if same:
        return same[0]
    close = difflib.get_close_matches(name, options, n=1)
    if close:
        return close[0]
    lowered = {option.lower(): option for option in reversed(options)}   # the first spelling wins
    close = difflib.get_close_matches(name.lower(), list(lowered), n=1)
    return lowered[close[0]] if close else None


def did_you_mean(name: object, candidates) -> str:
    """`` (did you mean 'x'?)`` for the closest candidate (``closest_name``), or ``""``."""
    close = closest_name(str(name), candidates)
    return f" (did you mean '{close}'?)" if close is not None else ""


#: Where each quantity goes in ``Derivation.keys()`` (the sheet's and the JSON's order):
#: generalized, loops, reduced form (any other name), maximal; whatever stage ran first.
GENERALIZED_ORDER = ["T_g", "V_g", "L_g", "Y_g", "EOM_g1", "M_g", "C_g", "N_g", "EOM_g2", "D_g", "F_g"]
LOOP_KEYS = ["a_g", "A_g", "Adot_g", "lambda_g"]
MAXIMAL_MODEL_KEYS = ["q_m", "a_m", "A_m", "Adot_m", "T_m", "V_m", "L_m", "Y_m", "M_m", "C_m", "N_m",
                      "D_m", "F_m", "h", "H"]
MAXIMAL_EQUATION_KEYS = ["EOM_m1", "EOM_m2", "lambdaVec", "EOM_g3"]
MAXIMAL_ORDER = ["q_m", "a_m", "A_m", "Adot_m", "T_m", "V_m", "L_m", "Y_m", "EOM_m1", "M_m", "C_m", "N_m",
                 "EOM_m2", "D_m", "F_m", "lambdaVec", "h", "H", "EOM_g3"]


def quantity_rank(key: str, sequence: int) -> tuple[int, int]:
    """Where quantity ``key`` goes in that order; ``sequence``: how many were named before it."""
    if key in GENERALIZED_ORDER:
        return 0, GENERALIZED_ORDER.index(key)
    if key.startswith("J_b") and key[3:].isdigit():
        return 0, 100 + int(key[3:])
    if key in LOOP_KEYS:
        return 1, LOOP_KEYS.index(key)
    if key in MAXIMAL_ORDER:
        return 3, MAXIMAL_ORDER.index(key)
    return 2, sequence


#: What each quantity is, for the sheet, the terminal and the JSON consumers.
QUANTITY_DESCRIPTIONS = {
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
