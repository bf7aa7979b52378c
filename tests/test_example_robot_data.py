"""The URDF files of example-robot-data (the Gepetto robot collection Pinocchio's tutorials use)
against Pinocchio's own URDF parser.

Every URDF of the package that Pinocchio loads must load in dynderive, with the same moving
joints and the same mass on them, unless ``REFUSED`` names it with the reason, which the test
checks too (strictly: a file that starts to load must leave the table). A robot whose root
floats is loaded with its root welded to the world, as ``pin.buildModelFromUrdf`` without a
root joint does. Robots of at most ``DERIVE_MAX_JOINTS`` moving joints are also derived: the
input checks of ``dynderive.derive``, then the mass matrix (composite rigid bodies) and inverse
dynamics (Newton-Euler) programs, compared with Pinocchio at random states (about 30 s for
the 37 of them). Larger robots are only loaded here: deriving one takes 2 to 20 s (tiago_dual,
101 joints); ``DYNDERIVE_ERD_ALL=1`` derives them too (all 64 robots agree, 3 min in all).
``<mimic>`` joints are compared with Pinocchio's mimic model (``mimic=True``): one coordinate
for a leader and its followers.

Every file is far below the 2 MB limit of robot files. The package ships URDFs only (no
Python module), so it is found through its installed files. Skipped locally when it is not
installed; required in CI (CI=true), where ``pip install .[test]`` installs it.
"""

from __future__ import annotations

import importlib.metadata
import os
import re
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.errors import InputError
from dynderive.input.urdf import identifier
from dynderive.mechanics.recursive import inverse_dynamics_program, mass_matrix_program
from dynderive.model.symbols import SymbolTable
from dynderive.verify.pinocchio_checks import mass_matrix as _pinocchio_mass_matrix

pytestmark = pytest.mark.pinocchio
pin = pytest.importorskip("pinocchio")


def _package_urdfs() -> tuple[Path, list[str]]:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        if os.environ.get("CI"):
            raise RuntimeError("CI must run the example-robot-data tests, but the package is not installed") from None
        pytest.skip("example-robot-data is not installed", allow_module_level=True)
    paths = [Path(str(dist.locate_file(f))) for f in dist.files or () if f.suffix == ".urdf"]
    root = next(p for p in paths[0].parents if p.name == "robots")
    return root, sorted(str(p.relative_to(root)) for p in paths)


ROOT, URDFS = _package_urdfs()

#: Files Pinocchio loads and dynderive refuses, with (a fragment of) one of the errors.
REFUSED = {
    # a principal moment negative by far more than rounding (a hip's inertia, moving): not
    # positive semi-definite, so M(q) could be indefinite; Pinocchio does not check. Its two
    # gripper joints move links without <inertial> too: Pinocchio's M(q) is singular there
    "romeo_description/urdf/romeo_laas_small.urdf":
        "link 'LHipPitch_link' inertia: inertia is not positive semi-definite (smallest principal moment "
        "-0.00272042; rounding tolerance 9.62829e-07)",
    # its finger joints move links without <inertial> and nothing below them: their columns of
    # M(q) are zero (Pinocchio's crba gives a singular M too)
    "romeo_description/urdf/romeo.urdf":
        "link 'LFinger11Link' moves (joint 'LHand') but has no mass, nor has any link below it: the joint moves "
        "nothing",
    # one link and no joint: a floating body, nothing moves once its root is welded
    "hector_description/robots/quadrotor_base.urdf": "joints: expected a non-empty list of joints",
    "iris_description/robots/iris_simple.urdf": "joints: expected a non-empty list of joints",
}
#: Files accepted with a note each of these names at least once: inertias that miss
#: the triangle inequality by far more than rounding (1 to 80 % of the link's own moments, on
#: links that move) kept as written (Pinocchio does not check; Drake swaps in a sphere). The
#: massless links of human.urdf (between the revolute joints of a hip) need no note.
NOTED = {
    # its <mimic> elements name joints without the "Left_"/"Right_" prefix: ignored, a note each
    "alex_description/urdf/alex_psyonic_hands.urdf": "its <mimic> names joint 'index_q1', which the file does not have",
    "allegro_hand_description/urdf/allegro_left_hand.urdf":
        "link 'link_11.0' inertia: principal moments 2.30064e-06, 3.48527e-06, 7.2659e-06 violate the "
        "triangle inequality by 1.48e-06, beyond the rounding tolerance 3e-10: physically impossible, but kept "
        "as written (as Pinocchio does)",
    "allegro_hand_description/urdf/allegro_right_hand.urdf":
        "link 'link_3.0' inertia: principal moments 2.30064e-06, 3.48527e-06, 7.2659e-06 violate the "
        "triangle inequality by 1.48e-06, beyond the rounding tolerance",
    "romeo_description/urdf/romeo_small.urdf":
        "link 'RShoulderYawLink' inertia: principal moments 0.000661782, 0.000679363, 0.00656531 violate the "
        "triangle inequality by 0.00522417, beyond the rounding tolerance",
}
#: Robots of more moving joints are loaded, not derived (unless DYNDERIVE_ERD_ALL is set).
DERIVE_MAX_JOINTS = 12


