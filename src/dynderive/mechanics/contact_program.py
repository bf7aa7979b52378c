"""Contact dynamics as programs every target prints (DESIGN.md section 11): the steps of
``constrained_forward_dynamics`` and ``impulse_dynamics`` over named arrays, written once here;
a target prints them with its printer and implements the few primitives below once in its shim.

A program calls the generated tree functions (``mass_matrix``, ``inverse_dynamics`` at qdd = 0,
``generalized_forces``, ``frame_jacobian``, ``frame_jacobian_dot_qd``, ``frame_transform``),
appends each held contact's rows by its kind (a point: the world-aligned rows 0..2 of the frame's
Jacobian and drift; a surface: blockdiag(R^T, R^T) J and the spatial acceleration at qdd = 0,
the classical one minus omega x v, rotated), forms the Baumgarte drift gamma and ends in one
``SchurSolve``: M x = b + J^T lam, J x = target, by the Schur complement S = J M^-1 J^T.

The vocabulary (``Node`` and the steps) is ``model/array_program.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..model.array_program import (
    HELD,
    Append,
    Call,
    ContactProgram,
    Let,
    SchurSolve,
    Step,
    array,
    cross,
    position,
    rotation,
    scale,
    stack,
    vee,
)


def _rows(n: int, velocity: str | None) -> tuple[tuple[Step, ...], list[Step], list[Step]]:
    """Every contact's calls (the frame's Jacobian and, given the velocity, its drift), then a
    point's and a surface's rows appended. Point: world-aligned rows 0..2; surface:
    blockdiag(R^T, R^T) J, the drift the spatial acceleration at qdd = 0 in the frame's axes,
    (a - omega x v, alpha) rotated."""
    jf, acc, pose, twist = array("Jf", 6, n), array("acc", 6), array("T", 4, 4), array("twist", 6)
    rt = rotation(pose).T
    contact: tuple[Step, ...] = (Call("Jf", "frame_jacobian", ("q", "frame"), (6, n)),)
    point: list[Step] = [Append("J", jf[0:3])]
    surface: list[Step] = [Call("T", "frame_transform", ("q", "frame"), (4, 4)),
                           Append("J", stack(rt @ jf[0:3], rt @ jf[3:6]))]
    if velocity:
        contact += (Call("acc", "frame_jacobian_dot_qd", ("q", velocity, "frame"), (6,)),)
        point.append(Append("drift", acc[0:3]))
        surface += [Let("twist", jf @ array(velocity, n)),
                    Append("drift", stack(rt @ (acc[0:3] - cross(twist[3:6], twist[0:3])), rt @ acc[3:6]))]
    return contact, point, surface


def constrained_forward_dynamics_program(n: int, floating: bool) -> ContactProgram:
    """M qdd = tau - h + J^T forces, J qdd = -gamma (Pinocchio's forwardDynamics), h =
    inverse_dynamics(q, qd, 0), gamma = drift + kd J qd + kp e (e the position error against
    the anchors: p - p_ref for a point; R^T (p - p_ref) and the vee of the skew part of
    R_ref^T R for a surface); ``floating``: tau is the efforts at their velocity columns
    (``effort_map``), else generalized_forces(q, u)."""
    contact, point, surface = _rows(n, "qd")
    pose, anchor = array("T", 4, 4), array("anchor", 4, 4)
    point += [Call("T", "frame_transform", ("q", "frame"), (4, 4), anchored=True),
              Append("error", position(pose) - array("anchor", 3), anchored=True)]
    surface += [Let("turn", rotation(anchor).T @ rotation(pose), anchored=True),
                Append("error", stack(rotation(pose).T @ (position(pose) - position(anchor)), vee(array("turn", 3, 3))),
                       anchored=True)]
    tau = Call("tau", "effort_map", ("u",), (n,)) if floating else Call("tau", "generalized_forces", ("q", "u"), (n,))
    gamma = array("gamma", HELD)
    return ContactProgram(
        "constrained_forward_dynamics", ("q", "qd", "u"), ("kp", "kd"),
        setup=(Call("M", "mass_matrix", ("q",), (n, n)), Call("h", "inverse_dynamics", ("q", "qd", "zeros"), (n,)),
               tau),
        contact=contact, point=tuple(point), surface=tuple(surface),
        finish=(Let("gamma", array("drift", HELD) + scale("kd", array("J", HELD, n) @ array("qd", n))),
                Let("gamma", gamma + scale("kp", array("error", HELD)), anchored=True),
                SchurSolve("qdd", "forces", "M", "J", array("tau", n) - array("h", n), -gamma)),
        outputs=("qdd", "forces"), anchors=True)


def impulse_dynamics_program(n: int) -> ContactProgram:
    """M (qd_plus - qd_minus) = J^T impulses, J qd_plus = -restitution J qd_minus (Pinocchio's
    impulseDynamics): the jump dqd solves M dqd = J^T impulses, J dqd = -restitution J qd_minus
    - J qd_minus."""
    contact, point, surface = _rows(n, None)
    rate = array("rate", HELD)
    return ContactProgram(
        "impulse_dynamics", ("q", "qd_minus"), ("restitution",),
        setup=(Call("M", "mass_matrix", ("q",), (n, n)),),
        contact=contact, point=tuple(point), surface=tuple(surface),
        finish=(Let("rate", array("J", HELD, n) @ array("qd_minus", n)),
                SchurSolve("jump", "impulses", "M", "J", None, -scale("restitution", rate) - rate),
                Let("qd_plus", array("qd_minus", n) + array("jump", n))),
        outputs=("qd_plus", "impulses"), anchors=False)


@dataclass(frozen=True)
class ContactPrograms:
    """The two programs of a robot with contact dynamics (3-D, without closed loops)."""

    constrained_forward_dynamics: ContactProgram
    impulse_dynamics: ContactProgram

    def __iter__(self):
        return iter((self.constrained_forward_dynamics, self.impulse_dynamics))


def contact_programs(n: int, floating: bool) -> ContactPrograms:
    """Both programs for NV = ``n``; ``floating``: a base whose velocity is not its
    configuration's derivative (quaternions), whose efforts act at their columns."""
    return ContactPrograms(constrained_forward_dynamics_program(n, floating), impulse_dynamics_program(n))
