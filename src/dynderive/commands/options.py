"""Command-line values checked before any work: numbers, vectors and ``--param`` values.

Every problem is an ``InputError`` positioned at the option (``--rtol:1:1: ...``), so the
command exits 2 with one line per problem. ``--param`` values get exactly the checks a
robot file's own values get: the file is validated again with them (``validate``), and
what fails is reported at the option, with the place in the file it concerns.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..errors import InputError, Problem, ToolMissingError
from ..model.naming import did_you_mean
from ..verify.backends import Harness, backends, harness_of

#: The smallest relative tolerance an integrator can honour in double precision (SciPy
#: raises smaller ones to this, with a warning).
SMALLEST_RTOL = 100 * float(np.finfo(float).eps)


def problem(option: str, message: str, column: int = 1) -> Problem:
    return Problem(option, 1, column, message)


def require_scipy(command: str) -> None:
    """SciPy (a dependency of dynderive) importable, else ``ToolMissingError`` before any work."""
    try:
        import scipy  # noqa: F401
    except ImportError:
        raise ToolMissingError(f"{command} needs SciPy, a dependency of dynderive that is missing here: "
                               "pip install scipy") from None


def real_number(text: str) -> float | None:
    """``text``, an expression of numbers (``atan2(1,1)``, ``1e-3``), as a float; None when its
    value is not a finite real number. Raises the parser's errors (``ExpressionError``...)."""
    from ..model.expressions import parse_expression  # SymPy: loaded when an option needs it

    number = complex(parse_expression(text, {}).evalf(17))
    return None if number.imag or not math.isfinite(number.real) else number.real


def finite(value: float, option: str, what: str, low: float = -math.inf, strict: bool = False) -> None:
    """Refuse ``value`` unless it is finite and above ``low`` (``strict``) or at least ``low``."""
    if not math.isfinite(value) or (value <= low if strict else value < low):
        bound = "" if low == -math.inf else f" {'>' if strict else '>='} {low:g}"
        raise InputError(problem(option, f"expected {what}: a finite number{bound}, got {value:g}"))


def tolerances(rtol: float, atol: float) -> None:
    """``--rtol`` and ``--atol`` an adaptive integrator can work with."""
    problems = []
    if not (math.isfinite(rtol) and SMALLEST_RTOL <= rtol < 1):
        problems.append(problem("--rtol", f"expected a relative tolerance from {SMALLEST_RTOL:.3g} (the smallest a "
                                          f"double can honour) to below 1, got {rtol:g}"))
    if not (math.isfinite(atol) and atol >= 0):
        problems.append(problem("--atol", f"expected an absolute tolerance: a finite number >= 0, got {atol:g}"))
    if problems:
        raise InputError(problems)


def vector(text: str | None, size: int, option: str) -> np.ndarray | None:
    """``a,b,..`` (or spaces) -> ``size`` finite numbers; None when the option is absent."""
    if text is None:
        return None
    values = vector_any(text, option)
    if values is not None and len(values) == size:
        return np.array(values)
    raise InputError(problem(option, f"expected {size} numbers separated by commas, got {text!r}"))


def vector_any(text: str, option: str) -> list[float] | None:
    """``a,b,..`` (or spaces) -> finite numbers, as many as given; None if one is not a number
    (or none is given); a number that is not finite is refused at its column."""
    column, values = 1, []
    for part in text.replace(" ", ",").split(","):
        if part:
            try:
                number = float(part)
            except ValueError:
                break
            if not math.isfinite(number):
                raise InputError(problem(option, f"{part!r} is not a finite number", column))
            values.append(number)
        column += len(part) + 1
    else:
        return values or None
    return None


def split_top_level(text: str) -> list[str]:
    """``text`` split at the commas outside parentheses (``atan2(y, x)`` stays whole)."""
    parts, depth, start = [], 0, 0
    for i, char in enumerate(text):
        depth += (char == "(") - (char == ")")
        if char == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    return parts + [text[start:]]


