"""Inertias that miss being physical by rounding are accepted with a note and corrected;
links welded to the world are never refused; real violations stay positioned errors (those
are in ``tests/corpus``: ``inertia_3d_*`` and ``urdf_inertia_*``)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.input import inertia

runner = CliRunner()

ARM = """\
name: arm3d
planar: false
parameters:
  m: {{value: 2.0, unit: kg}}
  g: 9.81
gravity: [0, 0, -g]
links:
  - name: base
    mass: m
    com: [0, 0, 0.2]
    inertia: {base}
  - name: arm
    mass: m
    com: [0.2, 0, 0]
    inertia: {arm}
joints:
  - name: q1
    type: {first}
    parent: world
    child: base
  - name: q2
    type: revolute
    parent: base
    child: arm
    origin: {{xyz: [0, 0, 0.4], rpy: [0, 0, 0]}}
    axis: [0, 1, 0]
"""


def _arm(tmp_path, arm: str, base: str = "[0.02, 0.02, 0.01, 0, 0, 0]", first: str = "revolute"):
    path = tmp_path / "arm.yaml"
    path.write_text(ARM.format(arm=arm, base=base, first=first))
    return path, dynderive.load_robot(path)


def test_three_by_three_asymmetric_by_one_ulp_is_symmetrized(tmp_path):
    upper = 0.0012345678901234567
    lower = float(np.nextafter(upper, 1.0))
    path, robot = _arm(tmp_path, f"[[0.03, {upper!r}, 0], [{lower!r}, 0.04, 0], [0, 0, 0.05]]")
    mean = (upper + lower) / 2
    assert robot.notes == (f"{path}:15:50: note: links[1].inertia: entries [0][1] and [1][0] differ by "
                           f"{lower - upper:g}, within the rounding tolerance 1.2e-06: both taken as {mean!r}",)
    assert robot.links[1].inertia == (0.03, 0.04, 0.05, mean, 0, 0)


def test_triangle_missed_by_rounding_is_corrected_by_raising_the_smaller_moments(tmp_path):
    """A flat plate (c = a + b) whose c was rounded up by 1e-8 of ~0.004: the two smaller
    moments are raised by half the gap each, so that a + b = c again."""
    a, b, c = 0.00123456, 0.00234567, 0.00358024   # six significant digits; a + b = 0.00358023
    path, robot = _arm(tmp_path, f"[{a}, {b}, {c}, 0, 0, 0]")
    gap = c - a - b
    assert robot.notes == (f"{path}:15:14: note: links[1].inertia: principal moments {a:g}, {b:g}, {c:g} violate "
                           f"the triangle inequality by {gap:g}, within the rounding tolerance 7.16047e-08: corrected, "
                           f"principal moments raised by {gap / 2:g}, {gap / 2:g}, 0",)
    ixx, iyy, izz, *products = robot.links[1].inertia
    assert ixx == pytest.approx(a + gap / 2, rel=1e-14) and iyy == pytest.approx(b + gap / 2, rel=1e-14)
    assert izz == pytest.approx(c, rel=1e-14) and products == [0, 0, 0]
    assert ixx + iyy >= izz * (1 - 1e-15)


def test_negative_moment_within_the_tolerance_is_raised_to_zero(tmp_path):
    """A rod along x written with ixx = -1e-9 (an export's rounding of 0)."""
    path, robot = _arm(tmp_path, "[-1.0e-9, 0.02, 0.02, 0, 0, 0]")
    assert robot.notes == (f"{path}:15:14: note: links[1].inertia: inertia is not positive semi-definite (smallest "
                           "principal moment -1e-09), within the rounding tolerance 4e-07: corrected, principal "
                           "moments raised by 1e-09, 0, 0",)
    assert robot.links[1].inertia == (0, 0.02, 0.02, 0, 0, 0)


def test_entries_over_parameters_are_kept_as_written(tmp_path):
    path, robot = _arm(tmp_path, "[m*0.005, m*0.01, m*0.015000001, 0, 0, 0]")
    assert robot.notes == (f"{path}:15:14: note: links[1].inertia: principal moments 0.01, 0.02, 0.03 violate the "
                           "triangle inequality by 2e-09, within the rounding tolerance 6e-07: kept as written "
                           "(its entries depend on parameters)",)
    assert robot.links[1].inertia == ("m*0.005", "m*0.01", "m*0.015000001", 0, 0, 0)


def test_negative_moment_on_a_link_welded_to_the_world_is_a_note(tmp_path):
    """The welded link's inertia never enters M(q): far from physical, and still no error;
    the derivation is the same as with a physical inertia there."""
    path, robot = _arm(tmp_path, "[0.01, 0.02, 0.025, 0, 0, 0]", base="[-0.5, 0.02, 0.01, 0, 0, 0]", first="fixed")
    assert robot.notes == (f"{path}:11:14: note: links[0].inertia: inertia is not positive semi-definite (smallest "
                           "principal moment -0.5); ignored: the link is welded to the world, so its inertia never "
                           "enters the dynamics",)
    assert robot.links[0].inertia == (-0.5, 0.02, 0.01, 0, 0, 0)   # not corrected: irrelevant
    _, physical = _arm(tmp_path, "[0.01, 0.02, 0.025, 0, 0, 0]", base="[0.5, 0.02, 0.01, 0, 0, 0]", first="fixed")
    assert dynderive.derive(robot)["M_g"] == dynderive.derive(physical)["M_g"]


URDF = """\
<robot name="legged">
  <link name="base">
    <inertial><mass value="1e-6"/>
      <inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/></inertial>
  </link>
  <link name="trunk">
    <inertial><mass value="80"/>
      <inertia ixx="1.5725937" ixy="0.028375" ixz="-0.203139" iyy="8.5015928" iyz="-0.004462" izz="9.1954911"/>
    </inertial>
  </link>
  <joint name="trunk_mount" type="fixed"><parent link="base"/><child link="trunk"/></joint>
  <link name="antenna">
    <inertial><mass value="-0.000001"/>
      <inertia ixx="0.00000002371" ixy="0.00000006119" ixz="0.00000001179" iyy="0.00000002833"
               iyz="0.00000000774" izz="0.00000003849"/></inertial>
  </link>
  <joint name="antenna_mount" type="fixed"><parent link="base"/><child link="antenna"/></joint>
  <link name="leg">
    <inertial><origin xyz="0 0 -0.15" rpy="0.3 -0.2 0.1"/><mass value="2.5"/>
      <inertia ixx="0.0123456" ixy="0" ixz="0" iyy="0.0234567" iyz="0" izz="0.0358024"/></inertial>
  </link>
  <joint name="hip" type="revolute"><parent link="base"/><child link="leg"/><axis xyz="0 1 0"/></joint>
  <link name="foot">
    <inertial><mass value="1e-6"/>
      <inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/></inertial>
  </link>
  <joint name="ankle" type="fixed"><origin xyz="0 0 -0.3"/><parent link="leg"/><child link="foot"/></joint>
</robot>
"""


def test_urdf_notes_name_the_link_and_the_correction(tmp_path):
    """go1's root (moments 0, 0, 3e-6 of a placeholder), tiago's antenna (negative moment) with
    a negative mass, both welded to the root: notes. hyq's placeholder foot welded to the leg
    misses by its own size, 3e-6, within 1e-6 of the robot's largest inertia (hyq's trunk, 19):
    corrected, as the leg (a plate printed with six digits, its inertial frame rotated)."""
    path = tmp_path / "legged.urdf"
    path.write_text(URDF)
    robot = dynderive.load_robot(path)
    welded = "ignored: the link is welded to the world, so its {} never enters the dynamics"
    assert robot.notes == (
        f"{path}:4:7: note: link 'base' inertia: principal moments 0, 0, 3e-06 violate the "
        f"triangle inequality by 3e-06; {welded.format('inertia')}",
        f"{path}:13:15: note: link 'antenna' mass: must not be negative (got -1e-06); {welded.format('mass')}",
        f"{path}:14:7: note: link 'antenna' inertia: inertia is not positive semi-definite (smallest principal "
        f"moment -3.53486e-08); {welded.format('inertia')}",
        f"{path}:20:7: note: link 'leg' inertia: principal moments 0.0123456, 0.0234567, 0.0358024 violate the "
        "triangle inequality by 1e-07, within the rounding tolerance 1.92697e-05: corrected, principal moments "
        "raised by 5e-08, 5e-08, 0",
        f"{path}:25:7: note: link 'foot' inertia: principal moments 0, 0, 3e-06 violate the "
        "triangle inequality by 3e-06, within the rounding tolerance 1.92697e-05: corrected, principal moments "
        "raised by 1.5e-06, 1.5e-06, 0",
    )
    assert [link.name for link in robot.links] == ["leg"]


def test_notes_print_no_digits_of_the_eigensolvers_rounding():
    """The placeholder inertia (all six entries 1e-6: moments 0, 0, 3e-6) turned about many
    axes: the eigensolver's last bits differ with each turn (as they differ between CPUs and
    BLAS builds: -2.5e-22 on one, -2e-22 on another), the note does not."""
    tensor = np.full((3, 3), 1e-6)
    rng = np.random.default_rng(7)
    notes, noise = set(), set()
    for _ in range(50):
        axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        turned = axes @ tensor @ axes.T
        turned = (turned + turned.T) / 2
        noise.add(float(np.linalg.eigvalsh(turned)[0]))
        notes.add(inertia.judge(turned, 20.0, welded=False).note)
    assert len(noise) > 1   # the rounding the notes must hide is there
    assert notes == {"principal moments 0, 0, 3e-06 violate the triangle inequality by 3e-06, within the rounding "
                     "tolerance 2e-05: corrected, principal moments raised by 1.5e-06, 1.5e-06, 0"}


def test_a_small_moment_keeps_only_the_digits_above_the_rounding():
    """Against a largest moment of 1, a moment of 1.23456789e-11 keeps one digit (the
    eigensolver's rounding is about 1e-16 there, shown digits stop at 1e-12); a negative one
    of -1e-13 prints as 0."""
    assert inertia._g([-1e-13, 1.23456789e-11, 0.5, 1.0], 1.0) == "0, 1e-11, 0.5, 1"
    assert inertia._g([1.23456789e-3, -0.0], 1.0) == "0.00123457, 0"


def test_import_writes_the_corrected_numbers(tmp_path):
    """``dynderive import`` prints the notes and writes a physical inertia, which loads
    without a note and with the same links."""
    path = tmp_path / "legged.urdf"
    path.write_text(URDF)
    out = tmp_path / "legged.yaml"
    result = runner.invoke(app, ["import", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stderr.count(": note: ") == 5 and "link 'leg' inertia: principal moments" in result.stderr
    again = dynderive.load_robot(out)
    assert again.notes == () and again.links == dynderive.load_robot(path).links
    ixx, iyy, izz, ixy, ixz, iyz = again.links[0].inertia
    a, b, c = np.linalg.eigvalsh([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    assert a + b >= c - 1e-15 * c


def test_notes_reach_the_terminal_and_the_robot_derives(tmp_path):
    path = tmp_path / "legged.urdf"
    path.write_text(URDF)
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert f"{path}:20:7: note: link 'leg' inertia:" in result.stderr


def _rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


@pytest.mark.parametrize("seed", range(40))
def test_corrections_only_raise_and_end_physical(seed):
    """Random rotated inertias on the edge of the physical ones (plates, rods), pushed out by a
    random fraction of the tolerance: corrected to a physical inertia, the correction positive
    semi-definite and at most 1.5 times the violation; pushed 10 times beyond: refused."""
    rng = np.random.default_rng(seed)
    R = _rotation(rng)
    a, b = rng.uniform(0.001, 0.05, 2)
    moments = np.array([a, b, a + b]) if seed % 2 else np.array([0.0, a, a])   # a plate, a rod
    size = float(np.sum(moments))
    tol = inertia.tolerance(R @ np.diag(moments) @ R.T, 0.0)
    assert tol == pytest.approx(inertia.ROUNDING * size, rel=1e-12)
    push = rng.uniform(0.05, 0.95) * tol
    moments_out = moments + (np.array([0, 0, push]) if seed % 2 else np.array([-push, 0, 0]))
    tensor = R @ np.diag(moments_out) @ R.T
    verdict = inertia.judge(tensor, 0.0, welded=False)
    assert verdict.error is None and "within the rounding tolerance" in verdict.note
    change = np.linalg.eigvalsh(verdict.tensor - tensor)
    assert change[0] >= -1e-15 * size and change[2] <= 1.5 * push * (1 + 1e-9)
    lo, mid, hi = np.linalg.eigvalsh(verdict.tensor)
    assert lo >= -1e-15 * size and lo + mid >= hi - 1e-15 * size
    again = inertia.judge(verdict.tensor, 0.0, welded=False)
    assert again.error is None and again.note is None and again.tensor is verdict.tensor
    far = moments + (np.array([0, 0, 10 * tol]) if seed % 2 else np.array([-10 * tol, 0, 0]))
    refused = inertia.judge(R @ np.diag(far) @ R.T, 0.0, welded=False)
    assert refused.error is not None and refused.note is None
    assert inertia.judge(R @ np.diag(far) @ R.T, 0.0, welded=True).error is None


def test_the_robot_scale_is_a_floor_of_the_tolerance():
    """A placeholder inertia (1e-6 in every entry: moments 0, 0, 3e-6) is refused on its own,
    accepted in a robot whose largest inertia is at least 3 (3e-6 = 1e-6 of it)."""
    placeholder = np.full((3, 3), 1e-6)
    assert inertia.judge(placeholder, 0.0, welded=False).error is not None
    assert inertia.judge(placeholder, 2.9, welded=False).error is not None
    assert inertia.judge(placeholder, 3.1, welded=False).note is not None


def test_yaml_and_urdf_read_the_same_corrected_inertia(tmp_path):
    """The same near-plate through both readers gives the same corrected numbers."""
    urdf = tmp_path / "one.urdf"
    urdf.write_text(textwrap.dedent("""\
        <robot name="one">
          <link name="base"/>
          <link name="a"><inertial><mass value="2"/><origin xyz="0.2 0 0"/>
            <inertia ixx="0.00123456" ixy="0" ixz="0" iyy="0.00234567" iyz="0" izz="0.00358024"/></inertial></link>
          <joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/></joint>
        </robot>
        """))
    yaml = tmp_path / "one.yaml"
    yaml.write_text(textwrap.dedent("""\
        name: one
        planar: false
        gravity: [0, 0, -9.81]
        links:
          - {name: a, mass: 2, com: [0.2, 0, 0], inertia: [0.00123456, 0.00234567, 0.00358024, 0, 0, 0]}
        joints:
          - {name: j, type: revolute, parent: world, child: a, axis: [0, 1, 0]}
        """))
    from_urdf, from_yaml = dynderive.load_robot(urdf), dynderive.load_robot(yaml)
    np.testing.assert_allclose(np.array(from_urdf.links[0].inertia, dtype=float),
                               np.array(from_yaml.links[0].inertia, dtype=float), rtol=1e-15, atol=1e-19)
    assert len(from_urdf.notes) == len(from_yaml.notes) == 1


@pytest.mark.parametrize("seed", range(20))
def test_urdf_triangle_violations_beyond_the_tolerance_are_kept_negative_moments_are_not(seed):
    """``impossible=True`` (the URDF reader): a random rotated inertia whose largest moment
    exceeds the sum of the others by far more than the tolerance is kept as written (the same
    tensor, a note, flagged); with a moment also negative within the tolerance, only that
    moment is raised to 0; negative beyond the tolerance, still refused; YAML (the default)
    refuses them all."""
    rng = np.random.default_rng(100 + seed)
    R = _rotation(rng)
    a, b = rng.uniform(0.001, 0.05, 2)
    excess = rng.uniform(0.01, 0.8) * (a + b)
    tensor = R @ np.diag([a, b, a + b + excess]) @ R.T
    kept = inertia.judge(tensor, 0.0, welded=False, impossible=True)
    assert kept.error is None and kept.impossible and kept.tensor is tensor
    assert "physically impossible, but kept as written (as Pinocchio does)" in kept.note
    assert inertia.judge(tensor, 0.0, welded=False).error is not None
    tol = inertia.tolerance(R @ np.diag([0.0, b, a + b + excess]) @ R.T, 0.0)
    push = rng.uniform(0.05, 0.95) * tol
    slightly = R @ np.diag([-push, b, a + b + excess]) @ R.T
    raised = inertia.judge(slightly, 0.0, welded=False, impossible=True)
    assert raised.error is None and raised.impossible and raised.note.endswith("; negative moments raised to 0")
    np.testing.assert_allclose(raised.tensor, R @ np.diag([0.0, b, a + b + excess]) @ R.T, rtol=0, atol=1e-15)
    negative = R @ np.diag([-10 * tol, b, a + b + excess]) @ R.T
    refused = inertia.judge(negative, 0.0, welded=False, impossible=True)
    assert refused.note is None and "not positive semi-definite" in refused.error
    welded = inertia.judge(negative, 0.0, welded=True, impossible=True)
    assert welded.error is None and not welded.impossible and "welded to the world" in welded.note
