"""``dynderive check`` on an MJCF robot compares the generated module with MuJoCo itself
(``verify/mujoco_checks``): it passes on Gymnasium's models and fails on a module that is off."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.verify.checks import generated_module
from dynderive.verify.mujoco_checks import NAME, mujoco_rows, to_ours

mujoco = pytest.importorskip("mujoco")
gymnasium = pytest.importorskip("gymnasium")
ASSETS = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"


def _module(name: str):
    derivation = dynderive.derive(dynderive.load_robot(ASSETS / f"{name}.xml"))
    return derivation, generated_module(dynderive.render_code(derivation), name)


@pytest.mark.parametrize("name", ["hopper", "reacher", "ant"])
def test_the_mujoco_row_passes(name):
    derivation, module = _module(name)
    values = {p.name: p.value for p in derivation.robot.parameters}
    (row,) = mujoco_rows(derivation, module, values, 3, np.random.default_rng(3))
    assert (row.name, row.status) == (NAME, "pass"), row
    assert row.residual < 1e-10


def test_the_mujoco_row_fails_on_a_wrong_module():
    """A mass matrix 1 % too large, or a bias with gravity off, is caught."""
    derivation, module = _module("hopper")
    values = {p.name: p.value for p in derivation.robot.parameters}
    heavy = types.SimpleNamespace(**vars(module))
    heavy.mass_matrix = lambda q, **p: 1.01 * module.mass_matrix(q, **p)
    assert mujoco_rows(derivation, heavy, values, 2, np.random.default_rng(0))[0].status == "FAIL"
    weightless = types.SimpleNamespace(**vars(module))
    weightless.inverse_dynamics = lambda q, qd, qdd, **p: (module.inverse_dynamics(q, qd, qdd, **p)
                                                           - module.gravity_vector(q, **p))
    assert mujoco_rows(derivation, weightless, values, 2, np.random.default_rng(0))[0].status == "FAIL"


def test_other_parameter_values_are_not_compared():
    derivation, module = _module("reacher")
    values = {p.name: p.value * 2 for p in derivation.robot.parameters}
    assert mujoco_rows(derivation, module, values, 1, np.random.default_rng(0))[0].status == "skip"


def test_a_free_joint_maps_to_the_body_frame():
    """``to_ours``: the free joint's world linear velocity becomes R' v; quaternions w last."""
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>")
    angle = 0.7318927345123
    qpos = np.array([0.1, 0.2, 0.3, np.cos(angle / 2), 0, 0, np.sin(angle / 2)])   # about z
    qvel = np.array([1.0, 0, 0, 0, 0, 2.0])
    q, qd, T, W = to_ours(model, qpos, qvel)
    np.testing.assert_allclose(q, [0.1, 0.2, 0.3, 0, 0, np.sin(angle / 2), np.cos(angle / 2)])
    np.testing.assert_allclose(qd[:3], [np.cos(angle), -np.sin(angle), 0], atol=1e-15)
    np.testing.assert_allclose(T @ qvel, qd, atol=1e-15)
    np.testing.assert_allclose(W[:3], -np.cross(qd[3:], qd[:3]), atol=1e-15)
