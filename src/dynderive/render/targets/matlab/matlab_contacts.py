"""The MATLAB/Octave target's contact dynamics of a 3-D robot, its closed loops held too (DESIGN.md
sections 11 and 13): ``constrained_forward_dynamics``, ``impulse_dynamics`` and ``contacts()`` (the
robot file's declared contacts): the engine's contact programs (``mechanics/contact_program.py``)
printed by ``matlab_program.py`` on the package's own functions (a floating base's efforts act
through ``generalized_forces``), with MATLAB's own argument reading and messages. Each file
carries its local functions ``contact_list`` (frames by name, 1-based number or a struct with
fields ``frame`` and ``kind``) and ``schur_solve``, the shim of the programs' SchurSolve: MATLAB's
``\\`` after refusing a singular complement (redundant contacts, the NumPy module's
``CONTACT_RANK_TOLERANCE``).
"""

from __future__ import annotations

from ....derivation import Derivation
from ....model.array_program import Append, ContactProgram
from .matlab_loops import row_space_shim
from .matlab_names import matlab_string
from .matlab_print import MFunction, help_line
from .matlab_program import m_name, statements

#: The NumPy module's CONTACT_RANK_TOLERANCE: the smallest eigenvalue of S, relative to its
#: largest, below which the contacts are redundant.
RANK_TOLERANCE = "1e-12"
#: The help's note on the size of the forces (impulses): the API table's is the declared contacts'.
HELD_SIZE = "that size for the declared contacts, 3 per point and 6 per surface contact held."


def has_contacts(derivation: Derivation) -> bool:
    """Whether the robot has contact dynamics: 3-D (with closed loops, their rows solved with the
    contacts', as the NumPy module)."""
    return not derivation.robot.planar


def contacts_function(derivation: Derivation) -> list[MFunction]:
    """``contacts()``: the declared contacts as a struct array (fields frame, kind), which the
    contact functions take as their ``contacts`` argument; none for a robot without them."""
    if not has_contacts(derivation):
        return []
    robot = derivation.robot
    frames = ", ".join(matlab_string(c.frame) for c in robot.contacts)
    kinds = ", ".join(matlab_string(c.kind) for c in robot.contacts)
    listing = ", ".join(f"{c.frame} ({c.kind})" for c in robot.contacts) or "none"
    return [MFunction("contacts", "c", [],
                      ["CONTACTS  The contacts the robot file declares: a struct array with fields frame (a name) and",
                       "   kind ('point' or 'surface'), the default contacts of constrained_forward_dynamics and",
                       f"   impulse_dynamics: {listing}.", "",
                       f"   c = {robot.name}.contacts();  c(1).kind = 'surface';   (then pass c as contacts)"],
                      [f"c = struct('frame', {{{frames}}}, 'kind', {{{kinds}}});"])]


