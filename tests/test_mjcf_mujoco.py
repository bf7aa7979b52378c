"""MJCF input against MuJoCo on models written for the purpose.

* The bundled Panda and UR5 URDFs converted to MJCF by MuJoCo itself (``MjSpec.from_file`` on
  the ``.urdf``, ``to_xml``): dynderive's derivation of that MJCF has the URDF derivation's mass
  matrix and inverse dynamics (coordinates matched by joint name), and MuJoCo's.
* Small hand-written fixtures in ``tests/mjcf/`` (each one's comment says what it exercises),
  against MuJoCo's ``mj_fullM``, ``qfrc_bias``, ``mj_forward`` and frame poses.

The mapping between the two conventions (``mujoco_state``) is described in ``test_mjcf_gymnasium``.
"""

from __future__ import annotations

import ctypes
from contextlib import contextmanager
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.verify.mujoco_hard_limit import equality_rows, hard_limit

from conftest import ROBOTS, import_code

mujoco = pytest.importorskip("mujoco")
from conftest import compiled_model  # noqa: E402  (MjSpec: no MUJOCO_LOG.TXT)

FIXTURES = Path(__file__).parent / "mjcf"
TOLERANCE = 1e-9


# the two conventions, and the comparison with MuJoCo (test_mjcf_gymnasium's too) -------------

def quaternion_matrix(wxyz) -> np.ndarray:
    w, x, y, z = wxyz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def joint_name(m, j: int) -> str:
    """Our name of MuJoCo joint ``j`` (its own, or ``<body>_joint<k>`` for an unnamed one)."""
    from dynderive.input.urdf import identifier

    if m.joint(j).name:
        return identifier(m.joint(j).name)
    body = int(m.jnt_bodyid[j])
    return identifier(f"{m.body(body).name or f'body{body}'}_joint{j - int(m.body_jntadr[body]) + 1}")


def first_coordinate(m, j: int) -> str:
    name, kind = joint_name(m, j), int(m.jnt_type[j])
    return {0: f"{name}_x", 1: f"{name}_qx"}.get(kind, name)


def layout(module, m) -> list[tuple[int, int, int]]:
    """Per MuJoCo joint: (joint, our first coordinate index, our first velocity index), in our order."""
    starts = sorted((module.COORDINATES.index(first_coordinate(m, j)), j) for j in range(m.njnt))
    rows, v = [], 0
    for start, j in starts:
        rows.append((j, start, v))
        v += {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
    assert v == len(getattr(module, "VELOCITIES", module.COORDINATES)) == m.nv
    return rows


def mujoco_state(module, m, rng):
    """A random state in both conventions: (qpos, qvel, q, qd, T, W) with qd = T qvel and
    MuJoCo's zero acceleration our qdd = W."""
    qpos = m.qpos0.copy()
    qvel = rng.uniform(-1.5, 1.5, m.nv)
    q = np.zeros(len(module.COORDINATES))
    T, W = np.zeros((m.nv, m.nv)), np.zeros(m.nv)
    for j, c, v in layout(module, m):
        a, dof, kind = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), int(m.jnt_type[j])
        if kind in (0, 1):
            at = a + 3 if kind == 0 else a
            if kind == 0:
                qpos[a:a + 3] = rng.uniform(-1, 1, 3)
            quat = rng.normal(size=4)
            qpos[at:at + 4] = quat / np.linalg.norm(quat)
            quat = qpos[at:at + 4]
            if kind == 0:
                R = quaternion_matrix(quat)
                q[c:c + 3] = qpos[a:a + 3]
                T[v:v + 3, dof:dof + 3] = R.T
                T[v + 3:v + 6, dof + 3:dof + 6] = np.eye(3)
                local, omega = R.T @ qvel[dof:dof + 3], qvel[dof + 3:dof + 6]
                W[v:v + 3] = -np.cross(omega, local)
                q[c + 3:c + 7] = [*quat[1:], quat[0]]
            else:
                T[v:v + 3, dof:dof + 3] = np.eye(3)
                q[c:c + 4] = [*quat[1:], quat[0]]
        else:
            qpos[a] = rng.uniform(-1.5, 1.5)
            q[c] = qpos[a]
            T[v, dof] = 1
    return qpos, qvel, q, T @ qvel, T, W


