"""Property-based fuzzing of the robot-file front end and the derivation (Hypothesis).

1. Random *valid* planar and 3-D robots (trees of 1-3 joints, revolute / prismatic / fixed,
   random origins, axes, masses, inertias, gravity, optionally symbolic parameters with or
   without defaults) must load, derive and render; the generated module must give a symmetric
   positive definite mass matrix and ``inverse_dynamics(q, qd, forward_dynamics(q, qd, u))
   == generalized_forces(q, u)``, and every engine check that ran must pass.
2. Random *mutations* of the bundled robot files (lines deleted, duplicated, swapped,
   re-indented; tokens or characters replaced by hostile text; truncation) must either load
   (and then derive, or fail with ``InputError``) or raise ``InputError`` whose problems are
   positioned inside the file (line in range, column >= 1 and not past the end of its line),
   one-line messages, formatted ``FILE:LINE:COL: message``. Any other exception is a bug.
3. A few mutations through the CLI: exit code 0 or 2 (never 1), no traceback, one
   ``FILE:LINE:COL`` line per problem, and no output directory after exit code 2.

The bugs these tests found are kept as regression tests at the end, and their reproducers
as explicit ``@example``s of the fuzz tests: bugs 1-6 (all fixed).

Robots are kept small (derivation takes ~0.2-3 s each) and example counts modest so that the
whole file runs in about a minute on a 2-core machine. The Hypothesis database is off so that
runs leave nothing behind.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

import dynderive
from dynderive import InputError

from conftest import ROBOTS, import_code

_names = itertools.count()

SLOW = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]


def _settings(n: int) -> settings:
    return settings(max_examples=n, deadline=None, suppress_health_check=SLOW, database=None,
                    print_blob=True)


@pytest.fixture(scope="module")
def work_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def _fresh_dir(base: Path, stem: str) -> Path:
    folder = base / f"{stem}_{next(_names)}"
    folder.mkdir(parents=True)
    return folder


# ---------------------------------------------------------------------------------------
# Numbers: exact decimals written as text, so the file says exactly what we mean.
# ---------------------------------------------------------------------------------------

def _dec(units: int, places: int) -> str:
    """``units * 10**-places`` as an exact decimal string (``-0.25``, ``3``)."""
    if places == 0:
        return str(units)
    sign = "-" if units < 0 else ""
    digits = str(abs(units)).rjust(places + 1, "0")
    return f"{sign}{digits[:-places]}.{digits[-places:]}"


def decimals(lo: float, hi: float, places: int = 2) -> st.SearchStrategy[tuple[str, float]]:
    """(text, value) of a decimal in [lo, hi] with ``places`` decimals."""
    scale = 10**places
    return st.integers(round(lo * scale), round(hi * scale)).map(
        lambda n: (_dec(n, places), n / scale))


class _Params:
    """Parameters a generated robot declares, turning some numbers into symbols."""

    def __init__(self, draw, enabled: bool, limit: int = 3):
        self.draw = draw
        self.enabled = enabled
        self.limit = limit
        self.lines: list[str] = []
        self.kwargs: dict[str, float] = {}   # values of parameters without a default

    def value(self, text: str, places: int = 4) -> str:
        """``text`` itself, or an expression over a new parameter with the same value."""
        if not self.enabled or len(self.lines) >= self.limit or not self.draw(st.booleans()):
            return text
        name = f"c{len(self.lines) + 1}"
        scale = 10**places
        units = round(float(text) * scale)
        shift = self.draw(st.integers(-50, 50))  # expression "name + shift" keeps the value
        default = _dec(units - shift, places)
        style = self.draw(st.sampled_from(["short", "long", "none"]))
        if style == "short":
            self.lines.append(f"  {name}: {default}")
        elif style == "long":
            self.lines.append(f"  {name}: {{value: {default}, unit: m, description: 'fuzz: {name}'}}")
        else:
            self.lines.append(f"  {name}: ~")
            self.kwargs[name] = float(default)
        if shift == 0:
            return name
        return f"{name} + {_dec(shift, places)}" if shift > 0 else f"{name} - {_dec(-shift, places)}"

    def block(self) -> list[str]:
        return ["parameters:", *self.lines] if self.lines else [self.draw(st.sampled_from(
            ["parameters: {}", "parameters:", "# no parameters"]))]


def _tree(draw, max_joints: int = 3, min_moving: int = 1):
    """Joint types and parents of a tree: joint k's child is link k, its parent earlier."""
    # Biased towards bigger trees and moving joints (Hypothesis favours small values).
    n = draw(st.sampled_from([k for k in (1, 2, 2, 3, 3, 3) if min_moving <= k <= max_joints]))
    kinds = st.sampled_from(["revolute", "prismatic", "revolute", "prismatic", "fixed"])
    types = draw(st.lists(kinds, min_size=n, max_size=n))
    while sum(t != "fixed" for t in types) < min_moving:
        types[types.index("fixed")] = draw(st.sampled_from(["revolute", "prismatic"]))
    parents = [draw(st.integers(-1, k - 1)) for k in range(n)]
    return types, parents