def _contact_list(derivation: Derivation) -> MFunction:
    """``[frames, surface, held] = contact_list(contacts)``: frame numbers, surface flags and the
    contacts as text for messages."""
    robot = derivation.robot
    pkg, count = robot.name, len(robot.frames)
    declared = {c.frame: c.kind for c in robot.contacts}
    names = ", ".join(matlab_string(f.name) for f in robot.frames)
    kinds = ", ".join(matlab_string(declared.get(f.name, "point")) for f in robot.frames)
    what = (f"a contact is a frame name, a frame number from 1 to {count} or a struct with fields frame and kind")
    return MFunction(
        "contact_list", "[frames, surface, held]", ["contacts"],
        ["CONTACT_LIST  The frames held (numbers in the robot file's order), whether each is a surface",
         "   contact, and the contacts as text: [] means the declared ones, an empty cell array none."],
        [f"names = {{{names}}};",
         f"kinds = {{{kinds}}};   % each frame's declared kind, else point",
         "if isnumeric(contacts) && isempty(contacts)",
         f"    contacts = {pkg}.contacts();",
         "end",
         "if ischar(contacts)",
         "    entries = {contacts};",
         "elseif isstring(contacts)",
         "    entries = cellstr(contacts);",
         "elseif isnumeric(contacts)",
         "    entries = num2cell(contacts(:));",
         "elseif isstruct(contacts)",
         "    entries = num2cell(contacts(:));",
         "elseif iscell(contacts)",
         "    entries = contacts(:);",
         "else",
         f"    error('{pkg}:contacts', 'contacts must be frame names (a cell array), frame numbers or a struct "
         "array with fields frame and kind');",
         "end",
         "frames = zeros(numel(entries), 1);",
         "surface = false(numel(entries), 1);",
         "parts = cell(1, numel(entries));",
         "for k = 1:numel(entries)",
         "    frame = entries{k};",
         "    kind = [];",
         "    if isstruct(frame) && isscalar(frame) && isfield(frame, 'frame')",
         "        if isfield(frame, 'kind')",
         "            kind = frame.kind;",
         "        end",
         "        frame = frame.frame;",
         "    end",
         "    if ischar(frame) || (isstring(frame) && isscalar(frame))",
         "        index = find(strcmp(frame, names), 1);",
         "        if isempty(index)",
         f"            error('{pkg}:contacts', 'unknown frame ''%s'': give a name or a number from 1 to {count}', "
         "char(frame));",
         "        end",
         "    elseif isnumeric(frame) && isscalar(frame) && isreal(frame) && frame == fix(frame)",
         f"        if frame < 1 || frame > {count}",
         f"            error('{pkg}:contacts', 'frame number %d is out of range: give a number from 1 to {count}', "
         "frame);",
         "        end",
         "        index = double(frame);",
         "    else",
         f"        error('{pkg}:contacts', '{what}');",
         "    end",
         "    if isempty(kind)",
         "        kind = kinds{index};",
         "    end",
         "    if ~(ischar(kind) || isstring(kind)) || ~any(strcmp(kind, {'point', 'surface'}))",
         f"        error('{pkg}:contacts', 'the contact kind of frame ''%s'' must be ''point'' or ''surface''', "
         "names{index});",
         "    end",
         "    if any(frames(1:k - 1) == index)",
         f"        error('{pkg}:contacts', 'frame ''%s'' is held twice in contacts', names{{index}});",
         "    end",
         "    frames(k) = index;",
         "    surface(k) = strcmp(kind, 'surface');",
         "    parts{k} = sprintf('%s (%s)', names{index}, char(kind));",
         "end",
         "held = strjoin(parts, ', ');"])


def _contact_loop(derivation: Derivation, program: ContactProgram) -> list[str]:
    """The program's rows of every held contact, each its kind's steps (the anchor checked)."""
    pkg, n = derivation.robot.name, len(derivation.symbols.qd)
    stacked = dict.fromkeys(step.stacked for step in (*program.point, *program.surface) if isinstance(step, Append))
    anchor = [
        "    if ~isempty(anchors)",
        "        anchor = anchors{k};",
        "        if ~surface(k) && (~isnumeric(anchor) || numel(anchor) ~= 3)",
        f"            error('{pkg}:anchors', 'the anchor of point contact %d must be a position, 3 x 1', k);",
        "        elseif surface(k) && (~isnumeric(anchor) || ~isequal(size(anchor), [4, 4]))",
        f"            error('{pkg}:anchors', 'the anchor of surface contact %d must be a pose, 4 x 4', k);",
        "        elseif ~surface(k)",
        "            anchor = anchor(:);",
        "        end",
        "    end"] if program.anchors else []
    return [*(f"{m_name(a)} = zeros(0, {n if a == 'J' else 1});" for a in stacked),
            "for k = 1:numel(frames)",
            "    frame = frames(k);",
            *anchor,
            *(f"    {line}" for line in statements(program.contact, pkg, n)),
            "    if ~surface(k)",
            *(f"        {line}" for line in statements(program.point, pkg, n)),
            "    else",
            *(f"        {line}" for line in statements(program.surface, pkg, n)),
            "    end",
            "end"]


