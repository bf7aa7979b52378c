"""Every code target that can be loaded into this process (its harness's ``load``,
``verify/backends.py``: the module ``simulate --backend`` runs) gives the NumPy module's numbers.

One test, parametrized over the registry's targets with a loader times the robot classes:
planar (Coulomb friction and drives; random trees with full-precision numbers, small enough
for the explicit M, C, N and large enough for the programs, whose maximal form the Python
targets print), 3-D with generic random inertias, frames and centroidal quantities, a floating
base with quaternions (thrust efforts; damping, friction and frames), spherical joints on a
fixed and a floating base, closed loops (planar, 3-D, with frames and friction,
over-constrained, on a floating base with spherical joints: a target that refuses a class says so at the robot file and is skipped
here, its refusal tested in its own file), contacts (fixed and floating). Each function the target offers (its entry's ``offered``) that the NumPy module has
is compared, but those its entry's ``not_built`` rows list, at random full-precision states
(on the loops, on the quaternions' sphere), for a batch and for one state, with the
parameters at values other than their defaults, the smoothed friction sign, and a wrench at every
frame (``verify/compiled.py``, the harness ``check --backend`` runs): to 1e-12 relative to the
result's largest entry (``assemble``, an iteration, 1e-10). A new target's harness
is compared here with no new test file.
"""

from __future__ import annotations

import functools
import random
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render.api import group
from dynderive.render.offered import not_built, offered
from dynderive.render.targets import REFERENCE, reference
from dynderive.render.targets.target import public
from dynderive.verify.backends import HARNESSES
from dynderive.verify.compiled import compiled_checks

from conftest import ROBOTS, stable_seed

#: The targets' harnesses (a loader each).
LOADED = HARNESSES


def _planar_tree() -> str:
    from random_robots import random_planar_tree

    return random_planar_tree(random.Random(11), 3).yaml_text


def _planar_programs() -> str:
    from random_robots import random_planar_tree

    return random_planar_tree(random.Random(13), 5).yaml_text


def _spatial_tree() -> str:
    from random_robots3d import random_spatial_tree

    return random_spatial_tree(random.Random(21), 4).yaml_text


def _floating_tree() -> str:
    from test_free_flyer import _floating_tree

    return _floating_tree(2)


def _rough_tree() -> str:
    from test_drives import _text

    return _text(2)


def _spherical_fixed() -> str:
    from test_spherical import _tree

    return _tree(7, False)


#: A floating base, a spherical joint (two quaternions: NQ = NV + 2), a revolute joint on a
#: generic axis and a frame, with full-precision numbers (smaller than ``test_spherical``'s trees).
BALL_ARM = """name: ball_arm
planar: false
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: 2.1234567890123456, com: [0.1, 0.02, -0.03], inertia: [0.3, 0.2, 0.25, 0.01, 0.0, 0.02]}
  - {name: arm, mass: 1.3123456789012345, com: [0.2, 0.0, 0.01], inertia: [0.1, 0.12, 0.09, 0.0, 0.01, 0.0]}
  - {name: hand, mass: 0.7123456789012345, com: [0.05, 0.01, 0.0], inertia: [0.02, 0.03, 0.025, 0.0, 0.0, 0.001]}
joints:
  - {name: free, type: floating, parent: world, child: base, origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 0.1]}}
  - {name: ball, type: spherical, parent: base, child: arm, origin: {xyz: [0.2, 0.1, 0.0], rpy: [0.0, 0.4, 0.0]}}
  - {name: wrist, type: revolute, parent: arm, child: hand, origin: {xyz: [0.4, 0.0, 0.0]}, axis: [0, 0.6, 0.8],
     effort: tau}
frames:
  - {name: palm, link: hand, origin: {xyz: [0.1, 0.02, -0.01], rpy: [0.1, 0.2, 0.3]}}
"""