def mujoco_at(m, d, qpos, qvel, ctrl=None):
    d.qpos[:], d.qvel[:], d.qacc[:] = qpos, qvel, 0
    d.ctrl[:] = 0 if ctrl is None else ctrl
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return M


def assert_close(ours, theirs, what: str, floor: float = 1e-300) -> None:
    """``ours`` equals ``theirs`` to TOLERANCE relative to the largest entry of ``theirs`` (or
    ``floor``, for quantities that may vanish: a point on a free body's origin has no Jdot qd)."""
    scale = max(float(np.max(np.abs(theirs))), floor)
    error = float(np.max(np.abs(np.asarray(ours) - theirs)))
    assert error <= TOLERANCE * scale, f"{what}: max error {error:.3e}, relative {error / scale:.3e}"


def effort_columns(module) -> list[int]:
    """The velocity each effort acts on (a fixed-base module's efforts are named after coordinates)."""
    if hasattr(module, "EFFORT_COLUMNS"):
        return list(module.EFFORT_COLUMNS)
    return [module.COORDINATES.index(e.removeprefix("tau_").removeprefix("f_")) for e in module.EFFORTS]


def check_against_mujoco(module, m, seed: int, states: int = 3) -> None:
    """Mass matrix, bias and forward dynamics of ``module`` equal MuJoCo's for model ``m``."""
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.viscosity = m.opt.density = 0.0
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    for _ in range(states):
        qpos, qvel, q, qd, T, W = mujoco_state(module, m, rng)
        ctrl = rng.uniform(-1, 1, m.nu)
        lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
        limited = m.actuator_ctrllimited.astype(bool)
        ctrl[limited] = lo[limited] + (hi[limited] - lo[limited]) * rng.uniform(0, 1, int(limited.sum()))
        M = mujoco_at(m, d, qpos, qvel, ctrl)
        assert_close(T.T @ module.mass_matrix(q) @ T, M, "mass matrix")
        bias = d.qfrc_bias - d.qfrc_spring - d.qfrc_damper
        assert_close(T.T @ module.inverse_dynamics(q, qd, W), bias, "inverse dynamics at zero qacc")
        actuation = np.linalg.solve(T.T, d.qfrc_actuator)   # generalized forces: tau_mj = T^T tau_ours
        columns = effort_columns(module)
        unactuated = np.setdiff1d(np.arange(m.nv), columns)
        assert not np.any(actuation[unactuated]), "MuJoCo actuates a velocity that has no effort of ours"
        qdd = module.forward_dynamics(q, qd, actuation[columns])
        assert_close(np.linalg.solve(T, qdd - W), d.qacc, "forward dynamics")


def actuated_efforts(m) -> set[str]:
    """Our effort names of the hinge and slide joints MuJoCo's joint actuators drive."""
    names = set()
    for a in range(m.nu):
        if int(m.actuator_trntype[a]) in (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)):
            j = int(m.actuator_trnid[a, 0])
            if int(m.jnt_type[j]) in (2, 3):
                names.add(("tau_" if int(m.jnt_type[j]) == 3 else "f_") + joint_name(m, j))
    return names


def mujoco_frame(m, d, name: str):
    """(position, rotation, body) of the site or body called ``name`` in MuJoCo's data."""
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
    if site >= 0:
        return d.site_xpos[site], d.site_xmat[site].reshape(3, 3), int(m.site_bodyid[site])
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
    assert body >= 0, name
    return d.xpos[body], d.xmat[body].reshape(3, 3), body


