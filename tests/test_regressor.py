"""The identification regressor: ``regressor(q, qd, qdd) @ parameter_vector()`` is
``inverse_dynamics``, its columns are Pinocchio's ``computeJointTorqueRegressor`` link by link,
and the base parameters group as worked out by hand.

Robots: random 3-D trees (arbitrary axes and origins, full inertia tensors, a fixed weld under
a moving link, a link welded to the world) and random planar trees, with full-precision
numbers; the bundled RP arm, the damped cart-pole (damping, Coulomb friction, armature), the
mass-spring-damper (springs) and the UR5.

``dynderive identify`` of a floating-base robot: the base parameters' count equals the rank of
Pinocchio's stacked joint-torque regressor.
"""

from __future__ import annotations

import json
import keyword
import random
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app
from dynderive.verify.identification import base_parameters, random_states

from conftest import random_tree_derivation, text_derivation
from random_robots3d import random_spatial_tree

#: (seed, moving joints) of random 3-D trees: (1, 3) welds a link under a moving one,
#: (7, 2) welds the first link to the world.
SPATIAL = [(0, 3), (1, 3), (7, 2)]
#: random planar trees; (1, 3) has a fixed weld
PLANAR = [(1, 3), (2, 3)]
BUNDLED = ["rp_arm", "cart_pole_damped", "mass_spring_damper", "ur5"]


@pytest.fixture(scope="module")
def robot(tmp_path_factory, generated):
    """``robot(kind, key)`` -> (derivation, generated module)."""
    directory = str(tmp_path_factory.mktemp("regressor"))

    def get(kind, key):
        if kind == "spatial":
            tree = random_spatial_tree(random.Random(key[0]), key[1])
            return text_derivation(f"regressor_tree3d_{key[0]}_{key[1]}", tree.yaml_text, directory)
        if kind == "planar":
            return random_tree_derivation(*key, directory)
        from conftest import derivation_of
        return derivation_of(key), generated(key)

    return get


CASES = ([("spatial", k) for k in SPATIAL] + [("planar", k) for k in PLANAR] + [("bundled", k) for k in BUNDLED])
IDS = [f"{kind}-{key}" for kind, key in CASES]


def _states(module, count=20, seed=3):
    return random_states(len(module.COORDINATES), count, seed)


