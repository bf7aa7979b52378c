"""The C target's contact dynamics (DESIGN.md sections 11 and 13): ``<name>_constrained_forward_dynamics``
and ``<name>_impulse_dynamics`` of a 3-D robot, its closed loops held too, the engine's contact
programs (``mechanics/contact_program.py``, as every target) printed by ``c_program.py`` over
the C target's own functions, their ``SchurSolve`` by the shim's unrolled sparse L D L^T
(``c_solve.schur_solve``), a loop robot's ``RowSpaceSolve`` of the loops' rows over the
contacts' by ``c_solve.stacked_row_space_solve`` (its Baumgarte gains ``alpha`` and ``beta``
the parameters struct's members, as ``forward_dynamics`` reads them). This module adds what is
C's own: the signatures, the checks of the arguments, the loop over the held contacts (their
number and kinds known at run time, each contact's rows at ``count``, its anchor at ``at``) and
the header's macros. Every array is on the stack, sized at generation (NV, and 6 rows per
frame: a frame is held at most once, plus the loops' rows); no allocation.

Return codes (header macros ``<NAME>_CONTACT_...``): 0; 1 if M is not positive definite; 2 if
the contacts are redundant (a pivot of S not above 1e-12 of its diagonal entry; with loops,
the contacts' rows and the loops' together); 3 for a bad
argument (a contact count outside 0..NFRAMES, a frame number that is no frame or is held twice,
a kind that is neither 0 (point) nor 1 (surface)); 4 for a nonzero kp without anchors. Outputs are
untouched unless 0. No external wrenches (the NumPy module's ``wrenches=None``).
"""

from __future__ import annotations

from collections.abc import Iterator
from itertools import count

from ....derivation import Derivation
from ....model.array_program import HELD, Append, Call, ContactProgram, Let, RowSpaceSolve, SchurSolve
from ...codegen.constrained import loop_sizes
from .c_print import CFunction
from .c_program import assignment, c_name, call_line, flat_index
from .c_solve import fill_in, schur_solve, stacked_row_space_solve

#: The return codes, after 0: (macro suffix, value, meaning).
CODES = (("MASS_NOT_PD", 1, "M is not positive definite"),
         ("REDUNDANT", 2, "the contacts are redundant: J M^-1 J^T is singular (a pivot not above 1e-12 of its "
                          "diagonal entry)"),
         ("BAD_ARGUMENT", 3, "a contact count outside 0..NFRAMES, a frame number that is no frame or is held "
                             "twice, or a kind that is neither point (0) nor surface (1)"),
         ("NO_ANCHORS", 4, "baumgarte's kp is not 0 but anchors is NULL"))


def contact_macros(derivation: Derivation) -> list[str]:
    """The header's lines: the declared contacts (count, frame numbers, kinds), the kinds' and
    the return codes' macros; none where contact dynamics are not built."""
    if derivation.contact_programs is None:
        return []
    robot, macro = derivation.robot, derivation.robot.name.upper()
    numbers = {f.name: i for i, f in enumerate(robot.frames)}
    lines = [f"#define {macro}_NCONTACTS {len(robot.contacts)}   /* contacts the robot file declares (CONTACTS) */"]
    if robot.contacts:
        frames = ", ".join(str(numbers[c.frame]) for c in robot.contacts)
        kinds = ", ".join(str(int(c.kind == "surface")) for c in robot.contacts)
        lines += [f"#define {macro}_CONTACT_FRAMES {{ {frames} }}   /* their frame numbers (an initializer) */",
                  f"#define {macro}_CONTACT_KINDS {{ {kinds} }}   /* their kinds (an initializer) */"]
    lines += [f"#define {macro}_CONTACT_POINT 0   /* a point contact: 3 rows, world-aligned */",
              f"#define {macro}_CONTACT_SURFACE 1   /* a surface contact: 6 rows, in the frame's axes */"]
    lines += [f"#define {macro}_CONTACT_{suffix} {value}   /* returned: {meaning} */" for suffix, value, meaning in CODES]
    return lines