@st.composite
def planar_robots(draw):
    """(YAML text, parameter kwargs) of a valid planar tree of 1-3 joints."""
    params = _Params(draw, draw(st.booleans()), limit=2)
    types, parents = _tree(draw)
    link_lines, joint_lines = [], []
    moving = 0
    for k, (jtype, parent) in enumerate(zip(types, parents)):
        mass, _ = draw(decimals(0.2, 3.0))
        (cx, cxv), (cy, cyv) = draw(decimals(-1, 1)), draw(decimals(-1, 1))
        inertia, iv = draw(st.one_of(st.just(("0", 0.0)), decimals(0.01, 0.5, 3)))
        if iv == 0 and cxv == 0 and cyv == 0:   # a point mass on its own joint axis: no inertia
            cx = "0.5"
        link_lines.append(f"  - name: b{k + 1}")
        link_lines.append(f"    mass: {params.value(mass)}")
        if draw(st.booleans()) or (cx, cy) != ("0.00", "0.00"):
            link_lines.append(f"    com: [{params.value(cx)}, {params.value(cy)}]")
        if iv != 0 or draw(st.booleans()):
            link_lines.append(f"    inertia: {params.value(inertia)}")
        if jtype == "fixed":
            name = f"weld{k + 1}"
        else:
            moving += 1
            name = f"q{moving}"
        joint_lines += [f"  - name: {name}", f"    type: {jtype}",
                        f"    parent: {'world' if parent < 0 else f'b{parent + 1}'}",
                        f"    child: b{k + 1}"]
        origin = draw(st.sampled_from(["none", "xy", "xyt", "pi"]))
        x, y = draw(decimals(-1, 1))[0], draw(decimals(-1, 1))[0]
        if origin == "xy":
            joint_lines.append(f"    origin: [{params.value(x)}, {params.value(y)}]")
        elif origin == "xyt":
            theta = draw(decimals(-3.14, 3.14))[0]
            joint_lines.append(f"    origin: [{x}, {y}, {params.value(theta)}]")
        elif origin == "pi":
            theta = draw(st.sampled_from(["pi/2", "-pi/2", "pi", "pi/3", "'atan2(1, 2)'"]))
            joint_lines.append(f"    origin: [{x}, {y}, {theta}]")
        if jtype == "prismatic" and draw(st.booleans()):
            while True:
                (ax, axv), (ay, ayv) = draw(decimals(-2, 2, 1)), draw(decimals(-2, 2, 1))
                if abs(axv) + abs(ayv) >= 0.2:
                    break
            joint_lines.append(f"    axis: [{ax}, {ay}]")
        if jtype != "fixed" and draw(st.integers(0, 4)) > 0:
            joint_lines.append(f"    effort: u{moving}")
    angle_g = draw(st.sampled_from(["down", "numeric", "symbolic", "zero"]))
    if angle_g == "down":
        gravity = "[0, -9.81]"
    elif angle_g == "numeric":
        gravity = f"[{draw(decimals(-12, 12))[0]}, {draw(decimals(-12, 12))[0]}]"
    elif angle_g == "zero":
        gravity = "[0, 0]"
    else:
        gravity = f"[{params.value('0.0')}, -{params.value('9.81')}]"
    lines = ["# generated by tests/test_fuzz.py", "name: fuzz_planar",
             f"title: {draw(st.sampled_from(['Fuzz robot', 'A & B % $ _ # {x} ~^', 'Ünïcödé ∂ robot']))!r}",
             "planar: true", *params.block(), f"gravity: {gravity}", "links:", *link_lines,
             "joints:", *joint_lines]
    return "\n".join(lines) + "\n", params.kwargs


