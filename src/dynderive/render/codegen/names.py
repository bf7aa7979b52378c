"""What the C target needs of a robot's names and text: names that are valid C99 and C++
identifiers and clash with nothing the generated files use, and free text encoded for a
C comment.

Names are refused, not mangled: a parameter ``new`` would be the struct member ``p->new``,
which C++ cannot compile, and a silently renamed member (``new_``) would be a trap for the
programmer who fills the struct. The refusal names the robot file's line and column.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from ...errors import InputError, Problem
from ...model.robot import Robot
from ..encode import Code, code_point

#: C99 keywords, C11/C23 keywords, and C++ keywords and alternative operator names (the files
#: compile as C++ too).
C_KEYWORDS = frozenset("""
auto break case char const continue default do double else enum extern float for goto if inline int long
register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
_Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
alignas alignof bool constexpr false nullptr static_assert thread_local true typeof typeof_unqual
and and_eq asm bitand bitor catch char8_t char16_t char32_t class compl concept consteval constinit
const_cast co_await co_return co_yield decltype delete dynamic_cast explicit export friend mutable
namespace new noexcept not not_eq operator or or_eq private protected public reinterpret_cast requires
static_cast template this throw try typeid typename using virtual wchar_t xor xor_eq
""".split())

#: Object-like macros that ``<math.h>`` defines (C99, POSIX, glibc): a struct member of that
#: name would be replaced by the preprocessor. ``NULL`` too (other headers of a user's file).
MATH_MACROS = frozenset("""
HUGE_VAL HUGE_VALF HUGE_VALL INFINITY NAN FP_INFINITE FP_NAN FP_NORMAL FP_SUBNORMAL FP_ZERO
FP_FAST_FMA FP_FAST_FMAF FP_FAST_FMAL FP_ILOGB0 FP_ILOGBNAN MATH_ERRNO MATH_ERREXCEPT math_errhandling
M_E M_LOG2E M_LOG10E M_LN2 M_LN10 M_PI M_PI_2 M_PI_4 M_1_PI M_2_PI M_2_SQRTPI M_SQRT2 M_SQRT1_2
MAXFLOAT NULL EDOM ERANGE EILSEQ errno signgam
""".split())

_ASCII_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")


def c_problems(robot: Robot) -> list[Problem]:
    """Why the robot's names cannot be C names (empty when they can), each at its place."""
    name = robot.name
    if not _ASCII_IDENTIFIER.match(name) or "__" in name:
        return [Problem(robot.source, *robot.positions.get("name", (1, 1)),
                        f"--c: robot name '{name}' is not a C identifier of ASCII letters, digits and single '_' "
                        "starting with a letter (it prefixes every C name)")]
    ours = {f"{name.upper()}_{suffix}" for suffix in ("NQ", "NV", "NU", "NC", "NFRAMES", "DYNAMICS_H")}

    def why(parameter: str) -> str | None:
        if not _ASCII_IDENTIFIER.match(parameter) or "__" in parameter:
            return "is not a C identifier of ASCII letters, digits and single '_' starting with a letter"
        if parameter in C_KEYWORDS:
            return "is a C or C++ keyword"
        return "is a macro of <math.h> or of the generated header" if parameter in MATH_MACROS | ours else None

    return parameter_problems(robot, "--c", why, "a member of the C parameters struct")


def parameter_problems(robot: Robot, option: str, why: Callable[[str], str | None], use: str) -> list[Problem]:
    """The target ``option``'s refusal of each parameter name for which ``why`` gives a reason
    (None: the name is fine), at its place in the robot file: the name would be ``use``."""
    return [Problem(robot.source, *robot.positions.get(f"parameter:{p.name}", (1, 1)),
                    f"{option}: parameter name '{p.name}' {why(p.name)}: it would be {use}; rename it")
            for p in robot.parameters if why(p.name)]


def refuse(problems: list[Problem]) -> None:
    """Raise ``InputError`` (exit 2) if there are ``problems`` (names a target cannot use)."""
    if problems:
        raise InputError(problems)


def c_comment(text: object) -> Code:
    """``text`` for the inside of a ``/* ... */`` comment on one line, reversibly: printable
    ASCII stays except ``\\`` (``\\\\``), ``*/`` (``*\\/``), ``/*`` (``/\\*``), ``//`` and
    ``??`` (a trigraph; ``?\\?``), which could end the comment, warn, or change meaning;
    every other character (newlines, controls, non-ASCII) becomes ``\\xNN``, ``\\uNNNN`` or
    ``\\UNNNNNNNN`` text."""
    out: list[str] = []
    for char in str(text):
        previous = out[-1][-1:] if out else ""
        if char == "\\":
            out.append("\\\\")
        elif char == "/" and previous == "*":
            out.append("\\/")
        elif char == "*" and previous == "/":
            out.append("\\*")
        elif char == "/" and previous == "/":
            out.append("\\/")
        elif char == "?" and previous == "?":
            out.append("\\?")
        elif " " <= char <= "~":
            out.append(char)
        else:
            out.append(code_point(char))
    return Code("".join(out))