def second_difference(m, d, qpos, qvel, frame: str, h: float = 1e-4) -> np.ndarray:
    """The frame origin's acceleration at zero MuJoCo acceleration, (x(-h) - 2 x(0) + x(h)) / h^2
    along ``mj_integratePos`` with qvel held (error near 1e-8)."""
    points = []
    for step in (-h, 0.0, h):
        moved = qpos.copy()
        mujoco.mj_integratePos(m, moved, qvel, step)
        d.qpos[:], d.qvel[:] = moved, qvel
        mujoco.mj_kinematics(m, d)
        points.append(mujoco_frame(m, d, frame)[0].copy())
    return (points[0] - 2 * points[1] + points[2]) / h ** 2


def check_frames(module, m, seed: int, states: int = 3, jac_dot: bool = True) -> None:
    """Every frame of ``module`` (a site or a named welded body) has MuJoCo's pose
    (``site_xpos``/``site_xmat`` or ``xpos``/``xmat``), Jacobian (``mj_jac``, mapped by T) and
    acceleration at zero MuJoCo acceleration (``mj_jacDot`` times qvel; ours at qdd = W).
    ``jac_dot=False``: the origin's acceleration against a second difference of MuJoCo's
    positions instead, to 1e-6: at the site of ``floating.xml``'s hinge-ball-slide body (and of
    variants without the ball or without the slide) ``mj_jacDot`` differs from that second
    difference by 2e-4 to 1 relative, where ours agrees with it to 1e-7."""
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    for _ in range(states):
        qpos, qvel, q, qd, T, W = mujoco_state(module, m, rng)
        mujoco_at(m, d, qpos, qvel)
        for frame in module.FRAMES:
            position, rotation, body = mujoco_frame(m, d, frame)
            pose = module.frame_transform(q, frame)
            assert_close(pose[:3, 3], position, f"{frame} position")
            assert_close(pose[:3, :3], rotation, f"{frame} rotation")
            jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, jacp, jacr, position, body)
            J = module.frame_jacobian(q, frame)
            assert_close(J @ T, np.vstack([jacp, jacr]), f"{frame} Jacobian")
            ours = module.frame_jacobian_dot_qd(q, qd, frame) + J @ W
            if jac_dot:
                mujoco.mj_jacDot(m, d, jacp, jacr, position, body)
                assert_close(ours, np.concatenate([jacp @ qvel, jacr @ qvel]), f"{frame} Jdot qd", floor=1.0)
            else:
                difference = second_difference(m, d, qpos, qvel, frame)
                assert np.max(np.abs(ours[:3] - difference)) <= 1e-6 * max(1.0, np.max(np.abs(difference)))
                mujoco_at(m, d, qpos, qvel)



@contextmanager
def full_precision_xml():
    """MuJoCo writes numbers in saved XML to 6 significant digits; its test-only switch (the
    library's exported ``_mjPRIVATE__set_xml_precision``) makes them 17, so the saved model is
    the loaded one to the last bit."""
    library = ctypes.CDLL(str(next(Path(mujoco.__file__).parent.glob("libmujoco.so*"))))
    if not hasattr(library, "_mjPRIVATE__set_xml_precision"):
        pytest.skip("this MuJoCo has no switch to write full-precision XML")
    previous = library._mjPRIVATE__get_xml_precision()
    library._mjPRIVATE__set_xml_precision(17)
    try:
        yield
    finally:
        library._mjPRIVATE__set_xml_precision(previous)


@cache
def module_of_file(path: str, directory: str, name: str):
    derivation = dynderive.derive(dynderive.load_robot(path))
    return import_code(dynderive.render_code(derivation), Path(directory), f"{name}_dynamics")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("mjcf_mujoco"))


# the bundled arms through MuJoCo's URDF import -------------------------------------------------

