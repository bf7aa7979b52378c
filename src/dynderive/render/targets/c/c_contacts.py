"""The C target's contact dynamics (DESIGN.md section 11): ``<name>_constrained_forward_dynamics``
and ``<name>_impulse_dynamics`` of a 3-D robot without closed loops, the NumPy module's
(``templates/dynamics_contacts.py.j2``) written over the C target's own functions.

Forward: M = mass_matrix, h = inverse_dynamics(q, qd, 0) (Coriolis, gravity and friction, with
the struct's ``friction_smoothing``), tau = generalized_forces(q, u) (with quaternions: u at
the efforts' velocity columns). Each contact's rows: a point's world-aligned rows of
frame_jacobian and frame_jacobian_dot_qd; a surface's rows blockdiag(R^T, R^T) J in the frame's
axes, with the spatial acceleration at qdd = 0 (the classical one minus omega x v, rotated) as
drift. Then gamma = drift + kd J qd (+ kp e with anchors). M is factored in reverse order, P M
P = L D L^T unrolled for this robot's sparsity (P the reversal: the leaves first, so a tree's
factor has no fill-in); Y = L^-1 P J^T and e = L^-1 P (tau - h) by forward substitution, the
Schur complement S = J M^-1 J^T = Y^T D^-1 Y factored by dense Cholesky loops, forces = S^-1
(-gamma - Y^T D^-1 e) (J M^-1 (tau - h) = Y^T D^-1 e), qdd = P L^-T D^-1 (e + Y forces), one
back substitution. Impulse: forces = S^-1 (-restitution J qd_minus - J qd_minus), qd_plus =
qd_minus + P L^-T D^-1 Y forces. Every array is on the stack, sized at generation (NV, and 6
rows per frame: a frame is held at most once); no allocation.

Return codes (header macros ``<NAME>_CONTACT_...``): 0; 1 if M is not positive definite; 2 if
the contacts are redundant (a pivot of S not above 1e-12 of its diagonal entry); 3 for a bad
argument (a contact count outside 0..NFRAMES, a frame number that is no frame or is held twice,
a kind that is neither 0 (point) nor 1 (surface)); 4 for a nonzero kp without anchors. Outputs are
untouched unless 0. No external wrenches (the NumPy module's ``wrenches=None``).
"""

from __future__ import annotations

from ....derivation import Derivation
from ...codegen.constrained import contacts_built
from .c_print import CFunction
from .c_solve import fill_in, ldl_factor

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
    if not contacts_built(derivation):
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
    """The two functions (none for a planar robot or one with loops); ``pattern``: which entries
    of M can be nonzero. M is factored in reverse order (P M P = L D L^T, P the reversal: the
    leaves first, so a tree's factor has no fill-in)."""
    if not contacts_built(derivation):
        return []
    n = len(pattern)
    nonzero = fill_in([[pattern[n - 1 - i][n - 1 - j] for j in range(n)] for i in range(n)], n)
    name = derivation.robot.name
    pp = f"const {name}_parameters *p"
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
        "wrenches. Returns 0; 1 M not positive definite; 2 redundant contacts; 3 a bad count, frame or kind; "
        "4 kp without anchors (outputs untouched unless 0).",
        _body(derivation, nonzero, impulse=False))
    impulse = CFunction(
        f"int {name}_impulse_dynamics(const double *q, const double *qd_minus, int ncontacts, const int *frames, "
        f"const int *kinds, double restitution, {pp}, double *qd_plus, double *impulses)",
        "qd_plus and the impulses of an impact that makes the contacts hold (frames, kinds as for "
        "constrained_forward_dynamics): M (qd_plus - qd_minus) = J^T impulses, J qd_plus = -restitution J qd_minus. "
        "Pinocchio's impulseDynamics(model, data, q, v, J, restitution, 0). Returns 0; 1 M not positive definite; "
        "2 redundant contacts; 3 a bad count, frame or kind (outputs untouched unless 0).",
        _body(derivation, nonzero, impulse=True))
    return [forward, impulse]


