"""Slips a new user makes, each refused at the spot with a hint, the user's files untouched:
an output over a file the model reads, a bundled robot's file name given outside the
repository (and ``copy`` to get it), a negative parameter default, MATLAB's operators, a
joint type in the wrong case, a plot suffix, an empty ``--symbolic``, a loop robot's
independent coordinates, contacts the robot file over-constrains."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from dynderive.verify.backends import backends
from test_hostile_outputs import _refused, _run

from conftest import ROBOTS


def _files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (links as where they point), by relative path."""
    return {str(p.relative_to(folder)): (os.readlink(p).encode() if p.is_symlink() else p.read_bytes())
            for p in sorted(folder.rglob("*")) if p.is_file() or p.is_symlink()}


# -- import (and simulate) never write over a file the model reads ------------------------------

PART = ('<mujoco>\n  <body name="arm">\n    <joint name="j1" type="hinge" axis="0 1 0"/>\n'
        '    <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/>\n  </body>\n</mujoco>\n')
MAIN = '<mujoco model="m">\n  <worldbody>\n    <include file="part.xml"/>\n  </worldbody>\n</mujoco>\n'
CUBE = "".join(f"v {x} {y} {z}\n" for z in (-0.1, 0.1) for y in (-0.1, 0.1) for x in (-0.1, 0.1)) + (
    "f 1 4 2\nf 1 3 4\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 2 4 8\nf 2 8 6\nf 4 3 7\nf 4 7 8\nf 3 1 5\nf 3 5 7\n")
MESHED = ('<mujoco model="arm">\n  <compiler meshdir="assets"/>\n  <asset>\n    <mesh name="box" file="box.obj"/>\n'
          '  </asset>\n  <worldbody>\n    <body name="b">\n      <joint name="j" type="hinge" axis="0 1 0"/>\n'
          '      <geom type="mesh" mesh="box" mass="1"/>\n    </body>\n  </worldbody>\n</mujoco>\n')
URDF_MESH = ('<robot name="r">\n  <link name="base"/>\n  <link name="l1"><inertial><mass value="1"/>'
             '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>\n'
             '    <visual><geometry><mesh filename="assets/box.obj"/></geometry></visual></link>\n'
             '  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
             '<limit effort="1" velocity="1" lower="-1" upper="1"/></joint>\n</robot>\n')


