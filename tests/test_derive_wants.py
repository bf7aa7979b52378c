"""``derive(robot, wants)`` derives what the requested outputs read before any renderer runs:
rendering a sheet or a code target afterwards runs no stage of the derivation and builds no
program (its progress, errors and time are ``derive``'s), for every robot class: small and
large planar robots, planar and 3-D loops, a 3-D arm, spherical and floating joints."""

from __future__ import annotations

import random

import pytest

import dynderive
from dynderive.commands.solve import output_wants
from dynderive.render.sheets.html import render_html
from dynderive.render.sheets.json import render_json
from dynderive.render.sheets.latex import render_latex
from dynderive.render.targets import TARGETS

FLOATING = """
name: hopper
planar: false
parameters: {m: 2.1234567890123, l: 0.4123456789012, g: 9.81}
gravity: [0, 0, -g]
links:
  - {name: base, mass: m, com: [0.0123456789, -0.0234567891, 0.1234567891],
     inertia: [0.0212345678, 0.0223456789, 0.0112345678, 0.0012345678, -0.0002345678, 0.0003456789]}
  - {name: arm, mass: m, com: [0.2123456789, 0.0134567891, -0.0145678912],
     inertia: [0.0112345678, 0.0312345678, 0.0323456789, 0.0001234567, 0.0002345678, -0.0003456789]}
joints:
  - {name: root, type: JOINT, parent: world, child: base, effort: tau1}
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, l]},
     axis: [0.1234567891, 0.9712345678, 0.2012345678], effort: tau2}
frames:
  - {name: tip, link: arm, origin: {xyz: [0.4123456789, 0.0123456789, -0.0212345678]}}
"""


def _robot(key, tmp_path):
    if key in ("floating", "spherical"):
        path = tmp_path / f"{key}.yaml"
        path.write_text(FLOATING.replace("JOINT", key))
        return dynderive.load_robot(path)
    if key == "planar_large":
        from random_robots import random_planar_tree

        path = tmp_path / "tree.yaml"
        path.write_text(random_planar_tree(random.Random(5), 5).yaml_text)
        return dynderive.load_robot(path)
    return dynderive.load_robot(key)


def _state(derivation):
    """What the derivation holds: its stages still to run, its built members, whether the
    checks ran."""
    return list(derivation._stages.pending), set(vars(derivation)), derivation._checks is None


OUTPUTS = ["latex", "html", "json", *(target.kind for target in TARGETS if target.kind != "c_extension")]
ROBOTS = ["rp_arm", "cart_pole", "four_bar", "slider_crank", "planar_large", "elbow_arm", "spatial_four_bar", "bennett", "ur5",
          "floating", "spherical"]


@pytest.mark.parametrize("key", ROBOTS)
def test_rendering_derives_nothing_after_derive(key, tmp_path):
    robot = _robot(key, tmp_path)
    for output in OUTPUTS:
        try:
            derivation = dynderive.derive(robot, wants=output_wants([output]))
        except dynderive.InputError:   # a target that refuses the class (its own tests)
            continue
        before = _state(derivation)
        if output == "latex":
            render_latex(derivation)
        elif output == "html":
            render_html(derivation)
        elif output == "json":
            render_json(derivation)
        else:
            try:
                next(t for t in TARGETS if t.kind == output).files(derivation, None, {}, tests=True)
            except dynderive.InputError:   # a target that refuses the class (its own tests)
                continue
        after = _state(derivation)
        assert after[0] == before[0], (output, [stage.run.__name__ for stage in before[0] if stage not in after[0]])
        assert after[1] == before[1], (output, sorted(after[1] - before[1]))
        assert after[2] == before[2], (output, "the checks ran while rendering")


def test_derive_without_wants_derives_on_first_use_and_refuses_unknown_wants():
    robot = dynderive.load_robot("rp_arm")
    derivation = dynderive.derive(robot)
    assert derivation._stages.pending and "programs" not in vars(derivation)
    _ = derivation.programs
    assert "programs" in vars(derivation)
    with pytest.raises(ValueError, match="unknown wants"):
        dynderive.derive(robot, wants=["pdf"])
