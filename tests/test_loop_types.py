"""Loop joint types beyond the bundled robots: a planar prismatic loop joint, and a planar
four-bar described in 3-D (a 3-D revolute loop joint whose out-of-plane rows are implied by
the others and dropped with a note). ``dynderive check`` runs every check on assembled states:
constraint residuals, the reduced form against the multiplier form (two routes in the
generated code), the power balance along the manifold, Pinocchio on the open tree."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app

HERE = Path(__file__).resolve().parent / "loops"


@pytest.mark.parametrize("name", ["crank_slider_prismatic", "four_bar_in_3d"])
def test_check_passes_on_the_constraint_manifold(name):
    result = CliRunner().invoke(app, ["check", str(HERE / f"{name}.yaml"), "--json", "-q"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    statuses = {row["name"]: row["status"] for row in report["checks"]}
    assert report["passed"] and "FAIL" not in statuses.values()
    assert any(n.startswith("reduced form") for n in statuses)


def test_prismatic_loop_keeps_the_block_on_the_axis():
    derivation = dynderive.derive(dynderive.load_robot(HERE / "crank_slider_prismatic.yaml"))
    model = derivation.loop_model
    assert [what for _, what in model.rows] == ["offset across the sliding axis", "relative rotation"]
    q1, q2, q3 = model.assembled
    r, l = 0.2, 0.7
    assert r * np.sin(q1) + l * np.sin(q1 + q2) == pytest.approx(0, abs=1e-10)   # the block is on y = 0
    assert q1 + q2 + q3 == pytest.approx(0, abs=1e-10)                             # and does not turn


def test_planar_loop_in_3d_drops_the_implied_rows_with_a_note():
    derivation = dynderive.derive(dynderive.load_robot(HERE / "four_bar_in_3d.yaml"))
    assert derivation["a_g"].shape == (2, 1)
    assert any("identically zero and were dropped" in note and "axis alignment" in note for note in derivation.notes)
    assert derivation.loop_model.rank == 2 and derivation.mobility == 1
