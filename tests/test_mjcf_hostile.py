"""Hostile robot files, run as the user runs them (``python -m dynderive`` in an empty working
folder): numbers that are not numbers (``nan``, ``inf``, ``1e200``) in MJCF, URDF and YAML,
and MJCF's XML hygiene (DTDs and entities, FIFOs named by ``<include>`` or an asset, nesting
deeper than MuJoCo reads). Each is one ``FILE:LINE:COL:`` line at the attribute or element,
exit 2, no traceback, no ``internal error``, nothing written in the working folder (no
``MUJOCO_LOG.TXT``) nor in ``--out``, and the robot file byte-identical."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[1]


def _model(body_attributes: str = "", joint_attributes: str = "", before: str = "", inertial: str = "") -> str:
    """An MJCF text: ``before`` at line 2, the moving body at line 4, its joint at line 5."""
    geom = inertial or '<geom size="0.1"/>'
    return (f'<mujoco model="hostile">\n{before or "  <compiler/>"}\n  <worldbody>\n'
            f'    <body name="a"{body_attributes}>\n      <joint name="j" type="hinge"{joint_attributes}/>\n'
            f'      {geom}\n    </body>\n  </worldbody>\n</mujoco>\n')


def _run(tmp_path: Path, robot: Path, *command: str) -> subprocess.CompletedProcess:
    """``dynderive COMMAND ROBOT`` from an empty working folder, which must stay empty; the
    robot file must be byte-identical afterwards."""
    cwd = tmp_path / "cwd"
    cwd.mkdir(exist_ok=True)
    before = robot.read_bytes() if robot.is_file() else None
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-m", "dynderive", command[0], str(robot), *command[1:]],
                          capture_output=True, text=True, timeout=120, cwd=cwd, env=env)
    assert sorted(os.listdir(cwd)) == [], "written into the working folder"
    if before is not None:
        assert robot.read_bytes() == before
    return done


def _refused(tmp_path: Path, robot: Path, command: str = "solve") -> str:
    """Exit 2 with exactly one positioned line (besides notes), nothing in ``--out``: the line."""
    out = tmp_path / "out"
    extra = ["--json", "--code", "--out", str(out), "-q"] if command == "solve" else ["-q"]
    done = _run(tmp_path, robot, command, *extra)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr + done.stdout and "internal error" not in done.stderr
    assert "WARNING" not in done.stderr + done.stdout   # MuJoCo's own, uncaptured
    lines = [line for line in done.stderr.strip().splitlines() if ": note: " not in line]
    assert len(lines) == 1 and re.match(r"^\S.*?:\d+:\d+: ", lines[0]), done.stderr
    assert not out.exists() or not any(out.iterdir())
    return lines[0]


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# -- numbers: MJCF ---------------------------------------------------------------------------------

def _at(text: str, line: int, written: str) -> str:
    """``LINE:COL`` of ``written`` (an attribute's ``name=``) on line ``line`` of ``text``."""
    return f"{line}:{text.splitlines()[line - 1].index(written) + 1}"


#: (MJCF text, line, the attribute as written, words of the message)
NUMBERS = {
    "nan position": (_model(' pos="0 nan 1"'), 4, "pos=", '<body pos="0 nan 1">: \'nan\' is not a finite number'),
    "inf quaternion": (_model(' quat="inf 0 0 1"'), 4, "quat=",
                       "<body quat=\"inf 0 0 1\">: 'inf' is not a finite number"),
    "huge position": (_model(' pos="0 1e200 1"'), 4, "pos=", "1e200 is out of range (numbers here are at most 1e10"),
    "NaN mass": (_model(inertial='<inertial pos="0 0 0" mass="NaN" diaginertia="1 1 1"/>'), 6, "mass=",
                 "<inertial mass=\"NaN\">: 'NaN' is not a finite number"),
    "negative infinity damping": (_model(joint_attributes=' damping="-Infinity"'), 5, "damping=",
                                  "'-Infinity' is not a finite number"),
    "beyond a double": (_model(joint_attributes=' armature="1e400"'), 5, "armature=",
                        "1e400 is out of the range of a double"),
    "in a default class": (_model(' childclass="c"', before='  <default><default class="c"><joint axis="0 0 nan"/>'
                                                            '</default></default>'), 2, "axis=", "'nan' is not a finite"),
    "huge gravity": (_model(before='  <option gravity="0 0 -1e11"/>'), 2, "gravity=", "-1e11 is out of range"),
    "huge hexadecimal": (_model(' pos="0 0x1p700 1"'), 4, "pos=", "0x1p700 is out of range"),
}


@pytest.mark.parametrize("case", NUMBERS, ids=list(NUMBERS))
def test_mjcf_numbers_that_are_not_numbers_are_refused_at_their_attribute(tmp_path, case):
    text, line, written, words = NUMBERS[case]
    robot = _write(tmp_path, "robot.xml", text)
    refused = _refused(tmp_path, robot)
    assert refused.startswith(f"{robot}:{_at(text, line, written)}: "), refused
    assert words in refused, refused


def test_check_refuses_a_huge_mjcf_position_instead_of_crashing(tmp_path):
    robot = _write(tmp_path, "robot.xml", _model(' pos="0 1e200 1"'))
    assert "1e200 is out of range" in _refused(tmp_path, robot, "check")


def test_a_number_in_an_included_file_is_placed_in_that_file(tmp_path):
    part = _write(tmp_path, "part.xml", '<mujoco>\n  <worldbody>\n    <body name="b" pos="inf 0 0">\n'
                  '      <joint type="hinge"/>\n      <geom size="0.1"/>\n    </body>\n  </worldbody>\n</mujoco>\n')
    robot = _write(tmp_path, "robot.xml", _model(before='  <include file="part.xml"/>'))
    refused = _refused(tmp_path, robot)
    assert refused.startswith(f"{part}:3:20: <body pos=\"inf 0 0\">: 'inf' is not a finite number"), refused
    assert refused.endswith(f"(included from {robot}:2)"), refused


def test_names_that_read_as_numbers_are_names(tmp_path):
    """A body called ``inf`` and a class called ``nan`` are names, not numbers: accepted."""
    text = _model(' childclass="nan"', before='  <default><default class="nan"><joint damping="0.1"/></default>'
                  '</default>').replace('name="a"', 'name="inf"')
    robot = _write(tmp_path, "robot.xml", text)
    done = _run(tmp_path, robot, "solve", "--json", "--out", str(tmp_path / "out"), "-q")
    assert done.returncode == 0, done.stderr
    assert "WARNING" not in done.stderr and (tmp_path / "out" / "hostile.json").is_file()


# -- numbers: URDF and YAML (their readers refuse them already) --------------------------------------

URDF = """<robot name="r">
  <link name="base"/>
  <link name="a"><inertial><mass value="MASS"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 Y 0"/><axis xyz="0 0 1"/>
    <limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
</robot>
"""


@pytest.mark.parametrize(("mass", "y", "line", "column", "words"), [
    ("1", "nan", 4, 70, "expected 3 finite numbers ('nan' is not one"),
    ("1", "inf", 4, 70, "expected 3 finite numbers ('inf' is not one"),
    ("1", "1e400", 4, 70, '<origin xyz="0 1e400 0">: expected 3 finite numbers'),
    ("nan", "0", 3, 27, "finite number"),
    ("1", "1e200", 4, 70, '<origin xyz="0 1e200 0">: out of range (a robot\'s numbers are at most 1e10'),
    ("1e12", "0", 3, 27, '<mass value="1e12">: out of range'),
], ids=["nan origin", "inf origin", "origin beyond a double", "nan mass", "huge origin", "huge mass"])
def test_urdf_numbers_that_are_not_numbers_are_refused(tmp_path, mass, y, line, column, words):
    robot = _write(tmp_path, "robot.urdf", URDF.replace("MASS", mass).replace("Y", y))
    refused = _refused(tmp_path, robot)
    assert refused.startswith(f"{robot}:{line}:"), refused
    assert words in refused, refused


def test_check_refuses_a_huge_urdf_origin_instead_of_crashing(tmp_path):
    """A length of 1e200 is a double, its square in M is not: refused at the reader, not an
    internal error of the code generator."""
    robot = _write(tmp_path, "robot.urdf", URDF.replace("MASS", "1").replace("Y", "1e200"))
    assert "out of range" in _refused(tmp_path, robot, "check")


YAML = """name: arm
planar: true
parameters:
  m: {value: MASS, unit: kg}
gravity: [0, -9.81]
links:
  - {name: upper, mass: m, com: [0.25, 0], inertia: 0.01}
joints:
  - {name: q1, type: revolute, parent: world, child: upper, effort: tau1, origin: [X, 0]}
"""


@pytest.mark.parametrize(("mass", "x", "line", "words"), [
    ("1.0", "1e400", 9, "number 'inf' is not finite"),
    ("1.0", "1e301", 9, "is out of range"),
    ("1e400", "0", 4, "default value must be finite"),
    (".nan", "0", 4, "default value must be finite"),
    ("1.0", "1e200", 9, "number '1e+200' is out of range (a robot's numbers are at most 1e10"),
    ("1e200", "0", 4, "default value 1e+200 is out of range"),
], ids=["origin beyond a double", "origin beyond 1e300", "infinite default", "nan default", "huge origin",
        "huge default"])
def test_yaml_numbers_that_are_not_numbers_are_refused(tmp_path, mass, x, line, words):
    robot = _write(tmp_path, "arm.yaml", YAML.replace("MASS", mass).replace("X", x))
    refused = _refused(tmp_path, robot)
    assert refused.startswith(f"{robot}:{line}:"), refused
    assert words in refused, refused


# -- XML hygiene ---------------------------------------------------------------------------------------

LAUGHS = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
          ' <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">\n]>\n')


