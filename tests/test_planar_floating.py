"""Planar floating joints (x, y, theta) and URDF ``planar`` joints.

A planar robot's ``floating`` joint is prismatic x, prismatic y and revolute theta in a row
(two massless links between them), derived by the fixed-base planar engine. The references are
independent: Pinocchio's ``JointModelPlanar`` (q = (x, y, cos, sin), local velocity), built
from the numbers, related to dynderive's (x, y, theta) and their time derivatives by
``v = T qd`` with ``T = blockdiag(R(theta)^T, 1, I)``; a free body's closed form; energy and
momentum along ``simulate``; Pinocchio's URDF parser.
"""

from __future__ import annotations

import csv
import random
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.model.naming import velocity_name

from conftest import import_code

runner = CliRunner()
TOL = {"rtol": 1e-9, "atol": 1e-9}
HERE = Path(__file__).parent


def _numbers(seed: int) -> dict[str, float]:
    """Full-precision random numbers of the hopper."""
    r = random.Random(seed)
    u = r.uniform
    return {"mb": u(1, 3), "ml": u(0.3, 1), "ms": u(0.2, 0.8), "Ib": u(0.1, 0.5), "Il": u(0.01, 0.1),
            "Is": u(0.01, 0.1), "g": 9.81, "bx": u(-0.2, 0.2), "by": u(-0.2, 0.2), "lx": u(0.05, 0.3),
            "ly": u(-0.05, 0.05), "sx": u(0.05, 0.3), "sy": u(-0.05, 0.05), "hx": u(-0.2, 0.2),
            "hy": u(-0.4, -0.1), "ht": u(-2, -1), "kx": u(0.2, 0.5), "ky": u(-0.1, 0.1), "kt": u(-0.5, 0.5),
            "ax": u(0.5, 1), "ay": u(-0.5, 0.5), "fx": u(-1, 1), "fy": u(-1, 1), "ft": u(-1, 1)}


def hopper_yaml(n: dict[str, float]) -> str:
    """A free body (its floating joint placed at (fx, fy, ft) in the world) with a leg: a
    revolute hip and a prismatic knee along a unit-less axis."""
    return f"""name: hopper
planar: true
parameters:
  g: {{value: {n['g']!r}}}
gravity: [0, -g]
links:
  - {{name: body, mass: {n['mb']!r}, com: [{n['bx']!r}, {n['by']!r}], inertia: {n['Ib']!r}}}
  - {{name: thigh, mass: {n['ml']!r}, com: [{n['lx']!r}, {n['ly']!r}], inertia: {n['Il']!r}}}
  - {{name: shin, mass: {n['ms']!r}, com: [{n['sx']!r}, {n['sy']!r}], inertia: {n['Is']!r}}}
joints:
  - {{name: base, type: floating, parent: world, child: body, origin: [{n['fx']!r}, {n['fy']!r}, {n['ft']!r}]}}
  - {{name: hip, type: revolute, parent: body, child: thigh, origin: [{n['hx']!r}, {n['hy']!r}, {n['ht']!r}], effort: tau_hip}}
  - {{name: knee, type: prismatic, parent: thigh, child: shin, origin: [{n['kx']!r}, {n['ky']!r}, {n['kt']!r}],
     axis: [{n['ax']!r}, {n['ay']!r}], effort: f_knee}}
"""


def _module(tmp_path: Path, name: str, text: str, suffix: str = ".yaml"):
    path = tmp_path / f"{name}{suffix}"
    path.write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    return derivation, import_code(dynderive.render_code(derivation), tmp_path, f"{name}_dynamics")


# --- Pinocchio's planar joint, and how its q, v map to (x, y, theta) and their rates ---------


