"""Centre of mass and centroidal momentum of a 3-D robot as straight-line programs, over the
one tree (``tree.py``) for every joint type (floating, spherical, mimic included).

Each moving body's spatial inertia is carried to the world origin (mass, first moment ``m c``,
rotational inertia about the origin), summed from the leaves up into its subtree's composite
(CRBA's upward pass, in world axes). A joint column's world motion ``(w, v0)`` (``v0`` the
velocity of the body point at the world origin) times its subtree's composite inertia is the
momentum that column gives, linear ``m v0 + w x h`` and angular ``h x v0 + I w`` about the
origin; shifted to the centre of mass ``G = h / m`` it is the column of Pinocchio's ``ccrba``
``A_G`` (linear rows, then angular about G, world axes). The CoM Jacobian is A_G's linear rows
over the mass; ``Jdot qd`` and ``Adot_G qd`` are the programs' forward derivatives along the
motion (the tangent of each line, as ``frames.py`` takes ``Jdot qd``).

When the tree's root joint is ``floating`` (the robot's base), the same is done in the base's
frame with the base at the identity: the composites and every other joint's columns then depend
on those joints' coordinates only (the momentum about the centre of mass does not depend on the
base's position), the base's six columns (its local twist, Pinocchio's free flyer) are entries
of the whole tree's composite, and the result is turned into world axes once, ``A_G = blkdiag(R,
R) A_G^base`` with ``R`` the base's rotation (``G = p + R G^base``, ``I_G = R I_G^base R^T``):
no link's pose is composed with the base's quaternion.

Bodies welded to the world carry no motion and are left out, as Pinocchio leaves out the
universe's inertia: the centre of mass of a fixed-base robot is that of its moving links.
"""

from __future__ import annotations

from typing import NamedTuple

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .frames import along_motion
from .program import Matrix3, Program, Vector, _add, _cross, _dot, _rotate, _times, part_of
from .recursive import moved_inertia
from .tree import Tree


class CentroidalPrograms(NamedTuple):
    """The programs of DESIGN.md section 11, by the generated function's name; matrices row
    by row."""

    total_mass: Program                        # no input: 1
    center_of_mass: Program                    # q: 3
    center_of_mass_velocity: Program           # q, qd: 3
    center_of_mass_jacobian: Program           # q: 3 x NV
    center_of_mass_acceleration_bias: Program  # q, qd: 3
    centroidal_momentum_matrix: Program        # q: 6 x NV
    centroidal_momentum: Program               # q, qd: 6
    centroidal_momentum_bias: Program          # q, qd: 6
    centroidal_inertia: Program                # q: 6 x 6


def _identity() -> Matrix3:
    one, zero = sympy.Integer(1), sympy.Integer(0)
    return ((one, zero, zero), (zero, one, zero), (zero, zero, one))   # type: ignore[return-value]


def _floating_root(tree: Tree, moving: list) -> tuple[object, tuple[Matrix3, Vector]] | None:   # noqa: ANN001
    """The one moving body at the top of the tree if its joint is ``floating``, with its world
    pose (its joint's motion after the static links above it), else None."""
    roots = [b for b in moving if b.parent in tree.static]
    if len(roots) != 1 or roots[0].joint.type != "floating":
        return None
    chain, link = [], roots[0].link
    while link != "world":
        chain.append(tree.by_link[link])
        link = chain[-1].parent
    pose: tuple[Matrix3, Vector] = (_identity(), (sympy.Integer(0),) * 3)   # type: ignore[assignment]
    for body in reversed(chain):
        pose = tree.compose(pose, body.rotation, body.position)
    return roots[0], pose