def _axis3(draw) -> str:
    while True:
        vals = [draw(decimals(-1, 1, 1)) for _ in range(3)]
        if sum(abs(v) for _, v in vals) >= 0.3:
            return "[" + ", ".join(t for t, _ in vals) + "]"


@st.composite
def spatial_robots(draw):
    """(YAML text, parameter kwargs) of a valid 3-D tree of 1-3 joints."""
    params = _Params(draw, draw(st.booleans()), limit=2)
    types, parents = _tree(draw)
    link_lines, joint_lines = [], []
    moving = 0
    for k, (jtype, parent) in enumerate(zip(types, parents)):
        mass, _ = draw(decimals(0.2, 3.0))
        com = [draw(decimals(-0.5, 0.5))[0] for _ in range(3)]
        # principal-ish moments in [1.00, 1.80] (triangle inequality with margin 0.20) and
        # off-diagonal entries of at most 0.03 (eigenvalues move by at most 0.06): still
        # positive definite and physically valid. Then scaled by 10**-places.
        places = draw(st.integers(2, 4))
        diag = [draw(st.integers(100, 180)) for _ in range(3)]
        off = [draw(st.integers(-3, 3)) for _ in range(3)]
        d = [_dec(x, places) for x in diag]
        o = [_dec(x, places) for x in off]
        d[0] = params.value(d[0], places + 1)
        link_lines += [f"  - name: b{k + 1}", f"    mass: {params.value(mass)}"]
        if draw(st.booleans()):
            link_lines.append(f"    com: [{', '.join(com)}]")
        if draw(st.booleans()):
            link_lines.append(f"    inertia: [{d[0]}, {d[1]}, {d[2]}, {o[0]}, {o[1]}, {o[2]}]")
        else:
            link_lines.append(f"    inertia: [[{d[0]}, {o[0]}, {o[1]}], [{o[0]}, {d[1]}, {o[2]}], "
                              f"[{o[1]}, {o[2]}, {d[2]}]]")
        if jtype == "fixed":
            name = f"weld{k + 1}"
        else:
            moving += 1
            name = f"q{moving}"
        joint_lines += [f"  - name: {name}", f"    type: {jtype}",
                        f"    parent: {'world' if parent < 0 else f'b{parent + 1}'}",
                        f"    child: b{k + 1}"]
        parts = []
        if draw(st.booleans()):
            parts.append("xyz: [" + ", ".join(draw(decimals(-0.8, 0.8))[0] for _ in range(3)) + "]")
        if draw(st.booleans()):
            rpy = [draw(st.one_of(decimals(-3.14, 3.14).map(lambda t: t[0]),
                                  st.sampled_from(["pi/2", "-pi/2", "pi", "0"]))) for _ in range(3)]
            parts.append("rpy: [" + ", ".join(rpy) + "]")
        if parts or draw(st.booleans()):
            joint_lines.append("    origin: {" + ", ".join(parts) + "}")
        if jtype != "fixed" and draw(st.booleans()):
            joint_lines.append(f"    axis: {_axis3(draw)}")
        if jtype != "fixed" and draw(st.integers(0, 4)) > 0:
            joint_lines.append(f"    effort: u{moving}")
    g = draw(st.sampled_from(["down", "numeric", "symbolic"]))
    if g == "down":
        gravity = "[0, 0, -9.81]"
    elif g == "numeric":
        gravity = "[" + ", ".join(draw(decimals(-10, 10))[0] for _ in range(3)) + "]"
    else:
        gravity = f"[0, 0, -{params.value('9.81')}]"
    planar_line = draw(st.sampled_from(["planar: false", "# planar: false is the default"]))
    lines = ["# generated by tests/test_fuzz.py", "name: fuzz_spatial", "title: Fuzz 3-D robot",
             planar_line, *params.block(), f"gravity: {gravity}", "links:", *link_lines,
             "joints:", *joint_lines]
    return "\n".join(lines) + "\n", params.kwargs


