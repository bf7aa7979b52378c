"""Careless and hostile input through names, URDF and YAML numbers (issue 27, items 3, 4 and
the velocity names of item 10): what is accepted gives the right result (exit 0), what is
refused gets one positioned line and exit 2. The refusals themselves are corpus cases
(``tests/corpus``: ``frame_name_*``, ``robot_name_too_long*``, ``urdf_xacro_*``,
``urdf_number_*``, ``parameter_*exponent*``, ``clash_velocity_d_d``); here are the inputs
that must pass, and the properties behind the refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.input.names import engine_quantities
from dynderive.model.naming import (
    acceleration_name,
    body_jacobian_index,
    frame_quantity_names,
    velocity_name,
)

from conftest import import_code

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

#: A planar arm: a revolute joint, then a prismatic one (``JOINT2``), a frame placeholder.
ARM = """\
name: NAME
planar: true
parameters:
  m: {value: MASS, unit: kg}
  l: 0.5
  g: 9.81
gravity: [0, -g]
links:
  - {name: upper, mass: m, com: [l/2, 0], inertia: m*l**2/12}
  - {name: slider, mass: m, com: [0, 0], inertia: INERTIA}
joints:
  - {name: q1, type: revolute, parent: world, child: upper, effort: tau1}
  - {name: JOINT2, type: prismatic, parent: upper, child: slider, origin: [l, 0], effort: f2}
"""


def _arm(tmp_path: Path, name: str = "arm", mass: str = "1.0", joint: str = "q2", inertia: str = "0.01",
         frames: str = "") -> Path:
    text = ARM.replace("NAME", name).replace("MASS", mass).replace("JOINT2", joint).replace("INERTIA", inertia)
    path = tmp_path / "arm.yaml"
    path.write_text(text + frames)
    return path


# -- YAML numbers ------------------------------------------------------------------------------

@pytest.mark.parametrize("written, value", [("1e-3", 1e-3), ("2E5", 2e5), ("-1.5e3", -1.5e3), ("+3e+0", 3.0),
                                            (".5e1", 5.0), ("1.0e3", 1e3)])
def test_yaml_exponent_without_dot_is_a_number(tmp_path, written, value):
    """YAML 1.1 reads ``1e-3`` as text; it is the number users mean (as in YAML 1.2)."""
    robot = dynderive.load_robot(_arm(tmp_path, mass=written if value > 0 else "1.0",
                                      inertia=written if value > 0 else "0.01"))
    if value > 0:
        assert robot.parameters[0].value == value
        assert robot.links[1].inertia == (value,)
    doc = dynderive.input.loader.parse_yaml(f"a: {written}\nb: '{written}'\n", "t.yaml")
    assert doc.data == {"a": value, "b": written}   # quoted stays text


def test_yaml_exponent_numbers_keep_positioned_errors(tmp_path):
    """A number read from ``-1e-3`` is still judged at its own line and column."""
    path = _arm(tmp_path, mass="1e-3")
    path.write_text(path.read_text().replace("mass: m, com: [0, 0]", "mass: -2e-3, com: [0, 0]"))
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert result.stderr.splitlines() == [f"{path}:10:26: links[1].mass: must be positive (got -0.002)"]


@pytest.mark.parametrize("end, written, kind, column", [("parent", "[upper]", "a list", 41),
                                                       ("child", "{a: 1}", "a mapping", 55)])
def test_a_joint_end_that_is_no_name_is_a_positioned_error(tmp_path, end, written, kind, column):
    """A list or a mapping where a link's name belongs is refused at its place (not a crash on an
    unhashable value)."""
    path = _arm(tmp_path)
    old = "parent: upper, child: slider"
    new = f"parent: {written}, child: slider" if end == "parent" else f"parent: upper, child: {written}"
    path.write_text(path.read_text().replace(old, new))
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    first = result.stderr.splitlines()[0]
    assert first == f"{path}:13:{column}: joints[1].{end}: expected a link's name, got {kind}"


# -- names -------------------------------------------------------------------------------------

def test_velocity_names_of_the_bundled_robots_are_unchanged():
    assert [velocity_name(n) for n in ("q1", "theta", "s", "th12", "panda_joint7", "x")] == \
        ["qd1", "thetad", "sd", "thd12", "panda_jointd7", "xd"]
    assert [acceleration_name(n) for n in ("q1", "theta", "phi2")] == ["qdd1", "thetadd", "phidd2"]


@pytest.mark.parametrize("name, velocity, acceleration", [("d", "d_d", "d_dd"), ("d2", "d2_d", "d2_dd"),
                                                          ("qd1", "qd1_d", "qd1_dd"), ("rod", "rod_d", "rod_dd")])
def test_a_stem_ending_in_d_gets_an_unambiguous_velocity(name, velocity, acceleration):
    """``d`` -> ``dd`` would read as an acceleration: names whose stem ends in ``d`` get ``_d``."""
    assert (velocity_name(name), acceleration_name(name)) == (velocity, acceleration)


def test_prismatic_joint_named_d_derives_and_runs(tmp_path):
    derivation = dynderive.derive(dynderive.load_robot(_arm(tmp_path, joint="d")))
    table = derivation.symbols
    assert [str(s) for s in table.qd] == ["qd1", "d_d"]
    assert [str(s) for s in table.qdd] == ["qdd1", "d_dd"]
    eom = derivation.quantities["EOM_g2"]
    assert sympy.Symbol("d_dd") in eom.free_symbols and sympy.Symbol("dd") not in eom.free_symbols
    assert r"\dot{d}" in dynderive.render_latex(derivation)
    module = import_code(dynderive.render_code(derivation), tmp_path)
    q, qd = np.array([0.3, 0.2]), np.array([0.1, -0.4])
    qdd = module.forward_dynamics(q, qd, np.array([1.0, 2.0]))
    assert np.allclose(module.inverse_dynamics(q, qd, qdd), [1.0, 2.0])


def test_robot_name_of_the_longest_length_writes_its_outputs(tmp_path):
    name = "a" * 100
    result = runner.invoke(app, ["solve", str(_arm(tmp_path, name=name)), "--code", "--tests", "--out",
                                 str(tmp_path / "out"), "-q"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / f"test_{name}_dynamics.py").is_file()


# -- frames and the engine's quantity names ------------------------------------------------------

def test_body_jacobians_are_described_as_the_links_and_frames_as_frames(tmp_path):
    frames = "frames:\n  - {name: b7, link: slider, origin: [l, 0]}\n"   # no link 7: b7 is free
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(_arm(tmp_path, frames=frames)), "--json", "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    quantities = json.loads((out / "arm.json").read_text())["quantities"]
    assert quantities["J_b1"]["description"].startswith("body Jacobian of link 1 (upper): ")
    assert quantities["J_b2"]["description"].startswith("body Jacobian of link 2 (slider): ")
    assert "(v_x, v_y, omega)" in quantities["J_b2"]["description"]
    assert quantities["J_b7"]["description"].startswith("world-frame geometric Jacobian of frame b7")
    assert quantities["J_b1"]["sympy"] != quantities["J_b7"]["sympy"]


def test_a_frame_name_that_collides_nowhere_is_accepted_on_a_3d_robot_without_loops():
    """``R_g`` is a quantity of robots with loops only: a frame ``g`` on an open 3-D chain is fine."""
    text = (ROOT / "robots" / "elbow_arm.yaml").read_text().replace("name: wrist", "name: g")
    robot = dynderive.input.schema.validate(dynderive.input.loader.parse_yaml(text, "elbow.yaml"))
    assert [f.name for f in robot.frames] == ["g"]


@pytest.mark.parametrize("robot", ["slider_crank", "spatial_four_bar"])
def test_engine_quantities_list_every_quantity_the_engine_derives(robot):
    """The names frames are checked against are all the names the engine gives (planar and
    3-D, with loops, maximal coordinates): a new engine quantity must be added there."""
    model = dynderive.load_robot(robot)
    engine = engine_quantities(list(model.links), model.planar, bool(model.loops))
    frames = {q for f in model.frames for q in frame_quantity_names(f.name, model.planar)}
    derived = set(dynderive.derive(model).keys())
    assert derived - frames <= set(engine)
    assert {body_jacobian_index(n, len(model.links)) for n in derived} - {None} == \
        set(range(1, len(model.links) + 1))


# -- URDF --------------------------------------------------------------------------------------

URDF = """\
<?xml version="1.0"?>
<robot name="two" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <link name="base"/>
  <link name="l1">
    <inertial><origin xyz="0 0 .5"/><mass value="MASS"/>
      <inertia ixx="1E-1" ixy="0" ixz="0" iyy="+0.1" iyz="0" izz="0.01"/></inertial>
  </link>
  <link name="WELDED"/>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0	1
    0"/></joint>
  <joint name="w" type="fixed"><parent link="l1"/><child link="WELDED"/><origin xyz="0 0 1"/></joint>
  <joint name="t" type="fixed"><parent link="l1"/><child link="tool"/><origin xyz="0 0 2"/></joint>
