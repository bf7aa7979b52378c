"""Drives and dissipation through the tool's surfaces: YAML and URDF input, the
quantities and their JSON, the generated module's API, the sheet, ``check`` and ``simulate``.

The closed forms and the Pinocchio comparisons of fixed-base robots are in
``test_drives_reference.py``.

Floating base: damping, Coulomb friction and wrenches at frames. The NumPy module of a random
floating tree (full-precision numbers, generic axes, full inertias, random damping and friction
on every revolute and prismatic joint, frames on the base and on a distal link) against
Pinocchio's free flyer, an independent reference: forward dynamics is ``aba`` with the joints'
friction taken from tau (exact and smoothed sign) and the frames' wrenches as ``fext`` (each a
``pin.Force`` in its joint's frame), inverse dynamics ``rnea`` plus the friction, linearize
``computeABADerivatives`` with the friction's slope. The JAX module, the C extension (one
compile) and the MATLAB/Octave package agree with the NumPy module; ``check`` passes its rows;
``simulate --force`` pushes a free body along its centre of mass as F/m.
"""

from __future__ import annotations

import csv
import io
import json
import os
import random
from pathlib import Path

import numpy as np
import pytest
import sympy
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import (
    ENERGY_RUN,
    MOMENTUM,
    POWER_BALANCE,
    random_configurations,
    run_checks,
)
from dynderive.verify.pinocchio_model import pinocchio_maps
from test_matlab_numeric import _Calls, _octave, _vector, needs_octave

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
        difference = ((sympy.Matrix(value) - expected) if isinstance(expected, sympy.MatrixBase)
                      else value - expected)
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
    text = (ROBOTS / "mass_spring_damper.yaml").read_text().replace("  d: {value",
                                                                    "  friction_smoothing: {value")
    text = text.replace("origin: [d, 0]", "origin: [friction_smoothing, 0]")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert "name 'friction_smoothing' is reserved by the generated module" in result.output


def test_sheet_shows_where_each_term_enters():
    tex = dynderive.render_latex(derivation_of("cart_pole_damped"))
    for text in (r"\paragraph{Drives and dissipation.}", "Rayleigh", r"T_a = ", r"D_g = ",
                 r"+ \dfrac{\partial D_g}{\partial \dot q_i} + f_{c,i} "
                 r"\operatorname{sign}(\dot q_i) = \Upsilon_i",
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
                                 "--csv", str(free), "-q", "--param", "bp=0", "--param", "bc=0",
                                 "--param", "fc=0"])
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
            lines += [f"{indent}{key}: {rng.uniform(0.05, 2.0)!r}"
                      for key in ("damping", "friction", "stiffness", "armature")]
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


# -- floating base: damping, Coulomb friction and wrenches at frames against Pinocchio ----

EPS = 0.05   # friction_smoothing of the smoothed runs


def _text(seed: int = 2) -> str:
    """A random floating tree with damping and friction on its scalar joints and two frames:
    on the base (below the floating joint) and on the last link (random origins)."""
    from test_free_flyer import _floating_tree  # that module needs Pinocchio

    rng = random.Random(100 + seed)
    data = yaml.safe_load(_floating_tree(seed, 3))
    for joint in data["joints"]:
        if joint["type"] in ("revolute", "prismatic"):
            joint["damping"] = rng.uniform(0.1, 1.0)
            joint["friction"] = rng.uniform(0.05, 0.5)
    last = [j for j in data["joints"] if j["type"] in ("revolute", "prismatic")][-1]["child"]
    data["frames"] = [{"name": name, "link": link,
                       "origin": {"xyz": [rng.uniform(-0.5, 0.5) for _ in range(3)],
                                  "rpy": [rng.uniform(-3, 3) for _ in range(3)]}}
                      for name, link in (("hull", "base"), ("tool", last))]
    data["name"] = "rough_tree"
    return yaml.safe_dump(data, sort_keys=False)


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    """(robot file, derivation, NumPy module, Pinocchio model, q and v places, drives by column)."""
    pytest.importorskip("pinocchio")
    folder = tmp_path_factory.mktemp("drives")
    path = folder / "rough_tree.yaml"
    path.write_text(_text())
    robot = dynderive.load_robot(path)
    derivation = dynderive.derive(robot)
    module = import_code(render_code(derivation), folder)
    model, qp, vp = pinocchio_maps(robot, {})
    where_v = robot.offsets()[1]
    b, fc = np.zeros(robot.velocity_count), np.zeros(robot.velocity_count)
    for joint in robot.joints:
        if joint.damping is not None:
            b[where_v[joint.name]], fc[where_v[joint.name]] = float(joint.damping), float(joint.friction)
    return path, derivation, module, model, qp, vp, b, fc