@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_urdf_converted_by_mujoco_keeps_the_urdf_dynamics(arm, folder):
    with full_precision_xml():
        spec = mujoco.MjSpec.from_file(str(ROBOTS / f"{arm}.urdf"))
        spec.compile()
        xml = spec.to_xml()
    path = Path(folder) / f"{arm}_from_urdf.xml"
    path.write_text(xml)
    assert "<inertial" in xml and "<joint" in xml
    converted = compiled_model(str(path))
    # MuJoCo kept every moving link's inertial (fusestatic folds only the fixed, massless ones
    # and the root welded to the world; no geoms, so no inertia from geoms)
    urdf = dynderive.load_robot(ROBOTS / f"{arm}.urdf")
    moving = sum(float(link.mass) for link in urdf.links if any(j.child == link.name for j in urdf.joints
                                                                  if j.type == "revolute"))
    assert abs(float(np.sum(converted.body_mass)) - moving) <= 1e-15 * moving

    ours = module_of_file(str(path), folder, f"{arm}_mjcf")
    reference = module_of_file(str(ROBOTS / f"{arm}.urdf"), folder, f"{arm}_urdf")
    assert sorted(ours.COORDINATES) == sorted(reference.COORDINATES)
    order = [reference.COORDINATES.index(c) for c in ours.COORDINATES]
    rng = np.random.default_rng(11 if arm == "ur5" else 12)
    for _ in range(4):
        q, qd, qdd = rng.uniform(-2, 2, (3, len(order)))
        M_ref = reference.mass_matrix(q[np.argsort(order)])
        assert_close(ours.mass_matrix(q), M_ref[np.ix_(order, order)], "mass matrix")
        tau_ref = reference.inverse_dynamics(q[np.argsort(order)], qd[np.argsort(order)], qdd[np.argsort(order)])
        assert_close(ours.inverse_dynamics(q, qd, qdd), tau_ref[order], "inverse dynamics")
    check_against_mujoco(ours, converted, seed=5)


# hand-written fixtures ---------------------------------------------------------------------------

def fixture_module(name: str, folder: str):
    return module_of_file(str(FIXTURES / f"{name}.xml"), folder, f"fixture_{name}")


def test_tree_fixture_agrees_with_mujoco(folder):
    """Several joints on one body, refs, springs, armature, a ball joint, welded bodies, motors."""
    module = fixture_module("tree", folder)
    m = compiled_model(str(FIXTURES / "tree.xml"))
    assert (m.njnt, m.nbody, m.nsite) == (5, 6, 2)
    assert np.all(m.qpos0[[0, 1, 2]] != 0) and np.all(m.jnt_stiffness[[0, 1]] != 0)
    check_against_mujoco(module, m, seed=21, states=4)


def test_floating_fixture_agrees_with_mujoco(folder):
    """A free body, welded bodies between it and a body with a hinge, a ball and a slide, a
    static body, gravity off the z axis, servo and general actuators."""
    module = fixture_module("floating", folder)
    m = compiled_model(str(FIXTURES / "floating.xml"))
    assert set(module.FRAMES) == {"weld1", "weld2", "s"}
    assert set(module.EFFORTS) == actuated_efforts(m) == {"tau_swing", "tau_twist", "f_push"}
    check_against_mujoco(module, m, seed=61)
    check_frames(module, compiled_model(str(FIXTURES / "floating.xml")), seed=62, jac_dot=False)


def test_what_mujoco_switches_off_is_left_out(folder):
    """Option flags that switch off gravity and springs, an inactive equality and a
    ``jointinparent`` motor: the module has MuJoCo's dynamics, j2 stays a coordinate (not a
    mimic) and both motors' joints have efforts."""
    module = fixture_module("flags", folder)
    m = compiled_model(str(FIXTURES / "flags.xml"))
    assert module.COORDINATES == ("j1", "j2", "j3")
    assert set(module.EFFORTS) == actuated_efforts(m) == {"tau_j1", "f_j3"}
    assert module.gravity_vector(np.array([0.3, -0.4, 0.1])).tolist() == [0.0, 0.0, 0.0]
    check_against_mujoco(module, m, seed=51)
    d = mujoco.MjData(m)
    mujoco_at(m, d, np.array([0.3, -0.4, 0.1]), np.array([0.5, -0.7, 0.9]))
    assert not np.any(d.qfrc_spring) and np.all(d.qfrc_damper)
    mujoco_at(m, d, np.array([0.3, -0.4, 0.1]), np.zeros(3))
    assert not np.any(d.qfrc_bias)   # no gravity


