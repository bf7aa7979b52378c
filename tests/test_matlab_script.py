"""The MATLAB derivation script ``<name>_derivation.m`` (render/targets/matlab/matlab_script.py).

Running it needs GNU Octave with the symbolic package: skipped locally without ``octave-cli``,
required in CI (CI=true). Octave's symbolic package is slow (each operation a round trip to
SymPy), so only a few robots run: the RP arm of the reference (every quantity compared with
the engine's at random points), the double pendulum, a robot with drives and one with a loop
(their checks must pass). The text tests (MATLAB-only syntax, encoded comments) need no Octave.
"""

from __future__ import annotations

import os
import random
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import sympy

import dynderive
from dynderive.render.targets.matlab.matlab_script import render_matlab_script
from dynderive.render.targets.matlab.matlab_text import matlab_code, matlab_comment, matlab_string

from conftest import BUNDLED, ROBOTS, derivation_of

OCTAVE = shutil.which("octave-cli") or shutil.which("octave")
RTOL = 1e-10
#: The reference's names (24-760 HW6): the RP arm's script must define each.
REFERENCE_NAMES = ["T_g", "V_g", "L_g", "Y_g", "EOM_g1", "M_g", "C_g", "N_g", "EOM_g2", "a_m", "A_m", "Adot_m",
                   "T_m", "V_m", "L_m", "Y_m", "M_m", "C_m", "N_m", "lambdaVec", "EOM_m1", "h", "H", "EOM_g3"]


def _octave() -> str:
    if OCTAVE is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must run the MATLAB script tests, but octave-cli was not found")
        pytest.skip("no GNU Octave")
    return OCTAVE