def _T(theta: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """v = T qd, and dT/dtheta (so that Tdot = dT/dtheta * thetadot)."""
    c, s = np.cos(theta), np.sin(theta)
    T, dT = np.eye(n), np.zeros((n, n))
    T[:2, :2] = [[c, s], [-s, c]]
    dT[:2, :2] = [[-s, c], [-c, -s]]
    return T, dT


def _pin_q(q: np.ndarray) -> np.ndarray:
    return np.concatenate([q[:2], [np.cos(q[2]), np.sin(q[2])], q[3:]])


def compare(module, model, efforts: list[int], seed: int, values: dict[str, float] | None = None) -> None:
    """M, nle (inverse dynamics at qdd = 0), gravity and aba of the generated module against
    Pinocchio's model whose first joint is a ``JointModelPlanar`` for dynderive's first three
    coordinates; ``efforts``: the coordinates the module's efforts act on, in order."""
    pin = pytest.importorskip("pinocchio")
    data, values = model.createData(), values or {}
    n = model.nv
    rng = np.random.default_rng(seed)
    for _ in range(6):
        q, qd, qdd = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)
        u = rng.uniform(-3, 3, len(efforts))
        T, dT = _T(q[2], n)
        Tdot_qd = qd[2] * dT @ qd
        qp, v = _pin_q(q), T @ qd
        M = T.T @ pin.crba(model, data, qp) @ T
        np.testing.assert_allclose(module.mass_matrix(q, **values), np.triu(M) + np.triu(M, 1).T, **TOL)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, np.zeros(n), **values),
                                   T.T @ pin.rnea(model, data, qp, v, Tdot_qd), **TOL)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd, **values),
                                   T.T @ pin.rnea(model, data, qp, v, T @ qdd + Tdot_qd), **TOL)
        np.testing.assert_allclose(module.gravity_vector(q, **values),
                                   T.T @ pin.computeGeneralizedGravity(model, data, qp), **TOL)
        tau = np.zeros(n)
        tau[efforts] = u
        a = pin.aba(model, data, qp, v, T @ tau)   # T^-T = T: a rotation on the base's block
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u, **values), np.linalg.solve(T, a - Tdot_qd), **TOL)


def _placement(pin, x: float, y: float, theta: float):
    c, s = np.cos(theta), np.sin(theta)
    return pin.SE3(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([x, y, 0.0]))


def hopper_pinocchio(n: dict[str, float]):
    """The hopper built from the numbers: JointModelPlanar, RZ, prismatic along the unit axis."""
    pin = pytest.importorskip("pinocchio")
    model = pin.Model()
    model.gravity.linear = np.array([0.0, -n["g"], 0.0])

    def body(mass: float, cx: float, cy: float, izz: float):
        return pin.Inertia(mass, np.array([cx, cy, 0.0]), np.diag([izz, izz, izz]))

    base = model.addJoint(0, pin.JointModelPlanar(), _placement(pin, n["fx"], n["fy"], n["ft"]), "base")
    model.appendBodyToJoint(base, body(n["mb"], n["bx"], n["by"], n["Ib"]), pin.SE3.Identity())
    hip = model.addJoint(base, pin.JointModelRZ(), _placement(pin, n["hx"], n["hy"], n["ht"]), "hip")
    model.appendBodyToJoint(hip, body(n["ml"], n["lx"], n["ly"], n["Il"]), pin.SE3.Identity())
    axis = np.array([n["ax"], n["ay"], 0.0]) / np.hypot(n["ax"], n["ay"])
    knee = model.addJoint(hip, pin.JointModelPrismaticUnaligned(axis), _placement(pin, n["kx"], n["ky"], n["kt"]), "knee")
    model.appendBodyToJoint(knee, body(n["ms"], n["sx"], n["sy"], n["Is"]), pin.SE3.Identity())
    return model


@pytest.mark.pinocchio
@pytest.mark.parametrize("seed", [1, 2])
def test_hopper_against_pinocchios_planar_joint(seed, tmp_path):
    numbers = _numbers(seed)
    derivation, module = _module(tmp_path, "hopper", hopper_yaml(numbers))
    assert module.COORDINATES == ("base_x", "base_y", "base_theta", "hip", "knee")
    assert module.EFFORTS == ("tau_hip", "f_knee")   # the floating joint is unactuated
    assert [lk.name for lk in derivation.robot.links][:3] == ["body", "thigh", "shin"]   # links keep their numbers
    compare(module, hopper_pinocchio(numbers), [3, 4], seed)