def _check_valid_robot(text: str, kwargs: dict[str, float], seed: int, base: Path) -> str:
    """Load, derive, render and exercise a valid robot; returns a label for statistics."""
    folder = _fresh_dir(base, "valid")
    path = folder / "robot.yaml"
    path.write_text(text, encoding="utf-8")
    robot = dynderive.load_robot(path)
    derivation = dynderive.derive(robot)
    for check in derivation.checks:
        if check.method != "skipped":
            assert check.passed, f"engine check failed: {check.summary()}\n{text}"
    source = dynderive.render_code(derivation)
    module = import_code(source, folder, f"fuzz_dynamics_{next(_names)}")

    n, m = len(module.COORDINATES), len(module.EFFORTS)
    assert n == len(robot.coordinates) >= 1
    rng = np.random.default_rng(seed)
    q, qd, u = rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n), rng.uniform(-3, 3, m)
    M = module.mass_matrix(q, **kwargs)
    assert M.shape == (n, n)
    assert np.all(np.isfinite(M))
    np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-12 * max(1.0, np.abs(M).max()))
    eig = np.linalg.eigvalsh(M)
    assert eig[0] > 1e-12 * max(1.0, eig[-1]), f"M not positive definite: {eig}\n{text}"

    qdd = module.forward_dynamics(q, qd, u, **kwargs)
    tau = module.inverse_dynamics(q, qd, qdd, **kwargs)
    Y = module.generalized_forces(q, u, **kwargs)
    scale = max(1.0, np.abs(Y).max(), np.abs(M @ qdd).max(), np.abs(module.gravity_vector(q, **kwargs)).max())
    np.testing.assert_allclose(tau, Y, rtol=0, atol=1e-8 * scale)
    # Without efforts: the unforced motion.
    qdd0 = module.forward_dynamics(q, qd, **kwargs)
    np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd0, **kwargs), np.zeros(n), atol=1e-8 * scale)
    return f"{len(robot.joints)} joints, {n} coordinates"


@_settings(20)
@given(robot=planar_robots(), seed=st.integers(0, 2**32 - 1))
def test_random_valid_planar_robot_derives_consistently(robot, seed, work_dir):
    text, kwargs = robot
    event(_check_valid_robot(text, kwargs, seed, work_dir))


@_settings(15)
@given(robot=spatial_robots(), seed=st.integers(0, 2**32 - 1))
def test_random_valid_spatial_robot_derives_consistently(robot, seed, work_dir):
    text, kwargs = robot
    event(_check_valid_robot(text, kwargs, seed, work_dir))


ONE_DOF_PLANAR = {
    "pendulum": """\
name: pendulum
planar: true
gravity: [0, -9.81]
links:
  - name: b1
    mass: 0.2
    com: [0.5, 0]
joints:
  - name: q1
    type: revolute
    parent: world
    child: b1
""",
    "slider_with_weld": """\
name: slider
planar: true
gravity: [0, -9.81]
links:
  - name: b1
    mass: 1
    inertia: 0.1
  - name: b2
    mass: 0.5
    com: [0.2, 0.1]
    inertia: 0.01
joints:
  - name: weld1
    type: fixed
    parent: world
    child: b1
    origin: [0.1, 0.2, 0.3]
  - name: x
    type: prismatic
    parent: b1
    child: b2
    axis: [1, 1]
    effort: f
""",
}