def with_parameters(model: Any, robot: str, assignments: list[str], required: bool,
                    command: str = "this command", load: dict[str, Any] | None = None) -> Any:
    """``model`` with the values of ``--param NAME=VALUE`` (VALUE: a number or a whitelisted
    expression of numbers, e.g. ``pi/4``); ``required``: every parameter must then have a
    value (otherwise those without one take 1.0, as ``command`` does). The robot file ``robot``
    is validated again with the values used, so a negative mass or an expression that is not
    real at them is refused as it would be in the file (a URDF read as ``load`` says:
    ``floating_base``, ``symbolic``, the options ``--floating-base`` and ``--symbolic``)."""
    from ..model.expressions import ExpressionError

    known = {p.name: p for p in model.parameters}
    given: dict[str, float] = {}
    texts: dict[str, tuple[str, int]] = {}   # name -> (the option's text, the column of its value)
    problems = []
    for text in assignments:
        name, sep, value = text.partition("=")
        column = len(name) + 2
        name = name.strip()
        if not sep or not name:
            problems.append(problem("--param", f"expected NAME=VALUE, got {text!r}"))
            continue
        if name not in known:
            names = ", ".join(known) or "none"
            problems.append(problem("--param", f"unknown parameter {name!r} (parameters of {model.name}: {names})"))
            continue
        try:
            number = real_number(value)
        except (ExpressionError, TypeError, ValueError, OverflowError) as exc:
            problems.append(problem("--param", f"{name}: {exc}", column + getattr(exc, "offset", 0)))
            continue
        if number is None:
            problems.append(problem("--param", f"{name}: {value!r} is not a finite real number", column))
            continue
        given[name] = number
        texts[name] = (text.strip(), column)
    parameters = tuple(dataclasses.replace(p, value=given.get(p.name, p.value)) for p in model.parameters)
    filled: dict[str, float] = {}
    for p in parameters:
        if p.value is None and required:
            line, column = model.positions.get(f"parameter:{p.name}", (1, 1))
            problems.append(Problem(model.source, line, column, f"parameter '{p.name}' has no default value: "
                                    f"give one with --param {p.name}=VALUE"))
        elif p.value is None:
            filled[p.name] = 1.0
    if problems:
        raise InputError(problems)
    if given or filled:
        _check_values(robot, given, filled, texts, command, load or {})
    return dataclasses.replace(model, parameters=parameters) if given else model


def _check_values(robot: str, given: dict[str, float], filled: dict[str, float],
                  texts: dict[str, tuple[str, int]], command: str, load: dict[str, Any]) -> None:
    """Validate the robot file again with the parameter values used; report what fails at the
    ``--param`` option responsible (alone, else those given together), or, for a parameter
    without a default, at the file with the value taken."""
    found = _revalidate(robot, given | filled, load)
    if not found:
        return
    owner: dict[tuple[str, int, int], list[str]] = {}
    if len(given) > 1 or (given and filled):
        for name, value in given.items():
            for p in _revalidate(robot, {name: value}, load):
                owner.setdefault((p.file, p.line, p.column), []).append(name)
    elif given:
        owner = {(p.file, p.line, p.column): list(given) for p in found}
    problems = []
    for p in found:
        message = p.message.replace("at the default parameter values", "at the parameter values")
        names = owner.get((p.file, p.line, p.column)) or list(given)
        if len(names) == 1 and (p.file, p.line, p.column) in owner:
            text, column = texts[names[0]]
            problems.append(Problem("--param", 1, column, f"{text}: {message} ({p.file}:{p.line}:{p.column})"))
        elif given and not filled:
            together = ", ".join(texts[n][0] for n in names)
            problems.append(Problem("--param", 1, 1, f"{together} together: {message} ({p.file}:{p.line}:{p.column})"))
        else:
            taken = ", ".join(f"{n} = {v:g}" for n, v in filled.items())
            also = f" and --param {', '.join(texts[n][0] for n in given)}" if given else ""
            problems.append(dataclasses.replace(p, message=f"{message} (with {taken}, the value {command} takes for a "
                                                           f"parameter without a default{also}: give one with "
                                                           "--param NAME=VALUE)"))
    raise InputError(problems)


