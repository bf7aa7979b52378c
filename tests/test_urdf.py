"""URDF: the bundled real arms against Pinocchio's own URDF parser; import; errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app

from conftest import ROBOTS, import_code

pin = pytest.importorskip("pinocchio")
runner = CliRunner()


@pytest.fixture(scope="module", params=["ur5", "panda"])
def arm(request, tmp_path_factory):
    name = request.param
    derivation = dynderive.derive(dynderive.load_robot(name))
    module = import_code(dynderive.render_code(derivation), tmp_path_factory.mktemp(name), f"{name}_urdf_dynamics")
    model = pin.buildModelFromUrdf(str(ROBOTS / f"{name}.urdf"))
    return module, model, model.createData()


def test_arm_agrees_with_pinocchio_urdf_parser(arm):
    module, model, data = arm
    assert model.nq == len(module.COORDINATES)
    assert tuple(model.names[1:]) == module.COORDINATES
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, qd, u = rng.uniform(-1.5, 1.5, (3, model.nq))
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(module.mass_matrix(q), M, atol=1e-9, rtol=1e-9)
        g = pin.computeGeneralizedGravity(model, data, q)
        np.testing.assert_allclose(module.gravity_vector(q), g, atol=1e-9, rtol=1e-9)
        np.testing.assert_allclose(module.coriolis_matrix(q, qd) @ qd, pin.rnea(model, data, q, qd, np.zeros(model.nv)) - g,
                                   atol=1e-9, rtol=1e-9)
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u), pin.aba(model, data, q, qd, u), atol=1e-8, rtol=1e-9)
        np.testing.assert_allclose(module.kinetic_energy(q, qd), pin.computeKineticEnergy(model, data, q, qd), rtol=1e-9)


def test_import_writes_equivalent_yaml(tmp_path):
    out = tmp_path / "panda.yaml"
    result = runner.invoke(app, ["import", str(ROBOTS / "panda.urdf"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text().startswith("# Imported by dynderive")
    assert dynderive.load_robot(out).links == dynderive.load_robot("panda").links
    assert dynderive.load_robot(out).joints == dynderive.load_robot("panda").joints


def _urdf(body: str) -> str:
    return f'<?xml version="1.0"?>\n<robot name="t">\n  <link name="base"/>\n{body}</robot>\n'


LINK = ('  <link name="a">\n    <inertial><mass value="1"/>'
        '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>\n  </link>\n')
JOINT = ('  <joint name="j1" type="{type}">\n    <parent link="base"/><child link="a"/>\n'
         '    <axis xyz="0 0 1"/>{extra}\n  </joint>\n')


@pytest.mark.parametrize("body,expected", [
    (LINK + JOINT.format(type="planar", extra="").replace('xyz="0 0 1"', 'xyz="0 0 0"'),
     "9:5: joint 'j1' axis: axis has zero length"),
    ('  <link name="a"/>\n' + JOINT.format(type="revolute", extra=""),
     "4:3: link 'a' moves (joint 'j1') but has no mass, nor has any link below it: the joint moves nothing; give "
     "the link an <inertial> with a positive mass"),
    (LINK + JOINT.format(type="revolute", extra="").replace('xyz="0 0 1"', 'xyz="0 0"'),
     '9:5: <axis xyz="0 0">: expected 3 finite numbers'),
    (LINK + JOINT.format(type="revolute", extra="").replace("</joint>", "</joint"),
     "11:1: malformed XML: not well-formed (invalid token)"),
    (LINK + JOINT.format(type="revolute", extra="").replace('link="a"/>', 'link="b"/>'),
     "8:26: joint 'j1': unknown child link 'b'"),
])
def test_urdf_errors_are_positioned(tmp_path, body, expected):
    path = tmp_path / "bad.urdf"
    path.write_text(_urdf(body))
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == f"{path}:{expected}"
    assert not (tmp_path / "out").exists()


def test_doctype_is_refused(tmp_path):
    path = tmp_path / "entity.urdf"
    path.write_text('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaa">]>\n<robot name="t"/>\n')
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert "DTDs and entities are not allowed" in result.stderr


def test_fixed_joints_are_merged_into_the_parent(tmp_path):
    """A body welded to a moving link adds its mass, COM and inertia to that link."""
    weld = ('  <link name="tip">\n    <inertial><origin xyz="0.5 0 0" rpy="0 0 0.3"/><mass value="2"/>'
            '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>\n  </link>\n'
            '  <joint name="w" type="fixed"><parent link="a"/><child link="tip"/>'
            '<origin xyz="0.2 0 0" rpy="0 0.4 0"/></joint>\n')
    path = tmp_path / "weld.urdf"
    limit = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    path.write_text(_urdf(LINK + JOINT.format(type="revolute", extra=limit) + weld))
    d = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(d), tmp_path, "weld_dynamics")
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    q = np.array([0.7])
    np.testing.assert_allclose(module.mass_matrix(q), pin.crba(model, data, q), atol=1e-12)
    np.testing.assert_allclose(module.gravity_vector(q), pin.computeGeneralizedGravity(model, data, q), atol=1e-12)
    assert Path(d.robot.source).suffix == ".urdf"


# --- precision near gimbal lock, snapping, notes ---------------------------------------


def _random_rotation(rng) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def _near_gimbal_lock(rng) -> np.ndarray:
    """A rotation whose pitch is within 1e-17..1e-6 of +-pi/2 (or exactly +-pi/2 in floats)."""
    from dynderive.input.urdf_values import rpy_matrix

    sign = rng.choice([-1.0, 1.0])
    pitch = sign * (np.pi / 2 - (10.0 ** rng.uniform(-17, -6) if rng.uniform() < 0.9 else 0.0))
    roll, yaw = rng.uniform(-np.pi, np.pi, 2)
    return rpy_matrix((roll, None), (pitch, None), (yaw, None))


@pytest.mark.parametrize("kind", ["random", "near_gimbal_lock"])
def test_rpy_extraction_reproduces_the_matrix(kind):
    """``rpy_matrix(matrix_to_rpy(R))`` is ``R`` to 1e-15, also within 1e-11 of gimbal lock
    (the classic ``roll = atan2(r21, r22)`` loses ~5 digits there)."""
    from dynderive.input.urdf_values import matrix_to_rpy, rpy_matrix

    rng = np.random.default_rng(11)
    make = _random_rotation if kind == "random" else _near_gimbal_lock
    worst = 0.0
    for _ in range(5000):
        R = make(rng)
        roll, pitch, yaw = matrix_to_rpy(R)
        assert -np.pi / 2 <= pitch <= np.pi / 2
        back = rpy_matrix((roll, None), (pitch, None), (yaw, None))
        worst = max(worst, float(np.max(np.abs(back - R))))
    assert worst <= 1e-15, worst


def test_composed_quarter_turns_stay_exact():
    """Rotations of whole quarter turns compose to an exact matrix, written as exact angles;
    near-quarter composed angles are not snapped."""
    from dynderive.input.urdf_values import Rotation, rpy_matrix

    quarter = Rotation.from_rpy([0, 0, 1.57079632679])
    assert quarter.rpy() == [0, 0, "pi/2"]
    composed = quarter @ Rotation.from_rpy([1.5707963268, 0, 0])
    assert composed.written is None
    assert set(np.unique(composed.matrix)) <= {-1.0, 0.0, 1.0}
    rpy = composed.rpy()
    assert all(isinstance(a, str) or a == 0 for a in rpy), rpy
    quarters = {0: 0, "pi/2": 1, "-pi/2": -1, "pi": 2, "-pi": -2}
    assert np.array_equal(rpy_matrix(*((0.0, quarters[a]) for a in rpy)), composed.matrix)
    tilted = Rotation.from_rpy([0, 0.3, 0]) @ Rotation.from_rpy([0, 1.2707963267948966, 0])
    assert all(not isinstance(a, str) for a in tilted.rpy())


def _read(body: str, tmp_path: Path, name: str = "t.urdf"):
    from dynderive.input.urdf import read_urdf

    path = tmp_path / name
    path.write_text(_urdf(body))
    return path, read_urdf(path.read_text(), str(path))


def test_snapping_applies_to_written_angles_only(tmp_path):
    """Written rpy values within 1e-9 of k*pi/2 are exactly k*pi/2 (joint and inertial
    origins); other written values, and angles that come out of composing rotations, are kept."""
    link = LINK.replace('<inertial>', '<inertial><origin xyz="0 0 0" rpy="0 0 1.57079632679"/>')
    link = link.replace('iyy="0.1"', 'iyy="0.3"').replace('izz="0.1"', 'izz="0.3"').replace('ixy="0"', 'ixy="0.01"')
    joint = JOINT.format(type="revolute", extra='<origin xyz="0 0 0" rpy="1.57079632679 -3.14159265359 0.3"/>')
    _, doc = _read(link + joint, tmp_path)
    assert doc.data["joints"][0]["origin"]["rpy"] == ["pi/2", "-pi", 0.3]
    # Rz(pi/2) exactly: ixx and iyy swap, ixy changes sign, nothing else moves
    assert doc.data["links"][0]["inertia"] == [0.3, 0.1, 0.3, -0.01, 0, 0]
    joint = JOINT.format(type="revolute", extra='<origin xyz="0 0 0" rpy="1.5708 1.570796 4.71238898038"/>')
    _, doc = _read(LINK + joint, tmp_path)
    assert doc.data["joints"][0]["origin"]["rpy"] == [1.5708, 1.570796, "3*pi/2"]


GIMBAL_URDF = """<?xml version="1.0"?>
<robot name="gimbal">
  <link name="base"/>
  <link name="stand"/>
  <link name="upper">
    <inertial><origin xyz="0.1234567890123 -0.0987654321 0.3141592653589793" rpy="0.7 -0.2 1.9"/>
      <mass value="1.2345678901234567"/>
      <inertia ixx="0.012345678901234" ixy="0.0011111111111" ixz="-0.0007777777777"
               iyy="0.023456789012345" iyz="0.00033333333333" izz="0.034567890123456"/></inertial>
  </link>
  <link name="bracket">
    <inertial><origin xyz="0.2 0.1 -0.05" rpy="-0.4 0.9 0.25"/>
      <mass value="0.7654321098765432"/>
      <inertia ixx="0.0055555555555" ixy="-0.0002222222" ixz="0.0001111111"
               iyy="0.0066666666666" iyz="0.0003333333" izz="0.0077777777777"/></inertial>
  </link>
  <link name="lower">
    <inertial><origin xyz="-0.1 0.25 0.15" rpy="1.1 0.3 -0.6"/>
      <mass value="2.3456789012345678"/>
      <inertia ixx="0.021" ixy="0.001" ixz="-0.002" iyy="0.032" iyz="0.0015" izz="0.043"/></inertial>
  </link>
  <joint name="weld" type="fixed"><parent link="base"/><child link="stand"/>
    <origin xyz="0.05 -0.02 0.3" rpy="{fixed}"/></joint>
  <joint name="shoulder" type="revolute"><parent link="stand"/><child link="upper"/>
    <origin xyz="0.1 0.2 0.3" rpy="{moving}"/><axis xyz="0.3 -0.5 0.8"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="bracket_weld" type="fixed"><parent link="upper"/><child link="bracket"/>
    <origin xyz="0.3 0.1 -0.2" rpy="{fixed}"/></joint>
  <joint name="elbow" type="revolute"><parent link="bracket"/><child link="lower"/>
    <origin xyz="-0.2 0.4 0.1" rpy="{moving}"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""


