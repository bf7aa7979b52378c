"""Drives and dissipation (issue 16) through the tool's surfaces: YAML and URDF input, the
quantities and their JSON, the generated module's API, the sheet, ``check`` and ``simulate``.

The closed forms and the Pinocchio comparisons are in ``test_drives_reference.py``.
"""

from __future__ import annotations

import csv
import io
import json
import random
from pathlib import Path

import numpy as np
import pytest
import sympy
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app

from conftest import ROBOTS, derivation_of, import_code

runner = CliRunner()

URDF = """<robot name="damped_pair">
  <link name="base"/>
  <link name="upper">
    <inertial><origin xyz="0 0 0.2"/><mass value="2.0"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.004"/></inertial>
  </link>
  <link name="lower">
    <inertial><origin xyz="0 0 0.15"/><mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.002"/></inertial>
  </link>
  <link name="tool">
    <inertial><mass value="0.3"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <dynamics damping="0.7301215437791212" friction="0.11932475802386"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/><child link="lower"/><origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>
    <dynamics damping="0.0" friction="0.0"/>
  </joint>
  <joint name="mount" type="fixed">
    <parent link="lower"/><child link="tool"/><origin xyz="0 0 0.3"/>
    <dynamics damping="1.0"/>
  </joint>
</robot>
"""


def test_urdf_dynamics_are_imported_never_dropped(tmp_path):
    path = tmp_path / "pair.urdf"
    path.write_text(URDF)
    robot = dynderive.load_robot(path)
    shoulder, elbow = robot.joints
    assert shoulder.damping == 0.7301215437791212 and shoulder.friction == 0.11932475802386
    assert elbow.damping is None and elbow.friction is None      # zeros mean no term
    assert any("<dynamics> on fixed joint 'mount' ignored" in note for note in robot.notes)
    d = dynderive.derive(robot)
    qd = d.symbols.qd
    assert sympy.simplify(d["F_g"][0] - (sympy.Rational("0.7301215437791212") * qd[0]
                                         + sympy.Rational("0.11932475802386") * sympy.sign(qd[0]))) == 0
    assert d["F_g"][1] == 0
    # `import` writes the same terms as YAML keys, and the YAML loads to the same joints
    result = runner.invoke(app, ["import", str(path), "-o", str(tmp_path / "pair.yaml")])
    assert result.exit_code == 0, result.output
    again = dynderive.load_robot(tmp_path / "pair.yaml")
    assert [(j.damping, j.friction) for j in again.joints] == [(j.damping, j.friction) for j in robot.joints]


def test_quantities_only_where_declared():
    plain, damped = derivation_of("cart_pole"), derivation_of("cart_pole_damped")
    assert "F_g" not in plain and "D_g" not in plain
    x, theta = damped.symbols.q
    xd, thetad = damped.symbols.qd
    p = damped.symbols.parameters
    assert damped["D_g"].equals((p["bc"] * xd**2 + p["bp"] * thetad**2) / 2)
    assert damped["F_g"] == sympy.Matrix([p["bc"] * xd + p["fc"] * sympy.sign(xd), p["bp"] * thetad])
    # armature only adds to M[x, x]; EOM_g2 = M qdd + C qd + N + F - Y
    difference = (damped["M_g"] - plain["M_g"]).applyfunc(sympy.expand)
    assert difference == sympy.Matrix([[p["Jm"], 0], [0, 0]])
    assert all(c.passed for c in damped.checks)


def test_json_parses_back_with_sign(tmp_path):
    d = derivation_of("cart_pole_damped")
    data = json.loads(dynderive.render_json(d))
    table = d.symbols.locals()
    for name in ("F_g", "D_g", "F_m", "D_m", "EOM_g1"):
        entry = data["quantities"][name]
        value = sympy.sympify(entry["sympy"], locals=table)
        expected = d[name]
        difference = (sympy.Matrix(value) - expected) if isinstance(expected, sympy.MatrixBase) else value - expected
        assert sympy.simplify(difference) == 0 * difference, name