@pytest.mark.parametrize("robot", sorted(ONE_DOF_PLANAR))
def test_planar_one_dof_generated_code(robot, work_dir):
    """Bug 1: render/targets/numpy/code.py printed every n x 1 matrix as a vector, so a 1-DOF planar robot's
    mass_matrix had shape (..., 1), not (..., 1, 1), and forward_dynamics raised ValueError
    in numpy.einsum ('too many subscripts for operand 0')."""
    _check_valid_robot(ONE_DOF_PLANAR[robot], {}, 0, work_dir)


# ---------------------------------------------------------------------------------------
# Mutations of the bundled robot files.
# ---------------------------------------------------------------------------------------

SOURCES = {name: (ROBOTS / f"{name}.yaml").read_text(encoding="utf-8")
           for name in ("rp_arm", "double_pendulum", "cart_pole", "elbow_arm")}

HOSTILE = [
    ":", "[", "]", "{", "}", "-", "- ", "'", '"', "**", "__import__", "__import__('os').system('x')",
    "#", "&a", "*a", "!!python/object/apply:os.system ['true']", "!!binary", "? ", "|", ">", "%",
    "~", "null", "true", "yes", "no", ".inf", "-.inf", ".nan", "1e309", "-1", "0", "1/0", "0/0",
    "0**-1", "9**9**9", "10**10000", "1e-400", "x" * 1100, "(" * 70 + "1" + ")" * 70, "()", "[1, 2]",
    "[1, 2, 3]", "[1, 2, 3, 4, 5, 6]", "[[1, 0, 0], [0, 1, 0], [0, 0, 1]]", "{}", "{a: 1}", "world",
    "fixed", "prismatic", "revolute", "continuous", "q1", "q2", "qd1", "x1", "phi1", "lambda1",
    "link1", "upper", "waist", "np", "mass_matrix", "sin", "pi", "E", "lambda: 0", "a if b else c",
    "é", "θ", "𝜃", "𝐦", "ｍ", "\u00a0", "\ufeff", "\u2028", "\x85", "\t", "\x00", "\x7f", "\r", "\\",
    "\\u0041", "planar: false", "planar: true", "planar: 3", "abs(-1)", "atan2(1)", "sqrt()",
    "m.__class__", "[m]*3", "f'x'", "b'x'", "1_000", "0x10", "1j", "2^3", "-m", "m - m", "sin(q1)",
    "&", "!", "<<", "<<: *a", "!!int", "!!float", "!!bool", "!!timestamp", "!!str", "!!set",
    "!!python/name:os.system", "---", "...", "%YAML 1.1", "\n", "  ", "ÿ" * 3,
]
TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*|\d+(?:\.\d+)?|\S")
#: The line breaks of YAML (PyYAML counts lines and columns with these).
LINE_BREAK = re.compile(r"\r\n|[\n\r\x85\u2028\u2029]")


@st.composite
def mutations(draw):
    """(source name, mutated text) from 1-3 random edits of a bundled robot file."""
    name = draw(st.sampled_from(sorted(SOURCES)))
    lines = SOURCES[name].split("\n")
    junk = st.one_of(st.sampled_from(HOSTILE), st.text(max_size=8))
    for _ in range(draw(st.integers(1, 3))):
        if not lines:
            lines = [""]
        i = draw(st.integers(0, len(lines) - 1))
        kind = draw(st.sampled_from(["delete", "duplicate", "swap", "token", "char", "insert",
                                     "truncate", "indent", "token", "char"]))
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "token":
            tokens = list(TOKEN.finditer(lines[i]))
            if tokens:
                t = draw(st.sampled_from(tokens))
                lines[i] = lines[i][:t.start()] + draw(junk) + lines[i][t.end():]
        elif kind in ("char", "insert"):
            line = lines[i]
            at = draw(st.integers(0, len(line)))
            cut = 1 if kind == "char" else 0
            lines[i] = line[:at] + draw(junk) + line[at + cut:]
        elif kind == "truncate":
            text = "\n".join(lines)
            at = draw(st.integers(0, len(text)))
            lines = text[:at].split("\n")
        else:
            stripped = lines[i].lstrip(" ")
            lines[i] = draw(st.sampled_from(["", " ", "  ", "   ", "    ", "      ", "\t", "        "])) + stripped
    return name, "\n".join(lines)