def contact_functions(derivation: Derivation, pattern: list[list[bool]]) -> list[CFunction]:
    """The two functions (none for a planar robot); ``pattern``: which entries
    of M can be nonzero. M is factored in reverse order (P M P = L D L^T, P the reversal: the
    leaves first, so a tree's factor has no fill-in)."""
    if derivation.contact_programs is None:
        return []
    n = len(pattern)
    nonzero = fill_in([[pattern[n - 1 - i][n - 1 - j] for j in range(n)] for i in range(n)], n)
    name = derivation.robot.name
    pp = f"const {name}_parameters *p"
    loops = (" The closed loops hold too: their rows (target with the struct's alpha and beta, as forward_dynamics) "
             "solved with the contacts'; forces are the contacts' alone." if derivation.robot.loops else "")
    kept = " The closed loops hold too: A qd_plus = 0." if derivation.robot.loops else ""
    forward = CFunction(
        f"int {name}_constrained_forward_dynamics(const double *q, const double *qd, const double *u, int ncontacts, "
        f"const int *frames, const int *kinds, const double *baumgarte, const double *anchors, {pp}, double *qdd, "
        "double *forces)",
        "qdd and the contact forces with `ncontacts` frames held (frames: their frame numbers; kinds: 0 point, "
        "1 surface, NULL for the robot file's kinds, else point): M qdd = tau - h + J^T forces, J qdd = -gamma, "
        "gamma = Jdot qd + kd J qd + kp e (baumgarte: (kp, kd), NULL for (0, 0); anchors: NULL, or per contact "
        "in order a point's held position (3) or a surface's held pose (4 x 4, row-major), e the position error). "
        "u NULL: no effort. forces: 3 per point contact (world-aligned), 6 per surface contact (force, then moment, "
        "in the frame's axes). Pinocchio's forwardDynamics(model, data, q, v, tau, J, gamma, 0). No external "
        f"wrenches.{loops} Returns 0; 1 M not positive definite; 2 redundant contacts; 3 a bad count, frame or kind; "
        "4 kp without anchors (outputs untouched unless 0).",
        _body(derivation, nonzero, derivation.contact_programs.constrained_forward_dynamics))
    impulse = CFunction(
        f"int {name}_impulse_dynamics(const double *q, const double *qd_minus, int ncontacts, const int *frames, "
        f"const int *kinds, double restitution, {pp}, double *qd_plus, double *impulses)",
        "qd_plus and the impulses of an impact that makes the contacts hold (frames, kinds as for "
        "constrained_forward_dynamics): M (qd_plus - qd_minus) = J^T impulses, J qd_plus = -restitution J qd_minus. "
        f"Pinocchio's impulseDynamics(model, data, q, v, J, restitution, 0).{kept} Returns 0; 1 M not positive definite; "
        "2 redundant contacts; 3 a bad count, frame or kind (outputs untouched unless 0).",
        _body(derivation, nonzero, derivation.contact_programs.impulse_dynamics))
    return [forward, impulse]


def _body(derivation: Derivation, nonzero: list[list[bool]], program: ContactProgram) -> list[str]:
    """One function's lines: the checks, then the engine's program printed (its ``SchurSolve``
    by the shim of ``c_solve.py``)."""
    robot = derivation.robot
    n = len(derivation.symbols.qd)
    frames = len(robot.frames)
    loops = loop_sizes(derivation)[1] if robot.loops else 0
    rows = 6 * max(frames, 1) + loops       # at most 6 rows per frame, and the loops' rows
    fresh = count()
    declared = {f: 0 for f in range(frames)}
    numbers = {f.name: i for i, f in enumerate(robot.frames)}
    for contact in robot.contacts:
        declared[numbers[contact.frame]] = int(contact.kind == "surface")
    table = ", ".join(str(declared[f]) for f in range(frames)) or "0"
    arrays = {c_name(a): size for a, size in _arrays(program, n, rows).items()}
    small = {c_name(step.output) for step in (*program.contact, *program.point, *program.surface)
             if isinstance(step, Call) and "frame" in step.arguments and arrays[c_name(step.output)] <= 16}
    lines = [
        f"static const int declared[{max(frames, 1)}] = {{ {table} }};   /* each frame's declared kind, else point */",
        # a frame function writes nothing for no such frame (ruled out below): its small outputs
        # start at zero, so that gcc -O2 sees them set (-Wmaybe-uninitialized)
        *(f"double {a}[{size}]{' = {0}' if a in small else ''};" for a, size in arrays.items()),
        "int count = 0, at = 0;" if program.anchors else "int count = 0;",
        f"if (ncontacts < 0 || ncontacts > {frames} || (ncontacts > 0 && !frames)) return 3;",
        "for (int c = 0; c < ncontacts; ++c) {",
        "    const int f = frames[c];",
        f"    if (f < 0 || f >= {frames}) return 3;",
        "    if (kinds && kinds[c] != 0 && kinds[c] != 1) return 3;",
        "    for (int k = 0; k < c; ++k) {",
        "        if (frames[k] == f) return 3;",
        "    }",
        "}",
    ]
    if "alpha" in program.scalars:   # a loop robot: its Baumgarte gains, the struct's members
        lines += [f"const {robot.name}_parameters *const P = p ? p : &{robot.name}_default_parameters;",
                  "const double alpha = P->alpha, beta = P->beta;"]
    if program.anchors:
        lines += ["const double kp = baumgarte ? baumgarte[0] : 0.0;",
                  "const double kd = baumgarte ? baumgarte[1] : 0.0;",
                  "if (kp != 0.0 && !anchors) return 4;"]
    if "zeros" in arrays:
        lines.append(f"for (int i = 0; i < {n}; ++i) zeros[i] = 0.0;")
    lines += _steps(derivation, program.setup, n, rows, nonzero, fresh, loops)
    contact, point, surface = (_steps(derivation, steps, n, rows, nonzero, fresh, loops)
                               for steps in (program.contact, program.point, program.surface))
    anchor = ["    const double *A = anchors ? anchors + at : anchors;"] if program.anchors else []
    lines += [
        "for (int c = 0; c < ncontacts; ++c) {   /* the rows of contact c */",
        "    const int f = frames[c];",
        *anchor,
        *(f"    {line}" for line in contact),
        "    if ((kinds ? kinds[c] : declared[f]) == 0) {",
        *(f"        {line}" for line in point),
        "        count += 3;",
        *(["        at += 3;"] if program.anchors else []),
        "    } else {",
        *(f"        {line}" for line in surface),
        "        count += 6;",
        *(["        at += 16;"] if program.anchors else []),
        "    }",
        "}",
        *_steps(derivation, program.finish, n, rows, nonzero, fresh, loops),
        "return 0;",
    ]
    return lines