@pytest.fixture
def model(tmp_path, monkeypatch):
    """A folder with an MJCF file including another, one with a mesh, and a URDF with a mesh."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "assets").mkdir()
    for name, text in (("part.xml", PART), ("main.xml", MAIN), ("assets/box.obj", CUBE), ("arm.xml", MESHED),
                       ("r.urdf", URDF_MESH)):
        (tmp_path / name).write_text(text)
    os.symlink("part.xml", tmp_path / "link.xml")
    os.link(tmp_path / "part.xml", tmp_path / "hard.xml")
    return tmp_path


@pytest.mark.parametrize("robot, output, named", [
    ("main.xml", "part.xml", "a file the robot file main.xml reads (part.xml)"),   # an included file
    ("main.xml", "link.xml", "a file the robot file main.xml reads (part.xml)"),   # a symlink to it
    ("main.xml", "hard.xml", "a file the robot file main.xml reads (part.xml)"),   # a hard link to it
    ("main.xml", "main.xml", "the robot file (main.xml)"),
    ("main.xml", "nowhere/../main.xml", "the robot file (main.xml)"),
    ("arm.xml", "assets/box.obj", "a file the robot file arm.xml reads (assets/box.obj)"),   # <compiler meshdir>
    ("r.urdf", "assets/box.obj", "a file the robot file r.urdf reads (assets/box.obj)"),     # a URDF's mesh
])
def test_import_never_writes_over_a_file_the_model_reads(model, robot, output, named):
    before = _files(model)
    line = _refused(_run("import", robot, "-o", output), "--output:1:1: ")
    assert f" is {named}: " in line
    assert _files(model) == before


def test_import_of_a_model_with_includes_and_meshes_writes_elsewhere(model):
    before = _files(model)
    for robot in ("main.xml", "arm.xml"):
        result = _run("import", robot, "-o", f"{robot}.yaml")
        assert result.exit_code == 0, result.output
        assert (model / f"{robot}.yaml").read_text().count("name: ") >= 2
    assert _files(model) == before | {f"{r}.yaml": (model / f"{r}.yaml").read_bytes() for r in ("main.xml", "arm.xml")}


def test_simulate_never_writes_a_plot_over_a_mesh(model):
    before = _files(model)
    _refused(_run("simulate", "r.urdf", "--csv", "assets/box.obj"), "--csv:1:1: assets/box.obj is a file the robot file r.urdf reads")
    assert _files(model) == before


# -- a bundled robot's file name, and copy --------------------------------------------------------

@pytest.mark.parametrize("given, name", [("rp_arm.yaml", "rp_arm"), ("robots/ur5.urdf", "ur5"),
                                         ("four_bar.yml", "four_bar")])
def test_a_missing_file_named_as_a_bundled_robot_says_how_to_get_it(tmp_path, monkeypatch, given, name):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("solve", given, "--latex"), f"{given}:1:1: no such file; `{name}` is a bundled robot")
    assert f"`dynderive copy {name}`" in line
    assert list(tmp_path.iterdir()) == []


def test_a_missing_file_of_another_name_is_plain(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("solve", "my_arm.yaml"), "my_arm.yaml:1:1: no such file")
    assert "bundled" not in line


def test_copy_writes_the_bundled_file_to_edit(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = _run("copy", "rp_arm")
    assert result.exit_code == 0 and result.stderr.strip() == "wrote rp_arm.yaml"
    assert (tmp_path / "rp_arm.yaml").read_bytes() == (ROBOTS / "rp_arm.yaml").read_bytes()
    (tmp_path / "mine").mkdir()
    assert _run("copy", "ur5", "mine").exit_code == 0
    assert (tmp_path / "mine" / "ur5.urdf").read_bytes() == (ROBOTS / "ur5.urdf").read_bytes()
    assert _run("copy", "rp_arm", "arm2.yml").exit_code == 0
    result = _run("solve", "arm2.yml")   # the copy is a working robot file
    assert result.exit_code == 0 and "M(q)" in result.stdout


def test_copy_never_replaces_a_file_without_force(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rp_arm.yaml").write_text("mine\n")
    os.symlink("elsewhere.yaml", tmp_path / "dangling.yaml")
    before = _files(tmp_path)
    _refused(_run("copy", "rp_arm"), "rp_arm.yaml:1:1: already exists: give another name, or --force")
    _refused(_run("copy", "rp_arm", "dangling.yaml"), "dangling.yaml:1:1: already exists")
    assert _files(tmp_path) == before
    assert _run("copy", "rp_arm", "--force").exit_code == 0
    assert (tmp_path / "rp_arm.yaml").read_bytes() == (ROBOTS / "rp_arm.yaml").read_bytes()


@pytest.mark.parametrize("args, prefix, words", [
    (["rp_ar"], "rp_ar:1:1: no bundled robot of that name (did you mean 'rp_arm'?)", "bundled: bennett,"),
    (["nothing_like_it"], "nothing_like_it:1:1: no bundled robot of that name (bundled: ", "ur5"),
    (["ur5", "ur5.yaml"], "ur5.yaml:1:1: the copy of a .urdf robot file must end in .urdf or .xml", ""),
    (["rp_arm", "no/such/folder.yaml"], "no/such/folder.yaml:1:1: the folder no/such does not exist", ""),
])
def test_copy_refuses_what_it_cannot_do(tmp_path, monkeypatch, args, prefix, words):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("copy", *args), prefix)
    assert words in line
    assert list(tmp_path.iterdir()) == []


# -- a robot file's slips: a negative default, MATLAB's operators, a type's case ------------------

ARM = """name: arm
planar: true
parameters:
  m1: {value: 1.0}
  l1: {value: 1.0}
  m2: {value: 1.0}
  l2: {value: 1.0}
  m3: {value: 0.5}
  g: {value: 9.81}
gravity: [0, -g]
links:
  - name: link1
    mass: m1
    com: [l1/2, 0]
    inertia: m1*l1**2/12
  - name: link2
    mass: m3
    com: [l2/2, 0]
    inertia: m3*l2**2/12