def _run(script: str, directory: Path, name: str) -> str:
    path = directory / f"{name}.m"
    path.write_text(script)
    result = subprocess.run([_octave(), "--no-gui", "--quiet", path.name], cwd=directory,
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def _assigned(script: str) -> list[str]:
    """The names the script assigns at the top level (``NAME = ...`` at a line's start)."""
    return list(dict.fromkeys(re.findall(r"^([A-Za-z][A-Za-z0-9_]*) = ", script, re.M)))


def _check_lines(output: str) -> list[str]:
    return [line for line in output.splitlines() if line.startswith(("pass: ", "FAIL: "))]


@pytest.mark.parametrize("robot", ["double_pendulum", "cart_pole_damped", "four_bar"])
def test_script_runs_and_its_checks_pass(robot, tmp_path):
    derivation = derivation_of(robot)
    script = render_matlab_script(derivation)
    # the closed-form multipliers (the double pendulum's) take Octave minutes and no check
    # reads them: run without that block (the RP arm's test runs it and compares lambdaVec)
    start, end = script.find("%% Constraint forces"), script.find("%% Change of basis")
    if "lambdaVec = " in script:
        assert 0 < start < end
        script = script[:start] + script[end:]
    checks = _check_lines(_run(script, tmp_path, f"{robot}_derivation"))
    assert checks and all(line.startswith("pass: ") for line in checks), checks
    assert len(checks) == script.count("isAlways(")


def test_rp_arm_script_reproduces_every_quantity(tmp_path):
    """Each quantity the script defines equals the engine's (which reproduces the reference)
    at random exact points: Octave prints double(subs(X, vars, vals)) to 17 digits."""
    derivation = derivation_of("rp_arm")
    script = render_matlab_script(derivation)
    names = [n for n in _assigned(script) if n in derivation.quantities]
    assert set(REFERENCE_NAMES) <= set(names), set(REFERENCE_NAMES) - set(names)
    assert {"EOM_m2", "J_b1", "J_b2", "q_m"} <= set(names)
    table = derivation.symbols
    symbols = sorted({s for n in names for s in sympy.Matrix([derivation[n]]).free_symbols}, key=str)
    rng = random.Random(29)
    points = [{s: sympy.Rational(rng.randint(-150, 150), 100) if s not in table.parameters.values()
               else sympy.Rational(rng.randint(50, 150), 100) for s in symbols} for _ in range(2)]
    lines = [script]
    for k, point in enumerate(points):
        variables = ", ".join(str(s) for s in point)
        values = ", ".join(f"sym({v.p})/sym({v.q})" for v in point.values())
        lines.append(f"vars = {{{variables}}};\nvals = {{{values}}};")
        for name in names:
            # evaluated before anything of its line is printed: a slow evaluation (lambdaVec's,
            # under load) makes the symbolic package print "Waiting....." and a newline into
            # stdout, which would otherwise split the line between its name and its numbers
            lines.append(f"value_ = double(subs({name}, vars, vals)); "
                         f"fprintf(1, 'VALUE {k} {name}%s\\n', sprintf(' %.17g', value_));")
    output = _run("\n".join(lines), tmp_path, "rp_arm_derivation")
    assert all(line.startswith("pass: ") for line in _check_lines(output)) and len(_check_lines(output)) == 5
    printed = {}
    # anywhere in a line: the symbolic package may print a notice of its own into stdout
    for match in re.finditer(r"VALUE (\d+) (\w+)((?: [-+\w.]+)*)$", output, re.M):
        printed[int(match.group(1)), match.group(2)] = [float(x) for x in match.group(3).split()]
    for k, point in enumerate(points):
        for name in names:
            value = derivation[name]
            entries = list(value.T) if isinstance(value, sympy.MatrixBase) else [value]
            expected = [float(sympy.sympify(e).xreplace(point).evalf(30)) for e in entries]
            got = printed.get((k, name))
            assert got is not None, (k, name, output[-3000:])
            assert len(got) == len(expected), name
            for a, b in zip(got, expected):
                assert abs(a - b) <= RTOL * max(1.0, abs(b)), (name, got, expected)


#: Octave-only syntax (outside comments and strings): # comments, !, !=, ++, --, +=, -=, *=,
#: /=, ** powers, the end-keywords, printf/puts, double-quoted strings, unwind_protect.
OCTAVE_ONLY = re.compile(r'#|!|\+\+|(?<![\w)\]])--|[-+*/^]=|\*\*|"|\b(?:endfunction|endif|endfor|endwhile|endswitch|'
                         r"end_try_catch|end_unwind_protect|unwind_protect|printf|puts|fputs|fdisp)\b")


def _code_part(line: str) -> str:
    """``line`` without its comment and with its single-quoted strings emptied."""
    out, in_string, k = [], False, 0
    while k < len(line):
        c = line[k]
        if in_string:
            if c == "'" and line[k + 1: k + 2] == "'":
                k += 2
                continue
            if c == "'":
                in_string = False
                out.append("''")
        elif c == "%":
            break
        elif c == "'" and (not out or not re.match(r"[\w)\].']", out[-1][-1:] if out[-1] else "")):
            in_string = True
        else:
            out.append(c)
        k += 1
    return "".join(out)


def _matlab_problems(script: str) -> list[str]:
    problems = []
    for number, line in enumerate(script.splitlines(), 1):
        stripped = line.strip()
        if stripped in ("%{", "%}", "#{", "#}"):
            problems.append(f"{number}: block comment marker")
        code = _code_part(line)
        if "pkg" in code and stripped != "if exist('OCTAVE_VERSION', 'builtin'), pkg load symbolic; end":
            problems.append(f"{number}: unguarded pkg")
        if OCTAVE_ONLY.search(code):
            problems.append(f"{number}: {line}")
    return problems


def test_the_syntax_check_catches_octave_only_tokens():
    for bad in ('x = "a";', "x += 1;", "if x != 1, end", "x++;", "y = x ** 2;", "endif", "printf('a')", "# note",
                "%{"):
        assert _matlab_problems(bad), bad
    assert not _matlab_problems("y = x.';  % a comment with # and != inside\nz = ['it''s', 'a'];")


@pytest.mark.parametrize("robot", BUNDLED + ["panda", "ur5"])
def test_every_bundled_script_is_matlab_only(robot):
    script = render_matlab_script(derivation_of(robot))
    assert _matlab_problems(script) == []
    assert script.count("pkg load symbolic") == 1
    # what is left out is said, never silent
    if derivation_of(robot).intermediate_form or derivation_of(robot).robot.loops:
        assert "% Left out of this script:" in script


def test_comments_and_strings_cannot_be_broken_out_of():
    hostile = "a\nerror('x')\r%{\n#{\u2028\x00\\ '}\"é"
    comment = matlab_comment(hostile)
    assert "\n" not in comment and "\r" not in comment and comment.isascii() and comment.isprintable()
    assert "%{" not in comment and "#{" not in comment
    string = matlab_string(hostile)   # not printable ASCII: the code points, char([97 10 ...])
    assert string == "char([" + " ".join(str(ord(c)) for c in hostile) + "])"
    plain = matlab_string("it's 9.81 m/s^2")
    assert plain == "'it''s 9.81 m/s^2'"


def test_hostile_title_and_descriptions_stay_in_comments(tmp_path):
    source = (ROBOTS / "double_pendulum.yaml").read_text()
    hostile = "x\\n%{\\nerror('title')\\n%}\\n#{\\u00e9"
    source = re.sub(r"(?m)^title: .*$", lambda _: f'title: "{hostile}"', source)
    source = re.sub(r"description: [^,}]*", lambda _: f'description: "{hostile}"', source, count=1)
    path = tmp_path / "hostile.yaml"
    path.write_text(source)
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert "error('title')" in derivation.robot.title
    script = render_matlab_script(derivation)
    assert "error('title')" in script   # the text is kept, encoded ...
    for line in script.splitlines():    # ... only ever inside a comment
        if "error('title')" in line:
            assert line.lstrip().startswith("%"), line
        assert line.strip() not in ("%{", "%}", "#{", "#}")
    assert _matlab_problems(script) == []


def test_numbers_are_exact():
    x = sympy.Symbol("x")
    assert matlab_code(sympy.Rational(-1, 3)) == "(sym(-1)/sym(3))"
    assert matlab_code(sympy.Float(9.81) * x) == "(sym(981)/sym(100))*x"
    assert matlab_code(sympy.sqrt(2) * x) == "sqrt(sym(2))*x"
    assert matlab_code(sympy.pi * x) == "sym(pi)*x"
    assert matlab_code(sympy.Integer(2**60) * x) == f"sym('{2**60}')*x"
    assert matlab_code(sympy.Matrix([[x, -x]])) == "[x, -x]"
    assert matlab_code(sympy.Integer(0)) == "sym(0)"   # never a double
    assert matlab_code(sympy.Matrix([0, 1])) == "[sym(0); sym(1)]"
    assert matlab_code(sympy.Matrix([[x, 0], [0, 0]])) == "[x, 0; sym(0), sym(0)]"


@pytest.mark.parametrize(("old", "new"), [("l", "H"), ("l", "gvec"), ("m", "lambdaVec")])
def test_a_name_the_script_assigns_is_refused_at_its_place(old, new, tmp_path):
    """A parameter the script would overwrite mid-derivation (``H``, ``gvec``, a quantity's
    name) is refused at its line and column, and nothing is written."""
    import re as regex

    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    from conftest import ROBOTS

    text = (ROBOTS / "rp_arm.yaml").read_text()
    robot = tmp_path / "arm.yaml"
    robot.write_text(regex.sub(rf"\b{old}\b", new, text))
    result = CliRunner().invoke(app, ["solve", str(robot), "--matlab", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    line = next(i for i, row in enumerate(robot.read_text().splitlines(), 1) if row.strip().startswith(f"{new}:"))
    assert f"{robot}:{line}:" in result.output and f"'{new}' is also a variable of the derivation script" in result.output
    assert not (tmp_path / "out").exists()
