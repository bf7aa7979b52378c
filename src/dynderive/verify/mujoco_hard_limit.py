"""MuJoCo's constrained accelerations in the hard limit of its ``connect`` equalities, built from
its own data (the reference for a robot whose loops dynderive closes exactly).

MuJoCo's equalities are soft: its impedance is at most 0.9999, so its ``qacc`` keeps a relative
error of 1e-5 to 1e-4 however stiff ``solref`` is, and its reference acceleration leaves out
``Jdot qvel``. The limit it tends to is Gauss's principle on MuJoCo's pieces: the ``qacc``
closest to the unconstrained ``a0 = qacc_smooth`` in the metric ``M = mj_fullM`` with ``J qacc =
-Jdot qvel`` (``J``: the equalities' rows of ``efc_J``; ``Jdot qvel`` from ``mj_jacDot`` at the
two ends of each ``connect``). It is unique even where the rows are dependent (an
over-constrained linkage), where the multipliers are not: the solve is of least norm in the row
space, so no multiplier is needed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Singular values of ``J M^-1/2`` below this fraction of the largest are dependent rows.
RANK_TOLERANCE = 1e-9


def full_mass_matrix(model: Any, data: Any) -> np.ndarray:
    """``mj_fullM``'s dense M (MuJoCo 4 takes the data, MuJoCo 3 the sparse ``qM``)."""
    import mujoco

    M = np.zeros((model.nv, model.nv))
    try:
        mujoco.mj_fullM(model, data, M)
    except TypeError:
        mujoco.mj_fullM(model, M, data.qM)
    return M


def connect_ends(model: Any, data: Any, e: int) -> tuple[tuple[int, np.ndarray], tuple[int, np.ndarray]]:
    """The two points a ``connect`` equality ties together, each as (body, world position):
    the anchors on two bodies, or the origins of two sites."""
    import mujoco

    first, second = int(model.eq_obj1id[e]), int(model.eq_obj2id[e])
    if int(model.eq_objtype[e]) == int(mujoco.mjtObj.mjOBJ_SITE):
        return tuple((int(model.site_bodyid[s]), data.site_xpos[s].copy()) for s in (first, second))  # type: ignore[return-value]
    anchors = (model.eq_data[e, 0:3], model.eq_data[e, 3:6])
    return tuple((body, data.xpos[body] + data.xmat[body].reshape(3, 3) @ anchor)  # type: ignore[return-value]
                 for body, anchor in zip((first, second), anchors))


def equality_rows(model: Any, data: Any) -> tuple[np.ndarray, np.ndarray]:
    """After ``mj_forward`` with dense Jacobians: the rows of ``efc_J`` of every active connect
    equality, stacked in MuJoCo's order, and the rows' acceleration at zero ``qacc``
    (``Jdot qvel``: the two ends' ``mj_jacDot`` times ``qvel``, first minus second)."""
    import mujoco

    nv = model.nv
    J = np.asarray(data.efc_J[:data.nefc * nv]).reshape(data.nefc, nv)
    rows = [r for r in range(data.nefc) if int(data.efc_type[r]) == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)]
    ids = np.array([int(data.efc_id[r]) for r in rows], dtype=int)
    drift = np.zeros(len(rows))
    for e in dict.fromkeys(ids.tolist()):   # each equality once, in MuJoCo's order
        if int(model.eq_type[e]) != int(mujoco.mjtEq.mjEQ_CONNECT):
            raise ValueError(f"equality {e} is not a connect: its rows' Jdot qvel is not built")
        rates = []
        for body, point in connect_ends(model, data, e):
            jacp = np.zeros((3, nv))
            mujoco.mj_jacDot(model, data, jacp, None, point, body)
            rates.append(jacp @ data.qvel)
        drift[ids == e] = rates[0] - rates[1]
    return J[rows], drift


def hard_limit(model: Any, data: Any, J: np.ndarray, jdot_v: np.ndarray) -> np.ndarray:
    """MuJoCo's constrained ``qacc`` in the hard limit: ``a0 + M^-1 J^T lambda`` with ``J qacc =
    -Jdot qvel``, as ``a0 + L^-T x`` with ``x`` the least-norm solution of ``J L^-T x = -Jdot qvel
    - J a0`` (``M = L L^T``): the same accelerations, without forming ``J M^-1 J^T`` (whose
    conditioning is the square) and with dependent rows dropped by their singular values."""
    M = full_mass_matrix(model, data)
    a0 = np.array(data.qacc_smooth)
    L = np.linalg.cholesky(M)
    JLinvT = np.linalg.solve(L, J.T).T   # J L^-T
    x = np.linalg.lstsq(JLinvT, -jdot_v - J @ a0, rcond=RANK_TOLERANCE)[0]
    return a0 + np.linalg.solve(L.T, x)