def _fext(model, data, robot, q_pin, wrenches):
    """Pinocchio's ``fext`` of world-aligned wrenches at frames (moment about the frame's
    origin): each as a force about the world origin, then in its joint's frame."""
    import pinocchio as pin

    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    pin.forwardKinematics(model, data, q_pin)
    for name, (f, n) in wrenches.items():
        frame = next(fr for fr in robot.frames if fr.name == name)
        # a moving joint: link frame = joint frame
        joint = next(j for j in robot.joints if j.child == frame.link)
        jid = model.getJointId(joint.name)
        x, y, z, roll, pitch, yaw = (float(e) for e in frame.origin)
        where = data.oMi[jid] * pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.array([x, y, z]))
        world = pin.Force(f, n + np.cross(where.translation, f))
        fext[jid] = fext[jid] + data.oMi[jid].actInv(world)
    return fext


def test_friction_and_wrenches_equal_pinocchio(tree):
    pin = pytest.importorskip("pinocchio")
    path, derivation, module, model, qp, vp, b, fc = tree
    robot = derivation.robot
    data = model.createData()
    rng = np.random.default_rng(5)
    assert module.PARAMETER_VECTOR[-6:] == tuple(f"{kind}_{name}" for name in ("q1", "q2", "q3")
                                                 for kind in ("damping", "friction"))
    for q in random_configurations(robot, rng, 3):
        v, a = rng.normal(size=module.NV), rng.normal(size=module.NV)
        u = rng.normal(size=len(module.EFFORTS))
        applied = np.zeros(module.NV)
        applied[list(robot.effort_columns())] = u
        wrenches = {"hull": (rng.normal(size=3), rng.normal(size=3)),
                    "tool": (rng.normal(size=3), rng.normal(size=3))}
        ours = {name: np.concatenate(w) for name, w in wrenches.items()}
        fext = _fext(model, data, robot, q[qp], wrenches)
        for smoothing, direction in ((0.0, np.sign(v)), (EPS, np.tanh(v / EPS))):
            friction = b * v + fc * direction   # zero on the floating joint's six
            np.testing.assert_allclose(module.friction_forces(v, friction_smoothing=smoothing), friction,
                                       rtol=1e-15)
            tau = applied - friction
            expected = pin.aba(model, data, q[qp], v[vp], tau[vp])
            np.testing.assert_allclose(module.forward_dynamics(q, v, u, friction_smoothing=smoothing)[vp],
                                       expected,
                                       rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(expected))))
            expected = pin.aba(model, data, q[qp], v[vp], tau[vp], fext)
            np.testing.assert_allclose(module.forward_dynamics(q, v, u, ours,
                                                               friction_smoothing=smoothing)[vp],
                                       expected, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(expected))))
            expected = pin.rnea(model, data, q[qp], v[vp], a[vp], fext) + friction[vp]
            got = module.inverse_dynamics(q, v, a, ours, friction_smoothing=smoothing)
            np.testing.assert_allclose(got[vp], expected, rtol=0,
                                       atol=1e-9 * max(1.0, np.max(np.abs(expected))))
            np.testing.assert_allclose(module.regressor(q, v, a, friction_smoothing=smoothing)
                                       @ module.parameter_vector(),
                                       module.inverse_dynamics(q, v, a, friction_smoothing=smoothing), rtol=0,
                                       atol=1e-9 * max(1.0, np.max(np.abs(expected))))
            # linearize: Pinocchio's ABA derivatives at tau - F, with F's slope through M^-1
            pin.computeABADerivatives(model, data, q[qp], v[vp], tau[vp])
            minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
            slope = b + (fc * (1.0 - np.tanh(v / EPS) ** 2) / EPS if smoothing else 0.0)
            A, _ = module.linearize(q, v, u, friction_smoothing=smoothing)
            np.testing.assert_allclose(A[module.NV:, :module.NV][np.ix_(vp, vp)], data.ddq_dq, rtol=0,
                                       atol=1e-8)
            np.testing.assert_allclose(A[module.NV:, module.NV:][np.ix_(vp, vp)],
                                       data.ddq_dv - minv @ np.diag(slope[vp]), rtol=0, atol=1e-8)
    with pytest.raises(ValueError, match="unknown frame 'hand'"):
        module.forward_dynamics(q, v, u, {"hand": np.zeros(6)})
    with pytest.raises(ValueError, match="friction_smoothing must not be negative"):
        module.friction_forces(v, friction_smoothing=-1.0)