joints:
  - name: q1
    type: revolute
    parent: world
    child: link1
  - name: q2
    type: revolute
    parent: link1
    child: link2
    origin: [l1, 0]
"""


def _slip(tmp_path, text: str, *options: str) -> str:
    """``solve`` of the robot file ``text``: its one line of refusal; the file is unchanged and
    nothing else is written."""
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    line = _refused(_run("solve", path, "--out", tmp_path / "out", *options), f"{path}:")
    assert path.read_text() == text and sorted(p.name for p in tmp_path.iterdir()) == ["arm.yaml"]
    return line[len(str(path)) + 1:]


@pytest.mark.parametrize("written, expected", [
    ("  m3: {value: -0.5}", "8:15: parameters.m3.value: default value -0.5 is negative, but it is links[1].mass "
                            "(at 17:11), which must be positive"),
    ("  m3: -0.5", "8:7: parameters.m3: default value -0.5 is negative, but it is links[1].mass (at 17:11), "
                   "which must be positive"),
])
def test_a_negative_default_is_reported_once_at_the_parameter(tmp_path, written, expected):
    assert _slip(tmp_path, ARM.replace("  m3: {value: 0.5}", written), "--latex") == expected


def test_a_negative_default_used_in_a_sum_and_twice(tmp_path):
    text = ARM.replace("m3: {value: 0.5}", "m3: {value: -0.5}").replace("mass: m1", "mass: m3 + 0.2")
    assert _slip(tmp_path, text) == ("8:15: parameters.m3.value: default value -0.5 is negative, and makes "
                                     "links[0].mass (at 13:11) -0.3, which must be positive")


def test_a_negative_default_of_a_3d_mass(tmp_path):
    text = ("name: box\nparameters:\n  m: {value: -2}\ngravity: [0, 0, -9.81]\nlinks:\n  - name: a\n    mass: m\n"
            "    inertia: [m/12, m/12, 0.1, 0, 0, 0]\njoints:\n  - {name: q1, type: revolute, parent: world, "
            "child: a, axis: [0, 1, 0]}\n")
    assert _slip(tmp_path, text) == ("3:14: parameters.m.value: default value -2 is negative, but it is "
                                     "links[0].mass (at 7:11), which must not be negative")


@pytest.mark.parametrize("expression, column, operator", [
    ("m3*l2.^2/12", 19, ".^"), ("m3.*l2**2/12", 16, ".*"), ("m3./12*l2**2", 16, "./"), ("m3*l2. ^ 2/12", 19, ". ^"),
])
def test_matlab_operators_get_a_hint(tmp_path, expression, column, operator):
    text = ARM.replace("inertia: m3*l2**2/12", f"inertia: {expression}")
    assert _slip(tmp_path, text) == (f"19:{column}: links[1].inertia: malformed expression: '{operator}' is "
                                     "MATLAB's element-wise operator; write ** (or ^) for powers, * and / for "
                                     "products and quotients")


def test_a_decimal_point_before_a_product_and_a_caret_power_still_parse(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text(ARM.replace("inertia: m3*l2**2/12", "inertia: 1.*m3*l2^2/12."))
    result = _run("solve", path)
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("written, expected", [
    ("Revolute", "'Revolute'; expected one of revolute, prismatic, fixed, floating, spherical, helical, universal, planar (did you mean "
                 "'revolute'?)"),
    ("revolut", "'revolut'; expected one of revolute, prismatic, fixed, floating, spherical, helical, universal, planar (did you mean "
                "'revolute'?)"),
    ("PRISMATIC", "'PRISMATIC'; expected one of revolute, prismatic, fixed, floating, spherical, helical, universal, planar (did you mean "
                  "'prismatic'?)"),
])
def test_a_joint_type_gets_a_did_you_mean(tmp_path, written, expected):
    text = ARM.replace("type: revolute", f"type: {written}")   # both joints: two lines, nothing else
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    result = _run("solve", path)
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert result.stderr.splitlines() == [f"{path}:{line}:11: joints[{i}].type: unsupported joint type {expected}"
                                          for i, line in ((0, 22), (1, 26))]
    assert path.read_text() == text


def test_a_loop_joint_type_gets_a_did_you_mean(tmp_path):
    text = (ROBOTS / "four_bar.yaml").read_text()
    assert "loops:" in text
    head, _, tail = text.partition("loops:")
    text = head + "loops:" + tail.replace("type: revolute", "type: Revolute", 1)
    line = _slip(tmp_path, text)
    assert line.endswith("unsupported planar loop joint type 'Revolute'; expected one of revolute, prismatic "
                         "(did you mean 'revolute'?)")


@pytest.mark.parametrize("args, expected", [
    (["--method", "rk54"], "--method:1:1: expected one of LSODA, Radau, BDF, RK45, DOP853, got 'rk54' (did you "
                           "mean 'RK45'?)"),
    (["--backend", "nunpy"], f"--backend:1:1: expected one of {', '.join(backends())}, got 'nunpy' (did you "
                             "mean 'numpy'?)"),
    (["--coordinates", "Maximal"], "--coordinates:1:1: expected generalized or maximal, got 'Maximal' (did you "
                                   "mean 'maximal'?)"),
])
def test_simulate_choices_get_a_did_you_mean(tmp_path, monkeypatch, args, expected):
    monkeypatch.chdir(tmp_path)
    assert _refused(_run("simulate", "rp_arm", *args), expected) == expected
    assert list(tmp_path.iterdir()) == []


# -- simulate --plot writes the format its suffix names ------------------------------------------

MAGIC = {".png": b"\x89PNG\r\n\x1a\n", ".jpg": b"\xff\xd8\xff", ".JPEG": b"\xff\xd8\xff", ".pdf": b"%PDF-",
         ".svg": b"<?xml"}


def test_plot_writes_the_format_its_suffix_names(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    for suffix, magic in MAGIC.items():
        result = _run("simulate", "rp_arm", "--duration", "0.2", "--frames", "5", "--plot", f"run{suffix}", "-q")
        assert result.exit_code == 0, result.output
        data = (tmp_path / f"run{suffix}").read_bytes()
        assert data.startswith(magic), (suffix, data[:8])
        if suffix == ".svg":
            assert b"<svg" in data[:2000]
    again = _run("simulate", "rp_arm", "--duration", "0.2", "--frames", "5", "--plot", "again.svg", "-q")
    assert again.exit_code == 0 and (tmp_path / "again.svg").read_bytes() == (tmp_path / "run.svg").read_bytes()


@pytest.mark.parametrize("name, said", [("run.gif", "has '.gif'"), ("run", "has no suffix"), ("run.tiff", "has '.tiff'")])
def test_plot_refuses_a_suffix_it_cannot_write(tmp_path, monkeypatch, name, said):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("simulate", "rp_arm", "--plot", name), f"--plot:1:1: {name} {said}: the plot is written")
    assert ".png, .pdf, .svg, .jpg" in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, said", [("run.png", "has '.png'"), ("run", "has no suffix"), ("run.mp4", "has '.mp4'")])
def test_animate_refuses_a_name_that_is_not_a_gif(tmp_path, monkeypatch, name, said):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    _refused(_run("simulate", "rp_arm", "--animate", name), f"--animate:1:1: {name} {said}: the animation is a GIF")
    assert list(tmp_path.iterdir()) == []


# -- a closed loop's --q0: every coordinate, or the independent ones ------------------------------

def test_a_loop_robot_starts_from_its_independent_coordinates(tmp_path, monkeypatch):
    pytest.importorskip("scipy")
    monkeypatch.chdir(tmp_path)
    runs = {}
    for name, q0 in (("short", "0.3"), ("full", None)):
        if q0 is None:   # every coordinate, the dependent ones as the short run assembled them
            q0 = ",".join(repr(float(v)) for v in runs["short"][0][1:4])
        result = _run("simulate", "four_bar", "--q0", q0, "--duration", "0.2", "--frames", "3", "--csv",
                      f"{name}.csv", "-q")
        assert result.exit_code == 0, result.output
        assert "largest constraint drift" in result.stdout
        lines = (tmp_path / f"{name}.csv").read_text().splitlines()
        assert lines[0].startswith("t,q1,q2,q3,")
        runs[name] = [[float(v) for v in line.split(",")] for line in lines[1:]]
    assert runs["short"][0][1] == 0.3
    assert runs["short"][0][2] != 0.5   # assembled, not the 0.5 rad a free joint starts at
    assert runs["short"] == runs["full"]


@pytest.mark.parametrize("q0", ["0.3,1", "0.3,1,2,3", "0.3,x", ""])
def test_a_loop_robot_refuses_another_count(tmp_path, monkeypatch, q0):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("simulate", "four_bar", "--q0", q0, "--csv", "run.csv"), "--q0:1:1: expected 3 numbers "
                    "(every coordinate: q1, q2, q3) or 1 (the independent coordinates q1), separated by commas")
    assert line.endswith(f"got {q0!r}")
    assert list(tmp_path.iterdir()) == []


# -- an empty --symbolic, and the names the generated module keeps --------------------------------

@pytest.mark.parametrize("args", [["solve", "ur5"], ["check", "ur5"], ["simulate", "ur5", "--csv", "run.csv"],
                                  ["solve", "rp_arm"], ["build", str(ROBOTS / "ur5.urdf"), "--out", "built"]])
def test_an_empty_symbolic_is_refused(tmp_path, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    _refused(_run(*args, "--symbolic", ""), "--symbolic:1:1: expected LINK.FIELD (FIELD: mass, com, inertia or *), "
             "got ''")
    assert list(tmp_path.iterdir()) == []


def test_the_names_page_lists_every_argument_and_local_of_the_module():
    from dynderive.input.names import API_ARGUMENTS, MODULE_LOCALS

    page = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "names.md").read_text()
    missing = sorted(name for name in API_ARGUMENTS | MODULE_LOCALS if f"`{name}`" not in page)
    assert not missing, missing


@pytest.mark.parametrize("target", ["--casadi", "--code", "--jax"])
def test_a_parameter_p_is_refused_for_every_target(tmp_path, target):
    text = ARM.replace("  m3: {value: 0.5}", "  p: {value: 0.5}").replace("mass: m3", "mass: p").replace(
        "m3*l2**2/12", "p*l2**2/12")
    assert _slip(tmp_path, text, target) == "8:3: parameters.p: name 'p' is reserved by the generated module"


# -- contacts the robot file declares, over-constrained ---------------------------------------------

HELD_TWICE = """name: held
planar: false
parameters:
  m: {value: 2.0, unit: kg}
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: m, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
  - {name: arm, mass: m, com: [0.2, 0, 0], inertia: [0.001, 0.03, 0.03, 0, 0, 0]}
