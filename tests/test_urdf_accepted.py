"""URDF input that Pinocchio loads and dynderive accepts as Pinocchio does, each against
Pinocchio's own parser (``buildModelFromXML``; with ``mimic=True`` for ``<mimic>`` joints):
moving ``<mimic>`` joints following their leaders (one coordinate), massless links between joints
(the whole pipeline: sheet, PDF, code, JSON, import), and inertias that miss the triangle
inequality by far more than rounding, kept as written (a note; refused by ``import`` and in a
YAML file). The errors that remain are in ``tests/corpus`` (``urdf_inertia_not_psd``,
``urdf_moving_link_without_inertial``, ``urdf_massless_link_between_coaxial_joints``,
``inertia_3d_triangle*``, ``mass_zero_3d_leaf``, ``mass_negative_3d``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.verify.checks import generated_module

from conftest import import_code

pin = pytest.importorskip("pinocchio")
runner = CliRunner()

LIMIT = '<limit lower="-3" upper="3" effort="100" velocity="5"/>'


def _agrees_with_pinocchio(module, text: str, seed: int) -> None:
    """M, inverse and forward dynamics at random states equal Pinocchio's (same joint order)
    to 1e-11 of their size."""
    model = pin.buildModelFromXML(text)
    data = model.createData()
    assert tuple(model.names[1:]) == module.COORDINATES
    rng = np.random.default_rng(seed)
    for q, qd, qdd in rng.uniform(-1.5, 1.5, (3, 3, model.nq)):
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(model, data, q, qd, qdd)
        for ours, theirs in ((module.mass_matrix(q), M), (module.inverse_dynamics(q, qd, qdd), tau),
                             (module.forward_dynamics(q, qd, tau), pin.aba(model, data, q, qd, tau))):
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-11 * np.max(np.abs(theirs)))


# -- <mimic> on a moving joint --------------------------------------------------------------

GRIPPER = f"""\
<robot name="gripper">
  <link name="base"/>
  <link name="palm">
    <inertial><origin xyz="0.0123456789012345 -0.00456789012345678 0.0612345678901234"/>
      <mass value="0.712345678901234"/>
      <inertia ixx="0.00112345678901234" ixy="0.0000312345678901" ixz="0" iyy="0.00123456789012345" iyz="0"
               izz="0.000812345678901234"/></inertial>
  </link>
  <link name="finger_left">
    <inertial><origin xyz="0 0.0112345678901234 0.0223456789012345"/><mass value="0.0512345678901234"/>
      <inertia ixx="0.0000231234567890" ixy="0" ixz="0" iyy="0.0000212345678901" iyz="0"
               izz="0.00000512345678901"/></inertial>
  </link>
  <link name="finger_right">
    <inertial><origin xyz="0 -0.0112345678901234 0.0223456789012345"/><mass value="0.0512345678901234"/>
      <inertia ixx="0.0000231234567890" ixy="0" ixz="0" iyy="0.0000212345678901" iyz="0"
               izz="0.00000512345678901"/></inertial>
  </link>
  <joint name="wrist" type="revolute"><parent link="base"/><child link="palm"/>
    <origin xyz="0 0 0.312345678901234" rpy="0.2 0 0"/><axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="finger_left_joint" type="prismatic"><parent link="palm"/><child link="finger_left"/>
    <origin xyz="0 0.01 0.0912345678901234"/><axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="finger_right_joint" type="prismatic"><parent link="palm"/><child link="finger_right"/>
    <origin xyz="0 -0.01 0.0912345678901234"/><axis xyz="0 -1 0"/>{LIMIT}
    <mimic joint="finger_left_joint" multiplier="1" offset="0"/>
  </joint>
