"""What the tests of a joint type run on random trees (``test_helical``, ``test_universal``,
``test_planar_joint``): the generated module against Pinocchio on a tree mixing the type with
spherical joints (fixed base) or below a floating base, and ``check`` on a vector-space tree,
every row passing (the sheet path's symbolic quantities and Pinocchio's)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from test_free_flyer import _compare, _module
from test_spherical import _aba_differences, _compare_more, _coriolis_properties, _pinocchio

#: The rows of ``check`` a vector-space tree must pass (beside every other row).
CHECK_ROWS = ("generated kinetic_energy == symbolic T_g", "generated potential_energy == symbolic V_g",
              "generated gravity_vector == symbolic N_g", "agrees with Pinocchio (crba, rnea, aba)",
              "centroidal agrees with Pinocchio (ccrba, centerOfMass, jacobianCenterOfMass, dhg)")


def tree_equals_pinocchio(data: dict, kind: str, floating: bool, seed: int, tmp_path: Path,
                          pinocchio_derivatives: bool = True) -> tuple[object, object, object]:
    """``data`` (a tree with joints of type ``kind`` and spherical ones) written, loaded and
    compared with its Pinocchio model (``_compare``, ``_compare_more``); returns the robot, its
    module and the model."""
    path = tmp_path / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    robot = dynderive.load_robot(path)
    kinds = [j.type for j in robot.joints]
    assert kind in kinds and "spherical" in kinds and ("floating" in kinds) == floating
    model, qp, vp = _pinocchio(robot)
    module = _module(robot, tmp_path)
    _compare(robot, module, model, qp, vp, seed)
    _compare_more(robot, module, model, qp, vp, seed, pinocchio_derivatives=pinocchio_derivatives)
    return robot, module, model


def check_passes_every_row(text: str, tmp_path: Path, rows: tuple[str, ...] = CHECK_ROWS) -> None:
    """``check`` on the robot file ``text``: exit 0, ``rows`` among the passing ones, none failed."""
    path = tmp_path / "tree.yaml"
    path.write_text(text)
    result = CliRunner().invoke(app, ["check", str(path), "--quiet"])
    assert result.exit_code == 0, result.output
    found = {line.split("  ")[0]: line for line in result.stdout.splitlines()}
    for row in rows:
        assert " pass " in found[row], found[row]
    assert " 0 failed" in result.stdout


def module_equals_pinocchio(text: str, kind: str, tmp_path: Path, seed: int = 7) -> None:
    """The generated module of the vector-space tree ``text`` (with joints of type ``kind``)
    against Pinocchio at random states: the mass matrix (``crba``), inverse dynamics (``rnea``),
    ``linearize`` at u = 0 against central differences of its ``aba`` (Pinocchio 4.1's
    ``computeABADerivatives`` and ``computeCoriolisMatrix`` leave out a universal joint's
    column rates), and C by its properties."""
    import pinocchio as pin

    path = tmp_path / "tree.yaml"
    path.write_text(text)
    robot = dynderive.load_robot(path)
    model, qp, vp = _pinocchio(robot)
    assert [j for j in robot.joints if j.type == kind]
    module = _module(robot, tmp_path)
    data, rng = model.createData(), np.random.default_rng(seed)
    for _ in range(3):
        q, v, a = (rng.uniform(-1, 1, size=model.nv) for _ in range(3))
        M = pin.crba(model, data, q[qp])
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(module.mass_matrix(q)[np.ix_(vp, vp)], M, rtol=0, atol=1e-9 * max(1, abs(M).max()))
        tau = pin.rnea(model, data, q[qp], v[vp], a[vp])
        np.testing.assert_allclose(module.inverse_dynamics(q, v, a)[vp], tau, rtol=0, atol=1e-9 * max(1, abs(tau).max()))
        A, _ = module.linearize(q, v, np.zeros(len(module.EFFORTS)))
        dq, dv = _aba_differences(model, q[qp], v[vp], np.zeros(model.nv))
        n = model.nv
        np.testing.assert_allclose(A[n:, :n][np.ix_(vp, vp)], dq, rtol=0, atol=1e-6 * max(1, abs(dq).max()))
        np.testing.assert_allclose(A[n:, n:][np.ix_(vp, vp)], dv, rtol=0, atol=1e-6 * max(1, abs(dv).max()))
        _coriolis_properties(model, module.coriolis_matrix(q, v)[np.ix_(vp, vp)], q[qp], v[vp])
