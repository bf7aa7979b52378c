"""What every target prints of the constrained solves the same way: which robots get contact
dynamics (``contacts_built``), the loop solve's sizes (``loop_sizes``) and the Baumgarte gains
the compiled targets take beside the parameters (``BAUMGARTE``)."""

from __future__ import annotations

from ...derivation import Derivation

#: A loop robot's Baumgarte gains: (name, default as a C literal, what it does).
BAUMGARTE = (("alpha", "0.0", "Baumgarte gain of forward_dynamics: - 2 alpha A qd (0: none)"),
             ("beta", "0.0", "Baumgarte gain of forward_dynamics: - beta^2 a(q) (0: none)"))


def contacts_built(derivation: Derivation) -> bool:
    """Contact dynamics concern 3-D robots without closed loops (as in the NumPy module)."""
    return not derivation.robot.planar and not derivation.robot.loops


def loop_sizes(derivation: Derivation) -> tuple[int, int, int]:
    """(NV, NC, rank of the loop rows)."""
    return (len(derivation.symbols.q), derivation.quantities["a_g"].shape[0], derivation.steps["loops"].rank)