#: A floating base whose arm (a spherical shoulder, a damped elbow on a generic axis) is tied back
#: to the base by a spherical loop joint, and a frame held by a point contact (solved with the
#: loop's rows): full-precision numbers, rows on the twists.
TIED_ARM = """name: tied_arm
planar: false
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: 3.1234567890123456, com: [0.0112345678901234, -0.0123456789012345, 0.0212345678901234], inertia: [0.0312345678901234, 0.0423456789012345, 0.0512345678901234, 0.0012345678901234, -0.0009876543210987, 0.0007654321098765]}
  - {name: upper, mass: 1.2345678901234567, com: [0.1523456789012345, 0.0112345678901234, -0.0087654321098765], inertia: [0.0011234567890123, 0.0081234567890123, 0.0079876543210987, 0.0001234567890123, -0.0002345678901234, 0.0000987654321098]}
  - {name: lower, mass: 0.6543210987654321, com: [0.1412345678901234, -0.0098765432109876, 0.0123456789012345], inertia: [0.0010987654321098, 0.0041234567890123, 0.0039876543210987, -0.0000876543210987, 0.0001234567890123, 0.0000543210987654]}
joints:
  - {name: root, type: floating, parent: world, child: base, origin: {xyz: [0.0123456789012345, -0.0234567890123456, 0.4123456789012345], rpy: [0.1234567890123456, -0.0987654321098765, 0.3123456789012345]}}
  - {name: shoulder, type: spherical, parent: base, child: upper, origin: {xyz: [0.1123456789012345, 0.0212345678901234, -0.0131234567890123], rpy: [0.0512345678901234, -0.1123456789012345, 0.0712345678901234]}}
  - {name: elbow, type: revolute, parent: upper, child: lower, origin: {xyz: [0.3123456789012345, 0.0123456789012345, -0.0098765432109876], rpy: [0.0312345678901234, 0.0212345678901234, -0.0412345678901234]},
     axis: [0.1234567890123456, 0.5432109876543210, 0.8312345678901234], effort: tau_elbow, damping: 0.0312345678901234}
loops:
  - {name: tie, type: spherical, parent: lower, child: base, origin: {xyz: [0.2871234567890123, 0.0112345678901234, 0.0098765432109876], rpy: [0, 0, 0]},
     child_origin: {xyz: [0.1312345678901234, 0.3412345678901234, 0.0212345678901234], rpy: [0, 0, 0]}}
frames:
  - {name: wrist, link: lower, origin: {xyz: [0.2712345678901234, -0.0212345678901234, 0.0112345678901234], rpy: [0.2123456789012345, -0.1312345678901234, 0.4123456789012345]}}
contacts:
  - {frame: wrist}
"""


def _framed_loop() -> str:
    """The four-bar with damping, friction and a frame at the coupler's far end."""
    text = (ROBOTS / "four_bar.yaml").read_text()
    text = text.replace("    effort: tau1\n", "    effort: tau1\n    damping: 0.3\n    friction: 0.2\n")
    return text.rstrip("\n") + "\nframes:\n  - {name: tip, link: coupler, origin: [b/2, 0.1]}\n"


def _contacts(seed: int, floating: bool):
    def text() -> str:
        import yaml

        from test_contacts import _tree

        data = yaml.safe_load(_tree(seed, floating))
        if not floating:   # a fixed tree holds its point contact only (a surface one too is redundant)
            data["contacts"] = [{"frame": "toe"}]
        return yaml.safe_dump(data, sort_keys=False)
    return text


#: Robot classes: a bundled robot's name, or a function returning a robot file's text.
CLASSES = {
    "planar_friction": "cart_pole_damped",
    "planar_random_tree": _planar_tree,
    "planar_random_tree_programs": _planar_programs,
    "spatial_random_tree": _spatial_tree,
    "frames_centroidal": "elbow_arm",
    "floating_tree": _floating_tree,
    "floating_friction": _rough_tree,
    "spherical_fixed": _spherical_fixed,
    "spherical_floating": lambda: BALL_ARM,
    "loops_planar": "four_bar",
    "loops_spatial": "spatial_four_bar",
    "loops_with_frames": _framed_loop,
    "loops_overconstrained": "bennett",
    "loops_floating": lambda: TIED_ARM,
    "contacts_fixed": _contacts(6, False),
    "contacts_floating": _contacts(10, True),
}


@cache
def _derived(key: str, directory: str):
    """(derivation, the NumPy module's source) of a robot class, derived once per process."""
    made = CLASSES[key]
    if isinstance(made, str):
        robot = dynderive.load_robot(made)
    else:
        path = Path(directory) / key / "robot.yaml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(made())
        robot = dynderive.load_robot(path)
    derivation = dynderive.derive(robot)
    return derivation, reference(derivation)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("agree")


@pytest.fixture(autouse=True)
def _unoptimized_extension(monkeypatch):
    """The C extension compiled at -O0 here: the values are compared, not the speed (the
    commands' -O2 build: ``test_backend_c.py``)."""
    from dynderive.render.targets.c_extension import compile as extension

    monkeypatch.setattr(extension, "build_extension", functools.partial(extension.build_extension, optimization="-O0"))


def _compared(rows, label: str) -> set[str]:
    """The functions the rows compared (``LABEL NAME ... == NumPy module``)."""
    return {m.group(1) for row in rows if (m := re.match(rf"{re.escape(label)} (\w+).* == NumPy module$", row.name))}


