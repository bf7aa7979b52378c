"""Every target offers every function of the NumPy module's API, or the table of what is not
built (its registry entry's ``not_built``, gathered in ``render/offered.py``'s NOT_BUILT) lists
it with a one-line reason; the table in
``docs/reference/numpy.md`` is the one the code gives (read from what each target generates)."""

from __future__ import annotations

from functools import cache

import pytest

import dynderive
from dynderive.render.offered import NOT_BUILT, TARGETS, gaps, markdown_table, offered
from dynderive.render.targets import by_name

from conftest import ROOT, derivation_of

#: A planar robot, one with drives (maximal_friction_forces), a closed loop, a 3-D robot with
#: frames, and a floating base: the robots of the documented table, in its order.
SAMPLES = ("rp_arm", "cart_pole_damped", "four_bar", "spatial_four_bar", "elbow_arm", "tests/floating_elbow.urdf")
DOCS = ROOT / "docs" / "reference" / "numpy.md"
BEGIN, END = "<!-- offered: begin -->\n", "<!-- offered: end -->\n"


@cache
def _derivation(robot: str):
    if "/" in robot:
        return dynderive.derive(dynderive.load_robot(ROOT / robot))
    return derivation_of(robot)


@pytest.mark.parametrize("robot", SAMPLES)
@pytest.mark.parametrize("target", TARGETS)
def test_every_target_offers_the_api_or_says_why_not(robot, target):
    derivation = _derivation(robot)
    missing = gaps(derivation, target)
    assert target != "numpy" or derivation.robot.floating or not missing
    unlisted = sorted(f for f, reason in missing.items() if reason is None)
    assert not unlisted, f"{target} lacks {unlisted} for {robot}: build them or list them in NOT_BUILT"
    have = offered(derivation, target)
    assert "mass_matrix" in have and "forward_dynamics" in have   # the reading of the target's code works


def test_not_built_lists_nothing_that_is_built():
    """A function a target's entry lists that the target does offer, for a robot the row
    concerns, is stale (the reference's rows, which every target inherits, excepted: MATLAB
    builds generalized_forces for a floating base, which the NumPy module does not)."""
    for robot in SAMPLES:
        derivation = _derivation(robot)
        floating, frames = bool(derivation.robot.floating), bool(derivation.robot.frames)
        for target in TARGETS:
            listed = {f for row in by_name(target).not_built if row.concerns(floating, frames) for f in row.functions}
            stale = sorted(listed & offered(derivation, target))
            assert not stale, (robot, target, stale)


def test_reasons_are_one_line():
    assert {target for target, _ in NOT_BUILT} <= set(TARGETS)
    for _, row in NOT_BUILT:
        assert row.functions and row.kind in ("vector_space", "quaternions", "quaternion_loops", "frameless", "any")
        assert "\n" not in row.reason and len(row.reason) < 120 and "issue" not in row.reason.lower(), row.reason


def test_the_documented_table_is_the_codes():
    text = DOCS.read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1
    documented = text.split(BEGIN)[1].split(END)[0]
    expected = markdown_table([_derivation(r) for r in SAMPLES])
    assert documented == expected, f"docs/reference/numpy.md's table is out of date; it should read:\n{expected}"