@pytest.mark.parametrize("kind, key", CASES, ids=IDS)
def test_regressor_times_parameters_is_inverse_dynamics(robot, kind, key):
    derivation, module = robot(kind, key)
    q, qd, qdd = _states(module)
    Y = module.regressor(q, qd, qdd)
    n, size = len(module.COORDINATES), len(module.PARAMETER_VECTOR)
    assert Y.shape == (20, n, size) and module.parameter_vector().shape == (size,)
    pi = module.parameter_vector()
    tau = module.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(Y @ pi, tau, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(tau).max()))
    # one state on floats (math) is the same body
    np.testing.assert_allclose(module.regressor(q[0], qd[0], qdd[0]), Y[0], rtol=1e-13, atol=1e-13)
    # the friction column follows friction_smoothing as friction_forces does
    smooth = module.regressor(q, qd, qdd, friction_smoothing=0.3) @ pi
    np.testing.assert_allclose(smooth, module.inverse_dynamics(q, qd, qdd, friction_smoothing=0.3),
                               rtol=1e-10, atol=1e-10 * max(1.0, np.abs(tau).max()))
    # other parameter values: pi and Y follow them
    if module.PARAMETERS:
        changed = {name: 1.3 * value + 0.1 for name, value in module.PARAMETERS.items()}
        np.testing.assert_allclose(module.regressor(q, qd, qdd, **changed) @ module.parameter_vector(**changed),
                                   module.inverse_dynamics(q, qd, qdd, **changed), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("kind, key", CASES, ids=IDS)
def test_parameter_names(robot, kind, key):
    derivation, module = robot(kind, key)
    names = module.PARAMETER_VECTOR
    assert len(set(names)) == len(names)
    assert all(name.isidentifier() and name.isascii() and not keyword.iskeyword(name) for name in names)
    per_link = ("m", "mcx", "mcy", "Izz") if derivation.robot.planar else (
        "m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
    links = [f"{kind}_{link.name}" for link in derivation.robot.links for kind in per_link]
    assert list(names[:len(links)]) == links
    drives = names[len(links):]
    assert all(name.split("_", 1)[0] in ("damping", "friction", "armature", "stiffness") for name in drives)


def test_drive_columns(robot):
    """The damped cart-pole's drive columns are qd, sign(qd) and qdd of the cart's coordinate
    and qd of the pole's; the mass-spring-damper's springs take q - rest."""
    _, module = robot("bundled", "cart_pole_damped")
    names = list(module.PARAMETER_VECTOR)
    assert names[-4:] == ["damping_x", "friction_x", "armature_x", "damping_theta"]
    q, qd, qdd = np.array([0.3, -0.2]), np.array([-0.7, 0.4]), np.array([1.1, -2.0])
    Y = module.regressor(q, qd, qdd)
    np.testing.assert_array_equal(Y[:, names.index("damping_x")], [qd[0], 0.0])
    np.testing.assert_array_equal(Y[:, names.index("friction_x")], [-1.0, 0.0])
    np.testing.assert_array_equal(Y[:, names.index("armature_x")], [qdd[0], 0.0])
    np.testing.assert_array_equal(Y[:, names.index("damping_theta")], [0.0, qd[1]])
    derivation, module = robot("bundled", "mass_spring_damper")
    names = list(module.PARAMETER_VECTOR)
    springs = [(i, d) for i, d in enumerate(derivation.joint_drives) if d.stiffness != 0]
    assert springs
    for i, drive in springs:
        column = module.regressor(q, qd, qdd)[:, names.index(f"stiffness_{module.COORDINATES[i]}")]
        rest = float(drive.rest.subs({s: module.PARAMETERS[str(s)] for s in drive.rest.free_symbols}))
        expected = np.zeros(2)
        expected[i] = q[i] - rest
        np.testing.assert_allclose(column, expected, rtol=1e-15)


# --- Pinocchio --------------------------------------------------------------------------


def _pinocchio(derivation, module):
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    model, perm = pinocchio_model(derivation.robot, dict(module.PARAMETERS))
    return pin, model, model.createData(), perm


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, key", CASES, ids=IDS)
def test_columns_match_pinocchio(robot, kind, key):
    """Link by link where the frames coincide (a link on a moving joint: Pinocchio's joint
    frame is the link frame); everywhere, ``Y pi`` with Pinocchio's own parameters (welded
    links merged into their joint's inertia) and the column spans."""
    derivation, module = robot(kind, key)
    pin, model, data, perm = _pinocchio(derivation, module)
    robot_ = derivation.robot
    names = list(module.PARAMETER_VECTOR)
    kinds = ("m", "mcx", "mcy", "Izz") if robot_.planar else (
        "m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
    pin_columns = [0, 1, 2, 9] if robot_.planar else list(range(10))
    pi_pin = np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, model.njoints)])
    ours, theirs = [], []
    q, qd, qdd = _states(module, count=8)
    for state in zip(q, qd, qdd):
        Y = module.regressor(*state)[perm]          # rows in Pinocchio's order
        Y_pin = pin.computeJointTorqueRegressor(model, data, *(x[perm] for x in state)).copy()
        for link in robot_.links:
            joint = robot_.parent_joint(link.name)
            if not joint.moves:
                continue
            block = slice(10 * (model.getJointId(joint.name) - 1), 10 * model.getJointId(joint.name))
            mine = Y[:, [names.index(f"{k}_{link.name}") for k in kinds]]
            np.testing.assert_allclose(mine, Y_pin[:, block][:, pin_columns], rtol=1e-9, atol=1e-9)
            if robot_.planar:   # what planar motion leaves out is zero in Pinocchio too
                np.testing.assert_allclose(Y_pin[:, block][:, [3, 4, 5, 6, 7, 8]], 0, atol=1e-9)
        links = len(robot_.links) * len(kinds)
        np.testing.assert_allclose(Y[:, :links] @ module.parameter_vector()[:links], Y_pin @ pi_pin,
                                   rtol=1e-9, atol=1e-9)
        ours.append(Y[:, :links])
        theirs.append(Y_pin)
    A, B = np.concatenate(ours), np.concatenate(theirs)
    rank = np.linalg.matrix_rank
    assert rank(A, tol=1e-9) == rank(B, tol=1e-9) == rank(np.hstack([A, B]), tol=1e-9)


@pytest.mark.pinocchio
@pytest.mark.parametrize("kind, key", [("spatial", (1, 3)), ("planar", (2, 3)), ("bundled", "ur5")],
                         ids=["spatial-1-3", "planar-2-3", "ur5"])
def test_base_parameters(robot, kind, key):
    """As many base parameters as Pinocchio's regressor has rank; Y_base pi_base = tau on fresh
    states; the dependent columns are the base ones times beta."""
    derivation, module = robot(kind, key)
    pin, model, data, perm = _pinocchio(derivation, module)
    result = base_parameters(derivation, module, dict(module.PARAMETERS))
    q, qd, qdd = _states(module, count=60, seed=11)
    stacked = np.concatenate([pin.computeJointTorqueRegressor(model, data, a[perm], b[perm], c[perm]).copy()
                              for a, b, c in zip(q, qd, qdd)])
    drives = len(result.names) - (len(derivation.robot.links) * (4 if derivation.robot.planar else 10))
    assert result.rank == np.linalg.matrix_rank(stacked, tol=1e-9) + drives
    Y = module.regressor(q, qd, qdd)
    tau = module.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(Y[..., result.base] @ result.base_values, tau, rtol=1e-9,
                               atol=1e-9 * np.abs(tau).max())
    np.testing.assert_allclose(Y[..., result.dependent], Y[..., result.base] @ result.beta, atol=1e-8)
    np.testing.assert_allclose(Y[..., result.unidentifiable], 0, atol=1e-12)


