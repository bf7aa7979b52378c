"""What the tests of a joint type run on random trees (``test_helical``, ``test_universal``,
``test_planar_joint``): the generated module against Pinocchio on a tree mixing the type with
spherical joints (fixed base) or below a floating base, and ``check`` on a vector-space tree,
every row passing (the sheet path's symbolic quantities and Pinocchio's)."""

from __future__ import annotations

from pathlib import Path

import yaml
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from test_free_flyer import _compare, _module
from test_spherical import _compare_more, _pinocchio

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
