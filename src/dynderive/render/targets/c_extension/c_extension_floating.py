"""The rows of the CPython binding (``c_extension.py``) for a floating-base robot:
the floating NumPy module's API (``render/targets/numpy/floating_code.py``) on the C functions of
``c_floating.py``. ``q`` has NQ entries, ``qd``, ``qdd`` and ``v`` NV; ``linearize`` works on
the tangent space (2 NV x 2 NV). The configuration-space functions (``neutral_configuration``,
``integrate``, ``difference``, ``configuration_rate``) take no parameters (``parameters``
False), and ``integrate``'s ``dt`` is a number per state (``number``, default 1.0).
``friction_forces``, ``friction_smoothing`` and ``wrenches=`` are the fixed-base binding's
(the C target's ``friction_forces`` and ``*_wrenches`` functions).
"""

from __future__ import annotations

from ....derivation import Derivation
from ..c.c_binding import Binding


def floating_bindings(derivation: Derivation) -> list[Binding]:
    """The extension's functions of a floating-base robot, in the order of its NumPy module."""
    nq, nv, nu = len(derivation.symbols.q), len(derivation.symbols.qd), len(derivation.symbols.efforts)
    count = len(derivation.parameter_vector)
    dissipative = derivation.robot.dissipative
    sign = dissipative and bool(derivation.programs["regressor"].extra_inputs)
    q, qd, qdd, u, v = ("q", nq), ("qd", nv), ("qdd", nv), ("u", nu), ("v", nv)
    return [
        Binding("mass_matrix", "mass_matrix", (q,), ((nv, nv),),
                "Mass matrix M(q) by the composite-rigid-body algorithm, shape (..., NV, NV) (Pinocchio's crba)."),
        Binding("coriolis_matrix", "coriolis_matrix", (q, qd), ((nv, nv),),
                "Coriolis matrix C(q, qd), shape (..., NV, NV) (Pinocchio's computeCoriolisMatrix)."),
        Binding("gravity_vector", "gravity_vector", (q,), ((nv,),),
                "Gravity vector N(q) (Newton-Euler at rest), shape (..., NV)."),
        Binding("inverse_dynamics", "inverse_dynamics", (q, qd, qdd), ((nv,),),
                "Generalized forces M qdd + C qd + N + F - sum J^T w by recursive Newton-Euler, shape (..., NV) "
                "(Pinocchio's rnea); the floating joint's entries are the wrench the base would need; wrenches: None "
                "or {frame: w} in world axes.", wrenches="inverse_dynamics_wrenches", smoothing=True,
                refuses_negative=dissipative),
        Binding("forward_dynamics", "forward_dynamics", (q, qd, u), ((nv,),),
                "Accelerations qdd solving M qdd = Y(u) - C qd - N - F + sum J^T w, shape (..., NV) (Pinocchio's "
                "aba); u=None: no effort. NaN where M is not positive definite.", returns="status", optional=True,
                wrenches="forward_dynamics_wrenches", smoothing=True, refuses_negative=dissipative),
        Binding("kinetic_energy", "kinetic_energy", (q, qd), ((),), "Kinetic energy T = 1/2 qd^T M qd, shape (...).",
                returns="value", scalar=True),
        Binding("potential_energy", "potential_energy", (q,), ((),),
                "Potential energy V(q) of gravity and the springs, shape (...).", returns="value"),
        Binding("friction_forces", "friction_forces", (qd,), ((nv,),),
                "Dissipative forces F = b qd + fc sign(qd) (tanh(qd / friction_smoothing) when it is positive), "
                "shape (..., NV), zero on a floating or spherical joint's entries.", smoothing=True,
                refuses_negative=dissipative),
        Binding("linearize", "linearize", (q, qd, u), ((2 * nv, 2 * nv), (2 * nv, nu)),
                "(A, B) of xdot = A dx + B du about x = (q, qd) and u on the tangent space (q perturbed as "
                "integrate(q, dq)), shapes (..., 2 NV, 2 NV) and (..., 2 NV, nu); NaN where M is not positive "
                "definite.", returns="status", optional=True, smoothing=True, refuses_negative=dissipative),
        Binding("regressor", "regressor", (q, qd, qdd), ((nv, count),),
                "Regressor Y(q, qd, qdd), shape (..., NV, len(PARAMETER_VECTOR)): Y @ parameter_vector() equals "
                "inverse_dynamics(q, qd, qdd).", smoothing=True, refuses_negative=sign),
        Binding("parameter_vector", "parameter_vector", (), ((count,),),
                "The regressor's parameters pi (PARAMETER_VECTOR), shape (len(PARAMETER_VECTOR),)."),
        Binding("frame_transform", "frame_transform", (q,), ((4, 4),),
                "Pose of frame (a name of FRAMES) in the world, [[R, p], [0, 1]], shape (..., 4, 4).",
                returns="status", frame=True),
        Binding("frame_jacobian", "frame_jacobian", (q,), ((6, nv),),
                "World-aligned Jacobian of frame (a name of FRAMES): linear rows, then angular, shape (..., 6, NV).",
                returns="status", frame=True),
        Binding("frame_jacobian_dot_qd", "frame_jacobian_dot_qd", (q, qd), ((6,),),
                "Jdot(q, qd) qd of frame (a name of FRAMES), world axes, shape (..., 6).", returns="status",
                frame=True),
        Binding("neutral_configuration", "neutral_configuration", (), ((nq,),),
                "The neutral configuration (Pinocchio's neutral): zeros, and identity quaternions, shape (NQ,).",
                parameters=False),
        Binding("integrate", "integrate", (q, v, ("dt", 1)), ((nq,),),
                "The configuration reached from q moving at v for dt (Pinocchio's integrate(q, v dt)), shape "
                "(..., NQ); dt: a number or an array of them (batch dimensions).", parameters=False, number="1.0"),
        Binding("configuration_rate", "configuration_rate", (q, v), ((nq,),),
                "dq/dt of the configuration q moving at velocity v, shape (..., NQ).", parameters=False),
        Binding("difference", "difference", (("q_from", nq), ("q_to", nq)), ((nv,),),
                "The velocity v that integrate turns q_from into q_to in unit time (Pinocchio's difference), shape "
                "(..., NV).", parameters=False),
    ]


__all__ = ["floating_bindings"]