def _body(derivation: Derivation, nonzero: list[list[bool]], impulse: bool) -> list[str]:
    """One function's lines: the checks, M (and h, tau), the contact rows, the two solves."""
    robot = derivation.robot
    name, n, nu = robot.name, len(derivation.symbols.qd), len(derivation.symbols.efforts)
    frames = len(robot.frames)
    rows = 6 * max(frames, 1)       # at most 6 rows per frame
    quaternions = len(derivation.symbols.q) != n
    declared = {f: 0 for f in range(frames)}
    numbers = {f.name: i for i, f in enumerate(robot.frames)}
    for contact in robot.contacts:
        declared[numbers[contact.frame]] = int(contact.kind == "surface")
    table = ", ".join(str(declared[f]) for f in range(frames)) or "0"
    lines = [
        f"static const int declared[{max(frames, 1)}] = {{ {table} }};   /* each frame's declared kind, else point */",
        f"double M[{n * n}], J[{rows * n}], target[{rows}];",
        f"double Jf[{6 * n}], T[16];",
        *([] if impulse else ["double acc[6];"]),
        "int count = 0;" if impulse else "int count = 0, at = 0;",
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
    if impulse:
        lines += [f"{name}_mass_matrix(q, p, M);"]
    else:
        lines += [
            "const double kp = baumgarte ? baumgarte[0] : 0.0;",
            "const double kd = baumgarte ? baumgarte[1] : 0.0;",
            "if (kp != 0.0 && !anchors) return 4;",
            f"double zero[{n}], h[{n}], tau[{n}];",
            f"for (int i = 0; i < {n}; ++i) zero[i] = 0.0;",
            f"{name}_mass_matrix(q, p, M);",
            f"{name}_inverse_dynamics(q, qd, zero, p, h);",
        ]
        if quaternions:
            columns = robot.effort_columns()
            lines += [f"for (int i = 0; i < {n}; ++i) tau[i] = 0.0;",
                      *(["if (u) {", *(f"    tau[{c}] = u[{k}];" for k, c in enumerate(columns)), "}"]
                        if nu else ["(void)u;"])]
        else:
            lines += [f"{name}_generalized_forces(q, u ? u : zero, p, tau);"]
    lines += [
        "for (int c = 0; c < ncontacts; ++c) {   /* the rows of contact c: J, and the target of J qdd */",
        "    const int f = frames[c];",
        "    const int kind = kinds ? kinds[c] : declared[f];",
        f"    {name}_frame_jacobian(q, f, p, Jf);",
        *([] if impulse else [f"    {name}_frame_jacobian_dot_qd(q, qd, f, p, acc);"]),
        "    if (kind == 1 || anchors) {" if not impulse else "    if (kind == 1) {",
        f"        {name}_frame_transform(q, f, p, T);",
        "    }",
        "    if (kind == 0) {",
        "        for (int i = 0; i < 3; ++i) {",
        f"            for (int j = 0; j < {n}; ++j) J[(count + i) * {n} + j] = Jf[i * {n} + j];",
        *([] if impulse else ["            target[count + i] = acc[i];"]),
        "        }",
        *([] if impulse else [
            "        if (anchors) {",
            "            for (int i = 0; i < 3; ++i) acc[3 + i] = T[4 * i + 3] - anchors[at + i];   /* e */",
            "            at += 3;",
            "        }"]),
        "    } else {",
        "        for (int i = 0; i < 3; ++i) {",
        f"            for (int j = 0; j < {n}; ++j) {{",
        f"                J[(count + i) * {n} + j] = T[i]*Jf[j] + T[4 + i]*Jf[{n} + j] + T[8 + i]*Jf[{2 * n} + j];",
        f"                J[(count + 3 + i) * {n} + j] = T[i]*Jf[{3 * n} + j] + T[4 + i]*Jf[{4 * n} + j]"
        f" + T[8 + i]*Jf[{5 * n} + j];",
        "            }",
        "        }",
    ]
    if not impulse:
        lines += [
            "        {   /* the spatial acceleration at qdd = 0 in the frame's axes: (a - w x v, alpha) rotated */",
            "            double v[6], linear[3];",
            "            for (int i = 0; i < 6; ++i) {",
            "                v[i] = 0.0;",
            f"                for (int j = 0; j < {n}; ++j) v[i] += Jf[i * {n} + j]*qd[j];",
            "            }",
            "            linear[0] = acc[0] - (v[4]*v[2] - v[5]*v[1]);",
            "            linear[1] = acc[1] - (v[5]*v[0] - v[3]*v[2]);",
            "            linear[2] = acc[2] - (v[3]*v[1] - v[4]*v[0]);",
            "            for (int i = 0; i < 3; ++i) {",
            "                target[count + i] = T[i]*linear[0] + T[4 + i]*linear[1] + T[8 + i]*linear[2];",
            "                target[count + 3 + i] = T[i]*acc[3] + T[4 + i]*acc[4] + T[8 + i]*acc[5];",
            "            }",
            "        }",
            "        if (anchors) {   /* e: R^T (p - p_ref), vee of the skew part of R_ref^T R */",
            "            const double *A = anchors + at;",
            "            double d[3], turn[9];",
            "            for (int i = 0; i < 3; ++i) d[i] = T[4 * i + 3] - A[4 * i + 3];",
            "            for (int i = 0; i < 3; ++i) {",
            "                for (int j = 0; j < 3; ++j) turn[3 * i + j] = A[i]*T[j] + A[4 + i]*T[4 + j] + A[8 + i]*T[8 + j];",
            "            }",
            "            Jf[0] = T[0]*d[0] + T[4]*d[1] + T[8]*d[2];   /* Jf is free: e kept in its first 6 */",
            "            Jf[1] = T[1]*d[0] + T[5]*d[1] + T[9]*d[2];",
            "            Jf[2] = T[2]*d[0] + T[6]*d[1] + T[10]*d[2];",
            "            Jf[3] = (turn[7] - turn[5]) / 2;",
            "            Jf[4] = (turn[2] - turn[6]) / 2;",
            "            Jf[5] = (turn[3] - turn[1]) / 2;",
            "            at += 16;",
            "        }",
        ]
    lines += ["    }"]
    size = "(kind == 0 ? 3 : 6)"
    if impulse:
        lines += [f"    for (int r = count; r < count + {size}; ++r) {{",
                  "        double rate = 0.0;",
                  f"        for (int j = 0; j < {n}; ++j) rate += J[r * {n} + j]*qd_minus[j];",
                  "        target[r] = -restitution*rate;",
                  "    }"]
    else:
        lines += [f"    for (int r = count; r < count + {size}; ++r) {{   /* -gamma = -(drift + kd J qd + kp e) */",
                  "        double rate = 0.0;",
                  f"        for (int j = 0; j < {n}; ++j) rate += J[r * {n} + j]*qd[j];",
                  "        target[r] += kd*rate;",
                  "        if (anchors) target[r] += kp*(kind == 0 ? acc[3 + r - count] : Jf[r - count]);",
                  "        target[r] = -target[r];",
                  "    }"]
    lines += [f"    count += {size};", "}"]
    # M reversed (P M P, leaves first: a tree's factor has no fill-in) = L D L^T unrolled;
    # Y = L^-1 P J^T, e = L^-1 P (tau - h); S = Y^T D^-1 Y, J M^-1 (tau - h) = Y^T D^-1 e
    lines += ldl_factor(lambda i, j: f"M[{(n - 1 - i) * n + n - 1 - j}]", n, nonzero, "m", "return 1;")
    lines += [f"double Y[{n * rows}], dinv[{n}], z[{n}];",
              *(f"dinv[{i}] = 1.0 / md{i};" for i in range(n)),
              "for (int c = 0; c < count; ++c) {",
              *(f"    {line}" for line in _forward(n, nonzero, "w", [f"J[c * {n} + {n - 1 - i}]" for i in range(n)])),
              *(f"    Y[{i * rows} + c] = w{i};" for i in range(n)), "}"]
    if impulse:
        lines += [f"for (int i = 0; i < {n}; ++i) z[i] = 0.0;"]
    else:
        lines += [*_forward(n, nonzero, "e", [f"tau[{n - 1 - i}] - h[{n - 1 - i}]" for i in range(n)]),
                  *(f"z[{i}] = e{i};" for i in range(n))]
    out, multipliers = ("qd_plus", "impulses") if impulse else ("qdd", "forces")
    lines += [
        "if (count > 0) {   /* S = Y^T D^-1 Y, L L^T in place (lower triangle); the forces; z += Y forces */",
        f"    double S[{rows * rows}], lam[{rows}];",
        "    for (int a = 0; a < count; ++a) {",
        "        for (int b = 0; b <= a; ++b) {",
        "            double sum = 0.0;",
        f"            for (int i = 0; i < {n}; ++i) sum += Y[i * {rows} + a]*dinv[i]*Y[i * {rows} + b];",
        f"            S[a * {rows} + b] = sum;",
        "        }",
        "        lam[a] = target[a];",
        *([f"        for (int j = 0; j < {n}; ++j) lam[a] -= J[a * {n} + j]*qd_minus[j];"] if impulse else
          [f"        for (int i = 0; i < {n}; ++i) lam[a] -= Y[i * {rows} + a]*dinv[i]*z[i];"]),
        "    }",
        "    for (int j = 0; j < count; ++j) {",
        f"        double pivot = S[j * {rows} + j];",
        f"        for (int k = 0; k < j; ++k) pivot -= S[j * {rows} + k]*S[j * {rows} + k];",
        f"        if (!(pivot > 1e-12*S[j * {rows} + j])) return 2;",
        f"        S[j * {rows} + j] = sqrt(pivot);",
        "        for (int i = j + 1; i < count; ++i) {",
        f"            double sum = S[i * {rows} + j];",
        f"            for (int k = 0; k < j; ++k) sum -= S[i * {rows} + k]*S[j * {rows} + k];",
        f"            S[i * {rows} + j] = sum / S[j * {rows} + j];",
        "        }",
        "    }",
        "    for (int i = 0; i < count; ++i) {",
        f"        for (int k = 0; k < i; ++k) lam[i] -= S[i * {rows} + k]*lam[k];",
        f"        lam[i] /= S[i * {rows} + i];",
        "    }",
        "    for (int i = count - 1; i >= 0; --i) {",
        f"        for (int k = i + 1; k < count; ++k) lam[i] -= S[k * {rows} + i]*lam[k];",
        f"        lam[i] /= S[i * {rows} + i];",
        "    }",
        f"    for (int i = 0; i < {n}; ++i) {{",
        f"        for (int c = 0; c < count; ++c) z[i] += Y[i * {rows} + c]*lam[c];",
        "    }",
        f"    for (int c = 0; c < count; ++c) {multipliers}[c] = lam[c];",
        "}",
        *_back(n, nonzero, "x", "z"),
        *((f"{out}[{n - 1 - i}] = qd_minus[{n - 1 - i}] + x{i};" for i in range(n)) if impulse else
          (f"{out}[{n - 1 - i}] = x{i};" for i in range(n))),
        "return 0;",
    ]
    return lines


def _forward(n: int, nonzero: list[list[bool]], name: str, rhs: list[str]) -> list[str]:
    """``<name><i>`` solving ``L w = rhs`` (L the unit lower factor ``mL``, forward substitution)."""
    return [f"const double {name}{i} = {rhs[i]}" + "".join(f" - mL{i}_{k}*{name}{k}" for k in range(i) if nonzero[i][k])
            + ";" for i in range(n)]


def _back(n: int, nonzero: list[list[bool]], name: str, rhs: str) -> list[str]:
    """``<name><i>`` solving ``D L^T x = rhs[]`` (back substitution)."""
    return [f"const double {name}{i} = {rhs}[{i}] / md{i}" + "".join(f" - mL{k}_{i}*{name}{k}" for k in range(i + 1, n)
                                                                   if nonzero[k][i]) + ";" for i in reversed(range(n))]