def test_fixed_then_revolute_near_gimbal_lock_agrees_with_pinocchio(tmp_path):
    """A fixed joint (rpy 0.3 1.2 -0.7) then a revolute joint whose rpy composes with it to a
    pitch 3e-12 short of pi/2, twice: dynderive's merged model against Pinocchio's own URDF
    parser (which keeps the fixed joints), M, rnea and aba to 1e-12 relative. Extracting the
    composed roll from the tiny r21/r22 and snapping the composed pitch to pi/2 gave 1e-5."""
    from dynderive.verify.checks import generated_module

    fixed = [0.3, 1.2, -0.7]
    R_fixed = pin.rpy.rpyToMatrix(*fixed)
    target = pin.rpy.rpyToMatrix(0.41, np.pi / 2 - 3e-12, -1.13)
    moving = [float(a) for a in pin.rpy.matrixToRpy(R_fixed.T @ target)]
    composed_pitch = pin.rpy.matrixToRpy(R_fixed @ pin.rpy.rpyToMatrix(*moving))[1]
    assert 0 < np.pi / 2 - composed_pitch < 1e-11
    assert all(abs(a - k * np.pi / 2) > 1e-3 for a in fixed + moving for k in range(-4, 5))  # nothing to snap
    text = GIMBAL_URDF.format(fixed=" ".join(map(repr, fixed)), moving=" ".join(map(repr, moving)))
    path = tmp_path / "gimbal.urdf"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    assert [j.name for j in robot.joints] == ["shoulder", "elbow"]
    pitch = robot.joints[0].origin[4]
    assert not isinstance(pitch, str) and 0 < np.pi / 2 - pitch < 1e-11  # composed: not snapped
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "gimbal")
    model = pin.buildModelFromXML(text)
    data = model.createData()
    assert tuple(model.names[1:]) == module.COORDINATES
    rng = np.random.default_rng(5)
    worst = {}
    for _ in range(6):
        q, qd, qdd = rng.uniform(-2, 2, (3, model.nq))
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(model, data, q, qd, qdd)
        pairs = {"M": (module.mass_matrix(q), M),
                 "rnea": (module.inverse_dynamics(q, qd, qdd), tau),
                 "aba": (module.forward_dynamics(q, qd, tau), pin.aba(model, data, q, qd, tau))}
        for key, (ours, theirs) in pairs.items():
            error = float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))
            worst[key] = max(worst.get(key, 0.0), error)
    assert max(worst.values()) < 1e-12, worst