#: Line breaks other than '\n' that PyYAML counts (a lone CR, NEL, LS, PS).
OTHER_BREAK = re.compile(r"\r(?!\n)|[\x85\u2028\u2029]")


def _check_problems(error: InputError, path: Path, text: str) -> None:
    assert error.problems, "InputError without problems"
    for problem in error.problems:
        lines = LINE_BREAK.split(text)
        assert problem.file == str(path), problem
        assert isinstance(problem.line, int) and isinstance(problem.column, int), problem
        assert 1 <= problem.line <= len(lines) + 1, f"line out of range ({len(lines)} lines): {problem}"
        assert problem.column >= 1, f"column out of range: {problem}"
        assert problem.message and problem.message.strip(), f"empty message: {problem!r}"
        assert str(problem) == f"{path}:{problem.line}:{problem.column}: {problem.message}"
        # the CLI prints one 'FILE:LINE:COL: message' line per problem (bug 5)
        assert "\n" not in problem.message, f"message spans several lines: {problem!r}"
        if problem.line <= len(lines):  # (bug 4)
            assert problem.column <= len(lines[problem.line - 1]) + 1, (
                f"column past the end of line {problem.line} ({lines[problem.line - 1]!r}): {problem}")
    assert str(error) == "\n".join(str(p) for p in error.problems)


def _write(text: str, folder: Path) -> Path:
    path = folder / "robot.yaml"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    return path


@_settings(200)
@given(case=mutations(), derive=st.integers(0, 9))
@example(case=("cart_pole", SOURCES["cart_pole"].replace("type: revolute", "type: fixed")), derive=0)  # bug 1
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("    mass: m1\n", "    mass: m1\n    <<: {com: [0, 0]}\n")), derive=9)
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("mass: m1", "mass: !!int abc")), derive=9)
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("mass: m1", "mass: 𝐦1*𝐦1 + foo")), derive=9)
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("mass: m1", "mass: m\x1f1")), derive=9)
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("mass: m1", "mass: m1\r  \x1f")), derive=9)
def test_mutated_robot_file_loads_or_reports_positioned_problems(case, derive, work_dir):
    _, text = case
    path = _write(text, _fresh_dir(work_dir, "mutant"))
    try:
        robot = dynderive.load_robot(path)
    except InputError as error:
        _check_problems(error, path, text)
        return
    assert isinstance(robot, dynderive.Robot)
    event(f"loaded, {len(robot.coordinates)} coordinates")
    assert robot.coordinates, "a robot without coordinates loaded (it cannot be derived: bug 3)"
    # Deriving is the expensive part: only small robots, and only now and then.
    if derive == 0 and len(robot.coordinates) <= 3:
        event("derived")
        try:
            derivation = dynderive.derive(robot)
        except InputError as error:
            _check_problems(error, path, text)
            return
        dynderive.render_code(derivation)


# ---------------------------------------------------------------------------------------
# The CLI on mutated files.
# ---------------------------------------------------------------------------------------

def _solve(path: Path, out: Path):
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    return CliRunner().invoke(app, ["solve", str(path), "--code", "--out", str(out), "-q"])


@_settings(6)
@given(case=mutations())
@example(case=("cart_pole", "\x1f" + SOURCES["cart_pole"][1:]))  # bug 5
@example(case=("double_pendulum", SOURCES["double_pendulum"].replace("mass: m1", "mass: !!int abc")))  # bug 2
@example(case=("rp_arm", SOURCES["rp_arm"].replace("m: {value: 1.0", "m: {value: 2.5")))  # exit 0
def test_cli_solve_on_mutated_file_exits_0_or_2(case, work_dir):
    _, text = case
    folder = _fresh_dir(work_dir, "cli")
    path = _write(text, folder)
    out = folder / "out"
    result = _solve(path, out)
    output = result.output  # stdout and stderr, as a terminal shows them
    assert "Traceback" not in output
    assert result.exit_code in (0, 2), f"exit {result.exit_code}: {output}\n{result.exception!r}"
    if result.exit_code == 2:
        assert not out.exists(), "exit code 2 but an output directory was created"
        assert output.strip()
        for line in output.strip().splitlines():
            assert line.startswith(f"{path}:"), line
    else:
        assert (out / f"{dynderive.load_robot(path).name}_dynamics.py").is_file()


