"""Contacts on robots with closed loops (DESIGN.md section 13: loops and contacts are one kind of
constraint on the one tree): ``constrained_forward_dynamics`` and ``impulse_dynamics`` hold the
loops and the contacts together.

The reference is MuJoCo's, built from its own data: a point contact is a ``connect`` equality
between the frame's body and the world at the frame's origin, a surface contact three such
connects at non-collinear points of the body (a weld in the hard limit); the constrained
accelerations are MuJoCo's hard limit of all its connects (``verify/mujoco_hard_limit``), and the
velocities after an impact the ones closest to those before in MuJoCo's ``M`` on the rows of
``efc_J``. Both at states on the loops, with efforts applied.
"""

from __future__ import annotations

import importlib.util
import os
import re
import tempfile
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app

mujoco = pytest.importorskip("mujoco")

from dynderive.verify.motions import loop_drift  # noqa: E402
from dynderive.verify.mujoco_checks import _loop_states, _unmodelled_drives_off, from_ours, to_ours  # noqa: E402
from dynderive.verify.mujoco_hard_limit import equality_rows, full_mass_matrix, hard_limit  # noqa: E402

FIXTURES = Path(__file__).parent / "mjcf"
runner = CliRunner()

#: A point on body e of the fixtures (the far end of the second arm), and a frame on the torso.
TOE = '<site name="toe" pos="0.0312345678901234 -0.0415432109876543 0.0211234567890123"/>\n            '
SOLE = '<site name="sole" pos="0.0213456789012345 -0.0112345678901234 -0.0817654321098765"/>\n      '


def _floating_loop() -> str:
    text = (FIXTURES / "floating_loop.xml").read_text()
    text = text.replace('<joint name="je"', TOE + '<joint name="je"')
    return text.replace('<freejoint name="base"/>', '<freejoint name="base"/>\n      ' + SOLE.rstrip() + "\n     ")


def _fixed_loop() -> str:
    """loop.xml (five hinges, three loop rows) with two more hinges, so that a point contact
    leaves motion: seven coordinates, no quaternion (the loops' rank known symbolically)."""
    text = (FIXTURES / "loop.xml").read_text()
    text = text.replace('<joint name="je"', TOE.replace("            ", "          ") + '<joint name="je"')
    text = text.replace('<joint name="jc" type="hinge"', '<joint name="jc2" type="hinge" axis="0.2 -0.7 0.6855654600401044"/>\n'
                        '      <joint name="jc" type="hinge"')
    return text.replace('<joint name="ja" type="hinge"', '<joint name="ja2" type="hinge" axis="0.6123724356957945 0.6123724356957945 0.5"/>\n'
                        '      <joint name="ja" type="hinge"')


def _written(folder: Path, text: str, option: str, pattern: str):
    """The module ``solve ROBOT <option>`` writes for the MJCF ``text`` (the file matching
    ``pattern``), imported, and the robot file's path."""
    path = folder / "robot.xml"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path), option, "--out", str(folder / "out")])
    assert result.exit_code == 0, result.output
    module_path = next((folder / "out").glob(pattern))
    spec = importlib.util.spec_from_file_location(module_path.stem, module_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, path


@cache
def _solved(text: str):
    """(the NumPy module, its effort columns) of an MJCF text, derived once per process."""
    module, path = _written(Path(tempfile.mkdtemp(prefix="contacts_on_loops_")), text, "--code", "*_dynamics.py")
    return module, list(dynderive.load_robot(path).effort_columns())


def _with_connects(text: str, connects: list[tuple[str, np.ndarray]]):
    """MuJoCo's model of ``text`` with a connect between each (body, point in its frame) and the
    world, the equalities' rows alone (contacts, limits, friction loss, actuation off)."""
    lines = "".join(f'    <connect body1="{body}" body2="world" anchor="{" ".join(repr(float(v)) for v in point)}"/>\n'
                    for body, point in connects)
    model = mujoco.MjModel.from_xml_string(text.replace("</equality>", lines + "  </equality>"))
    off = mujoco.mjtDisableBit
    model.opt.disableflags |= int(off.mjDSBL_CONTACT) | int(off.mjDSBL_LIMIT) | int(off.mjDSBL_FRICTIONLOSS)
    model.opt.disableflags |= int(off.mjDSBL_ACTUATION)
    model.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_DENSE)
    _unmodelled_drives_off(model)
    return model


def _site(model, name: str) -> tuple[str, np.ndarray, np.ndarray]:
    """(its body's name, its position and rotation in the body's frame)."""
    site = model.site(name)
    quaternion, rotation = site.quat, np.zeros(9)
    mujoco.mju_quat2Mat(rotation, quaternion)
    return model.body(int(site.bodyid[0])).name, site.pos.copy(), rotation.reshape(3, 3)