def _schur_solve(derivation: Derivation) -> MFunction:
    """``[x, forces] = schur_solve(M, Jc, b, target, held)``: the engine's SchurSolve."""
    pkg = derivation.robot.name
    return MFunction(
        "schur_solve", "[x, forces]", ["M", "Jc", "b", "target", "held"],
        ["SCHUR_SOLVE  x and forces with M x = b + Jc' forces and Jc x = target (b [] for zero), by the Schur",
         "   complement S = Jc M^-1 Jc': forces = S^-1 (target - Jc M^-1 b), x = M^-1 b + M^-1 Jc' forces.",
         f"   S singular (smallest eigenvalue below {RANK_TOLERANCE} of the largest): redundant contacts, an error."],
        ["if isempty(b)", "    free = zeros(size(M, 1), 1);", "else", "    free = M \\ b;", "end",
         "if isempty(Jc)", "    x = free;", "    forces = zeros(0, 1);", "    return", "end",
         "MiJt = M \\ Jc';",
         "S = Jc * MiJt;",
         "S = (S + S') / 2;",
         "if all(isfinite(S(:)))",
         "    e = eig(S);",
         f"    if min(e) <= {RANK_TOLERANCE} * max(abs(e))",
         f"        error('{pkg}:redundant', ['the contacts %s are redundant here: J M^-1 J'' (%d x %d) is singular, "
         "their constraint ' ...",
         "              'rows are dependent and their forces not unique; hold fewer contacts (a point contact ' ...",
         "              'instead of a surface one, or fewer frames)'], held, size(S, 1), size(S, 1));",
         "    end",
         "end",
         "forces = S \\ (target - Jc * free);",
         "x = free + MiJt * forces;"])