def test_rp_arm_base_parameters_by_hand(robot):
    """The RP arm, by hand: link 1 turns about its own origin, so its mass moves nothing
    (``m_link1`` is unidentifiable); link 2 slides along link 1's x axis and turns with it, so
    its inertia about its origin only ever adds to link 1's (both columns are ``[qdd1, 0]``):
    ``Izz_link1 + Izz_link2``. Everything else is independent: ``mcx_link1, mcy_link1`` (gravity
    on joint 1 only), ``m_link2`` (its columns hold ``q2**2 qdd1``), ``mcx_link2`` (``-qd1**2``
    on joint 2), ``mcy_link2`` (``-qdd1`` on joint 2). Six base parameters, and at the defaults
    (m = l = 1) ``Izz_link1 + Izz_link2 = 2 m l**2/3``: M_11 = 2 m l**2/3 + m q2**2 + m l q2."""
    derivation, module = robot("bundled", "rp_arm")
    result = base_parameters(derivation, module, dict(module.PARAMETERS))
    assert result.rank == 6
    assert [g.text for g in result.groupings] == [
        "mcx_link1", "mcy_link1", "Izz_link1 + Izz_link2", "m_link2", "mcx_link2", "mcy_link2"]
    assert [result.names[i] for i in result.unidentifiable] == ["m_link1"]
    np.testing.assert_allclose(result.base_values, [0.5, 0.0, 2 / 3, 1.0, 0.5, 0.0], atol=1e-12)


def test_double_pendulum_grouping_is_symbolic(generated):
    """The textbook grouping of a 2R arm, with the coefficients recognised as the link length:
    link 2's mass moves into link 1's first moment and inertia."""
    from conftest import derivation_of

    result = base_parameters(derivation_of("double_pendulum"), generated("double_pendulum"),
                             dict(generated("double_pendulum").PARAMETERS))
    texts = [g.text for g in result.groupings]
    assert "mcx_upper + l1*m_lower" in texts and "Izz_upper + l1**2*m_lower" in texts
    assert result.rank == 6


def test_identify_command():
    runner = CliRunner()
    result = runner.invoke(app, ["identify", "rp_arm", "-q"])
    assert result.exit_code == 0, result.output
    assert "Base parameters: 6 of 8" in result.output and "Izz_link1 + Izz_link2" in result.output
    assert "Not identifiable (zero columns): m_link1" in result.output
    result = runner.invoke(app, ["identify", "rp_arm", "-q", "--json", "--param", "l=2"])
    assert result.exit_code == 0
    import json

    data = json.loads(result.output)
    assert data["rank"] == 6 and data["parameters"][3] == {"name": "Izz_link1", "value": pytest.approx(4 / 3)}
    result = runner.invoke(app, ["identify", "rp_arm", "--param", "nope=1"])
    assert result.exit_code == 2
    assert "--param:1:1: unknown parameter 'nope'" in result.output


# -- floating base --------------------------------------------------------------------------------
# test_free_flyer skips itself without Pinocchio: imported where its model of the floating
# elbow is needed, so that the rest of this file runs without it.

ELBOW = Path(__file__).parent / "floating_elbow.urdf"


@pytest.mark.pinocchio
def test_identify_counts_the_base_parameters_of_pinocchios_regressor():
    pin = pytest.importorskip("pinocchio")
    from test_free_flyer import urdf_in_pinocchio

    pytest.importorskip("scipy")
    robot, model, qp, vp = urdf_in_pinocchio(ELBOW)   # a revolute shoulder, a free body below it
    result = CliRunner().invoke(app, ["identify", str(ELBOW), "--json", "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    data = model.createData()
    rng = np.random.default_rng(4)
    rows = []
    for _ in range(60):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        rows.append(pin.computeJointTorqueRegressor(model, data, q, rng.normal(size=7), rng.normal(size=7)).copy())
    rank = np.linalg.matrix_rank(np.vstack(rows), tol=1e-9 * np.abs(np.vstack(rows)).max())
    assert document["rank"] == rank == 13   # the shoulder's pendulum: 3; the free body: all 10
    pi = np.concatenate([model.inertias[i].toDynamicParameters() for i in range(1, model.njoints)])
    assert np.max(np.abs(np.array([p["value"] for p in document["parameters"]]) - pi)) <= 1e-12
    text = CliRunner().invoke(app, ["identify", str(ELBOW), "-q"])
    assert text.exit_code == 0 and "regressor Y(q, qd, qdd) of shape (7, 20)" in text.stdout