def test_check_passes_its_rows(tree):
    """``check``'s rows: the energy balance takes the friction's power out, the run keeps energy
    plus dissipated work, and the Pinocchio row compares aba with the friction taken from tau."""
    _, derivation, module, *_ = tree
    rows = run_checks(derivation, render_code(derivation), states=6)
    assert all(row.status == "pass" for row in rows), [(row.name, row.status, row.residual) for row in rows]
    assert {POWER_BALANCE, ENERGY_RUN, MOMENTUM} <= {row.name for row in rows}
    assert any(row.name.startswith("agrees with Pinocchio") for row in rows)


def test_jax_and_c_extension_agree_with_numpy(tree, tmp_path):
    """One compile: the extension and the JAX module at one state and a batch, wrenches and smoothing."""
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from dynderive.render.targets.jax.jax import render_jax

    _, derivation, module, *_ = tree
    jx = import_code(render_jax(derivation), tmp_path)
    try:
        from test_c_extension import _load

        extension = _load(derivation, tmp_path / "c", "-O0")
    except Exception as exc:   # no compiler: the JAX half still runs
        if os.environ.get("CI"):
            raise
        extension = None
        print(f"no C extension: {exc}")
    rng = np.random.default_rng(9)
    qs = random_configurations(derivation.robot, rng, 3)
    vs, us = rng.normal(size=(3, module.NV)), rng.normal(size=(3, len(module.EFFORTS)))
    wrenches = {"tool": rng.normal(size=(3, 6)), "hull": rng.normal(size=6)}
    def outputs(target, smoothing: float) -> dict:
        return {
            "friction_forces": target.friction_forces(vs, friction_smoothing=smoothing),
            "forward_dynamics": target.forward_dynamics(qs, vs, us, wrenches, friction_smoothing=smoothing),
            "inverse_dynamics": target.inverse_dynamics(qs, vs, vs, wrenches, friction_smoothing=smoothing),
            "regressor": target.regressor(qs, vs, vs, friction_smoothing=smoothing),
            "linearize": target.linearize(qs[0], vs[0], us[0], friction_smoothing=smoothing)[0],
        }

    for smoothing in (0.0, EPS):
        expected = outputs(module, smoothing)
        for target in (jx, extension):
            if target is None:
                continue
            got = outputs(target, smoothing)
            for name, value in expected.items():
                np.testing.assert_allclose(np.asarray(got[name]), value, rtol=1e-12,
                                           atol=1e-12 * max(1.0, np.max(np.abs(value))),
                                           err_msg=f"{target}: {name}")
            one = target.forward_dynamics(qs[1], vs[1], us[1], {"tool": wrenches["tool"][1]},
                                          friction_smoothing=smoothing)
            np.testing.assert_allclose(np.asarray(one), module.forward_dynamics(
                qs[1], vs[1], us[1], {"tool": wrenches["tool"][1]}, friction_smoothing=smoothing),
                rtol=1e-12, atol=1e-12)


@needs_octave
def test_matlab_friction_agrees_with_numpy(tree, tmp_path):
    from dynderive.render.targets.matlab.matlab import render_matlab

    _, derivation, module, *_ = tree
    for path, text in render_matlab(derivation).items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    name = derivation.robot.name
    calls = _Calls(name)
    calls.lines.append(f"p = {name}.parameters();")
    rng = np.random.default_rng(3)
    q = random_configurations(derivation.robot, rng, 1)[0]
    qd, qdd, u = rng.normal(size=module.NV), rng.normal(size=module.NV), rng.normal(size=len(module.EFFORTS))
    Q, QD, QDD, U = (_vector(x) for x in (q, qd, qdd, u))
    for k, smoothing in enumerate((0.0, EPS)):
        calls.lines.append(f"p.friction_smoothing = {smoothing!r};")
        calls.add(f"F{k}", f"friction_forces({QD}, p)",
                  module.friction_forces(qd, friction_smoothing=smoothing))
        calls.add(f"tau{k}", f"inverse_dynamics({Q}, {QD}, {QDD}, p)",
                  module.inverse_dynamics(q, qd, qdd, friction_smoothing=smoothing))
        calls.add(f"qdd{k}", f"forward_dynamics({Q}, {QD}, {U}, p)",
                  module.forward_dynamics(q, qd, u, friction_smoothing=smoothing))
        calls.add(f"Y{k}", f"regressor({Q}, {QD}, {QDD}, p)",
                  module.regressor(q, qd, qdd, friction_smoothing=smoothing))
        calls.add(f"lin{k}", f"linearize({Q}, {QD}, {U}, p)",
                  module.linearize(q, qd, u, friction_smoothing=smoothing),
                  outputs=2)
    calls.check(_octave(tmp_path, "\n".join(calls.lines) + "\n"))