def test_dtds_and_entities_are_refused_in_mjcf_as_in_urdf(tmp_path):
    mjcf = _write(tmp_path, "laughs.xml", LAUGHS + _model().replace('model="hostile"', 'model="&lol2;"'))
    urdf = _write(tmp_path, "laughs.urdf", LAUGHS + URDF.replace("MASS", "1").replace("Y", "0")
                  .replace('name="r"', 'name="&lol2;"'))
    said = [_refused(tmp_path, path) for path in (mjcf, urdf)]
    assert said == [f"{mjcf}:2:1: DTDs and entities are not allowed in MJCF files",
                    f"{urdf}:2:1: DTDs and entities are not allowed in URDF files"]


def test_an_external_entity_in_an_included_file_is_refused_there(tmp_path):
    part = _write(tmp_path, "part.xml", '<!DOCTYPE mujoco [ <!ENTITY x SYSTEM "/etc/hostname"> ]>\n'
                  '<mujoco><worldbody><body name="b"><joint/><geom size="0.1"/></body></worldbody></mujoco>\n')
    robot = _write(tmp_path, "robot.xml", _model(before='  <include file="part.xml"/>'))
    assert _refused(tmp_path, robot) == (f"{part}:1:1: DTDs and entities are not allowed in MJCF files "
                                         f"(included from {robot}:2)")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize(("before", "words"), [
    ('  <include file="part.xml"/>', '<include file="part.xml">: not a regular file (a FIFO)'),
    ('  <asset><mesh name="m" file="part.xml"/></asset>', '<mesh file="part.xml">: not a regular file (a FIFO)'),
    ('  <compiler meshdir="meshes"/><asset><mesh file="part.xml"/></asset>', "not a regular file (a FIFO)"),
], ids=["include", "mesh", "mesh in meshdir"])
def test_a_fifo_named_by_the_model_is_refused_not_waited_on(tmp_path, before, words):
    folder = tmp_path / "meshes" if "meshdir" in before else tmp_path
    folder.mkdir(exist_ok=True)
    os.mkfifo(folder / "part.xml")
    robot = _write(tmp_path, "robot.xml", _model(before=before))
    refused = _refused(tmp_path, robot)   # the subprocess' timeout guards against a hang
    assert refused.startswith(f"{robot}:2:{before.index('file=') + 1}: "), refused
    assert words in refused, refused


@pytest.mark.parametrize("depth", [600, 1500])
def test_nesting_deeper_than_mujoco_reads_is_said_in_words(tmp_path, depth):
    text = ('<mujoco model="deep">\n<worldbody>\n' + '<body>\n' * depth + '<joint/><geom size="0.1"/>\n'
            + '</body>\n' * depth + '</worldbody>\n</mujoco>\n')
    robot = _write(tmp_path, "deep.xml", text)
    assert _refused(tmp_path, robot) == (f"{robot}:500:1: <body>: elements nested more than 499 deep "
                                         "(the most MuJoCo's XML reader accepts)")