def test_robots_without_drives_keep_the_same_api(generated):
    module = generated("double_pendulum")
    qd = np.array([[0.3, -1.2], [0.0, 2.5]])
    assert np.array_equal(module.friction_forces(qd, friction_smoothing=0.1), np.zeros((2, 2)))
    q, qdd = np.array([0.4, -0.2]), np.array([1.0, 0.5])
    assert np.allclose(module.inverse_dynamics(q, qd[0], qdd, friction_smoothing=0.01),
                       module.inverse_dynamics(q, qd[0], qdd))


def test_smoothed_coulomb_friction(generated):
    module = generated("cart_pole_damped")
    p = module.PARAMETERS
    qd = np.array([[0.0, 0.0], [2e-4, -1e-3], [-0.7, 0.4]])
    exact = module.friction_forces(qd)
    assert np.allclose(exact[:, 0], p["bc"] * qd[:, 0] + p["fc"] * np.sign(qd[:, 0]))
    assert np.allclose(exact[:, 1], p["bp"] * qd[:, 1])
    eps = 1e-3
    smooth = module.friction_forces(qd, friction_smoothing=eps)
    assert np.allclose(smooth[:, 0], p["bc"] * qd[:, 0] + p["fc"] * np.tanh(qd[:, 0] / eps))
    assert abs(smooth[1, 0] - exact[1, 0]) > 0.01   # within eps of 0 the two laws differ
    with pytest.raises(ValueError, match="friction_smoothing"):
        module.friction_forces(qd, friction_smoothing=-1.0)
    # forward dynamics uses the same law: inverse dynamics with it gives back the effort
    q, u = np.array([0.1, 0.4]), np.array([0.8])
    for smoothing in (0.0, eps):
        qdd = module.forward_dynamics(q, qd[1], u, friction_smoothing=smoothing)
        assert np.allclose(module.inverse_dynamics(q, qd[1], qdd, friction_smoothing=smoothing),
                           module.generalized_forces(q, u), atol=1e-12)


def test_parameter_values_change_the_drives(generated):
    module = generated("mass_spring_damper")
    qd = np.array([0.2538174319460236, -0.5127930624817112])
    b2, k1, k2 = 1.9386027145920357, 3.1415874210936882, 5.072984113640275
    assert np.allclose(module.friction_forces(qd, b1=0.0, b2=b2), [0.0, b2 * qd[1]], rtol=1e-14, atol=0)
    q = np.array([0.10384719263540127, -0.19735201836471048])
    assert np.allclose(module.gravity_vector(q, k1=k1, k2=k2), [k1 * q[0], k2 * q[1]], rtol=1e-14, atol=0)


def test_reserved_argument_name_refused(tmp_path):
    text = (ROBOTS / "mass_spring_damper.yaml").read_text().replace("  d: {value", "  friction_smoothing: {value")
    text = text.replace("origin: [d, 0]", "origin: [friction_smoothing, 0]")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert "name 'friction_smoothing' is reserved by the generated module" in result.output


def test_sheet_shows_where_each_term_enters():
    tex = dynderive.render_latex(derivation_of("cart_pole_damped"))
    for text in (r"\paragraph{Drives and dissipation.}", "Rayleigh", r"T_a = ", r"D_g = ",
                 r"+ \dfrac{\partial D_g}{\partial \dot q_i} + f_{c,i} \operatorname{sign}(\dot q_i) = \Upsilon_i",
                 r"\mathrm{diag}(I_{a,i})", r"M_g \ddot q_g + C_g \dot q_g + N_g + F_g = \Upsilon_g",
                 r"H^T F_m = F_g"):
        assert text in tex, text
    springs = dynderive.render_latex(derivation_of("mass_spring_damper"))
    assert r"V_s = " in springs and "(gravity and the springs)" in springs
    assert "Drives and dissipation" not in dynderive.render_latex(derivation_of("rp_arm"))