def centroidal_programs(robot: Robot, table: SymbolTable) -> CentroidalPrograms:
    """Every program of ``CentroidalPrograms``, from one shared list of lines.

    When the tree's root joint is ``floating``, the composites and columns are taken in the
    floating base's frame with the base at the identity (they depend on the other joints only:
    the momentum about the centre of mass does not depend on the base's position, and the
    base's rotation turns it as a whole), and A_G, the centre of mass and the inertia about it
    are turned into world axes once at the end. The base's own six columns (a local twist) are
    then entries of the whole tree's composite. Otherwise every body is carried to the world."""
    tree = Tree(robot, table)
    program = tree.program
    let, vec = program.let, program.vector
    moving = [b for b in tree.bodies if b.link not in tree.static]
    base = _floating_root(tree, moving)
    if base is None:
        poses = tree.world_poses()
    else:   # each moving body's pose in the base's frame
        root, (R_base, p_base) = base
        poses = {root.link: (_identity(), (sympy.Integer(0),) * 3)}   # type: ignore[dict-item]
        for body in moving:
            if body is not root:
                poses[body.link] = tree.compose(poses[body.parent], body.rotation, body.position)
    composite: dict[str, tuple[sympy.Expr, Vector, tuple]] = {}
    for body in moving:   # each body's inertia about the origin of the frame of ``poses``, its axes
        R, origin = poses[body.link]
        h_r, inertia = moved_inertia(program, body.mass, body.first_moment, body.inertia, R, origin)
        composite[body.link] = (body.mass, vec(_add(h_r, _times(origin, body.mass))), program.symmetric(inertia))
    roots = []
    for body in reversed(moving):   # the subtrees' composites, leaves first
        if body.parent in tree.static:
            roots.append(body.link)
            continue
        mass, h, inertia = composite[body.link]
        p_mass, p_h, p_inertia = composite[body.parent]
        composite[body.parent] = (let(p_mass + mass), vec(_add(p_h, h)),
                                  program.symmetric([[p_inertia[a][b] + inertia[a][b] for b in range(3)]
                                                     for a in range(3)]))
    zero = sympy.Integer(0)
    mass = let(sum((composite[r][0] for r in roots), zero))
    h = vec([sum((composite[r][1][k] for r in roots), zero) for k in range(3)])
    inertia = [[sum((composite[r][2][a][b] for r in roots), zero) for b in range(3)] for a in range(3)]
    inverse_mass = let(1 / mass)
    com = vec(_times(h, inverse_mass))
    n = tree.size
    momentum: list[list[sympy.Expr]] = [[zero] * n for _ in range(6)]   # about the origin of ``poses``
    for body in moving:
        R, origin = poses[body.link]
        m, hb, ib = composite[body.link]
        for j, sw, sv in body.columns:
            w = vec(_rotate(R, sw))
            v0 = vec(_add(_rotate(R, sv), _cross(origin, w)))   # the velocity of the point at the origin
            linear = _add(_times(v0, m), _cross(w, hb))
            angular = _add(_cross(hb, v0), _rotate(ib, w))
            for k, value in enumerate((*linear, *angular)):   # a <mimic> follower adds to its leader's column
                momentum[k][j] = let(momentum[k][j] + value)
    matrix = [[momentum[k][j] for j in range(n)] for k in range(3)]
    for k in range(3):   # angular momentum about G: K_O - G x L
        matrix.append([let(momentum[3 + k][j] - _cross(com, [momentum[r][j] for r in range(3)])[k])
                       for j in range(n)])
    if base is not None:   # into world axes: A_G = blkdiag(R, R) A_G^base, G = p + R G^base
        for rows in (matrix[:3], matrix[3:]):
            turned = [vec(_rotate(R_base, [rows[k][j] for k in range(3)])) for j in range(n)]
            for k in range(3):
                rows[k][:] = [turned[j][k] for j in range(n)]
        com = vec(_add(p_base, _rotate(R_base, com)))
    jacobian = [[let(matrix[k][j] * inverse_mass) for j in range(n)] for k in range(3)]
    qd = table.qd

    def times_qd(rows: list[list[sympy.Expr]]) -> list[sympy.Expr]:
        return [let(sum((row[j] * qd[j] for j in range(n)), zero)) for row in rows]

    shift = [[(h[0] ** 2 + h[1] ** 2 + h[2] ** 2 if a == b else 0) - h[a] * h[b] for b in range(3)] for a in range(3)]
    about_com = [[let(inertia[a][b] - shift[a][b] * inverse_mass) for b in range(3)] for a in range(3)]
    if base is not None:   # R I_G R^T
        turned = [[let(_dot(about_com[a], R_base[b])) for b in range(3)] for a in range(3)]   # I_G R^T
        about_com = [list(row) for row in program.symmetric(
            [[_dot(R_base[a], [turned[k][b] for k in range(3)]) for b in range(3)] for a in range(3)])]
    spatial = [[mass if a == b else zero for b in range(3)] + [zero] * 3 for a in range(3)] + \
        [[zero] * 3 + about_com[a] for a in range(3)]
    velocity, total_momentum = times_qd(jacobian), times_qd(matrix)
    bias = along_motion(tree)   # d/dt along the motion: the rows' tangents times qd
    com_bias, momentum_bias = bias(jacobian), bias(matrix)
    lines = list(program.lines)
    flat = lambda rows: [e for row in rows for e in row]  # noqa: E731
    return CentroidalPrograms(
        total_mass=part_of(lines, [mass]),
        center_of_mass=part_of(lines, list(com)),
        center_of_mass_velocity=part_of(lines, velocity),
        center_of_mass_jacobian=part_of(lines, flat(jacobian)),
        center_of_mass_acceleration_bias=part_of(lines, com_bias),
        centroidal_momentum_matrix=part_of(lines, flat(matrix)),
        centroidal_momentum=part_of(lines, total_momentum),
        centroidal_momentum_bias=part_of(lines, momentum_bias),
        centroidal_inertia=part_of(lines, flat(spatial)),
    )
