"""``--symbolic``: a URDF's inertial values as named parameters (DESIGN.md section 9).

The Panda with its hand (robots/panda.urdf plus example-robot-data's ``panda_hand``, welded to
``panda_link8`` turned by -pi/4): the hand and link 7 made parameters give the plain module's
numbers at the defaults, and another hand mass gives Pinocchio's gravity for a URDF with that
mass (Pinocchio merges the hand into joint 7's body as dynderive does).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.verify.checks import generated_module

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
HAND = """  <joint name="panda_hand_joint" type="fixed">
    <parent link="panda_link8"/>
    <child link="panda_hand"/>
    <origin rpy="0 0 -0.7853981633974483" xyz="0 0 0"/>
  </joint>
  <link name="panda_hand">
    <inertial>
      <origin rpy="0 0 0" xyz="-0.01 0 0.03"/>
      <mass value="MASS"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0025" iyz="0" izz="0.0017"/>
    </inertial>
  </link>
</robot>"""
SYMBOLIC = ("panda_link7.*", "panda_hand.*")
runner = CliRunner()


def panda_with_hand(folder: Path, mass: float = 0.73) -> Path:
    path = folder / f"panda_hand_{mass:g}.urdf"
    text = (ROBOTS / "panda.urdf").read_text().replace("</robot>", HAND.replace("MASS", repr(mass)))
    path.write_text(text)
    return path


def module(path: Path, symbolic=None):
    robot = dynderive.load_robot(path, symbolic=symbolic)
    return robot, generated_module(dynderive.render_code(dynderive.derive(robot)), robot.name)


@pytest.fixture(scope="module")
def modules(tmp_path_factory):
    path = panda_with_hand(tmp_path_factory.mktemp("panda"))
    return path, module(path), module(path, SYMBOLIC)


def test_parameters_have_the_files_values_as_defaults(modules):
    _, _, (robot, symbolic) = modules
    values = {p.name: p.value for p in robot.parameters}
    assert values["m_panda_hand"] == 0.73 and values["m_panda_link7"] == 0.735522
    assert [values[f"c_panda_hand_{a}"] for a in "xyz"] == [-0.01, 0.0, 0.03]
    assert [values[f"I_panda_link7_{k}"] for k in ("xx", "xy", "xz", "yy", "yz", "zz")] == [
        0.012516, -0.000428, -0.001196, 0.010027, -0.000741, 0.004815]
    assert len(values) == 1 + 2 * 10   # g, then 10 per link
    assert symbolic.PARAMETERS["I_panda_hand_yy"] == 0.0025


def test_equal_to_the_plain_module_at_the_defaults(modules):
    _, (_, plain), (_, symbolic) = modules
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, (3, 7))
        for name, args in (("mass_matrix", (q,)), ("gravity_vector", (q,)),
                           ("inverse_dynamics", (q, qd, qdd))):
            np.testing.assert_allclose(getattr(symbolic, name)(*args), getattr(plain, name)(*args),
                                       rtol=0, atol=1e-12)


def test_a_heavier_hand_as_pinocchio(modules, tmp_path):
    if os.environ.get("CI"):
        import pinocchio as pin
    else:
        pin = pytest.importorskip("pinocchio")
    _, _, (_, symbolic) = modules
    heavier = pin.buildModelFromUrdf(str(panda_with_hand(tmp_path, 2.5)))
    data = heavier.createData()
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-2, 2, 7)
        expected = pin.computeGeneralizedGravity(heavier, data, q)
        np.testing.assert_allclose(symbolic.gravity_vector(q, m_panda_hand=2.5), expected, rtol=0, atol=1e-9)
        assert not np.allclose(symbolic.gravity_vector(q), expected, atol=1e-6)


def test_every_massive_link_mass(modules):
    path = modules[0]
    robot = dynderive.load_robot(path, symbolic="*.mass")
    names = [p.name for p in robot.parameters if p.name != "g"]
    # panda_link8 is massless, panda_link0 welded to the world
    assert names == [f"m_panda_link{k}" for k in range(1, 8)] + ["m_panda_hand"]


@pytest.mark.parametrize("option, message", [
    ("x.mass", "--symbolic:1:1: no link matches 'x.mass' (links: panda_link1, "),
    ("panda_link7.mass,panda_link7.masss", "--symbolic:1:30: unknown field 'masss' in 'panda_link7.masss' "
                                           "(fields: mass, com, inertia) (did you mean 'mass'?)"),
    ("panda_link0.com", "--symbolic:1:1: no link matches 'panda_link0.com' (link 'panda_link0' is welded to "
                        "the world"),
    ("mass", "--symbolic:1:1: expected LINK.FIELD"),
])
def test_bad_patterns(option, message):
    result = runner.invoke(app, ["solve", str(ROBOTS / "panda.urdf"), "--symbolic", option])
    assert result.exit_code == 2
    assert result.output.startswith(message) and result.output.count("\n") == 1, result.output


def test_refused_on_a_yaml_robot():
    result = runner.invoke(app, ["check", "rp_arm", "--symbolic", "*.mass"])
    assert result.exit_code == 2
    assert result.output.startswith("--symbolic:1:1: --symbolic makes a URDF's inertial values parameters; "
                                    "a YAML robot file names")
    with pytest.raises(InputError):
        dynderive.load_robot("rp_arm", symbolic=("*.mass",))


def test_c_struct_and_casadi_p(modules, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(modules[0]), "--c", "--casadi", "--symbolic",
                                 ",".join(SYMBOLIC), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    header = (out / "panda_dynamics.h").read_text()
    assert "double m_panda_hand;" in header and "double I_panda_link7_xy;" in header
    casadi_text = (out / "panda_dynamics_casadi.py").read_text()
    assert '"m_panda_hand"' in casadi_text and '"c_panda_hand_z"' in casadi_text


def test_param_through_the_command_line(modules):
    result = runner.invoke(app, ["linearize", str(modules[0]), "--symbolic", "panda_hand.mass",
                                 "--param", "m_panda_hand=1.5", "--json", "-q"])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["linearize", str(modules[0]), "--symbolic", "panda_hand.mass",
                                 "--param", "m_panda_hand=-1", "-q"])
    assert result.exit_code == 2 and "--param:1:" in result.output, result.output


def test_names_are_made_unique():
    from dynderive.input.urdf_symbolic import free_name

    taken = {"m_a", "g"}
    assert free_name("m_a", taken) == "m_a_2" and free_name("m_a", taken) == "m_a_3"
    assert free_name("m_b", taken) == "m_b"


def test_a_floating_joint_and_param():
    urdf = str(Path(__file__).parent / "floating_elbow.urdf")
    result = runner.invoke(app, ["check", urdf, "--symbolic", "*.*", "--param", "m_lower=2", "-q"])
    assert result.exit_code == 0, result.output