def _pinocchio(name: str):
    try:   # with mimic joints; without, where Pinocchio cannot (talos_full_v2: a leader it meets late)
        return pin.buildModelFromUrdf(str(ROOT / name), mimic=True)
    except (RuntimeError, ValueError):
        pass
    try:
        return pin.buildModelFromUrdf(str(ROOT / name))
    except (RuntimeError, ValueError) as exc:   # ur3.urdf: an include stub without a robot name
        pytest.skip(f"Pinocchio does not load it: {str(exc).replace(str(ROOT / name), name)[:100]}")


def test_the_package_is_the_one_the_table_describes():
    assert len(URDFS) >= 60
    assert set(REFUSED) | set(NOTED) <= set(URDFS), "a table names a file the package does not have"


@pytest.mark.parametrize("name", URDFS)
def test_loads_with_pinocchios_joints_and_masses(name):
    model = _pinocchio(name)
    path = ROOT / name
    if name in REFUSED:
        with pytest.raises(InputError) as refused:
            dynderive.load_robot(path)
        problems = refused.value.problems
        assert all(p.file == str(path) and p.line >= 1 and p.column >= 1 for p in problems)
        assert any(REFUSED[name] in p.message for p in problems), str(refused.value)
        return
    robot = dynderive.load_robot(path)
    followers = {j.name for j in robot.joints if j.mimic is not None}   # in Pinocchio's list without mimic=True
    assert sorted(robot.coordinates) == sorted({identifier(n) for n in _coordinates(model)} - followers)
    # Pinocchio keeps what is welded to the world in the universe's inertia (joint 0)
    moving_mass = sum(model.inertias[i].mass for i in range(1, model.njoints))
    assert sum(float(link.mass) for link in robot.links) == pytest.approx(moving_mass, rel=1e-12)
    assert all(re.match(rf"{re.escape(str(path))}:\d+:\d+: note: ", note) for note in robot.notes)
    if name in NOTED:
        assert any(NOTED[name] in note for note in robot.notes), robot.notes


def _coordinates(model) -> list[str]:
    """Pinocchio's joints with a coordinate of their own (not its mimic joints), in its order."""
    return [n for n, j in zip(model.names[1:], model.joints[1:]) if j.shortname() != "JointModelMimic"]


def _mass_matrix(model, data, q: np.ndarray) -> np.ndarray:
    """Pinocchio's M(q) as ``dynderive check`` takes it: its crba; with mimic joints, column by
    column from its rnea (Pinocchio 4.1's crba is wrong for some mimic joints below their
    leaders: tests/test_mimic.py)."""
    return _pinocchio_mass_matrix(pin, model, data, q)


def _program(program, table: SymbolTable):
    arguments = [*table.parameters.values(), *table.q, *table.qd, *table.qdd]
    return sympy.lambdify(arguments, program.outputs, modules="math", cse=lambda outputs: (program.lines, outputs))


def _tolerances(notes: tuple[str, ...]) -> list[float]:
    """The rounding tolerances of the inertias the reader corrected (from its notes)."""
    return [float(m.group(1)) for note in notes
            for m in [re.search(r"within the rounding tolerance (\S+): corrected", note)] if m]