def _revalidate(robot: str, values: dict[str, float], load: dict[str, Any]) -> list[Problem]:
    """The problems of the robot file ``robot`` read again with the parameter ``values``."""
    from ..input.loader import resolve_robot_path
    from ..input.schema import validate
    from ..input.sources import read_source

    document = read_source(resolve_robot_path(robot), **load)
    block = document.data.get("parameters") or {}
    document.replaced |= set(values)
    for name, value in values.items():
        if isinstance(block.get(name), dict):
            block[name]["value"] = value
        else:
            block[name] = value
    try:
        validate(document)
    except InputError as exc:
        return exc.problems
    return []


def symbolic_kind(symbolic: str | None) -> tuple[str, ...]:
    """``build --symbolic``: the patterns' form checked before any work (what they match is
    each URDF file's matter), as the input kind ``symbolic:PATTERNS``."""
    if symbolic is None:
        return ()
    from ..input.urdf_symbolic import parse_patterns, patterns_of

    parse_patterns(patterns_of(symbolic) or ("",))   # '': a pattern left out, refused
    return (f"symbolic:{symbolic}",)


def backend_target(text: str) -> Harness | None:
    """The harness of ``--backend``'s target (any case): None for the generated NumPy module,
    else how ``check`` and ``simulate`` run that target's module (``verify/backends.py``). What it
    needs (a compiler, jax) is checked before any work; any other name is an InputError listing
    the choices."""
    choices = backends()
    if text.lower() not in choices:
        raise InputError(problem("--backend", f"expected one of {', '.join(choices)}, got {text!r}"
                                 + did_you_mean(text, choices)))
    harness = harness_of(text.lower())
    if harness is not None:
        harness.needs()
    return harness


#: Most significant digits ``--digits`` accepts (a double has 17; a file may write more).
MOST_DIGITS = 100


def sheet_digits_option(text: str | None, sheet: bool) -> int | None:
    """``--digits N``: the sheet's numbers to at most N significant digits (1 to MOST_DIGITS);
    ``sheet``: whether an output it applies to (the sheet, the page, the printed equations) is made."""
    if text is None:
        return None
    stripped = text.strip()
    if not (stripped.isascii() and stripped.isdigit()) or not 1 <= int(stripped) <= MOST_DIGITS:
        raise InputError(problem("--digits", f"expected a whole number of significant digits from 1 to "
                                             f"{MOST_DIGITS}, got {text!r}"))
    if not sheet:
        raise InputError(problem("--digits", "--digits shortens the numbers of the sheet: use it with --latex, "
                                             "--pdf or --html (or no output flag: the printed equations)"))
    return int(stripped)


def sheet_sections_option(text: str | None, sheet: bool) -> tuple[str, ...] | None:
    """``--sections``: the sheet's sections (``render.sheets.latex.parse_sections``), with a sheet only."""
    from ..render.sheets.latex import SECTIONS, parse_sections

    if text is None:
        return None
    try:
        chosen = parse_sections(text)
    except ValueError as exc:   # at the first name that is no section (column 1 when none is: an empty list)
        column = _section_column(text, lambda name: name not in SECTIONS) or 1
        raise InputError(problem("--sections", f"{exc} (choose from generalized, maximal, checks, or all)",
                                 column)) from None
    if not sheet:
        raise InputError(problem("--sections", "--sections chooses what the sheet shows: use it with --latex or "
                                               "--pdf (or --html)"))
    return chosen


def maximal_section_applies(text: str | None, planar: bool, floating: bool) -> None:
    """Refuse ``--sections`` naming ``maximal`` for a robot that has no maximal model (3-D or
    floating-base: the sheet would show the robot alone); ``all`` takes what applies."""
    column = _section_column(text or "", lambda name: name == "maximal")
    if column is None or (planar and not floating):
        return
    kind = "a floating-base robot" if floating else "a 3-D robot"
    raise InputError(problem("--sections", f"maximal coordinates are built for planar robots only (this is {kind}): "
                                           "leave 'maximal' out", column))


def _section_column(text: str, wanted) -> int | None:
    """1-based column in ``--sections``'s value of the first name ``wanted`` accepts, or None."""
    start = 0
    for part in text.split(","):
        name = part.strip()
        if name and wanted(name):
            return start + len(part) - len(part.lstrip()) + 1
        start += len(part) + 1
    return None