def test_check_measures_dissipation():
    """The JSON is read from stdout: progress lines go to stderr once a run passes 1 s."""
    result = runner.invoke(app, ["check", "cart_pole_damped", "--json"])
    assert result.exit_code == 0, result.output
    rows = {row["name"]: row for row in json.loads(result.stdout)["checks"]}
    assert rows["power balance dE/dt = qd . Y - qd . F"]["status"] == "pass"
    assert rows["H^T F_m = F_g"]["status"] == "pass"
    assert rows["generated friction_forces == symbolic F_g"]["status"] == "pass"


def _trajectory(output: str) -> dict[str, np.ndarray]:
    rows = list(csv.reader(io.StringIO(output)))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def test_simulate_damps_an_unactuated_joint(tmp_path):
    """The pole's bearing has damping but no actuator: the motion loses exactly the work
    damping and friction do (E + W stays constant), and without damping it loses none."""
    damped, free = tmp_path / "damped.csv", tmp_path / "free.csv"
    result = runner.invoke(app, ["simulate", "cart_pole_damped", "--duration", "3", "--q0", "0,2.5",
                                 "--csv", str(damped), "-q", "--param", "bp=0.05"])
    assert result.exit_code == 0, result.output
    assert "energy dissipated by damping and friction" in result.output
    run = _trajectory(damped.read_text())
    assert run["dissipated"][-1] > 0.01 and np.all(np.diff(run["dissipated"]) >= -1e-12)
    balance = run["energy"] - run["energy"][0] + run["dissipated"]
    assert np.max(np.abs(balance)) < 1e-6 * abs(run["energy"][0])
    result = runner.invoke(app, ["simulate", "cart_pole_damped", "--duration", "3", "--q0", "0,2.5",
                                 "--csv", str(free), "-q", "--param", "bp=0", "--param", "bc=0", "--param", "fc=0"])
    assert result.exit_code == 0, result.output
    run = _trajectory(free.read_text())
    assert np.max(np.abs(run["dissipated"])) < 1e-12
    assert np.max(np.abs(run["energy"] - run["energy"][0])) < 1e-6 * abs(run["energy"][0])


def test_random_drives_round_trip(tmp_path):
    """A generic planar tree with every drive term at full precision: the generated module
    agrees with the symbolic quantities and inverts its own forward dynamics."""
    from random_robots import random_planar_tree

    rng = random.Random(16)
    tree = random_planar_tree(rng, 3, fixed=False)
    lines = []
    for line in tree.yaml_text.splitlines():
        lines.append(line)
        if line.strip().startswith("type: revolute") or line.strip().startswith("type: prismatic"):
            indent = line[: len(line) - len(line.lstrip())]
            lines += [f"{indent}{key}: {rng.uniform(0.05, 2.0)!r}" for key in ("damping", "friction", "stiffness",
                                                                           "armature")]
            lines.append(f"{indent}rest: {rng.uniform(-1.0, 1.0)!r}")
    path = tmp_path / "tree.yaml"
    path.write_text("\n".join(lines) + "\n")
    d = dynderive.derive(dynderive.load_robot(path))
    assert all(c.passed for c in d.checks), [c for c in d.checks if not c.passed]
    module = import_code(dynderive.render_code(d), tmp_path, "random_drives_dynamics")
    n = len(module.COORDINATES)
    generator = np.random.default_rng(16)
    q, qd = generator.uniform(-1, 1, (2, 5, n))
    u = generator.uniform(-1, 1, (5, len(module.EFFORTS)))
    qdd = module.forward_dynamics(q, qd, u)
    assert np.allclose(module.inverse_dynamics(q, qd, qdd), module.generalized_forces(q, u), atol=1e-10)
    result = runner.invoke(app, ["check", str(path)])
    assert result.exit_code == 0, result.output
    assert Path(path).exists()