def _derivable(name: str):
    if name in REFUSED:
        pytest.skip(f"refused: {REFUSED[name]}")
    model = _pinocchio(name)
    if model.nv > DERIVE_MAX_JOINTS and not os.environ.get("DYNDERIVE_ERD_ALL"):
        pytest.skip(f"{model.nv} moving joints: over the {DERIVE_MAX_JOINTS} derived here (DYNDERIVE_ERD_ALL=1)")
    return model


@pytest.mark.parametrize("name", URDFS)
def test_derives_what_pinocchio_computes(name):
    """M(q) and inverse dynamics at two random states equal Pinocchio's to 1e-9 of their size;
    where the reader corrected inertias within the rounding tolerance, M(q) exceeds Pinocchio's
    (corrections only raise moments) by at most 1.5 n (sum of those tolerances), and both agree
    to 1e-9 with Pinocchio given dynderive's corrected numbers."""
    model = _derivable(name)
    data = model.createData()
    robot = dynderive.load_robot(ROOT / name)
    if robot.mimics and not model.mimicking_joints:
        pytest.skip("Pinocchio does not build its mimic model of it")
    dynderive.derive(robot)   # the input checks (M(q) not singular at the defaults)
    table = SymbolTable.for_robot(robot)
    mass_matrix = _program(mass_matrix_program(robot, table), table)
    inverse_dynamics = _program(inverse_dynamics_program(robot, table), table)
    n = len(robot.coordinates)
    order = [robot.coordinates.index(identifier(j)) for j in _coordinates(model)]  # Pinocchio's order
    values = [p.value for p in robot.parameters]
    corrected = _tolerances(robot.notes)
    if corrected:
        from dynderive.verify.pinocchio_model import pinocchio_model

        ours_model, perm = pinocchio_model(robot, {p.name: p.value for p in robot.parameters})
        ours_data = ours_model.createData()
    rng = np.random.default_rng(sum(map(ord, name)))
    for q, qd, qdd in rng.uniform(-1.5, 1.5, (2, 3, n)):
        M = np.reshape(mass_matrix(*values, *q, *qd, *qdd), (n, n))
        tau = np.array(inverse_dynamics(*values, *q, *qd, *qdd))
        q_pin = pin.integrate(model, pin.neutral(model), q[order])   # continuous joints: cos, sin
        M_pin = _mass_matrix(model, data, q_pin)
        tau_pin = pin.rnea(model, data, q_pin, qd[order], qdd[order])
        scale_M, scale_tau = np.max(np.abs(M_pin)), np.max(np.abs(tau_pin))
        if not corrected:
            np.testing.assert_allclose(M[np.ix_(order, order)], M_pin, rtol=0, atol=1e-9 * scale_M)
            np.testing.assert_allclose(tau[order], tau_pin, rtol=0, atol=1e-9 * scale_tau)
            continue
        grown = M[np.ix_(order, order)] - M_pin
        assert np.max(np.abs(grown)) <= 1.5 * n * sum(corrected)
        assert np.linalg.eigvalsh(grown)[0] >= -1e-12 * scale_M
        M_ours = pin.crba(ours_model, ours_data, q[perm])
        M_ours = np.triu(M_ours) + np.triu(M_ours, 1).T
        np.testing.assert_allclose(M[np.ix_(perm, perm)], M_ours, rtol=0, atol=1e-9 * scale_M)
        tau_ours = pin.rnea(ours_model, ours_data, q[perm], qd[perm], qdd[perm])
        np.testing.assert_allclose(tau[perm], tau_ours, rtol=0, atol=1e-9 * scale_tau)


def test_human_derives_with_its_massless_links():
    """human.urdf's hips, waist and ankles are revolute joints in a row with massless links
    between them (no <inertial>): they load with mass 0, and the mass matrix stays regular."""
    name = "human_description/robots/human.urdf"
    _pinocchio(name)
    robot = dynderive.load_robot(ROOT / name)
    empty = re.findall(r'<link name="([^"]+)"\s*/>', (ROOT / name).read_text())   # links without <inertial>
    assert len(empty) == 19 and all("virtual" in n for n in empty)
    assert sorted(link.name for link in robot.links if link.mass == 0) == sorted(map(identifier, empty))
    assert all(link.inertia == (0,) * 6 for link in robot.links if link.mass == 0)
    dynderive.derive(robot)   # the regularity check of M(q) at the defaults