</robot>
"""


def test_mimic_joint_follows_its_leader(tmp_path):
    """Panda's second finger mimics the first: one coordinate for both, no note, as Pinocchio's
    ``buildModelFromXML(..., mimic=True)`` models it (tests/test_mimic.py compares in depth)."""
    path = tmp_path / "gripper.urdf"
    path.write_text(GRIPPER)
    robot = dynderive.load_robot(path)
    assert robot.coordinates == ("wrist", "finger_left_joint")
    assert robot.notes == ()
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "gripper")
    model = pin.buildModelFromXML(GRIPPER, mimic=True)
    data = model.createData()
    for q, qd, qdd in np.random.default_rng(11).uniform(-1.5, 1.5, (3, 3, model.nq)):
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(module.mass_matrix(q), M, rtol=0, atol=1e-11 * np.max(np.abs(M)))
        tau = pin.rnea(model, data, q, qd, qdd)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd), tau, rtol=0, atol=1e-11 * np.max(np.abs(tau)))


def test_mimic_joint_reaches_the_module(tmp_path):
    path = tmp_path / "gripper.urdf"
    path.write_text(GRIPPER)
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "<mimic>" not in result.stderr
    text = (tmp_path / "out" / "gripper_dynamics.py").read_text()
    assert 'COORDINATES = ("wrist", "finger_left_joint")' in text


# -- massless links between joints ----------------------------------------------------------

HIP = f"""\
<robot name="hip">
  <link name="pelvis"/>
  <link name="thigh_virtual"/>
  <link name="thigh_virtual_2"/>
  <link name="thigh">
    <inertial><origin xyz="-0.0181234567890123 -0.0123456789012345 -0.188765432109876"/>
      <mass value="9.22345678901234"/>
      <inertia ixx="0.149712345678901" ixy="0.00872345678901234" ixz="-0.000712345678901234"
               iyy="0.0400512345678901" iyz="-0.00872345678901234" izz="0.160212345678901"/></inertial>
  </link>
  <link name="shank">
    <inertial><origin xyz="0.00912345678901234 0 -0.171234567890123"/><mass value="3.41234567890123"/>
      <inertia ixx="0.0321234567890123" ixy="0" ixz="0.00112345678901234" iyy="0.0331234567890123" iyz="0"
               izz="0.00412345678901234"/></inertial>
  </link>
  <link name="foot_virtual"/>
  <link name="foot">
    <inertial><origin xyz="0.0681234567890123 -0.0271234567890123 0.00512345678901234"/>
      <mass value="0.912345678901234"/>
      <inertia ixx="0.000812345678901234" ixy="0.000481234567890123" ixz="-0.000181234567890123"
               iyy="0.00385123456789012" iyz="0" izz="0.00364123456789012"/></inertial>
  </link>
  <joint name="hip_z" type="revolute"><parent link="pelvis"/><child link="thigh_virtual"/>
    <origin xyz="0.0123456789012345 -0.0871234567890123 0"/><axis xyz="0 0 1"/>{LIMIT}</joint>
  <joint name="hip_x" type="revolute"><parent link="thigh_virtual"/><child link="thigh_virtual_2"/>
    <axis xyz="1 0 0"/>{LIMIT}</joint>
  <joint name="hip_y" type="revolute"><parent link="thigh_virtual_2"/><child link="thigh"/>
    <axis xyz="0 -1 0"/>{LIMIT}</joint>
  <joint name="knee" type="revolute"><parent link="thigh"/><child link="shank"/>
    <origin xyz="0 0 -0.431234567890123"/><axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="ankle_y" type="revolute"><parent link="shank"/><child link="foot_virtual"/>
    <origin xyz="0 0 -0.412345678901234"/><axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="ankle_x" type="revolute"><parent link="foot_virtual"/><child link="foot"/>
    <axis xyz="-1 0 0"/>{LIMIT}</joint>