# ---------------------------------------------------------------------------------------
# Regression tests of the bugs these tests found (reproducers reduced by hand). Bug 1 (1-DOF
# planar generated code) is test_planar_one_dof_generated_code above.
# ---------------------------------------------------------------------------------------

DOUBLE_PENDULUM = SOURCES["double_pendulum"]
#: Bug 2 reproducers: (one edit of robots/double_pendulum.yaml, line of the problem).
YAML_CONSTRUCTOR_CASES = {
    "merge_key": (("    mass: m1\n", "    mass: m1\n    <<: {com: [0, 0]}\n"), 16),
    "tagged_key": (("    mass: m1\n", "    !!python/name:os.system : 1\n"), 15),
    "bad_int": (("mass: m1", "mass: !!int abc"), 15),
    "bad_float": (("mass: m1", "mass: !!float abc"), 15),
    "bad_bool": (("mass: m1", "mass: !!bool maybe"), 15),
    "bad_timestamp": (("mass: m1", "mass: !!timestamp 2001-13-45"), 15),
}


@pytest.mark.parametrize("case", sorted(YAML_CONSTRUCTOR_CASES))
def test_yaml_constructor_errors_are_input_errors(case, work_dir):
    """Bug 2: the loader caught yaml's ConstructorError only for scalar values: a merge key
    '<<' or a tagged mapping key raised ConstructorError, and tagged values that do not parse
    raised ValueError/KeyError from PyYAML's constructors, out of load_robot (CLI: exit 1)."""
    (old, new), line = YAML_CONSTRUCTOR_CASES[case]
    text = DOUBLE_PENDULUM.replace(old, new, 1)
    path = _write(text, _fresh_dir(work_dir, "bug2"))
    with pytest.raises(InputError) as info:
        dynderive.load_robot(path)
    _check_problems(info.value, path, text)
    assert info.value.problems[0].line == line, str(info.value)


def test_cli_yaml_tag_error_exits_2(work_dir):
    """Bug 2 through the CLI: 'internal error: ValueError', exit 1."""
    folder = _fresh_dir(work_dir, "bug2cli")
    path = _write(DOUBLE_PENDULUM.replace("mass: m1", "mass: !!int abc"), folder)
    result = _solve(path, folder / "out")
    assert result.exit_code == 2, result.output
    assert result.output.startswith(f"{path}:15:11: "), result.output
    assert not (folder / "out").exists()


ZERO_COORDINATES = {
    "planar": """\
name: welded
planar: true
gravity: [0, -9.81]
links:
  - name: b1
    mass: 1
joints:
  - name: w
    type: fixed
    parent: world
    child: b1
""",
    "spatial": """\
name: welded
gravity: [0, 0, -9.81]
links:
  - name: b1
    mass: 1
joints:
  - name: w
    type: fixed
    parent: world
    child: b1
""",
    # The bundled cart-pole with both joints welded (a one-word edit each, plus the axis and
    # effort a fixed joint may not have).
    "cart_pole_welded": SOURCES["cart_pole"].replace("type: prismatic", "type: fixed")
    .replace("type: revolute", "type: fixed").replace("    axis: [1, 0]\n", "")
    .replace("    effort: F\n", ""),
}


@pytest.mark.parametrize("case", sorted(ZERO_COORDINATES))
def test_robot_without_coordinates_is_an_input_error(case, work_dir):
    """Bug 3: a robot whose joints are all fixed passed validation, then derive() raised
    IndexError (planar: generalized.link_terms; 3-D: a Matrix slice); the CLI exited 1."""
    text = ZERO_COORDINATES[case]
    path = _write(text, _fresh_dir(work_dir, "bug3"))
    with pytest.raises(InputError) as info:
        dynderive.load_robot(path)
    _check_problems(info.value, path, text)


