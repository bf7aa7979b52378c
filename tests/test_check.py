"""`dynderive check`: every bundled robot passes; a wrong constraint override fails."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

from conftest import ROBOTS

runner = CliRunner()
ALL_BUNDLED = sorted(p.stem for p in ROBOTS.iterdir() if p.suffix in {".yaml", ".urdf"})


@pytest.mark.parametrize("robot", ALL_BUNDLED)
def test_every_bundled_robot_passes(robot):
    result = runner.invoke(app, ["check", robot, "--json", "-q"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    statuses = {row["name"]: row["status"] for row in report["checks"]}
    assert report["passed"] and "FAIL" not in statuses.values()
    assert statuses["M positive definite (12 random states)"] == "pass"
    assert statuses["Mdot - 2C skew-symmetric"] == "pass"
    power = [status for name, status in statuses.items() if name.startswith("power balance dE/dt = qd . Y")]
    assert power == ["pass"]   # "- qd . F" with damping or friction
    pinocchio = [status for name, status in statuses.items() if name.startswith("agrees with Pinocchio")]
    assert pinocchio == ["pass"]
    if robot in {"rp_arm", "double_pendulum", "cart_pole"}:
        for name in ("EOM_g1 == EOM_g2", "A_m(h(q)) H(q) == 0", "EOM_g3 == EOM_g1", "H^T M_m H = M_g",
                     "constraint forces consistent", "generated coriolis_matrix == symbolic C_g"):
            assert statuses[name] == "pass", name


def test_wrong_constraint_override_fails_and_says_which(tmp_path):
    path = tmp_path / "wrong.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("- phi2 - phi1", "- phi2 - 2*phi1"))
    result = runner.invoke(app, ["check", str(path), "-q"])
    assert result.exit_code == 1
    failing = [line.split("  ")[0] for line in result.stdout.splitlines() if "  FAIL  " in line]
    assert "a_m(h(q)) == 0" in failing and "A_m(h(q)) H(q) == 0" in failing
    assert "2 failed" in result.stdout