@pytest.mark.parametrize("key", CLASSES)
@pytest.mark.parametrize("target", LOADED, ids=lambda t: t.name)
def test_every_offered_function_agrees_with_the_numpy_module(target, key, folder):
    try:   # jax, casadi, a compiler: skipped where the target cannot run
        target.needs()
    except dynderive.InputError as exc:
        pytest.skip(str(exc))
    derivation, source = _derived(key, str(folder))
    robot = derivation.robot
    try:
        module = target.load(derivation)
    except dynderive.InputError as exc:   # a class the target refuses, at the robot file (its own tests)
        pytest.skip(str(exc))
    label = f"{target.name}:"
    seed = stable_seed(key)
    values = {p.name: 1.1 * (p.value if p.value is not None else 1.0) + 0.05 for p in robot.parameters}
    rows = compiled_checks(derivation, source, module, states=3, seed=seed, label=label, target=target.name,
                           values=values)
    failed = [f"{row.name}: {row.method} {row.residual:.3g}" for row in rows if row.status == "FAIL"]
    assert not failed, "\n".join(failed)
    # every function the target offers and the NumPy module has was compared, but what is not built
    numpy_functions = public(source)
    floating, frames, loops = bool(robot.floating), bool(robot.frames), bool(robot.loops)
    expected = {name for name in offered(derivation, target.name) & numpy_functions
                if not_built(target.name, name, floating, frames, loops) is None}
    if not frames:   # the frame functions of a robot without frames raise for any name: none to compare
        expected -= set(group("frames"))
    missing = {name for name in numpy_functions - offered(derivation, target.name)
               if not_built(target.name, name, floating, frames, loops) is None}
    assert not missing, f"{target.name} lacks {sorted(missing)}, which its entry does not list as not built"
    compared = _compared(rows, label)
    assert expected <= compared, f"not compared: {sorted(expected - compared)}"
    assert len(compared) >= 12


def test_the_reference_is_the_numpy_module_and_every_loader_is_a_target_of_the_registry():
    """What this file compares with is the NumPy module, and every target ``simulate --backend``
    can load is compared (C, JAX, CasADi, PyTorch today), each a target of the registry."""
    from dynderive.render.targets import by_name

    assert REFERENCE.name == "numpy" and REFERENCE.name not in {harness.name for harness in LOADED}
    assert {harness.name for harness in LOADED} >= {"c", "jax", "casadi", "torch"}
    assert all(by_name(harness.name) is harness.target for harness in LOADED)


#: A floating box with a damped arm (smoothed Coulomb friction) and a frame: what ``simulate``
#: integrates through a loaded target (forward dynamics with a wrench, the configuration rate,
#: the friction forces).
ROUGH_BOX = """name: rough_box
planar: false
gravity: [0, 0, -9.81]
links:
  - {name: base, mass: 2.1234567890123456, com: [0.01, 0.02, 0.1], inertia: [0.02, 0.03, 0.025, 0.001, 0.002, 0.003]}
  - {name: arm, mass: 0.7123456789012345, com: [0.2, 0, 0], inertia: [0.001, 0.03, 0.03, 0, 0, 0]}
joints:
  - {name: root, type: floating, parent: world, child: base, origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 1.1]}}
  - {name: q2, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 0.4]}, axis: [0, 0.6, 0.8],
     effort: tau2, damping: 0.0712345678901234, friction: 0.0312345678901234}
frames:
  - {name: tip, link: arm, origin: {xyz: [0.4, 0.05, -0.02]}}
"""


@pytest.mark.parametrize("target", LOADED, ids=lambda t: t.name)
def test_simulate_with_the_target_follows_the_numpy_run(target, tmp_path):
    """``simulate --backend NAME`` (an effort, a wrench at a frame, smoothed friction, a floating
    base) gives the NumPy run's trajectory and dissipated work."""
    from typer.testing import CliRunner

    from dynderive.commands.cli import app

    try:
        target.needs()
    except dynderive.InputError as exc:
        pytest.skip(str(exc))
    path = tmp_path / "rough_box.yaml"
    path.write_text(ROUGH_BOX)
    runs = {}
    for backend in ("numpy", target.name):
        csv = tmp_path / f"{backend}.csv"
        result = CliRunner().invoke(app, ["simulate", str(path), "--backend", backend, "--duration", "0.3",
                                          "--frames", "4", "--effort", "tau2=0.3*sin(3*t)", "--force",
                                          "tip=0.5,0,1.5*t,0,0.1,0", "--friction-smoothing", "0.01",
                                          "--qd0", "0.1,0,0.2,0.3,-0.2,0.1,1.0", "--csv", str(csv), "-q"])
        assert result.exit_code == 0, result.output
        lines = csv.read_text().splitlines()
        assert lines[0].endswith(",energy,dissipated")
        runs[backend] = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    assert np.max(np.abs(runs["numpy"][-1] - runs["numpy"][0])) > 0.05   # it moved
    np.testing.assert_allclose(runs[target.name], runs["numpy"], rtol=0, atol=1e-8)
