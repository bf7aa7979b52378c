"""The recursion a large robot's sheet states: Newton-Euler's inverse dynamics and the
composite-rigid-body mass matrix, as one straight-line program whose lines say what they
mean (``program.Meaning``), in the style of OpenSYMORO's customized Newton-Euler.

The program is built by the same functions as the generated module's programs
(``recursive._newton_euler``, ``recursive._composite_mass_matrix``) on a tree of its own,
so nothing of the module's programs depends on whether a sheet was written. Newton-Euler
runs with symbolic joint rates and accelerations and gravity as an upward acceleration of
the base; its outputs are ``tau = M qdd + C qd + N`` (with the drives' armature and springs):
``N = tau(q, 0, 0)`` and ``C qd = tau(q, qd, 0) - N``. The mass matrix's entries are CRBA's.

>>> r = newton_euler_recursion(robot, table)          # doctest: +SKIP
>>> r.program.labels[r.program.lines[20][0]]           # doctest: +SKIP
Meaning(quantity='omega', link='panda_link2', index=(0,), column=-1)
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .program import Program
from .recursive import _composite_mass_matrix, _newton_euler
from .tree import Tree

#: The quantities a line may mean (``Meaning.quantity``), each of link i unless said, in link
#: i's axes; λ(i) is i's parent.
MEANINGS = {
    "R": "entry of R_i, link i's axes in its parent's frame (with the joint's motion)",
    "p": "link i's origin in its parent's frame",
    "m": "mass", "h": "first moment m c about the link origin",
    "I": "inertia about the link origin",
    "omega_in": "the parent's angular velocity", "v_in": "the parent's velocity at link i's origin",
    "alpha_in": "the parent's angular acceleration", "a_in": "the parent's acceleration at link i's origin",
    "omega": "angular velocity", "v": "velocity of the origin",
    "alpha": "angular acceleration", "a": "linear part of the spatial acceleration",
    "k": "angular momentum about the origin", "l": "linear momentum",
    "F": "force the link's motion needs", "N": "moment (about the origin) the link's motion needs",
    "f_up": "joint force of link i in its parent's axes", "n_up": "joint moment of link i about the parent's origin",
    "f": "force through joint i", "n": "moment through joint i, about the origin",
    "tau": "generalized force of joint i",
    "mc": "composite mass of link i and its descendants", "hc": "composite first moment",
    "Ic": "composite inertia about the origin", "hc_up": "composite first moment of link i in the parent's axes",
    "IRt": "product I^c_i R_i^T of the composite inertia", "Fcol": "force of column j",
    "Ncol": "moment of column j", "M": "entry of the mass matrix",
}


@dataclass
class Recursion:
    """The sheet's recursion: ``program`` (lines, ``labels``, ``records`` in the order built:
    Newton-Euler's forward pass link by link, its backward pass, then CRBA), the sines and
    cosines it reads (``trig``: ``(name, sin or cos of a coordinate)``), ``tau`` (Newton-Euler's
    generalized forces over the names), ``mass_matrix`` (CRBA's, rows of names and numbers),
    ``parents`` (each link's parent, ``world`` for the base) and ``order`` (the links, parents first)."""

    program: Program
    trig: list[tuple[sympy.Symbol, sympy.Expr]]
    tau: list[sympy.Expr]
    mass_matrix: list[list[sympy.Expr]]
    parents: dict[str, str]
    order: list[str]


def newton_euler_recursion(robot: Robot, table: SymbolTable) -> Recursion:
    """Newton-Euler (symbolic q, qd, qdd) and CRBA over one labelled program (module doc)."""
    tree = Tree(robot, table)
    tau = _newton_euler(tree, table.qd, table.qdd)   # its lines first, then CRBA's
    return Recursion(tree.program, tree.trig, tau, _composite_mass_matrix(tree),
                     {b.link: b.parent for b in tree.bodies}, [b.link for b in tree.bodies])