joints:
  - {name: root, type: floating, parent: world, child: base, origin: {xyz: [0, 0, 0.3]}}
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 1, 0], effort: tau2}
frames:
  - {name: pad, link: base, origin: {xyz: [0, 0, -0.1]}}
  - {name: pad2, link: base, origin: {xyz: [0.1, 0, -0.1]}}
  - {name: tip, link: arm, origin: {xyz: [0.4, 0, 0]}}
contacts:
  - {frame: pad, kind: surface}
  - {frame: CONTACT, kind: surface}
"""


@pytest.mark.parametrize("second", ["pad2", "tip"])
def test_over_constrained_contacts_of_the_file_are_refused_at_its_contacts_entry(tmp_path, monkeypatch, second):
    monkeypatch.chdir(tmp_path)
    text = HELD_TWICE.replace("CONTACT", second)
    (tmp_path / "held.yaml").write_text(text)
    line = _refused(_run("simulate", "held.yaml", "--duration", "0.1", "--csv", "run.csv"),
                    f"held.yaml:16:1: contacts: the contacts pad (surface), {second} (surface) are redundant here")
    assert line.endswith("or run with --contacts naming fewer, or --contacts none")
    # given on the command line, the same contacts are refused at the option
    _refused(_run("simulate", "held.yaml", "--duration", "0.1", "--contacts", f"pad,{second}", "--csv", "run.csv"),
             f"--contacts:1:1: the contacts pad (surface), {second} (surface) are redundant here")
    assert _files(tmp_path) == {"held.yaml": text.encode()}
    result = _run("simulate", "held.yaml", "--duration", "0.1", "--frames", "3", "--contacts", "pad", "-q")
    assert result.exit_code == 0, result.output