</robot>
"""


@pytest.fixture(scope="module")
def hip(tmp_path_factory):
    """``solve --latex --code --json`` of a leg whose hip (three revolute joints) and ankle (two)
    have massless links between their joints, as human.urdf of example-robot-data."""
    folder = tmp_path_factory.mktemp("hip")
    path = folder / "hip.urdf"
    path.write_text(HIP)
    out = folder / "out"
    result = runner.invoke(app, ["solve", str(path), "--latex", "--code", "--json", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return path, out, result


def test_massless_links_load_with_zero_mass_and_no_note(hip):
    path, _, result = hip
    robot = dynderive.load_robot(path)
    masses = {link.name: link.mass for link in robot.links}
    assert masses == {"thigh_virtual": 0, "thigh_virtual_2": 0, "thigh": 9.22345678901234,
                      "shank": 3.41234567890123, "foot_virtual": 0, "foot": 0.912345678901234}
    assert all(link.inertia == (0, 0, 0, 0, 0, 0) for link in robot.links if link.mass == 0)
    assert robot.notes == () and ": note: " not in result.stderr


def test_massless_links_code_agrees_with_pinocchio(hip, tmp_path):
    _, out, _ = hip
    module = import_code((out / "hip_dynamics.py").read_text(), tmp_path, "hip_massless_dynamics")
    _agrees_with_pinocchio(module, HIP, seed=7)


def test_massless_links_sheet_and_json(hip):
    _, out, _ = hip
    tex = (out / "hip.tex").read_text()
    assert r"\texttt{hip\_x} & revolute & \texttt{thigh\_virtual} & \texttt{thigh\_virtual\_2}" in tex
    document = json.loads((out / "hip.json").read_text())
    assert document["degrees_of_freedom"] == 6
    assert document["checks"] and all(check["passed"] for check in document["checks"])


@pytest.mark.pdf
def test_massless_links_sheet_compiles(hip, tmp_path):
    if shutil.which("pdflatex") is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must run the PDF tests, but pdflatex is missing")
        pytest.skip("no pdflatex")
    _, out, _ = hip
    shutil.copy(out / "hip.tex", tmp_path / "sheet.tex")
    result = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", "sheet.tex"],
                            cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-2000:]


def test_massless_links_import_to_yaml_that_loads(hip, tmp_path):
    """A 3-D robot file may have massless links too: the imported YAML loads, same links."""
    path, _, _ = hip
    out = tmp_path / "hip.yaml"
    result = runner.invoke(app, ["import", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert dynderive.load_robot(out).links == dynderive.load_robot(path).links


# -- inertias that miss the triangle inequality ---------------------------------------------

#: allegro_left_hand.urdf's link_11.0 (moments 2.30064e-06, 3.48527e-06, 7.2659e-06: c exceeds
#: a + b by 1.48e-06, 26 % of c), on the lower link of a two-link arm.
ALLEGRO = """\
<robot name="two_link">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 0.2" rpy="0 0 0"/>
      <mass value="2.0"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.004"/>
    </inertial>
  </link>
  <link name="lower">
    <inertial>
      <origin xyz="0 0 0.15" rpy="0 0 0"/>
      <mass value="0.0096"/>
      <inertia ixx="4.701248e-06" ixy="1.255968e-06" ixz="1.2936e-06" iyy="3.649312e-06" iyz="1.7622e-06" izz="4.701248e-06"/>
    </inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="lower"/><origin xyz="0 0 0.4" rpy="0 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
</robot>
"""
TRIANGLE = ("principal moments 2.30064e-06, 3.48527e-06, 7.2659e-06 violate the triangle inequality by "
            "1.48e-06")


def test_urdf_inertia_missing_the_triangle_inequality_is_kept_as_written(tmp_path):
    path = tmp_path / "allegro.urdf"
    path.write_text(ALLEGRO)
    robot = dynderive.load_robot(path)
    assert robot.notes == (f"{path}:14:7: note: link 'lower' inertia: {TRIANGLE}, beyond the rounding tolerance "
                           "6.4e-08: physically impossible, but kept as written (as Pinocchio does)",)
    assert robot.links[1].inertia == (4.701248e-06, 3.649312e-06, 4.701248e-06, 1.255968e-06, 1.2936e-06, 1.7622e-06)
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "allegro_link")
    _agrees_with_pinocchio(module, ALLEGRO, seed=3)


def test_import_refuses_an_inertia_a_yaml_file_may_not_have(tmp_path):
    """The YAML it would write would not load: refused at the inertia, after the note, nothing written."""
    path = tmp_path / "allegro.urdf"
    path.write_text(ALLEGRO)
    out = tmp_path / "allegro.yaml"
    result = runner.invoke(app, ["import", str(path), "-o", str(out)])
    assert result.exit_code == 2 and not out.exists()
    assert result.stderr.splitlines() == [
        f"{path}:14:7: note: link 'lower' inertia: {TRIANGLE}, beyond the rounding tolerance 6.4e-08: physically "
        "impossible, but kept as written (as Pinocchio does)",
        f"{path}:14:7: link 'lower' inertia: not imported: it misses the triangle inequality (see the note), which a "
        "YAML robot file may not; correct it in the URDF, or use the URDF itself"]


def test_the_same_inertia_in_a_yaml_file_is_an_error(tmp_path):
    """A robot file's own numbers stay strict."""
    path = tmp_path / "allegro.yaml"
    path.write_text("""\
name: two_link
planar: false
gravity: [0, 0, -9.81]
links:
  - {name: upper, mass: 2.0, com: [0, 0, 0.2], inertia: [0.03, 0.03, 0.004, 0, 0, 0]}
  - name: lower
    mass: 0.0096
    com: [0, 0, 0.15]
    inertia: [4.701248e-06, 3.649312e-06, 4.701248e-06, 1.255968e-06, 1.2936e-06, 1.7622e-06]
joints:
  - {name: shoulder, type: revolute, parent: world, child: upper, origin: {xyz: [0, 0, 0.1]}, axis: [0, 1, 0]}
  - {name: elbow, type: revolute, parent: upper, child: lower, origin: {xyz: [0, 0, 0.4]}, axis: [1, 0, 0]}
""")
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"{path}:9:14: links[1].inertia: {TRIANGLE} (rounding tolerance 6.4e-08)"
