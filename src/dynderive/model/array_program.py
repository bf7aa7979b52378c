"""The vocabulary of the engine's array programs (plain data, no SymPy): expression trees of
``Node`` over named arrays, and the steps a program is made of (``Call`` of a generated function,
``Let``, ``Append`` of a contact's rows, ``SchurSolve``, ``RowSpaceSolve``). The engine writes programs in it
(``mechanics/contact_program.py``); each target's printer reads it and prints the few primitives
once in its shim.

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
        """Rows start..stop; stop None: to the end (the contacts' rows after the loops')."""
        rows = HELD if bounds.stop is None else bounds.stop - bounds.start
        return Node("rows", (self, bounds.start, bounds.stop), (rows,) + self.shape[1:])

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
    """Rows of ``top`` then ``bottom``; with the contacts' rows (HELD) their batches broadcast."""
    held = HELD in (top.shape[0], bottom.shape[0])
    return Node("stack", (top, bottom), (HELD if held else top.shape[0] + bottom.shape[0],) + top.shape[1:])


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


@dataclass(frozen=True)
class RowSpaceSolve:
    """``(x, multipliers)`` with M x = b + J^T multipliers and J x = target in the row space of
    J's k rows, by the Schur complement S_r = J_r M^-1 J_r^T: ``rank`` k (J's rows themselves), a
    known r < k (J_r = U_r^T J, U_r the r left singular vectors of J with the largest singular
    values) or None (found at each state: the singular values above a tolerance of the largest,
    the other rows' multipliers 0); the multipliers of least norm, U_r lambda_r. ``held``: the
    stacked contact rows J's last rows are (a loop robot's contacts), their count added to a
    known rank (contacts are taken as independent); ``b`` None: zero. A target refuses (or
    flags) M not positive definite and S_r singular."""

    x: str
    multipliers: str
    mass: str
    jacobian: str
    b: Node | None
    target: Node
    rank: int | None
    anchored: bool = False
    held: str | None = None


#: A step; one whose ``anchored`` is set runs only when anchors (held positions and poses) are given.
Step = Call | Let | Append | SchurSolve | RowSpaceSolve


@dataclass(frozen=True)
class ArrayProgram:
    """A straight-line function: ``steps`` from the arrays ``inputs`` and the numbers ``scalars``
    to ``outputs``."""

    name: str
    inputs: tuple[str, ...]
    scalars: tuple[str, ...]
    steps: tuple[Step, ...]
    outputs: tuple[str, ...]


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
