"""Contact dynamics as programs every target prints (DESIGN.md section 11): the steps of
``constrained_forward_dynamics`` and ``impulse_dynamics`` over named arrays, written once here;
a target prints them with its printer and implements the few primitives below once in its shim.

A program calls the generated tree functions (``mass_matrix``, ``inverse_dynamics`` at qdd = 0,
``generalized_forces``, ``frame_jacobian``, ``frame_jacobian_dot_qd``, ``frame_transform``),
appends each held contact's rows by its kind (a point: the world-aligned rows 0..2 of the frame's
Jacobian and drift; a surface: blockdiag(R^T, R^T) J and the spatial acceleration at qdd = 0,
the classical one minus omega x v, rotated), forms the Baumgarte drift gamma and ends in one
``SchurSolve``: M x = b + J^T lam, J x = target, by the Schur complement S = J M^-1 J^T.

Expressions are trees of ``Node``; every ``Node`` has a fixed shape (NV known), ``rows == -1``
for the contacts' stacked rows (their number is known when the target runs).
"""

from __future__ import annotations

from dataclasses import dataclass

#: The operations of an expression ``Node``, each a primitive every target prints:
#: name (an array), rows (rows start..stop of a matrix, or entries of a vector), position (a
#: pose's translation), rotation (its 3 x 3 block), transpose, matmul, cross, add, sub, scale
#: (a scalar name times an array), neg, stack (rows), vee (the axial vector of (X - X^T) / 2).
OPERATIONS = ("name", "rows", "position", "rotation", "transpose", "matmul", "cross", "add", "sub", "scale", "neg",
              "stack", "vee")

#: The contacts' stacked rows: their number is the program's size at run time.
HELD = -1


@dataclass(frozen=True)
class Node:
    """``op`` applied to ``args`` (nodes, or for ``name`` the array's name, for ``rows`` the
    bounds, for ``scale`` the scalar's name first); ``shape`` (rows,) or (rows, columns)."""

    op: str
    args: tuple
    shape: tuple[int, ...]

    def __add__(self, other: Node) -> Node:
        return Node("add", (self, other), self.shape)

    def __sub__(self, other: Node) -> Node:
        return Node("sub", (self, other), self.shape)

    def __neg__(self) -> Node:
        return Node("neg", (self,), self.shape)

    def __matmul__(self, other: Node) -> Node:
        return Node("matmul", (self, other), self.shape[:1] + other.shape[1:])

    def __getitem__(self, bounds: slice) -> Node:
        return Node("rows", (self, bounds.start, bounds.stop), (bounds.stop - bounds.start,) + self.shape[1:])

    @property
    def T(self) -> Node:   # noqa: N802 - the matrix transpose, as NumPy spells it
        return Node("transpose", (self,), self.shape[::-1])


def array(name: str, *shape: int) -> Node:
    """A named array: an input, a called function's output or an earlier step's."""
    return Node("name", (name,), shape)


def scale(scalar: str, node: Node) -> Node:
    return Node("scale", (scalar, node), node.shape)


def cross(a: Node, b: Node) -> Node:
    return Node("cross", (a, b), (3,))


def stack(top: Node, bottom: Node) -> Node:
    return Node("stack", (top, bottom), (top.shape[0] + bottom.shape[0],) + top.shape[1:])


def position(pose: Node) -> Node:
    return Node("position", (pose,), (3,))


def rotation(pose: Node) -> Node:
    return Node("rotation", (pose,), (3, 3))


def vee(matrix: Node) -> Node:
    return Node("vee", (matrix,), (3,))


@dataclass(frozen=True)
class Call:
    """``output = function(*arguments)``: a generated function; ``frame`` among the arguments
    is the held contact's frame, ``zeros`` a vector of NV zeros."""

    output: str
    function: str
    arguments: tuple[str, ...]
    shape: tuple[int, ...]
    anchored: bool = False


@dataclass(frozen=True)
class Let:
    """``name = value``."""

    name: str
    value: Node
    anchored: bool = False


@dataclass(frozen=True)
class Append:
    """The contact's rows ``value`` appended to the stacked array ``stacked`` (``J``,
    ``drift`` or ``error``)."""

    stacked: str
    value: Node
    anchored: bool = False


@dataclass(frozen=True)
class SchurSolve:
    """``(x, multipliers)`` with M x = b + J^T multipliers and J x = target (b None: zero):
    multipliers = S^-1 (target - J M^-1 b), S = J M^-1 J^T, x = M^-1 (b + J^T multipliers). A
    target refuses (or flags) M not positive definite and S singular (redundant contacts)."""

    x: str
    multipliers: str
    mass: str
    jacobian: str
    b: Node | None
    target: Node
    anchored: bool = False


#: A step; one whose ``anchored`` is set runs only when anchors (held positions and poses) are given.
Step = Call | Let | Append | SchurSolve


@dataclass(frozen=True)
class ContactProgram:
    """One contact function: ``setup`` before the contacts, each held contact's ``contact``
    steps then its kind's (``point`` or ``surface``), then ``finish``. ``inputs``: the arrays of the function's signature (q, qd, u or
    qd_minus), ``outputs`` its two results, ``scalars`` the numbers it reads (kp, kd or
    restitution), ``anchors`` whether it takes anchors."""

    name: str
    inputs: tuple[str, ...]
    scalars: tuple[str, ...]
    setup: tuple[Step, ...]
    contact: tuple[Step, ...]
    point: tuple[Step, ...]
    surface: tuple[Step, ...]
    finish: tuple[Step, ...]
    outputs: tuple[str, str]
    anchors: bool


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
