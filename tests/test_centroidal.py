"""Centre of mass and centroidal momentum (DESIGN.md section 11) in the generated module, against
Pinocchio to 1e-9: ``computeTotalMass``, ``centerOfMass`` (position, velocity, acceleration at
zero qdd), ``jacobianCenterOfMass``, ``ccrba`` (A_G and the composite inertia ``Ig``),
``computeCentroidalMomentum`` and ``computeCentroidalMomentumTimeVariation`` at zero
acceleration; on the Panda (fixed base), legged robots with ``--floating-base`` (solo12, go1,
anymal_c, talos_reduced), random floating trees with spherical joints and full-precision
numbers. A floating base with mimic joints (which Pinocchio's algorithms do not all take) by
properties: the CoM Jacobian and A_G against central differences along ``integrate``, the
biases against the differences of ``J qd`` along the motion. Planar robots have none.
"""

from __future__ import annotations

import numpy as np
import pytest

import dynderive
from dynderive.verify.checks import generated_module

from conftest import derivation_of, floating_module_source, module_of, stable_seed

pin = pytest.importorskip("pinocchio")

from test_free_flyer import _example_robot, free_flyer_model  # noqa: E402
from test_mimic import FLOATING_ARM, _pinocchio_free_flyer  # noqa: E402
from test_spherical import _pinocchio, _tree  # noqa: E402

TOLERANCE = 1e-9


def _close(actual, expected, what: str) -> None:
    scale = max(1.0, float(np.max(np.abs(expected))))
    error = float(np.max(np.abs(np.asarray(actual) - np.asarray(expected))))
    assert error <= TOLERANCE * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


def _agree(module, model, qp, vp, seed: int, states: int = 3) -> None:
    """Every centroidal function of ``module`` against Pinocchio at random states."""
    data = model.createData()
    rng = np.random.default_rng(seed)
    pin.seed(seed)
    nq, nv = model.nq, model.nv
    _close(module.total_mass(), pin.computeTotalMass(model), "total_mass")
    for _ in range(states):
        q_pin = pin.randomConfiguration(model, -np.ones(nq), np.ones(nq))
        v_pin = rng.normal(size=nv)
        q, v = np.empty(nq), np.empty(nv)
        q[qp], v[vp] = q_pin, v_pin
        pin.centerOfMass(model, data, q_pin, v_pin, np.zeros(nv))
        _close(module.center_of_mass(q), data.com[0], "center_of_mass")
        _close(module.center_of_mass_velocity(q, v), data.vcom[0], "center_of_mass_velocity")
        _close(module.center_of_mass_acceleration_bias(q, v), data.acom[0], "center_of_mass_acceleration_bias")
        _close(module.center_of_mass_jacobian(q)[:, vp], pin.jacobianCenterOfMass(model, data, q_pin),
               "center_of_mass_jacobian")
        A = pin.ccrba(model, data, q_pin, v_pin)
        _close(module.centroidal_momentum_matrix(q)[:, vp], A, "centroidal_momentum_matrix")
        _close(module.centroidal_inertia(q), data.Ig.matrix(), "centroidal_inertia")
        pin.computeCentroidalMomentumTimeVariation(model, data, q_pin, v_pin, np.zeros(nv))
        _close(module.centroidal_momentum(q, v), data.hg.vector, "centroidal_momentum")
        _close(module.centroidal_momentum_bias(q, v), data.dhg.vector, "centroidal_momentum_bias")
    # a batch gives each state's values
    Q = np.stack([q, q])
    _close(module.centroidal_momentum_matrix(Q)[1], module.centroidal_momentum_matrix(q), "batch")


def test_panda_fixed_base(tmp_path):
    module = module_of("panda", str(tmp_path))
    model = pin.buildModelFromUrdf(str(derivation_of("panda").robot.source))
    _agree(module, model, np.arange(7), np.arange(7), seed=1)


@pytest.mark.pinocchio
@pytest.mark.parametrize("relative", ["solo_description/robots/solo12.urdf", "go1_description/urdf/go1.urdf",
                                      "anymal_c_simple_description/urdf/anymal.urdf",
                                      "talos_data/robots/talos_reduced.urdf"])
def test_legged_robots_with_a_floating_base(relative, tmp_path):
    path = _example_robot(relative)
    robot = dynderive.load_robot(path, floating_base=True)
    model, qp, vp = free_flyer_model(path, robot)
    module = generated_module(floating_module_source(relative), robot.name)
    _agree(module, model, qp, vp, seed=stable_seed(relative), states=2)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("floating", [True, False])
def test_random_trees_with_spherical_joints(seed, floating, tmp_path):
    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_tree(seed, floating))
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), f"spherical_{seed}_{floating}")
    _agree(module, model, qp, vp, seed=seed)


def test_mimic_joints_by_differences_along_integrate(tmp_path):
    """The floating arm with mimic joints: J_G v and A_G v are the rates of the CoM and of
    A_G's momentum along ``integrate``; Jdot v and Adot v the rates of J v and A v at fixed v;
    the total mass is Pinocchio's."""
    path = tmp_path / "mimic_arm.urdf"
    path.write_text(FLOATING_ARM)
    robot = dynderive.load_robot(path, floating_base=True)
    module = generated_module(dynderive.render_code(dynderive.derive(robot)), "centroidal_mimic")
    model, qp, _ = _pinocchio_free_flyer(path, robot)
    _close(module.total_mass(), pin.computeTotalMass(model), "total_mass")
    rng = np.random.default_rng(5)
    pin.seed(5)
    step = 1e-6
    for _ in range(3):
        q = np.empty(model.nq)
        q[qp] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v = rng.normal(size=module.NV)
        ahead, behind = module.integrate(q, v, step), module.integrate(q, v, -step)
        rate = (module.center_of_mass(ahead) - module.center_of_mass(behind)) / (2 * step)
        np.testing.assert_allclose(module.center_of_mass_jacobian(q) @ v, rate, atol=1e-8)
        np.testing.assert_allclose(module.center_of_mass_velocity(q, v), rate, atol=1e-8)
        for matrix, bias in ((module.center_of_mass_jacobian, module.center_of_mass_acceleration_bias),
                             (module.centroidal_momentum_matrix, module.centroidal_momentum_bias)):
            rate = (matrix(ahead) @ v - matrix(behind) @ v) / (2 * step)
            np.testing.assert_allclose(bias(q, v), rate, atol=1e-7 * max(1.0, np.max(np.abs(rate))))
        # linear momentum is the mass times the CoM velocity; I_G of the composite is symmetric
        np.testing.assert_allclose(module.centroidal_momentum(q, v)[:3],
                                   module.total_mass() * module.center_of_mass_velocity(q, v), atol=1e-12)
        inertia = module.centroidal_inertia(q)
        np.testing.assert_allclose(inertia, inertia.T, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(inertia) > 0)


def test_planar_robots_have_none(tmp_path):
    module = module_of("rp_arm", str(tmp_path))
    assert not hasattr(module, "center_of_mass") and not hasattr(module, "centroidal_momentum_matrix")
