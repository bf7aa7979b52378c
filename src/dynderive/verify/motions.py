"""The motions a robot's closed loops allow at a configuration (the null space of the generated
module's loop Jacobian): the checks' and ``simulate``'s velocities on the loops, and the MuJoCo
row's states."""

from __future__ import annotations

from typing import Any

import numpy as np


def loop_drift(module: Any, q: np.ndarray, qd: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """Adot qd of the loop rows: the module's own (quaternions in q) or loop_jacobian_dot times qd."""
    if hasattr(module, "loop_jacobian_dot_qd"):
        return module.loop_jacobian_dot_qd(q, qd, **values)
    return module.loop_jacobian_dot(q, qd, **values) @ qd


def allowed_velocity(module: Any, q: np.ndarray, qd: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """``qd`` projected onto the motions the loops allow at ``q``."""
    null = allowed_motions(module, q, values)
    return null.T @ (null @ qd)


def allowed_motions(module: Any, q: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """Orthonormal rows spanning the motions the loops allow at ``q``: the null space of A_g,
    of dimension the mobility (the rows of an over-constrained mechanism's A_g are dependent)."""
    A = module.loop_jacobian(q, **values)
    _, sigma, rows = np.linalg.svd(A)
    if hasattr(module, "INDEPENDENT_COORDINATES"):
        return rows[A.shape[1] - len(module.INDEPENDENT_COORDINATES):]
    # quaternions in q (no independent coordinates): the rank of A_g here, as the module's solve takes it
    return rows[int(np.sum(sigma > 1e-7 * max(float(sigma[0]) if len(sigma) else 0.0, 1e-300))):]