def test_tree_fixture_frames_are_mujocos_sites_and_bodies(folder):
    """The named welded body (``tool``) and the sites are frames (the unnamed welded body is not)."""
    module = fixture_module("tree", folder)
    m = compiled_model(str(FIXTURES / "tree.xml"))
    assert set(module.FRAMES) == {"tool", "tip", "hand"}
    check_frames(module, m, seed=22, states=4)


REFS = {"drive": 0.3, "follow": -0.2}   # mimic.xml's hinge refs (MuJoCo's qpos0)


@pytest.mark.parametrize("leader, follower", [("drive", "follow"), ("follow", "drive")])
def test_joint_equality_is_a_mimic_joint(leader, follower, folder, tmp_path):
    """``follower - ref = 0.25 - 1.5 (leader - ref)`` makes ``follower`` a mimic joint, whether it
    is the leader's child or its parent: on MuJoCo's configuration that satisfies it (MuJoCo's
    own residual ``efc_pos`` is zero there), our reduced M is G^T M_mj G and our inverse dynamics
    G^T (M_mj G qdd + bias - springs - dampers), G the map from our velocities to MuJoCo's
    (constant: the relation is linear), and the end site is where MuJoCo puts it."""
    if follower == "follow":
        path = FIXTURES / "mimic.xml"
        module = fixture_module("mimic", folder)
    else:
        path = tmp_path / "mimic_reversed.xml"
        path.write_text((FIXTURES / "mimic.xml").read_text().replace('joint1="follow" joint2="drive"',
                                                                       'joint1="drive" joint2="follow"'))
        module = module_of_file(str(path), folder, "mimic_reversed")
    m = compiled_model(str(path))
    d = mujoco.MjData(m)
    assert module.COORDINATES == (leader, "lin")
    assert module.EFFORTS == (("tau_drive", "f_lin") if leader == "drive" else ("f_lin",))
    lead, follow, lin = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in (leader, follower, "lin"))
    G = np.zeros((m.nv, 2))
    G[m.jnt_dofadr[lead], 0], G[m.jnt_dofadr[follow], 0], G[m.jnt_dofadr[lin], 1] = 1, -1.5, 1
    rng = np.random.default_rng(31)
    for _ in range(4):
        q, qd, qdd = rng.uniform(-1.2, 1.2, (3, 2))
        qpos = np.zeros(m.nq)
        qpos[m.jnt_qposadr[lead]], qpos[m.jnt_qposadr[lin]] = q
        qpos[m.jnt_qposadr[follow]] = REFS[follower] + 0.25 - 1.5 * (q[0] - REFS[leader])   # the file's polycoef
        M = mujoco_at(m, d, qpos, G @ qd)
        assert d.nefc == 1 and abs(d.efc_pos[0]) < 1e-15
        assert_close(module.mass_matrix(q), G.T @ M @ G, "reduced mass matrix")
        tau = G.T @ (M @ G @ qdd + d.qfrc_bias - d.qfrc_spring - d.qfrc_damper)
        assert_close(module.inverse_dynamics(q, qd, qdd), tau, "reduced inverse dynamics")
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "end")
        pose = module.frame_transform(q, "end")
        assert_close(pose[:3, 3], d.site_xpos[site], "site position")
        assert_close(pose[:3, :3], d.site_xmat[site].reshape(3, 3), "site rotation")