def _arrays(program: ContactProgram, n: int, rows: int) -> dict[str, int]:
    """The local arrays a program writes (its outputs are the C function's), with their sizes."""
    sizes: dict[str, int] = {}
    for step in (*program.setup, *program.contact, *program.point, *program.surface, *program.finish):
        if isinstance(step, Call) and {"u", "zeros"} & set(step.arguments):
            sizes["zeros"] = n
        if isinstance(step, Call):
            shape = step.shape
            sizes[step.output] = shape[0] * (shape[1] if len(shape) == 2 else 1)
        elif isinstance(step, Let):
            shape = step.value.shape
            sizes[step.name] = (rows if shape[0] == HELD else shape[0]) * (shape[1] if len(shape) == 2 else 1)
        elif isinstance(step, Append):
            sizes[step.stacked] = rows * (step.value.shape[1] if len(step.value.shape) == 2 else 1)
        elif isinstance(step, SchurSolve):
            sizes[step.x] = n
        elif isinstance(step, RowSpaceSolve):
            sizes[step.x], sizes[step.multipliers] = n, rows
    return {a: size for a, size in sizes.items() if a not in program.outputs}


def _steps(derivation: Derivation, steps: tuple, n: int, rows: int, nonzero: list[list[bool]],
           fresh: Iterator[int], loops: int) -> list[str]:
    """The C of ``steps``, those needing anchors inside ``if (anchors)``."""
    lines: list[str] = []
    held = False
    for step in steps:
        if step.anchored != held:
            lines.append("if (anchors) {" if step.anchored else "}")
            held = step.anchored
        lines += [("    " if held else "") + line for line in _step(derivation, step, n, rows, nonzero, fresh, loops)]
    return lines + (["}"] if held else [])


def _step(derivation: Derivation, step, n: int, rows: int, nonzero: list[list[bool]], fresh: Iterator[int],
          loops: int) -> list[str]:
    if isinstance(step, Call):
        return call_line(derivation, step, n)
    if isinstance(step, SchurSolve):
        return schur_solve(step, n, nonzero, rows, fresh)
    if isinstance(step, RowSpaceSolve):
        return stacked_row_space_solve(step, n, nonzero, rows, loops, fresh)
    if isinstance(step, Let):
        name, columns = c_name(step.name), step.value.shape[1] if len(step.value.shape) == 2 else None
        return assignment(lambda i, j: f"{name}[{flat_index(i, columns, j)}]", step.value, n, fresh)
    name, columns = c_name(step.stacked), step.value.shape[1] if len(step.value.shape) == 2 else None
    return assignment(lambda i, j: f"{name}[{flat_index(f'count + {i}', columns, j)}]", step.value, n, fresh)