def _states(module, model, count: int, seed: int):
    draw, rng, states = _loop_states(module, {}), np.random.default_rng(seed), []
    while len(states) < count:
        state = draw(model, rng)
        if state is not None:
            states.append((*state, rng.uniform(-1.0, 1.0, len(module.EFFORTS))))
    return states


def _mujoco_qacc(model, qpos, qvel, columns, u):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    data.qfrc_applied[columns] = u
    mujoco.mj_forward(model, data)
    return hard_limit(model, data, *equality_rows(model, data)), data


CASES = {
    "floating base, point": (_floating_loop, ["toe"]),
    "floating base, surface": (_floating_loop, [("sole", "surface")]),
    "floating base, point and surface": (_floating_loop, ["toe", ("sole", "surface")]),
    "fixed base, point": (_fixed_loop, ["toe"]),
}


def _at_rest(module, q, qd, contacts):
    """``qd`` with the surfaces held at rest and the loops closed (its part in the null space of
    their rows): a body at rest holds its three points as the surface holds its twist; a point
    contact may move (its drift is compared too)."""
    rows = [module.loop_jacobian(q)] + [module.frame_jacobian(q, c[0]) for c in contacts if isinstance(c, tuple)]
    _, sigma, vt = np.linalg.svd(np.vstack(rows))
    null = vt[int(np.sum(sigma > 1e-9 * sigma[0])):]
    return null.T @ (null @ qd)


def _connects(model, contacts) -> list[tuple[str, np.ndarray]]:
    """MuJoCo's connects for ``contacts``: the point's origin, or three points of the surface."""
    connects = []
    for contact in contacts:
        name, kind = contact if isinstance(contact, tuple) else (contact, "point")
        body, position, rotation = _site(model, name)
        offsets = [np.zeros(3)] if kind == "point" else [np.zeros(3), 0.1 * rotation[:, 0], 0.1 * rotation[:, 1]]
        connects += [(body, position + offset) for offset in offsets]
    return connects


@pytest.mark.parametrize("case", CASES)
def test_constrained_and_impulse_dynamics_equal_mujocos_hard_limit(case):
    """qdd with the loops and the contacts held equals MuJoCo's constrained accelerations in the
    hard limit (its connect loop and the contacts as connects to the world), and qd_plus of an
    impact (restitution 0.3) the velocities closest to qd_minus in M on MuJoCo's rows, at 3
    states on the loops; the contact rows hold and the loops stay closed."""
    made, contacts = CASES[case]
    text = made()
    module, columns = _solved(text)
    plain = mujoco.MjModel.from_xml_string(text)
    model = _with_connects(text, _connects(plain, contacts))
    for qpos, qvel, u in _states(module, plain, 3, seed=7):
        q, qd, _, _ = to_ours(plain, qpos, qvel)
        qpos, qvel = from_ours(plain, q, _at_rest(module, q, qd, contacts))
        q, qd, T, W = to_ours(plain, qpos, qvel)
        qacc, data = _mujoco_qacc(model, qpos, qvel, columns, u)
        qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts=contacts)
        ours = np.linalg.solve(T, qdd - W)
        assert np.max(np.abs(ours - qacc)) <= 1e-9 * max(np.max(np.abs(qacc)), 1.0), case
        rows = sum(3 if isinstance(c, str) else 6 for c in contacts)
        assert forces.shape == (rows,)
        A = module.loop_jacobian(q)
        assert np.max(np.abs(A @ qdd + loop_drift(module, q, qd, {}))) < 1e-9
        # the impact: qd_plus = argmin |x - qd_minus|_M on MuJoCo's rows, the loops' target 0
        J = np.asarray(data.efc_J[:data.nefc * model.nv]).reshape(data.nefc, model.nv)
        loop_rows = J.shape[0] - 3 * len(_connects(plain, contacts))
        target = np.concatenate([np.zeros(loop_rows), -0.3 * (J[loop_rows:] @ qvel)])
        M = full_mass_matrix(model, data)
        L = np.linalg.cholesky(M)
        JL = np.linalg.solve(L, J.T).T
        expected = qvel + np.linalg.solve(L.T, np.linalg.lstsq(JL, target - J @ qvel, rcond=1e-9)[0])
        qd_plus, impulses = module.impulse_dynamics(q, qd, contacts=contacts, restitution=0.3)
        assert impulses.shape == (rows,)
        assert np.max(np.abs(from_ours(plain, q, qd_plus)[1] - expected)) <= 1e-9 * max(np.max(np.abs(qvel)), 1.0)


