"""URDF: the bundled real arms against Pinocchio's own URDF parser; import; errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.cli import app

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
    (LINK + JOINT.format(type="revolute", extra='<mimic joint="j0"/>'),
     "9:24: joint 'j1': <mimic> joints are not supported"),
    (LINK + JOINT.format(type="floating", extra=""),
     "7:3: joint 'j1': floating joints are not supported (only revolute, continuous, prismatic and fixed)"),
    ('  <link name="a"/>\n' + JOINT.format(type="revolute", extra=""),
     "4:3: link 'a' moves (joint 'j1') but has no mass: give it an <inertial> with a positive mass"),
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
