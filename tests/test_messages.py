"""Messages a student can act on: YAML syntax errors in plain words, case-insensitive name
suggestions, positions inside option values, refusals instead of empty sheets."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.input.loader import parse_yaml
from dynderive.model.naming import closest_name

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
runner = CliRunner()


def _message(text: str) -> str:
    with pytest.raises(InputError) as caught:
        parse_yaml(text, "robot.yaml")
    return str(caught.value)


@pytest.mark.parametrize(("text", "expected"), [
    # a key dedented to the list's dash: PyYAML says "expected <block end>, but found '?'"
    ("links:\n  - name: l1\n    mass: m\n  com: 1\n",
     "robot.yaml:4:3: this line is indented differently from the lines before it (its siblings at column 5)"),
    # dedented between two levels: "expected <block end>, but found '<block mapping start>'"
    ("a:\n    b: 1\n    c: 2\n  d: 3\n",
     "robot.yaml:4:3: this line is indented differently from the lines before it (its siblings at column 5)"),
    # a list item dedented below its siblings
    ("links:\n  - name: l1\n    mass: m\n - name: l2\n",
     "robot.yaml:4:2: this line is indented differently from the lines before it (its siblings at column 3)"),
    # comments and block scalars are no siblings
    ("a:\n  b:\n    # note\n    c: |\n        text\n   d: 2\n",
     "robot.yaml:6:4: this line is indented differently from the lines before it (its siblings at column 5)"),
    # indented more: PyYAML says "mapping values are not allowed here" at the ':'
    ("links:\n  - name: l1\n    mass: m\n      com: 1\n",
     "robot.yaml:4:7: this line is indented more than the line before it (its siblings at column 5)"),
    ("a: 1\n b: 2\n",
     "robot.yaml:2:2: this line is indented more than the line before it (its siblings at column 1)"),
    # "mapping values are not allowed here" on one line
    ("title: Arm: two links\n",
     "robot.yaml:1:11: a second ': ' on this line: a value that contains ': ' must be quoted, or the key "
     "belongs on a line of its own"),
    # "could not find expected ':'": the line without ':' (PyYAML points at the next line)
    ("links:\n  - name: l1\n    mass m\n    com: 1\n",
     "robot.yaml:3:5: this line has no ':' after its key (each line of a mapping is written 'key: value')"),
    ("a:\n  b: 1\n  c\n",
     "robot.yaml:3:3: this line has no ':' after its key (each line of a mapping is written 'key: value')"),
    # a ':' without a space (PyYAML: "could not find expected ':'" or "mapping values ...")
    ("links:\n  - name: l1\n    mass:m\n    com: 1\n",
     "robot.yaml:3:9: put a space after the ':' of 'mass:' (without it YAML reads the key and its value "
     "as one word)"),
    ("a:\n  b:1\n  c: 2\n",
     "robot.yaml:2:4: put a space after the ':' of 'b:' (without it YAML reads the key and its value "
     "as one word)"),
    # tabs: "found character '\t' that cannot start any token"
    ("a:\n  b: 1\n\tc: 2\n", "robot.yaml:3:1: this line is indented with a tab: YAML indentation must use spaces"),
    ("a: [1,\t2]\n", "robot.yaml:1:7: a tab cannot stand here in YAML: use spaces"),
    # a list mixed with keys: "expected <block end>, but found '-'" / "... found '?'"
    ("a:\n  b: 1\n  - c\n",
     "robot.yaml:3:3: list items ('- ...') and 'key: value' lines cannot be mixed at one indentation (column 3)"),
    ("a:\n  - b\n  c: 1\n",
     "robot.yaml:3:3: list items ('- ...') and 'key: value' lines cannot be mixed at one indentation (column 3)"),
])
def test_yaml_syntax_errors_in_student_words(text, expected):
    assert _message(text) == expected


def test_other_yaml_errors_keep_pyyaml_wording():
    assert _message("a: *x\n") == "robot.yaml:1:4: YAML syntax error: found undefined alias 'x'"


# --- suggestions ------------------------------------------------------------------------

@pytest.mark.parametrize(("name", "candidates", "expected"), [
    ("L3", ["l1", "l2", "l3", "m"], "l3"),   # difflib alone rates 'L3' and 'l3' 0.5: no match
    ("Q1", ["q1", "q2"], "q1"),
    ("masss", ["mass", "com"], "mass"),
    ("LENGTH", ["length2", "m"], "length2"),
    ("zzz", ["mass", "com"], None),
])
def test_closest_name_ignores_case(name, candidates, expected):
    assert closest_name(name, candidates) == expected


def test_undeclared_symbol_suggests_the_name_in_another_case(tmp_path):
    robot = tmp_path / "arm.yaml"
    text = (ROBOTS / "rp_arm.yaml").read_text()
    text = text.replace("  l: {value: 1.0, unit: m, description: length of each link}",
                        "  l3: {value: 1.0, unit: m, description: length of each link}").replace("l/2", "l3/2")
    text = text.replace("inertia: m*l**2/12", "inertia: m*L3**2/12", 1).replace("*l", "*l3").replace("(l", "(l3")
    robot.write_text(text)
    result = runner.invoke(app, ["solve", str(robot), "--latex", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "L3" in t)
    assert f"{robot}:{line}:16: links[0].inertia: undeclared symbol 'L3' (did you mean 'l3'?)" in \
        result.stderr.splitlines()
    assert not (tmp_path / "out").exists()


# --- --sections ---------------------------------------------------------------------------

@pytest.mark.parametrize(("value", "column", "name"), [
    ("maximal,foo", 9, "foo"),
    ("foo", 1, "foo"),
    ("generalized, maximal,  bar", 24, "bar"),
    ("maximal,all", 9, "all"),
])
def test_unknown_section_is_positioned_at_its_name(value, column, name, tmp_path):
    result = runner.invoke(app, ["solve", "rp_arm", "--sections", value, "--latex", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"--sections:1:{column}: unknown section '{name}' (choose from generalized, "
                                     "maximal, checks, or all)")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("value", "column"), [("maximal", 1), ("generalized,maximal", 13)])
def test_maximal_section_of_a_3d_robot_is_refused(value, column, tmp_path):
    """A 3-D robot has no maximal model: the sheet would show the robot alone."""
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(ROBOTS / "elbow_arm.yaml"), "--sections", value, "--latex",
                                 "--out", str(out)])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"--sections:1:{column}: maximal coordinates are built for planar robots only "
                                     "(this is a 3-D robot): leave 'maximal' out")
    assert "Traceback" not in result.output
    assert not out.exists()


def test_all_sections_of_a_3d_robot_are_the_ones_that_apply(tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(ROBOTS / "elbow_arm.yaml"), "--sections", "all", "--latex", "-q",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "Generalized coordinates" in (out / "elbow_arm.tex").read_text()


# --- a floating root is not welded --------------------------------------------------------

LEGGED = """\
<robot name="legged">
  <link name="base">
    <inertial><mass value="1e-6"/>
      <inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/></inertial>
  </link>
  <link name="trunk">
    <inertial><mass value="5"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.06"/></inertial>
  </link>
  <joint name="trunk_mount" type="fixed"><parent link="base"/><child link="trunk"/></joint>
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <joint name="ja" type="revolute"><parent link="trunk"/><child link="a"/><axis xyz="0 1 0"/></joint>
  <joint name="jb" type="revolute"><parent link="trunk"/><child link="b"/><axis xyz="0 1 0"/></joint>
</robot>
"""


def test_a_floating_root_link_is_not_said_to_be_welded(tmp_path):
    """go1's root link 'base' (a placeholder inertia, moments 0, 0, 3e-6): with a fixed base it
    is welded to the world and its inertia ignored; with --floating-base it floats, and its
    inertia enters the dynamics as written (as Pinocchio reads it)."""
    path = tmp_path / "legged.urdf"
    path.write_text(LEGGED)
    triangle = "link 'base' inertia: principal moments 0, 0, 3e-06 violate the triangle inequality"
    fixed = dynderive.load_robot(path)
    assert f"{path}:4:7: note: {triangle} by 3e-06; ignored: the link is welded to the world, so its inertia never " \
           "enters the dynamics" in fixed.notes
    floating = dynderive.load_robot(path, floating_base=True)
    assert not any("welded" in note for note in floating.notes)
    assert floating.notes == (f"{path}:4:7: note: {triangle} by 3e-06, beyond the rounding tolerance 3e-07: "
                              "physically impossible, but kept as written (as Pinocchio does)",)
