"""What the MATLAB/Octave target needs of a robot's names and text: a robot name that can be a
package folder ``+<name>`` and a parameter name that can be a field of the parameters struct
(MATLAB identifiers, no keyword of MATLAB or Octave), and free text encoded for a ``%`` comment
or a character-vector literal.

Names are refused, not mangled, at their place in the robot file (as ``codegen/names.py`` does for
C): a renamed field would be a trap for the user who fills the struct. The robot's name is the
package's, which the generated functions call (``rp_arm.mass_matrix(q, p)``): it must not be a
local variable of theirs (``p.mass_matrix`` would read a field) or a function they call.
"""

from __future__ import annotations

import re

from ....errors import Problem
from ....model.robot import Robot
from ...codegen.names import parameter_problems
from ...encode import Code, code_point

#: MATLAB's keywords (``iskeyword``) and Octave's (``iskeyword`` of GNU Octave 7): a field or
#: package of that name cannot be written with a dot.
MATLAB_KEYWORDS = frozenset("""
break case catch classdef continue else elseif end for function global if otherwise parfor persistent
return spmd switch try while arguments enumeration events methods properties
do end_try_catch end_unwind_protect endclassdef endenumeration endevents endfor endfunction endif
endmethods endparfor endproperties endspmd endswitch endwhile unwind_protect unwind_protect_cleanup until
__FILE__ __LINE__
""".split())

#: The functions and local variables of the generated files: a package of that name would be
#: shadowed by them (or shadow them).
GENERATED_NAMES = frozenset("""
abs acos asin atan atan2 cos cosh exp log sin sinh sqrt tan tanh sign zeros eye isempty nargin svd
error ischar strcmp isnumeric numel struct nan NaN pi size reshape max min any all isfinite floor
q qd qdd u p frame M C N V F Y A B R X K E D G T J W x s r top bottom rhs solution lambda tau n index
Ur Ar Ub ans Adot Aj a alpha beta pi_ qdd0 loop_solve isstring isequal tanh
dtau_dq dtau_dqd dqdd_dq dqdd_dqd dqdd_du
m c cdot J_G Jdot_G_qd A_G h_G Adot_G_qd I_G
contacts baumgarte anchors restitution qd_minus qd_plus impulses forces frames surface held entries kinds names
parts k kind anchor turn w v e err drift gamma free Jc Jf MiJt S target contact_list contact_rows schur_solve
cross eig strjoin sprintf find num2cell cellstr isstruct isfield iscell isscalar isreal fix double false char
cell acc b gam h jump kd kp rate twist jac lam reduced row_space_solve Sb values diag sum rows loop_rate loop_drift
q_guess trace
""".split())

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
#: ``namelengthmax`` of MATLAB and Octave.
MAX_NAME = 63
#: The fields the parameters struct adds to the robot's parameters.
ADDED_FIELDS = ("friction_smoothing", "alpha", "beta")


def matlab_problems(robot: Robot) -> list[Problem]:
    """Why the robot's names cannot be MATLAB names (empty when they can), each at its place."""
    problems = []
    name = robot.name
    why = _why(name)
    if why is None and (name in GENERATED_NAMES or re.fullmatch(r"t[0-9]+", name)):
        why = "is a function or a local variable of the generated files"
    if why:
        problems.append(Problem(robot.source, *robot.positions.get("name", (1, 1)),
                                f"--matlab: robot name '{name}' {why}: it names the package +{name}; rename it"))
    added = ADDED_FIELDS if robot.loops else ADDED_FIELDS[:1]
    return problems + parameter_problems(
        robot, "--matlab", lambda p: _why(p) or ("is a field the generated parameters struct adds" if p in added else None),
        "a field of the MATLAB parameters struct")


def _why(name: str) -> str | None:
    if not _IDENTIFIER.match(name):
        return "is not a MATLAB identifier of ASCII letters, digits and '_' starting with a letter"
    if len(name) > MAX_NAME:
        return f"is longer than MATLAB's {MAX_NAME} characters"
    if name in MATLAB_KEYWORDS:
        return "is a MATLAB or Octave keyword"
    return None


def matlab_comment(text: object) -> Code:
    """``text`` for a ``%`` comment line, reversibly: printable ASCII stays except ``\\``
    (``\\\\``), ``{`` and ``}`` (``\\{``, ``\\}``: no ``%{`` or ``%}`` block-comment marker)
    and ``#`` (``\\#``: Octave's comment character, kept out of the files); every other
    character (newlines, controls, non-ASCII) becomes ``\\xNN``, ``\\uNNNN`` or
    ``\\UNNNNNNNN`` text."""
    out: list[str] = []
    for char in str(text):
        if char in "\\{}#":
            out.append("\\" + char)
        elif " " <= char <= "~":
            out.append(char)
        else:
            out.append(code_point(char))
    return Code("".join(out))


def matlab_string(text: str) -> Code:
    """A MATLAB expression whose value is the character vector ``text``: ``'...'`` with ``'``
    doubled when ``text`` is printable ASCII without ``#``, ``%``, ``{`` or ``}`` (nothing a
    scanner of comments or block markers could misread), else ``char([...])`` of its code
    points."""
    if all(" " <= c <= "~" and c not in "#%{}\"" for c in text):
        return Code("'" + text.replace("'", "''") + "'")
    return Code("char([" + " ".join(str(ord(c)) for c in text) + "])")