def contact_functions(derivation: Derivation) -> list[MFunction]:
    """``constrained_forward_dynamics`` and ``impulse_dynamics`` (none for a planar robot); with
    closed loops the engine's programs end in the loops' row-space solve (its shim is local)."""
    if not has_contacts(derivation):
        return []
    robot = derivation.robot
    pkg, nu = robot.name, len(derivation.symbols.efforts)
    local = [_contact_list(derivation), row_space_shim() if robot.loops else _schur_solve(derivation)]
    loops = ["   The closed loops stay closed: their rows (with the Baumgarte gains p.alpha, p.beta, as",
             "   forward_dynamics) are solved with the contacts' in the row space of the rows stacked; forces are",
             "   the contacts' alone; the contacts are taken as independent."] if robot.loops else []
    programs = derivation.contact_programs
    contacts_help = [
        "   contacts: frame names (a cell array; one name alone is one contact), frame numbers (1-based, the",
        "   robot file's order: a vector, or numbers in the cell array), or a struct array with fields frame",
        f"   and kind ('point' or 'surface'; empty: the frame's declared kind, else point), as {pkg}.contacts()",
        "   returns. Omitted or []: the declared contacts; an empty cell array holds none. Point: the frame's",
        "   origin's acceleration in world-aligned axes, 3 forces (world axes); surface: the frame's twist in",
        "   its own axes, 6 (force, then moment about the origin, frame axes). Forces are the environment's",
        "   on the robot."]
    forward = MFunction(
        "constrained_forward_dynamics", "[qdd, forces]", ["q", "qd", "u", "contacts", "baumgarte", "anchors", "p"],
        [help_line(derivation, "constrained_forward_dynamics", f"Forces: {HELD_SIZE}"), "",
         f"   [qdd, forces] = {pkg}.constrained_forward_dynamics(q, qd, u, contacts, baumgarte, anchors, p)", "",
         "   As Pinocchio's forwardDynamics: M qdd = tau - h + J' forces, J qdd = -gamma, with h =",
         "   inverse_dynamics(q, qd, 0) (friction with p.friction_smoothing) and tau = generalized_forces(q, u);",
         f"   u ({nu} x 1) may be [] (no effort). Solved by the Schur complement J M^-1 J' (redundant contacts:",
         f"   error {pkg}:redundant).",
         *contacts_help,
         "   baumgarte: [kp kd] (omitted or []: [0 0]); gamma = Jdot qd + kd J qd + kp e, so that the contacts",
         "   accelerate by -kd (velocity) - kp e. e needs anchors, a cell array with one entry per contact in",
         "   order: a point's held position (3 x 1, world), a surface's held pose (4 x 4); e = p - p_ref for a",
         "   point, [R' (p - p_ref); vee of the skew part of R_ref' R] for a surface. kp must be 0 without anchors.",
         "   forces: 3 per point and 6 per surface contact, in the order of contacts.", *loops],
        [*_arguments(["q", "qd"]),
         "if nargin < 3 || isempty(u)", f"    u = zeros({nu}, 1);", "end", "u = u(:);",
         "if nargin < 4", "    contacts = [];", "end",
         "if nargin < 5 || isempty(baumgarte)", "    baumgarte = [0, 0];", "end",
         "if ~isnumeric(baumgarte) || numel(baumgarte) ~= 2",
         f"    error('{pkg}:baumgarte', 'baumgarte must be a pair [kp kd]');", "end",
         "if nargin < 6", "    anchors = {};", "end",
         "if nargin < 7 || isempty(p)", f"    p = {pkg}.parameters();", "end",
         "[frames, surface, held] = contact_list(contacts);",
         "if isempty(anchors) && baumgarte(1) ~= 0",
         f"    error('{pkg}:baumgarte', 'baumgarte''s kp needs anchors (the held positions and poses): without them "
         "kp must be 0');",
         "end",
         "if ~isempty(anchors) && (~iscell(anchors) || numel(anchors) ~= numel(frames))",
         f"    error('{pkg}:anchors', 'anchors must be a cell array of one entry per contact (%d)', numel(frames));",
         "end",
         "kp = baumgarte(1);", "kd = baumgarte(2);", *(["alpha = p.alpha;", "beta = p.beta;"] if robot.loops else []),
         *_program(derivation, programs.constrained_forward_dynamics)],
        local)
    impulse = MFunction(
        "impulse_dynamics", "[qd_plus, impulses]", ["q", "qd_minus", "contacts", "restitution", "p"],
        [help_line(derivation, "impulse_dynamics", f"Impulses: {HELD_SIZE}"), "",
         f"   [qd_plus, impulses] = {pkg}.impulse_dynamics(q, qd_minus, contacts, restitution, p)", "",
         "   As Pinocchio's impulseDynamics, by the Schur complement J M^-1 J' (redundant contacts: error",
         f"   {pkg}:redundant).",
         *contacts_help,
         "   restitution: 0 (omitted or []: the contacts stop, a plastic impact) to 1 (their velocities reverse).",
         "   impulses: 3 per point and 6 per surface contact, in the order of contacts.",
         *(["   The closed loops stay closed: A qd_plus = 0, solved with the contacts' rows."] if robot.loops else [])],
        [*_arguments(["q", "qd_minus"]),
         "if nargin < 3", "    contacts = [];", "end",
         "if nargin < 4 || isempty(restitution)", "    restitution = 0;", "end",
         "if nargin < 5 || isempty(p)", f"    p = {pkg}.parameters();", "end",
         "[frames, surface, held] = contact_list(contacts);",
         *_program(derivation, programs.impulse_dynamics)],
        local)
    return [forward, impulse]


def _program(derivation: Derivation, program: ContactProgram) -> list[str]:
    """The engine's program: its setup, each held contact's rows, its finish."""
    pkg, n = derivation.robot.name, len(derivation.symbols.qd)
    return [*statements(program.setup, pkg, n), *_contact_loop(derivation, program),
            *statements(program.finish, pkg, n)]


def _arguments(vectors: list[str]) -> list[str]:
    return [f"{v} = {v}(:);" for v in vectors]