def test_no_contact_held_is_forward_dynamics_with_the_loops_closed():
    """contacts=() on a loop robot: forward_dynamics (with the loops' Baumgarte gains) and no
    force; an impact with no contact leaves velocities the loops allow as they are."""
    text = _floating_loop()
    module, _ = _solved(text)
    plain = mujoco.MjModel.from_xml_string(text)
    for qpos, qvel, u in _states(module, plain, 2, seed=3):
        q, qd, _, _ = to_ours(plain, qpos, qvel)
        qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts=(), alpha=2.0, beta=3.0)
        assert forces.shape == (0,)
        np.testing.assert_allclose(qdd, module.forward_dynamics(q, qd, u, alpha=2.0, beta=3.0), rtol=0, atol=1e-12)
        qd_plus, impulses = module.impulse_dynamics(q, qd, contacts=())
        assert impulses.shape == (0,)
        np.testing.assert_allclose(qd_plus, qd, rtol=0, atol=1e-12)


def test_contacts_on_loops_broadcast_over_a_batch():
    """A batch of states and one state give the same numbers."""
    text = _floating_loop()
    module, _ = _solved(text)
    plain = mujoco.MjModel.from_xml_string(text)
    states = [to_ours(plain, qpos, qvel)[:2] + (u,) for qpos, qvel, u in _states(module, plain, 3, seed=5)]
    q, qd, u = (np.stack(parts) for parts in zip(*states))
    qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts=["toe", ("sole", "surface")])
    assert qdd.shape == (3, module.NV) and forces.shape == (3, 9)
    for i, (qi, qdi, ui) in enumerate(states):
        one = module.constrained_forward_dynamics(qi, qdi, ui, contacts=["toe", ("sole", "surface")])
        np.testing.assert_allclose(qdd[i], one[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(forces[i], one[1], rtol=0, atol=1e-12)


def test_matlab_holds_contacts_on_loops_as_the_numpy_module(tmp_path):
    """The MATLAB/Octave package's constrained_forward_dynamics and impulse_dynamics on the
    floating loop (a point and a surface contact, none, the loops' gains p.alpha and p.beta, a
    restitution) equal the NumPy module's to 1e-12 relative, warning-free."""
    from test_matlab_numeric import OCTAVE, _Calls, _octave, _vector, _write

    if OCTAVE is None:
        pytest.skip("GNU Octave is not installed")
    text = _floating_loop()
    module, _ = _solved(text)
    folder = Path(tempfile.mkdtemp(prefix="contacts_on_loops_matlab_"))
    (folder / "robot.xml").write_text(text)
    derivation = dynderive.derive(dynderive.load_robot(folder / "robot.xml"))
    name = derivation.robot.name
    _write(derivation, tmp_path)
    plain = mujoco.MjModel.from_xml_string(text)
    calls = _Calls(name, tolerance=1e-12)
    calls.lines.append(f"p = {name}.parameters(); p.alpha = 1.5; p.beta = 2.5;")
    for index, (qpos, qvel, u) in enumerate(_states(module, plain, 2, seed=11)):
        q, qd, _, _ = to_ours(plain, qpos, qvel)
        calls.lines.append(f"q = {_vector(q)}; qd = {_vector(qd)}; u = {_vector(u)};")
        gains = {"alpha": 1.5, "beta": 2.5}
        calls.add(f"s{index}_both", "constrained_forward_dynamics(q, qd, u, struct('frame', {'toe', 'sole'}, "
                  "'kind', {'point', 'surface'}), [], [], p)",
                  module.constrained_forward_dynamics(q, qd, u, ["toe", ("sole", "surface")], **gains), outputs=2)
        calls.add(f"s{index}_kd", "constrained_forward_dynamics(q, qd, u, {'toe'}, [0 3], {}, p)",
                  module.constrained_forward_dynamics(q, qd, u, ["toe"], (0.0, 3.0), **gains), outputs=2)
        calls.add(f"s{index}_none", "constrained_forward_dynamics(q, qd, u, {}, [], [], p)",
                  module.constrained_forward_dynamics(q, qd, u, (), **gains), outputs=2)
        calls.add(f"s{index}_bounce", "impulse_dynamics(q, qd, {'toe'}, 0.5)",
                  module.impulse_dynamics(q, qd, ["toe"], 0.5), outputs=2)
    output = _octave(tmp_path, "\n".join(calls.lines) + "\n", warnings=False)
    calls.check(output)


def _simulated(tmp_path: Path, text: str, *options: str) -> tuple[str, np.ndarray]:
    """``simulate``'s summary line and its CSV rows (time, then q, then qd)."""
    path, csv = tmp_path / "robot.xml", tmp_path / "run.csv"
    path.write_text(text)
    result = runner.invoke(app, ["simulate", str(path), "--duration", "0.4", "--frames", "9", "--quiet",
                                 "--csv", str(csv), *options])
    assert result.exit_code == 0, result.output
    line = next(line for line in result.output.splitlines() if line.startswith("simulated "))
    return line, np.loadtxt(csv, delimiter=",", skiprows=1)


def _summary_number(line: str, what: str) -> float:
    return float(re.search(rf"{what} ([-+0-9.e]+)", line).group(1))


@pytest.mark.parametrize("contacts", [[], ["--contacts", "toe"], ["--contacts", "toe,sole:surface"]],
                         ids=["no contact", "point", "point and surface"])
def test_simulate_closes_the_loops_of_a_floating_base_and_holds_its_contacts(tmp_path, contacts):
    """``simulate`` on the floating loop (no damping or spring, so energy is conserved): every
    frame on the loops (constraint drift), the contacts where they start (contact drift), energy
    kept; the CSV's configurations close the loops and hold the toe."""
    text = _floating_loop().replace('damping="0.05"', "").replace('stiffness="0.4" springref="0.1"', "")
    line, rows = _simulated(tmp_path, text, *contacts)
    module, _ = _solved(_floating_loop())
    assert "floating_loop (floating base, on the manifold)" in line
    assert _summary_number(line, "largest relative energy change") < 1e-5
    assert _summary_number(line, "largest constraint drift") < 1e-8
    q = rows[:, 1:1 + module.NQ]
    assert np.max(np.abs(module.loop_constraints(q))) < 1e-8
    if contacts:
        assert "holding toe (point)" in line and _summary_number(line, r"largest contact drift") < 1e-8
        toe = module.frame_transform(q, "toe")[:, :3, 3]
        assert np.max(np.abs(toe - toe[0])) < 1e-8
    else:
        assert np.ptp(q[:, 2]) > 1e-2   # the torso falls


def test_simulate_holds_a_contact_on_a_fixed_base_loop(tmp_path):
    """The fixed-base loop (hinges only, the loops' rank known) holding its toe."""
    module, _ = _solved(_fixed_loop())
    start = ",".join(repr(float(v)) for v in module.ASSEMBLED_CONFIGURATION)   # MuJoCo's qpos0, on the loops
    line, rows = _simulated(tmp_path, _fixed_loop(), "--contacts", "toe", "--effort", "tau_ja=0.3*sin(5*t)",
                            "--q0", start)
    q = rows[:, 1:1 + len(module.COORDINATES)]
    toe = module.frame_transform(q, "toe")[:, :3, 3]
    assert np.max(np.abs(toe - toe[0])) < 1e-6 and _summary_number(line, "largest constraint drift") < 1e-8
    assert np.ptp(q[:, 0]) > 1e-4   # the mechanism moves


def test_casadi_holds_contacts_on_a_fixed_base_loop_as_the_numpy_module(tmp_path):
    """The CasADi module's Functions (one per set of contacts, the loops' gains alpha and beta as
    inputs) on the fixed-base loop equal the NumPy module's to 1e-12: a point contact, none, an
    impact with restitution."""
    if not os.environ.get("CI"):   # required in CI (casadi is in the test extra)
        pytest.importorskip("casadi")
    text = _fixed_loop()
    module, _ = _solved(text)
    casadi_module, _ = _written(tmp_path, text, "--casadi", "*_casadi.py")
    plain = mujoco.MjModel.from_xml_string(text)
    p = casadi_module.default_parameters()
    for qpos, qvel, u in _states(module, plain, 2, seed=13):
        q, qd, _, _ = to_ours(plain, qpos, qvel)
        for contacts in (["toe"], []):
            got = casadi_module.constrained_forward_dynamics(contacts)(q=q, qd=qd, u=u, p=p, alpha=1.5, beta=2.0)
            qdd, forces = module.constrained_forward_dynamics(q, qd, u, contacts, alpha=1.5, beta=2.0)
            scale = max(1.0, np.max(np.abs(qdd)))
            assert np.max(np.abs(np.ravel(got["qdd"]) - qdd)) <= 1e-12 * scale
            assert np.ravel(got["forces"]).shape == forces.shape
            assert np.max(np.abs(np.ravel(got["forces"]) - forces), initial=0.0) <= 1e-12 * max(1.0, np.max(np.abs(forces), initial=0.0))
            got = casadi_module.impulse_dynamics(contacts)(q=q, qd_minus=qd, p=p, restitution=0.3)
            qd_plus, impulses = module.impulse_dynamics(q, qd, contacts, 0.3)
            assert np.max(np.abs(np.ravel(got["qd_plus"]) - qd_plus)) <= 1e-12 * max(1.0, np.max(np.abs(qd_plus)))
            assert np.ravel(got["impulses"]).shape == impulses.shape