def test_mimic_on_a_fixed_joint_is_ignored_with_a_note(tmp_path):
    weld = ('  <link name="tip"/>\n  <joint name="w" type="fixed"><parent link="a"/><child link="tip"/>\n'
            '    <mimic joint="j1"/></joint>\n')
    path = tmp_path / "mimic.urdf"
    path.write_text(_urdf(LINK + JOINT.format(type="revolute", extra="") + weld))
    robot = dynderive.load_robot(path)
    assert [j.name for j in robot.joints] == ["j1"]
    assert robot.notes == (f"{path}:13:5: note: <mimic> on fixed joint 'w' ignored",)


@pytest.mark.parametrize("body,expected", [
    # a chain of fixed joints that closes on itself (used to recurse until RecursionError)
    (LINK + JOINT.format(type="revolute", extra="") + '  <link name="b"/>\n  <link name="c"/>\n'
     '  <joint name="f1" type="fixed"><parent link="b"/><child link="c"/></joint>\n'
     '  <joint name="f2" type="fixed"><parent link="c"/><child link="b"/></joint>\n',
     "14:3: joint 'f2': links b -> c -> b form a cycle not connected to 'world'"),
    # a link with two parents (used to be accepted, the first joint silently dropped)
    (LINK + JOINT.format(type="revolute", extra="") + '  <link name="b"/>\n'
     '  <joint name="f1" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
     '  <joint name="f2" type="fixed"><parent link="base"/><child link="b"/></joint>\n',
     "13:54: joint 'f2': link 'b' already has a parent joint (joint 'f1'); robots must be trees"),
])
def test_urdf_graph_errors_are_positioned(tmp_path, body, expected):
    path = tmp_path / "bad.urdf"
    path.write_text(_urdf(body))
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == f"{path}:{expected}"


def test_long_chain_of_fixed_joints_is_merged_without_recursion(tmp_path):
    """3000 fixed joints in series, read with Python's recursion limit at 300: nothing recurses
    along the chain (merging, the cycle check). Its speed is not timed here (a loaded machine
    makes a timed test flaky: benchmarks measure speed)."""
    import sys

    chain = "".join(f'  <link name="x{i}"/>\n' for i in range(3000))
    chain += '  <joint name="f0" type="fixed"><parent link="a"/><child link="x0"/></joint>\n'
    chain += "".join(f'  <joint name="f{i}" type="fixed"><parent link="x{i - 1}"/><child link="x{i}"/>'
                     '<origin rpy="0 0 0.1"/></joint>\n' for i in range(1, 3000))
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(300)
    try:
        _, doc = _read(LINK + JOINT.format(type="revolute", extra="") + chain, tmp_path)
    finally:
        sys.setrecursionlimit(limit)
    assert len(doc.data["joints"]) == 1