def test_chained_joint_equalities_are_composed(folder):
    """A joint following a follower, and a follower tied to a third joint: our one coordinate
    is MuJoCo's motion with every equality holding. The map G from our velocities to MuJoCo's
    comes from MuJoCo's constraint Jacobian (the followers' rows solved), the configuration from
    its residual (linear in qpos: one step puts it at zero), so nothing of ours builds it."""
    module = fixture_module("mimic_chain", folder)
    m = compiled_model(str(FIXTURES / "mimic_chain.xml"))
    d = mujoco.MjData(m)
    assert module.COORDINATES == ("j1", "j5")
    ours = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name) for name in module.COORDINATES]
    followers = [j for j in range(m.njnt) if j not in ours]
    rng = np.random.default_rng(71)
    for _ in range(4):
        q, qd, qdd = rng.uniform(-1.2, 1.2, (3, 2))
        qpos = m.qpos0.copy()
        qpos[ours] = q
        mujoco_at(m, d, qpos, np.zeros(m.nv))
        J = d.efc_J[:d.nefc * m.nv].reshape(d.nefc, m.nv)
        qpos[followers] -= np.linalg.solve(J[:, followers], d.efc_pos[:d.nefc])
        G = np.zeros((m.nv, 2))
        G[ours] = np.eye(2)
        G[followers] = -np.linalg.solve(J[:, followers], J[:, ours])
        M = mujoco_at(m, d, qpos, G @ qd)
        assert d.nefc == 3 and np.max(np.abs(d.efc_pos)) < 1e-14
        assert_close(module.mass_matrix(q), G.T @ M @ G, "reduced mass matrix")
        tau = G.T @ (M @ G @ qdd + d.qfrc_bias - d.qfrc_spring - d.qfrc_damper)
        assert_close(module.inverse_dynamics(q, qd, qdd), tau, "reduced inverse dynamics")


