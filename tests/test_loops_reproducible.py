"""The numbers a closed-loop derivation writes (the default assembly, in the generated module,
the sheet and the JSON) have the same bytes whatever the float solver's last digits: those
depend on the NumPy/SciPy build (issue 26: a fresh install wrote 0.234988638101119 where the
committed module had 0.2349886380976749). Here the float solver is disturbed on purpose (its
solutions moved by 1e-9 along every coordinate, its tolerance loosened) and the outputs must not
change by a byte."""

from __future__ import annotations

import numpy as np
import pytest

import dynderive
from dynderive.mechanics import loops

LOOP_ROBOTS = ["four_bar", "slider_crank", "spatial_four_bar", "bennett"]


def _assembled(robot: str) -> list[float]:
    return dynderive.derive(dynderive.load_robot(robot)).loop_model.assembled


@pytest.mark.parametrize("robot", LOOP_ROBOTS)
def test_default_assembly_does_not_depend_on_the_float_solver(robot, monkeypatch):
    reference = _assembled(robot)
    found = loops.assemblies
    rng = np.random.default_rng(7)

    def disturbed(numeric, robot_):
        return [q + rng.uniform(-1e-9, 1e-9, len(q)) for q in found(numeric, robot_)]

    monkeypatch.setattr(loops, "assemblies", disturbed)
    monkeypatch.setattr(loops, "ASSEMBLY_TOLERANCE", 1e-8)
    again = _assembled(robot)
    assert [x.hex() for x in again] == [x.hex() for x in reference]
    # and it is on the constraints to the last bit a double can hold
    derivation = dynderive.derive(dynderive.load_robot(robot))
    residual = loops._Numeric(derivation["a_g"], derivation["A_g"], derivation.symbols,
                              derivation.symbols.defaults(derivation.robot)).residual(np.array(reference))
    assert np.max(np.abs(residual)) < 1e-14


def test_generated_module_and_json_bytes_do_not_depend_on_the_float_solver(monkeypatch):
    robot = dynderive.load_robot("four_bar")
    first = dynderive.derive(robot)
    code, json = dynderive.render_code(first), dynderive.render_json(first)
    found = loops.assemblies
    monkeypatch.setattr(loops, "assemblies", lambda numeric, robot_: [q * (1 + 3e-10) for q in found(numeric, robot_)])
    second = dynderive.derive(dynderive.load_robot("four_bar"))
    assert dynderive.render_code(second) == code
    assert dynderive.render_json(second) == json
    assert "ASSEMBLED_CONFIGURATION = (" in code
