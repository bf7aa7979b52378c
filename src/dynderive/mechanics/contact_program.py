"""Contact dynamics as programs every target prints (DESIGN.md section 11): the steps of
``constrained_forward_dynamics`` and ``impulse_dynamics`` over named arrays, written once here;
a target prints them with its printer and implements the few primitives below once in its shim.

A program calls the generated tree functions (``mass_matrix``, ``inverse_dynamics`` at qdd = 0,
``generalized_forces``, ``frame_jacobian``, ``frame_jacobian_dot_qd``, ``frame_transform``),
appends each held contact's rows by its kind (a point: the world-aligned rows 0..2 of the frame's
Jacobian and drift; a surface: blockdiag(R^T, R^T) J and the spatial acceleration at qdd = 0,
the classical one minus omega x v, rotated), forms the Baumgarte drift gamma and ends in one
``SchurSolve``: M x = b + J^T lam, J x = target, by the Schur complement S = J M^-1 J^T. On a
robot with closed loops the loops are constraints of the same kind (DESIGN.md section 13): their
rows (``loop_solve.loop_rows``) go first, the contacts' after them, and one ``RowSpaceSolve``
solves both (the loops' rows may be redundant, ``loop_solve.py``); the contacts' forces are the
multipliers after the loops'.

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
    RowSpaceSolve,
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
from .loop_solve import efforts, loop_rows

#: A robot's closed loops as the contact programs see them: (rows k, their rank, None: found at
#: each state), or None without loops.
Loops = tuple[int, int | None] | None


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


def constrained_forward_dynamics_program(n: int, floating: bool, loops: Loops = None) -> ContactProgram:
    """M qdd = tau - h + J^T forces, J qdd = -gamma (Pinocchio's forwardDynamics), h =
    inverse_dynamics(q, qd, 0), gamma = drift + kd J qd + kp e (e the position error against
    the anchors: p - p_ref for a point; R^T (p - p_ref) and the vee of the skew part of
    R_ref^T R for a surface); ``floating``: tau is the efforts at their velocity columns
    (``effort_map``), else generalized_forces(q, u). ``loops``: the loop rows (their target with
    the gains alpha and beta, as forward_dynamics) stacked above the contacts'."""
    contact, point, surface = _rows(n, "qd")
    pose, anchor = array("T", 4, 4), array("anchor", 4, 4)
    point += [Call("T", "frame_transform", ("q", "frame"), (4, 4), anchored=True),
              Append("error", position(pose) - array("anchor", 3), anchored=True)]
    surface += [Let("turn", rotation(anchor).T @ rotation(pose), anchored=True),
                Append("error", stack(rotation(pose).T @ (position(pose) - position(anchor)), vee(array("turn", 3, 3))),
                       anchored=True)]
    setup = (Call("M", "mass_matrix", ("q",), (n, n)), Call("h", "inverse_dynamics", ("q", "qd", "zeros"), (n,)),
             efforts(n, floating))
    gamma, b = array("gamma", HELD), array("tau", n) - array("h", n)
    finish = (Let("gamma", array("drift", HELD) + scale("kd", array("J", HELD, n) @ array("qd", n))),
              Let("gamma", gamma + scale("kp", array("error", HELD)), anchored=True))
    scalars = ("kp", "kd")
    if loops is None:
        finish += (SchurSolve("qdd", "forces", "M", "J", b, -gamma),)
    else:
        k, _ = loops
        setup += loop_rows(n, k, floating, "loop_drift")
        finish += _stacked_solve(n, "qdd", b, array("bottom", k), -gamma, loops, "forces")
        scalars += ("alpha", "beta")
    return ContactProgram("constrained_forward_dynamics", ("q", "qd", "u"), scalars, setup=setup, contact=contact,
                          point=tuple(point), surface=tuple(surface), finish=finish, outputs=("qdd", "forces"),
                          anchors=True)


def _stacked_solve(n: int, x: str, b, loop_target, contact_target, loops: Loops, multipliers: str) -> tuple:
    """The loop rows ``jac`` over the contacts' ``J``, their targets likewise, one RowSpaceSolve
    (the loops' known rank plus the contacts' rows, or found at each state), and the contacts'
    multipliers: those after the loops' k."""
    k, rank = loops
    return (Let("rows", stack(array("jac", k, n), array("J", HELD, n))),
            Let("target", stack(loop_target, contact_target)),
            RowSpaceSolve(x, "lam", "M", "rows", b, array("target", HELD), rank, held="J"),
            Let(multipliers, array("lam", HELD)[k:None]))


def impulse_dynamics_program(n: int, loops: Loops = None) -> ContactProgram:
    """M (qd_plus - qd_minus) = J^T impulses, J qd_plus = -restitution J qd_minus (Pinocchio's
    impulseDynamics): the jump dqd solves M dqd = J^T impulses, J dqd = -restitution J qd_minus
    - J qd_minus; ``loops``: the loops' rows hold too, A qd_plus = 0."""
    contact, point, surface = _rows(n, None)
    rate = array("rate", HELD)
    setup: tuple = (Call("M", "mass_matrix", ("q",), (n, n)),)
    target = -scale("restitution", rate) - rate
    if loops is None:
        solve: tuple = (SchurSolve("jump", "impulses", "M", "J", None, target),)
    else:
        k, _ = loops
        setup += (Call("jac", "loop_jacobian", ("q",), (k, n)), Let("loop_rate", array("jac", k, n) @ array("qd_minus", n)))
        solve = _stacked_solve(n, "jump", None, -array("loop_rate", k), target, loops, "impulses")
    return ContactProgram(
        "impulse_dynamics", ("q", "qd_minus"), ("restitution",), setup=setup,
        contact=contact, point=tuple(point), surface=tuple(surface),
        finish=(Let("rate", array("J", HELD, n) @ array("qd_minus", n)), *solve,
                Let("qd_plus", array("qd_minus", n) + array("jump", n))),
        outputs=("qd_plus", "impulses"), anchors=False)


@dataclass(frozen=True)
class ContactPrograms:
    """The two programs of a 3-D robot's contact dynamics."""

    constrained_forward_dynamics: ContactProgram
    impulse_dynamics: ContactProgram

    def __iter__(self):
        return iter((self.constrained_forward_dynamics, self.impulse_dynamics))


def contact_programs(n: int, floating: bool, loops: Loops = None) -> ContactPrograms:
    """Both programs for NV = ``n``; ``floating``: a base whose velocity is not its
    configuration's derivative (quaternions), whose efforts act at their columns; ``loops``: the
    closed loops' rows and rank, None without loops."""
    return ContactPrograms(constrained_forward_dynamics_program(n, floating, loops), impulse_dynamics_program(n, loops))
