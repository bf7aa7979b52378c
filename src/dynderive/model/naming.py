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
    if not stem:  # a name of digits only cannot happen (identifiers), keep it whole
        return name, ""
    return stem, digits


def velocity_name(name: str) -> str:
    """``q1`` -> ``qd1``; ``phi2`` -> ``phid2``; ``x`` -> ``xd``."""
    stem, digits = split_index(name)
    return f"{stem}d{digits}"


def acceleration_name(name: str) -> str:
    """``q1`` -> ``qdd1``; ``phi2`` -> ``phidd2``; ``x`` -> ``xdd``."""
    stem, digits = split_index(name)
    return f"{stem}dd{digits}"


def maximal_coordinate_names(link_count: int) -> list[str]:
    """Planar maximal coordinates: ``x<k>, y<k>, phi<k>`` of each link's COM frame."""
    return [f"{v}{k}" for k in range(1, link_count + 1) for v in ("x", "y", "phi")]


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