def test_cli_robot_without_coordinates_exits_2(work_dir):
    """Bug 3 through the CLI: 'internal error: IndexError', exit 1."""
    folder = _fresh_dir(work_dir, "bug3cli")
    path = _write(ZERO_COORDINATES["cart_pole_welded"], folder)
    result = _solve(path, folder / "out")
    assert result.exit_code == 2, result.output
    assert not (folder / "out").exists()


#: Bug 4 reproducers: (edit of double_pendulum.yaml, acceptable (line, column)s).
COLUMN_CASES = {
    # 'foo' is the 9th character of the value but its 15th UTF-8 byte (ast col_offset counts
    # bytes; '𝐦' NFKC-normalises to 'm', so '𝐦1' is the declared parameter m1). Was 15:25 on a
    # line of 21 characters.
    "non_ascii_before_error": (("mass: m1", "mass: 𝐦1*𝐦1 + foo"), {(15, 19)}),
    # A plain scalar folded over two lines: the offset was counted in the folded text and
    # added to the first line's column (15:16, past its end). The ')' itself (16:7) or the
    # start of the value (15:11) are both fine.
    "folded_scalar": (("mass: m1\n", "mass: m1 +\n      )\n"), {(16, 7), (15, 11)}),
}


@pytest.mark.parametrize("case", sorted(COLUMN_CASES))
def test_expression_error_column_is_inside_the_line(case, work_dir):
    """Bug 4: expression errors were placed at a UTF-8 byte offset or at an offset into a
    folded multi-line scalar, past the end of the line."""
    (old, new), expected = COLUMN_CASES[case]
    text = DOUBLE_PENDULUM.replace(old, new, 1)
    path = _write(text, _fresh_dir(work_dir, "bug4"))
    with pytest.raises(InputError) as info:
        dynderive.load_robot(path)
    _check_problems(info.value, path, text)
    (problem,) = info.value.problems
    assert (problem.line, problem.column) in expected, str(problem)


def test_non_printable_character_is_positioned(work_dir):
    """Bug 5: a non-printable character (yaml.reader.ReaderError, not a MarkedYAMLError) was
    reported at 1:1 wherever it was, with PyYAML's two-line text as the message
    ('...not allowed\\n  in "<unicode string>", position 631'), breaking the CLI's one
    'FILE:LINE:COL: message' line per problem."""
    text = DOUBLE_PENDULUM.replace("mass: m1", "mass: m\x1f1", 1)
    path = _write(text, _fresh_dir(work_dir, "bug5"))
    with pytest.raises(InputError) as info:
        dynderive.load_robot(path)
    _check_problems(info.value, path, text)
    (problem,) = info.value.problems
    assert (problem.line, problem.column) == (15, 12), str(problem)


#: Bug 6 reproducers: (edit of double_pendulum.yaml, (line, column) as PyYAML counts them).
READER_BREAK_CASES = {
    # a lone CR is a line break to YAML: the U+001F is on line 16, column 3
    "carriage_return": (("mass: m1", "mass: m1\r  \x1f"), (16, 3)),
    # NEL (U+0085) in the first comment: the U+001F is on line 2, column 8
    "next_line": (("# A planar", "# A\x85 planar\x1f"), (2, 8)),
}


@pytest.mark.parametrize("case", sorted(READER_BREAK_CASES))
def test_non_printable_character_position_counts_yaml_line_breaks(case, work_dir):
    (old, new), expected = READER_BREAK_CASES[case]
    text = DOUBLE_PENDULUM.replace(old, new, 1)
    path = _write(text, _fresh_dir(work_dir, "bug6"))
    with pytest.raises(InputError) as info:
        dynderive.load_robot(path)
    (problem,) = info.value.problems
    assert (problem.line, problem.column) == expected, str(problem)