</robot>
"""


@pytest.mark.parametrize("written, mass", [("2", 2.0), ("2.", 2.0), (".5", 0.5), ("+2.5e-1", 0.25), ("3E0", 3.0),
                                           (" 1.5 ", 1.5)])
def test_urdf_numbers_in_xml_syntax_are_read(tmp_path, written, mass):
    """XML Schema doubles (signs, a fraction alone, exponents, XML white space between
    numbers) are read; the xacro namespace declared but unused (as xacro's output keeps it) is fine."""
    path = tmp_path / "two.urdf"
    path.write_text(URDF.replace("MASS", written).replace("WELDED", "flange"))
    robot = dynderive.load_robot(path)
    assert float(robot.links[0].mass) == mass
    assert tuple(float(a) for a in robot.joints[0].axis) == (0.0, 1.0, 0.0)
    assert [float(x) for x in robot.links[0].com] == [0.0, 0.0, 0.5]


def test_urdf_welded_link_named_like_a_body_jacobian_is_left_out_with_a_note(tmp_path):
    """A link ``b1`` welded to link 1 would make a frame ``b1``, whose ``J_b1`` is link 1's
    body Jacobian: that frame is left out with a note, the URDF is read."""
    path = tmp_path / "two.urdf"
    path.write_text(URDF.replace("MASS", "1").replace("WELDED", "b1"))
    result = runner.invoke(app, ["solve", str(path), "--json", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert f"{path}:8:3: note: link 'b1' (welded to 'l1') is not made a frame: its Jacobian would be J_b1, " \
        "link 1's body Jacobian" in result.stderr.splitlines()
    assert [f.name for f in dynderive.load_robot(path).frames] == ["tool"]
    quantities = json.loads((tmp_path / "out" / "two.json").read_text())["quantities"]
    assert quantities["J_b1"]["description"].startswith("body Jacobian of link 1 (l1)")
    assert "J_tool" in quantities