def test_connect_equality_is_a_spherical_loop(folder):
    """The connect equality becomes a spherical loop joint. The loop is closed at MuJoCo's qpos0,
    and where ``assemble`` closes it MuJoCo's residual is zero too. Constrained forward dynamics:
    MuJoCo's equality is soft (impedance at most 0.9999, so its qacc keeps a relative error of
    1e-5 to 1e-4 however stiff solref is, and its reference acceleration leaves out Jdot qvel), so the hard
    limit is built from MuJoCo's own pieces, qacc = a0 + M^-1 J^T lambda with J qacc = -Jdot qvel
    (a0 = qacc_smooth, J = efc_J, M = mj_fullM, Jdot qvel from mj_jacDot): ours equals it to
    1e-9, and MuJoCo's soft qacc at zero velocity is within 1e-3 of it."""
    module = fixture_module("loop", folder)
    m = compiled_model(str(FIXTURES / "loop.xml"))
    d = mujoco.MjData(m)
    assert module.COORDINATES == ("ja", "jb", "jc", "jd", "je") and len(module.LOOPS) == 1
    assert np.max(np.abs(module.loop_constraints(m.qpos0))) < 1e-15
    rng = np.random.default_rng(41)
    for k in range(4):
        guess = np.array(module.ASSEMBLED_CONFIGURATION) + rng.uniform(-0.3, 0.3, 5)
        q = module.assemble(guess)
        ctrl = rng.uniform(-1, 1, m.nu)
        d.qpos[:], d.qvel[:], d.ctrl[:] = q, 0, ctrl
        mujoco.mj_forward(m, d)
        assert d.nefc == 3 and np.max(np.abs(d.efc_pos)) < 1e-12
        J, _ = equality_rows(m, d)
        basis = np.linalg.svd(J)[2][3:].T   # the velocities the loop allows, by MuJoCo's Jacobian
        qvel = basis @ rng.uniform(-1.5, 1.5, 2) if k else np.zeros(m.nv)
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        J, jdot_v = equality_rows(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        a0 = d.qacc_smooth.copy()
        MinvJT = np.linalg.solve(M, J.T)
        hard = a0 + MinvJT @ np.linalg.solve(J @ MinvJT, -jdot_v - J @ a0)
        assert_close(hard_limit(m, d, J, jdot_v), hard, "hard_limit's least-norm solve")   # check's reference
        u = d.qfrc_actuator[[0, 3]]
        assert not np.any(d.qfrc_actuator[[1, 2, 4]])
        assert_close(module.forward_dynamics(q, qvel, u), hard, "constrained forward dynamics")
        if not k:
            assert np.max(np.abs(d.qacc - hard)) <= 1e-3 * np.max(np.abs(hard))


def mujoco_configuration(module, m, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Our configuration ``q`` in MuJoCo's convention: (qpos, T, W) with our qd = T qvel and, at
    MuJoCo's zero acceleration, our qdd = W (``mujoco_state``'s maps, the other way)."""
    qpos, T = m.qpos0.copy(), np.zeros((m.nv, m.nv))
    for j, c, v in layout(module, m):
        a, dof, kind = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), int(m.jnt_type[j])
        if kind == 0:
            qpos[a:a + 3], qpos[a + 3], qpos[a + 4:a + 7] = q[c:c + 3], q[c + 6], q[c + 3:c + 6]
            T[v:v + 3, dof:dof + 3] = quaternion_matrix(qpos[a + 3:a + 7]).T
            T[v + 3:v + 6, dof + 3:dof + 6] = np.eye(3)
        elif kind == 1:
            qpos[a], qpos[a + 1:a + 4] = q[c + 3], q[c:c + 3]
            T[v:v + 3, dof:dof + 3] = np.eye(3)
        else:
            qpos[a], T[v, dof] = q[c], 1
    return qpos, T


def test_connect_on_a_floating_base_is_mujocos_hard_limit(folder):
    """A connect equality on a model with a free joint and a ball joint in the loop (the loop rows on
    the tree's twists): the generated module's constrained accelerations, mapped to MuJoCo's
    convention, equal the hard limit built from MuJoCo's efc_J, qacc_smooth and mj_fullM to 1e-9
    (MuJoCo's own soft qacc within 1e-3 of it); the loops close where MuJoCo's residual is zero, and
    the accelerations keep them closed (A qdd = -Adot qd)."""
    module = fixture_module("floating_loop", folder)
    m = compiled_model(str(FIXTURES / "floating_loop.xml"))
    d = mujoco.MjData(m)
    assert (m.nq, m.nv, module.NQ, module.NV, module.LOOPS) == (15, 13, 15, 13, ("closure",))
    rng = np.random.default_rng(43)
    for k in range(4):
        q = module.assemble(mujoco_state(module, m, rng)[2])
        qpos, T = mujoco_configuration(module, m, q)
        d.qpos[:], d.qvel[:] = qpos, 0
        mujoco.mj_forward(m, d)
        assert d.nefc == 3 and np.max(np.abs(d.efc_pos)) < 1e-12
        J = d.efc_J[:3 * m.nv].reshape(3, m.nv)
        allowed = np.linalg.svd(J)[2][3:].T   # the velocities the loop allows, by MuJoCo's Jacobian
        qvel = allowed @ rng.uniform(-1.5, 1.5, m.nv - 3) if k else np.zeros(m.nv)
        d.qvel[:], d.ctrl[:] = qvel, rng.uniform(-1, 1, m.nu)
        mujoco.mj_forward(m, d)
        hard = hard_limit(m, d, *equality_rows(m, d))
        free = qpos[3:7]   # the free joint's quaternion: MuJoCo's zero acceleration is our -omega x v
        R = quaternion_matrix(free)
        W = np.zeros(m.nv)
        W[:3] = -np.cross(qvel[3:6], R.T @ qvel[:3])
        qd = T @ qvel
        u = np.linalg.solve(T.T, d.qfrc_actuator)[list(module.EFFORT_COLUMNS)]
        assert np.max(np.abs(module.loop_jacobian(q) @ qd)) < 1e-12
        qdd = module.forward_dynamics(q, qd, u)
        assert_close(qdd, T @ hard + W, "constrained forward dynamics")
        drift = module.loop_jacobian(q) @ qdd + module.loop_jacobian_dot_qd(q, qd)
        assert np.max(np.abs(drift)) < 1e-10 * max(1.0, np.max(np.abs(qdd)))
        if not k:
            assert np.max(np.abs(d.qacc - hard)) <= 1e-3 * np.max(np.abs(hard))


def test_connect_between_sites_is_the_same_loop(tmp_path):
    """``connect site1 site2`` (the sites' origins coincide) is the loop of ``connect body1
    body2 anchor`` when the sites sit at the anchors (the second where MuJoCo puts it)."""
    text = (FIXTURES / "loop.xml").read_text()
    m = compiled_model(str(FIXTURES / "loop.xml"))
    second = " ".join(repr(float(v)) for v in m.eq_data[0, 3:6])
    text = text.replace('<joint name="jb"', '<site name="pin" pos="0.2391 -0.0127 0.0183"/>\n        <joint name="jb"')
    text = text.replace('<joint name="je"', f'<site name="hole" pos="{second}"/>\n          <joint name="je"')
    text = text.replace('body1="b" body2="e" anchor="0.2391 -0.0127 0.0183"', 'site1="pin" site2="hole"')
    path = tmp_path / "loop_sites.xml"
    path.write_text(text)
    bodies, sites = dynderive.load_robot(FIXTURES / "loop.xml"), dynderive.load_robot(path)
    assert len(sites.loops) == 1 and not any("closure" in note for note in sites.notes)
    ours, theirs = sites.loops[0], bodies.loops[0]
    assert (ours.parent, ours.child, ours.type) == (theirs.parent, theirs.child, theirs.type)
    np.testing.assert_allclose(np.array(ours.origin, dtype=float), np.array(theirs.origin, dtype=float), rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.array(ours.child_origin, dtype=float), np.array(theirs.child_origin, dtype=float),
                               rtol=0, atol=1e-15)


def test_notes_name_what_is_not_modelled(tmp_path):
    """An equality that is not modelled is named by its kind, one that would make two joints
    follow each other is noted, and so is an actuator on a joint that follows another."""
    path = tmp_path / "notes.xml"
    path.write_text('<mujoco model="notes">\n  <worldbody>\n'
                    '    <body name="a"><joint name="j1" axis="0 1 0"/>'
                    '<inertial pos="0.1 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>\n'
                    '      <body name="b" pos="0.2 0 0"><joint name="j2" axis="0 1 0"/>'
                    '<inertial pos="0.1 0 0" mass="1" diaginertia="0.1 0.1 0.1"/></body>\n'
                    '    </body>\n  </worldbody>\n  <equality>\n'
                    '    <joint name="gear" joint1="j2" joint2="j1" polycoef="0 0.5 0 0 0"/>\n'
                    '    <joint name="back" joint1="j1" joint2="j2" polycoef="0 2 0 0 0"/>\n'
                    '    <weld name="glue" body1="a"/>\n'
                    '  </equality>\n  <actuator>\n    <motor joint="j2"/>\n  </actuator>\n</mujoco>\n')
    robot = dynderive.load_robot(path)
    assert [j.name for j in robot.joints if j.mimic] == ["j2"] and all(j.effort is None for j in robot.joints)
    assert f"{path}:9:5: note: equality 'back': neither 'j1' nor 'j2' can follow the other (it follows a joint " \
           "already, or they would follow each other): not modelled" in robot.notes
    assert f"{path}:10:5: note: equality 'glue' (weld) is not modelled (joint equalities of degree one and " \
           "connect between two moving bodies are)" in robot.notes
    assert any(note.startswith(f"{path}:4:36: note: ") and "joint 'j2' follows 'j1' (a joint equality): the force of its "
               "actuator is not modelled" in note for note in robot.notes), robot.notes