PUCK = """name: puck
planar: false
parameters:
  m: {value: 2.5, unit: kg}
gravity: [0, 0, 0]
links:
  - {name: body, mass: m, com: [0.1, -0.2, 0.3], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
joints:
  - {name: root, type: floating, parent: world, child: body}
frames:
  - {name: com, link: body, origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 0.1]}}
"""


def test_simulate_force_pushes_a_free_body_as_f_over_m(tmp_path):
    """A constant force through the centre of mass (world axes): the body does not turn, and
    its origin moves by F t^2 / (2 m) (closed form)."""
    path = tmp_path / "puck.yaml"
    path.write_text(PUCK)
    run_csv = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", str(path), "--duration", "2", "--frames", "5", "--force",
                                 "com=1, -2, 0.5, 0, 0, 0", "--csv", str(run_csv), "-q"])
    assert result.exit_code == 0, result.output
    rows = np.loadtxt(run_csv, delimiter=",", skiprows=1)
    t = rows[:, 0]
    force = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(rows[:, 1:4], np.outer(t**2, force / (2 * 2.5)), rtol=0, atol=1e-7)
    np.testing.assert_allclose(rows[:, 4:8], np.tile([0, 0, 0, 1], (len(t), 1)), rtol=0, atol=1e-9)
    np.testing.assert_allclose(rows[:, 8:11], np.outer(t, force / 2.5), rtol=0,
                               atol=1e-7)   # v in the body frame
    result = runner.invoke(app, ["simulate", str(path), "--force", "hand=0,0,0,0,0,0", "--csv", str(run_csv)])
    assert result.exit_code == 2 and "expected FRAME=EXPR,EXPR,.. with FRAME one of com" in result.stderr


def test_generated_property_checks_take_the_friction_out(tree, tmp_path):
    """``--code --tests`` of the rough tree: the energy balance and C qd hold with F taken out."""
    import subprocess
    import sys

    from dynderive.render.targets.numpy.code import render_code_tests

    _, derivation, *_ = tree
    (tmp_path / "rough_tree_dynamics.py").write_text(render_code(derivation))
    (tmp_path / "test_rough_tree_dynamics.py").write_text(render_code_tests(derivation))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "test_rough_tree_dynamics.py"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and " passed" in run.stdout and "failed" not in run.stdout, \
        run.stdout + run.stderr


def test_sheet_and_json_carry_the_friction(tree):
    """The JSON dump's F_g and EOM_g2 = M vdot + C v + N + F - Y agree with the module's
    inverse_dynamics at a random state (the sheet shows the same F)."""
    import sympy

    from dynderive.render.sheets.json import render_json
    from dynderive.render.sheets.latex import render_latex

    _, derivation, module, *_ = tree
    dump = json.loads(render_json(derivation))
    quantities = dump["quantities"]
    table = derivation.symbols
    rng = np.random.default_rng(11)
    q = random_configurations(derivation.robot, rng, 1)[0]
    v, a, u = rng.normal(size=module.NV), rng.normal(size=module.NV), rng.normal(size=len(module.EFFORTS))
    at = (dict(zip(table.q, q)) | dict(zip(table.qd, v)) | dict(zip(table.qdd, a))
          | dict(zip(table.efforts.values(), u)))
    names = {str(s): s for s in (*table.q, *table.qd, *table.qdd, *table.efforts.values())}
    for name, entry in dump.get("intermediates", {}).items():   # a larger robot's lines, in order
        at[sympy.Symbol(name)] = sympy.sympify(entry["sympy"], locals=names).xreplace(at).evalf(30)
    values = {name: np.array(sympy.sympify(quantities[name]["sympy"], locals=names).xreplace(at),
                             dtype=float).ravel()
              for name in ("F_g", "EOM_g2")}
    applied = np.zeros(module.NV)
    applied[list(derivation.robot.effort_columns())] = u
    np.testing.assert_allclose(values["F_g"], module.friction_forces(v), rtol=1e-12)
    expected = module.inverse_dynamics(q, v, a) - applied
    np.testing.assert_allclose(values["EOM_g2"], expected, rtol=0,
                               atol=1e-9 * max(1.0, np.max(np.abs(expected))))
    assert "the joints' damping and Coulomb friction $F = " in render_latex(derivation)