def test_free_body_closed_form(tmp_path):
    """One body on a floating joint: M = [[m, 0, -m (s cx + c cy)], [0, m, m (c cx - s cy)],
    [., ., I + m (cx^2 + cy^2)]] (diag(m, m, I) with the COM at the joint), N = m g (0, 1, c cx - s cy)."""
    m, izz, cx, cy, g = 1.7, 0.23, 0.31, -0.12, 9.81
    text = (f"name: puck\nplanar: true\nparameters: {{g: {g}}}\ngravity: [0, -g]\n"
            f"links:\n  - {{name: body, mass: {m}, com: [{cx}, {cy}], inertia: {izz}}}\n"
            "joints:\n  - {name: free, type: floating, parent: world, child: body}\n")
    derivation, module = _module(tmp_path, "puck", text)
    assert derivation.robot.coordinates == ("free_x", "free_y", "free_theta")
    for theta in (0.0, 0.7, -2.1):
        c, s = np.cos(theta), np.sin(theta)
        q = np.array([0.4, -1.3, theta])
        expected = np.array([[m, 0, -m * (s * cx + c * cy)], [0, m, m * (c * cx - s * cy)],
                             [-m * (s * cx + c * cy), m * (c * cx - s * cy), izz + m * (cx**2 + cy**2)]])
        np.testing.assert_allclose(module.mass_matrix(q), expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(module.gravity_vector(q), m * g * np.array([0, 1, c * cx - s * cy]), atol=1e-12)
    centred, module = _module(tmp_path, "puck0", text.replace("puck", "puck0").replace(f"com: [{cx}, {cy}], ", ""))
    np.testing.assert_allclose(module.mass_matrix(np.array([1.0, 2.0, 0.3])), np.diag([m, m, izz]), atol=1e-15)


def test_simulate_conserves_energy_and_momentum(tmp_path):
    """Without efforts and gravity the hopper's energy and its linear momentum (the x and y
    rows of M qd: the base's coordinates are world coordinates) stay constant along simulate."""
    numbers = _numbers(3)
    text = hopper_yaml(numbers)
    _, module = _module(tmp_path, "hopper", text)
    path = tmp_path / "hopper.yaml"
    result = runner.invoke(app, ["simulate", str(path), "--duration", "1", "--q0", "0.1,0.2,0.3,-0.4,0.05",
                                 "--qd0", "0.5,-0.3,1.1,-0.7,0.4", "--param", "g=0", "--rtol", "1e-11",
                                 "--atol", "1e-11", "--frames", "21", "--csv", str(tmp_path / "t.csv"), "-q"])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader((tmp_path / "t.csv").open()))
    energy = np.array([float(r["energy"]) for r in rows])
    assert np.ptp(energy) < 1e-7 * abs(energy[0]) and energy[0] > 0.1
    names = module.COORDINATES
    q = np.array([[float(r[c]) for c in names] for r in rows])
    qd = np.array([[float(r[velocity_name(c)]) for c in names] for r in rows])
    momentum = np.einsum("tij,tj->ti", module.mass_matrix(q, g=0.0)[:, :2], qd)
    assert np.ptp(q[:, 2]) > 0.5   # it turned
    np.testing.assert_allclose(momentum, np.broadcast_to(momentum[0], momentum.shape), atol=1e-7)


