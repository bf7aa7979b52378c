"""Centre of mass and centroidal momentum of a 3-D robot as straight-line programs, over the
one tree (``tree.py``) for every joint type (floating, spherical, mimic included).

Each subtree's composite inertia (mass, first moment ``m c``, rotational inertia about the
link origin) is summed from the leaves up in its root link's own frame (CRBA's upward pass: a
child's composite moves into its parent's frame by the joint's transform, a rotation about one
axis, so the moves are cheap). A joint column ``(s_w, s_v)`` (link frame) times its subtree's
composite is the momentum that column gives, linear ``m s_v + s_w x h`` and angular ``h x s_v +
I s_w`` about the link origin (for a unit axis, entries of the composite); turned into world
axes by the link's world rotation ``R`` and moved to the centre of mass ``G`` (``K_G = R K +
(o - G) x R L``, ``o`` the link's world origin) it is the column of Pinocchio's ``ccrba`` ``A_G``
(linear rows, then angular about G, world axes). ``G`` and the inertia about it come from the
roots' composites carried to the world. The CoM Jacobian is A_G's linear rows over the mass;
``Jdot qd`` and ``Adot_G qd`` are the programs' forward derivatives along the motion (the
tangent of each line, as ``frames.py`` takes ``Jdot qd``).

Carrying every link's inertia into world axes first (``R I R^T`` with a full rotation per
link) and summing there, as ``ccrba`` does, took about twice the operations for talos_reduced; so did
taking the composites in a floating base's frame and turning the 6 x NV result by the base's
rotation at the end.

Bodies welded to the world carry no motion and are left out, as Pinocchio leaves out the
universe's inertia: the centre of mass of a fixed-base robot is that of its moving links.
"""

from __future__ import annotations

from typing import NamedTuple

import sympy

from ..model.robot import Robot
from ..model.symbols import SymbolTable
from .frames import along_motion
from .program import Program, Vector, _add, _cross, _rotate, _times, part_of
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


def centroidal_programs(robot: Robot, table: SymbolTable) -> CentroidalPrograms:
    """Every program of ``CentroidalPrograms``, from one shared list of lines."""
    tree = Tree(robot, table)
    program = tree.program
    let, vec = program.let, program.vector
    moving = [b for b in tree.bodies if b.link not in tree.static]
    composite: dict[str, tuple[sympy.Expr, Vector, tuple]] = {
        b.link: (b.mass, b.first_moment, b.inertia) for b in moving}   # link frame, about its origin
    roots = []
    for body in reversed(moving):   # the subtrees' composites, leaves first, each in its link's frame
        if body.parent in tree.static:
            roots.append(body)
            continue
        mass, h, inertia = composite[body.link]
        h_r, moved = moved_inertia(program, mass, h, inertia, body.rotation, body.position)
        p_mass, p_h, p_inertia = composite[body.parent]
        composite[body.parent] = (let(p_mass + mass), vec(_add(p_h, _add(h_r, _times(body.position, mass)))),
                                  program.symmetric([[p_inertia[a][b] + moved[a][b] for b in range(3)]
                                                     for a in range(3)]))
    poses = tree.world_poses()
    zero = sympy.Integer(0)
    total, first, about_origin = zero, (zero,) * 3, [[zero] * 3 for _ in range(3)]
    for root in roots:   # the whole tree's composite about the world origin, world axes
        R, origin = poses[root.link]
        m, hr, ir = composite[root.link]
        h_r, moved = moved_inertia(program, m, hr, ir, R, origin)
        total, first = total + m, _add(first, _add(h_r, _times(origin, m)))
        about_origin = [[about_origin[a][b] + moved[a][b] for b in range(3)] for a in range(3)]
    mass, h = let(total), vec(first)
    inertia = program.symmetric(about_origin)
    inverse_mass = let(1 / mass)
    com = vec(_times(h, inverse_mass))
    n = tree.size
    matrix: list[list[sympy.Expr]] = [[zero] * n for _ in range(6)]
    for body in moving:   # a column's momentum in the link's frame about its origin, into world axes about G
        R, origin = poses[body.link]
        m, hb, ib = composite[body.link]
        lever = None
        for j, sw, sv in body.columns:
            linear = vec(_rotate(R, _add(_times(sv, m), _cross(sw, hb))))
            angular = _rotate(R, _add(_cross(hb, sv), _rotate(ib, sw)))
            if any(e != 0 for e in linear):
                lever = lever or vec([o - g for o, g in zip(origin, com)])
                angular = _add(angular, _cross(lever, linear))
            for k, value in enumerate((*linear, *angular)):   # a <mimic> follower adds to its leader's column
                matrix[k][j] = let(matrix[k][j] + value)
    jacobian = [[let(matrix[k][j] * inverse_mass) for j in range(n)] for k in range(3)]
    qd = table.qd

    def times_qd(rows: list[list[sympy.Expr]]) -> list[sympy.Expr]:
        return [let(sum((row[j] * qd[j] for j in range(n)), zero)) for row in rows]

    shift = [[(h[0] ** 2 + h[1] ** 2 + h[2] ** 2 if a == b else 0) - h[a] * h[b] for b in range(3)] for a in range(3)]
    about_com = [[let(inertia[a][b] - shift[a][b] * inverse_mass) for b in range(3)] for a in range(3)]
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