def test_every_output_and_the_sheet(tmp_path):
    path = tmp_path / "hopper.yaml"
    path.write_text(hopper_yaml(_numbers(4)))
    flags = ["--latex", "--code", "--json", "--html", "--c", "--matlab", "--jax", "--tests"]
    if shutil.which("latexmk") is not None:
        flags.append("--pdf")
    result = runner.invoke(app, ["solve", str(path), *flags, "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "out"
    assert "base_theta" in (out / "hopper.json").read_text()
    assert (out / "hopper_dynamics.c").exists() and (out / "+hopper" / "mass_matrix.m").exists()
    if shutil.which("latexmk") is not None:
        assert (out / "hopper.pdf").read_bytes().startswith(b"%PDF")


def test_check_passes(tmp_path):
    path = tmp_path / "hopper.yaml"
    path.write_text(hopper_yaml(_numbers(5)))
    result = runner.invoke(app, ["check", str(path)])
    assert result.exit_code == 0, result.output
    assert " 0 failed" in result.output


def test_a_loop_pins_the_free_body_into_a_pendulum(tmp_path):
    """A free body whose point (a, 0) is pinned to the world by a loop joint moves as a
    pendulum: the reduced mass I + m (cx - a)^2 about the pin."""
    m, izz, cx, a = 1.3, 0.07, 0.4, 0.1
    text = (f"name: pinned\nplanar: true\ngravity: [0, -9.81]\n"
            f"links:\n  - {{name: body, mass: {m}, com: [{cx}, 0], inertia: {izz}}}\n"
            "joints:\n  - {name: free, type: floating, parent: world, child: body}\n"
            f"loops:\n  - {{name: pin, type: revolute, parent: world, child: body, child_origin: [{a}, 0]}}\n"
            "independent: [free_theta]\n")
    derivation, module = _module(tmp_path, "pinned", text)
    theta = 0.6
    q = np.array([-a * np.cos(theta), -a * np.sin(theta), theta])
    np.testing.assert_allclose(module.loop_constraints(q), 0, atol=1e-12)
    R = module.reduced_basis(q)
    assert R[2, 0] == 1
    assert (R.T @ module.mass_matrix(q) @ R).item() == pytest.approx(izz + m * (cx - a) ** 2, rel=1e-12)


# --- URDF planar joints ----------------------------------------------------------------------

URDF = """<robot name="slider">
  <link name="base"/>
  <link name="body">
    <inertial><origin xyz="0.13 0.21 0.05" rpy="0.3 -0.2 0.4"/><mass value="2.3"/>
      <inertia ixx="0.31" ixy="0.011" ixz="0.023" iyy="0.42" iyz="0.031" izz="0.53"/></inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.3 0.02 -0.01"/><mass value="1.1"/>
      <inertia ixx="0.1" ixy="0.001" ixz="0" iyy="0.12" iyz="0" izz="0.09"/></inertial>
  </link>
  <joint name="slide" type="planar">
    <parent link="base"/><child link="body"/>
    <origin xyz="0.1 0.2 0.3" rpy="{rpy}"/>
    {axis}
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="body"/><child link="arm"/>
    <origin xyz="0.5 0.1 -0.2" rpy="0.2 0 0.1"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


@pytest.mark.pinocchio
def test_urdf_planar_joint_against_pinocchios_urdf_parser(tmp_path):
    pin = pytest.importorskip("pinocchio")
    text = URDF.format(rpy="0.1 0.2 0.3", axis='<axis xyz="0 0 1"/>')
    derivation, module = _module(tmp_path, "slider", text, ".urdf")
    assert module.COORDINATES == ("slide_x", "slide_y", "slide_theta", "elbow")
    assert module.EFFORTS == ("f_slide_x", "f_slide_y", "f_slide_theta", "tau_elbow")
    (tmp_path / "slider.urdf").write_text(text)
    model = pin.buildModelFromUrdf(str(tmp_path / "slider.urdf"))
    assert [j.shortname() for j in model.joints[1:]] == ["JointModelPlanar", "JointModelRY"]
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    compare(module, model, [0, 1, 2, 3], seed=11)


def _rpy(pin, R: np.ndarray) -> str:
    return " ".join(repr(float(a)) for a in pin.rpy.matrixToRpy(R))


@pytest.mark.pinocchio
def test_urdf_planar_joint_about_a_general_axis(tmp_path):
    """Axis n: x along e1 (the joint frame's x projected on the plane, normalized), y along
    e2 = n x e1, theta about n. Pinocchio's parser ignores the axis (it moves in the joint
    frame's xy plane), so the reference is the same robot written for it with the planar
    joint's frame turned to (e1, e2, n) and a fixed joint turning the child back."""
    pin = pytest.importorskip("pinocchio")
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    e1 = np.array([1.0, 0, 0]) - n[0] * n
    e1 /= np.linalg.norm(e1)
    A = np.column_stack([e1, np.cross(n, e1), n])
    R0 = pin.rpy.rpyToMatrix(0.1, 0.2, 0.3)
    ours = URDF.format(rpy="0.1 0.2 0.3", axis='<axis xyz="0.3 -0.5 0.8"/>')
    derivation, module = _module(tmp_path, "tilted", ours, ".urdf")
    theirs = (URDF.format(rpy=_rpy(pin, R0 @ A), axis='<axis xyz="0 0 1"/>')
              .replace('<child link="body"/>', '<child link="turned"/>')
              .replace('<link name="base"/>', '<link name="base"/><link name="turned"/>')
              .replace("</robot>", f'<joint name="back" type="fixed"><parent link="turned"/><child link="body"/>'
                                   f'<origin rpy="{_rpy(pin, A.T)}"/></joint></robot>'))
    (tmp_path / "theirs.urdf").write_text(theirs)
    model = pin.buildModelFromUrdf(str(tmp_path / "theirs.urdf"))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    compare(module, model, [0, 1, 2, 3], seed=12)
    # the axis along x: e1 is the joint frame's y axis, e2 = x cross y = z
    along_x = URDF.format(rpy="0 0 0", axis='<axis xyz="1 0 0"/>')
    path = tmp_path / "along_x.urdf"
    path.write_text(along_x)
    joint = dynderive.load_robot(path).joints[0]
    assert joint.kind.nq == 3 and tuple(float(a) for a in joint.axis) == (1, 0, 0)
    from dynderive.mechanics.joint_types.planar import plane_axes

    assert plane_axes(joint.axis) == ((0, 1, 0), (0, 0, 1))


# --- bad input -------------------------------------------------------------------------------

FREE = ("name: p\nplanar: true\ngravity: [0, -9.81]\nlinks:\n  - {name: a, mass: 1, inertia: 0.1}\n"
        "joints:\n  - {name: free, type: floating, parent: world, child: a}\n")


def _bad(tmp_path: Path, text: str, suffix: str = ".yaml") -> list[str]:
    path = tmp_path / f"robot{suffix}"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
    return [line.removeprefix(f"{path}:") for line in result.stderr.splitlines()]


def test_bad_planar_floating_joints(tmp_path):
    assert _bad(tmp_path, FREE.replace("child: a}", "child: a, axis: [1, 0]}")) == [
        "7:65: joints[0].axis: a floating joint takes no axis"]
    assert _bad(tmp_path, FREE.replace("child: a}", "child: a, effort: F}")) == [
        "7:67: joints[0].effort: a planar floating joint is unactuated (push its body with a wrench at a frame)"]
    assert _bad(tmp_path, FREE.replace("child: a}", "child: a, damping: 0.1}")) == [
        "7:59: joints[0].damping: drive terms on a floating joint are not built yet"]
    clash = FREE.replace("  - {name: a, mass: 1, inertia: 0.1}\n",
                         "  - {name: a, mass: 1, inertia: 0.1}\n  - {name: free_x_link, mass: 1}\n") \
        + "  - {name: free_theta, type: revolute, parent: a, child: free_x_link}\n"
    lines = _bad(tmp_path, clash)
    assert "8:12: joints[0].name: a planar floating joint is the joints free_x, free_y, free_theta and the " \
           "massless links free_x_link, free_y_link; 'free_theta' is taken by joint 'free_theta' at 9:5" in lines
    assert any("'free_x_link' is taken by link 'free_x_link' at 6:5" in line for line in lines)
    lines = _bad(tmp_path, FREE.replace("gravity: [0, -9.81]", "parameters: {free_y: 1}\ngravity: [0, -9.81]"))
    assert any("joints[0].name (coordinate 'free_y'): name 'free_y' clashes with parameters.free_y" in line
               for line in lines), lines


def test_bad_urdf_planar_joints(tmp_path):
    lines = _bad(tmp_path, URDF.format(rpy="0 0 0", axis='<axis xyz="0 0 0"/>'), ".urdf")
    assert lines == ["14:5: joint 'slide' axis: axis has zero length"]
    clash = URDF.format(rpy="0 0 0", axis="").replace('name="elbow"', 'name="slide_theta"')
    assert _bad(tmp_path, clash, ".urdf") == [
        "16:3: joint 'slide_theta' name: name 'slide_theta' clashes with joint 'slide' name (coordinate "
        "'slide_theta') (first at 11:3)"]
    universal = ("name: u\nplanar: false\ngravity: [0, 0, -9.81]\nlinks:\n  - {name: a, mass: 1, inertia: [0.1, 0.1, 0.1, 0, 0, 0]}\n"
                 "  - {name: b, mass: 1, inertia: [0.1, 0.1, 0.1, 0, 0, 0]}\njoints:\n"
                 "  - {name: cardan, type: universal, parent: world, child: a, axis2: [1, 0, 0], effort: t}\n"
                 "  - {name: cardan_2, type: revolute, parent: a, child: b, effort: t_1}\n")
    lines = _bad(tmp_path, universal)   # a joint of several coordinates claims each of their names
    assert any("'cardan_2' clashes with joints[0].name (coordinate 'cardan_2')" in line for line in lines), lines
    lines = _bad(tmp_path, universal.replace("name: cardan_2,", "name: elbow,"))
    assert any("'t_1' clashes with joints[0].effort ('t_1')" in line for line in lines), lines
    empty = re.sub(r'<link name="(body|arm)">.*?</link>', r'<link name="\1"/>', URDF.format(rpy="0 0 0", axis=""), flags=re.S)
    lines = _bad(tmp_path, empty, ".urdf")   # the child's error only, not its massless links'
    assert [line.split(": ")[1] for line in lines] == ["link 'body' moves (joint 'slide') but has no mass, nor has any link below it",
                                                       "link 'arm' moves (joint 'elbow') but has no mass, nor has any link below it"]


def test_a_mimic_on_a_urdf_planar_joint_is_refused(tmp_path):
    """A planar joint is three coordinates: it cannot follow one leader (positioned error)."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
                '</inertial>')
    text = (f'<robot name="pm">\n<link name="base">{inertial}</link>\n<link name="a">{inertial}</link>\n'
            f'<link name="b">{inertial}</link>\n'
            '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/></joint>\n'
            '<joint name="p" type="planar"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
            '<mimic joint="j1"/></joint>\n</robot>\n')
    path = tmp_path / "pm.urdf"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"{path}:6:85: joint 'p': <mimic> on a planar joint is not supported (only "
                                     "revolute, continuous and prismatic joints follow a leader)")
    assert not (tmp_path / "out").exists()
