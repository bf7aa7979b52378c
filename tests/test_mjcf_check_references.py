"""``dynderive check`` on models its reference engines find awkward keeps its whole table: a
mimic follower written before its leader (Pinocchio adds a mimic joint only after its leader),
a comparison that raises, drive terms on a ball joint (noted, not modelled: off on MuJoCo's
side too). The MuJoCo row of a model with ``connect`` loops: the closed loops' accelerations
against MuJoCo's hard limit, or a skip naming the equality that is not closed here. And what the
MJCF reader says about explicit ``<contact>`` entries, at their lines."""

from __future__ import annotations

import json
import re
import types
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.verify.checks import generated_module
from dynderive.verify.mujoco_checks import mujoco_rows

pytest.importorskip("mujoco")
pytest.importorskip("pinocchio")
runner = CliRunner()

#: Two hinges in a chain; ``<equality>`` makes the upper one (written first) follow the lower one.
CHAIN = """<mujoco model="follower_first">
  <worldbody>
    <body name="a">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      <body name="b" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="j1" joint2="j2" polycoef="0 0.5 0 0 0"/>
  </equality>
</mujoco>
"""
#: A hand whose left finger (written first) follows the right one, as in Menagerie's grippers.
FINGERS = """<mujoco model="fingers">
  <worldbody>
    <body name="hand">
      <joint name="wrist" type="hinge" axis="0 0 1"/>
      <geom size="0.1"/>
      <body name="left" pos="0 0.05 0">
        <joint name="finger_left" type="slide" axis="0 1 0"/>
        <geom size="0.02"/>
      </body>
      <body name="right" pos="0 -0.05 0">
        <joint name="finger_right" type="slide" axis="0 -1 0"/>
        <geom size="0.02"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="finger_left" joint2="finger_right" polycoef="0 1 0 0 0"/>
  </equality>
</mujoco>
"""
INERTIAL = ('<inertial><origin xyz="0 0 -0.25"/><mass value="1"/><inertia ixx="0.02" iyy="0.02" izz="0.001" '
            'ixy="0" ixz="0" iyz="0"/></inertial>')
#: The same chain as a URDF: ``j1`` mimics ``j2``, the joint below it.
CHAIN_URDF = f"""<robot name="follower_first">
  <link name="base"/>
  <link name="a">{INERTIAL}</link>
  <link name="b">{INERTIAL}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/>
    <limit effort="1" velocity="1" lower="-1" upper="1"/><mimic joint="j2" multiplier="0.5"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
</robot>
"""
#: A ball joint with damping and armature (noted, not modelled) above a damped hinge (modelled).
BALL = """<mujoco model="ball_damped">
  <worldbody>
    <body name="bob" pos="0 0 1">
      <joint name="swivel" type="ball" damping="0.3" armature="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.1 0 -0.5" size="0.05"/>
      <body name="tip" pos="0.1 0 -0.5">
        <joint name="elbow" type="hinge" axis="0 1 0" damping="0.2"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
PINOCCHIO = re.compile(r"^agrees with Pinocchio")
MUJOCO = re.compile(r"^agrees with MuJoCo")


def _check(tmp_path: Path, name: str, text: str) -> tuple[int, dict, str]:
    """``dynderive check ROBOT --json``: exit code, the JSON report, stderr; the file unchanged."""
    robot = tmp_path / name
    robot.write_text(text)
    result = runner.invoke(app, ["check", str(robot), "--json", "--states", "3"])
    assert "internal error" not in result.output and "Traceback" not in result.output, result.output
    assert robot.read_text() == text
    return result.exit_code, json.loads(result.stdout), result.stderr


def _row(report: dict, pattern: re.Pattern) -> dict:
    (row,) = [row for row in report["checks"] if pattern.search(row["name"])]
    return row


@pytest.mark.parametrize(("name", "text"), [("chain.xml", CHAIN), ("chain.urdf", CHAIN_URDF)])
def test_a_follower_above_its_leader_skips_only_the_pinocchio_row(tmp_path, name, text):
    code, report, _ = _check(tmp_path, name, text)
    assert code == 0 and report["passed"], report
    row = _row(report, PINOCCHIO)
    assert row["status"] == "skip"
    assert row["method"] == ("joint 'j1' follows 'j2', a joint below it: Pinocchio adds a mimic joint only "
                             "after the joint it follows")
    assert sum(r["status"] == "pass" for r in report["checks"]) >= 10   # the rest of the table is there


def test_a_finger_following_a_later_finger_is_compared_with_pinocchio(tmp_path):
    """Sibling branches are reordered for Pinocchio: the leader's branch first."""
    code, report, _ = _check(tmp_path, "fingers.xml", FINGERS)
    assert code == 0, report
    row = _row(report, PINOCCHIO)
    assert row["status"] == "pass" and row["residual"] < 1e-12, row


def test_a_comparison_that_raises_is_its_own_failed_row(tmp_path, monkeypatch):
    """Pinocchio's comparison raising (a refusal, one of its bugs) fails its row; the MuJoCo
    row and every other row are still computed and shown."""
    import dynderive.verify.pinocchio_checks as pinocchio_checks

    def refuses(*_):
        raise ValueError("index_mimicking is greater than index_mimicked")

    monkeypatch.setattr(pinocchio_checks, "pinocchio_rows", refuses)
    code, report, _ = _check(tmp_path, "ball.xml", BALL)
    assert code == 1 and not report["passed"]
    failed = [row for row in report["checks"] if row["status"] == "FAIL"]
    assert failed == [{"name": "agrees with Pinocchio", "status": "FAIL", "residual": None,
                       "method": "could not run: ValueError: index_mimicking is greater than index_mimicked"}]
    assert _row(report, MUJOCO)["status"] == "pass"


def test_damping_on_a_ball_joint_is_off_on_mujocos_side_too(tmp_path):
    code, report, stderr = _check(tmp_path, "ball.xml", BALL)
    assert "joint 'swivel': armature, damping on a spherical joint not modelled" in stderr
    assert code == 0, report
    row = _row(report, MUJOCO)
    assert row["status"] == "pass" and row["residual"] < 1e-9, row


def test_the_hinge_damping_is_still_compared_with_mujoco(tmp_path):
    """Only the ball joint's terms are switched off: a wrong hinge damping still fails."""
    code, report, _ = _check(tmp_path, "ball.xml", BALL.replace('damping="0.2"', 'damping="0.2" armature="0.1"'))
    assert _row(report, MUJOCO)["status"] == "pass"
    from dynderive.verify import mujoco_checks

    class Model:   # a hinge, a ball and a free joint: only the last two lose their terms
        njnt = 3
        jnt_type = [3, 1, 0]
        jnt_dofadr = [0, 1, 4]
        dof_armature = [1.0] * 10
        dof_damping = [2.0] * 10
        dof_frictionloss = [3.0] * 10
        jnt_stiffness = [4.0] * 3

    model = Model()
    for key in ("dof_armature", "dof_damping", "dof_frictionloss", "jnt_stiffness"):
        setattr(model, key, np.array(getattr(model, key)))
    mujoco_checks._unmodelled_drives_off(model)
    assert list(model.dof_damping) == [2.0] + [0.0] * 9
    assert list(model.jnt_stiffness) == [4.0, 0.0, 0.0]


# -- what the reader says ---------------------------------------------------------------------------

FIXTURES = Path(__file__).parent / "mjcf"
#: A floating pelvis, a thigh and a rod tied by two connects (six rows of rank five), an inactive weld.
TWO_CONNECTS = (FIXTURES / "two_connects.xml").read_text()


@pytest.mark.parametrize(("root", "joint"), [("<freejoint name=\"root\"/>", "hinge"),
                                            ("<joint name=\"root\" type=\"ball\"/>", "hinge"), ("", "ball")])
def test_connect_loops_on_a_model_with_quaternions_are_closed(tmp_path, root, joint):
    """Two connects on a free, ball or fixed base with a ball joint in the loop: the loops are
    rows on the tree's twists; check assembles states on them and every row passes, MuJoCo's
    hard limit too (on a fixed base with the ball joint the linkage is locked: no motion, and
    accelerations that are rounding on both sides)."""
    text = TWO_CONNECTS.replace('<freejoint name="root"/>', root).replace(
        '<joint name="rod_joint" type="hinge"', f'<joint name="rod_joint" type="{joint}"')
    code, report, stderr = _check(tmp_path, "loop.xml", text)
    assert code == 0 and report["passed"], report
    rows = {row["name"]: row for row in report["checks"]}
    assert rows["loop constraints a_g = 0 at 3 assembled states"]["status"] == "pass"
    assert rows["A_g qd = 0 for the velocities the loops allow"]["status"] == "pass"
    closed = next(row for name, row in rows.items() if name.endswith("+ A^T loop_forces at forward_dynamics' qdd"))
    assert closed["status"] == "pass" and closed["residual"] < 1e-9
    assert _row(report, MUJOCO)["status"] == "pass" and _row(report, MUJOCO)["residual"] < 1e-9
    assert "<connect>" not in stderr


# -- MuJoCo's constrained accelerations, in the hard limit, for models with loops -------------------

HARD_LIMIT = "agrees with MuJoCo (mj_fullM, qfrc_bias, qacc in the hard limit of its connect equalities)"


@pytest.mark.parametrize("name", ["floating_loop.xml", "loop.xml", "two_connects.xml"])
def test_the_mujoco_row_compares_the_closed_loops_with_its_hard_limit(tmp_path, name):
    """A floating torso with a ball joint in the loop, a fixed-base five-bar, two connects of
    dependent rows: ``forward_dynamics`` with the loops closed equals MuJoCo's constrained
    accelerations in the hard limit (``verify/mujoco_hard_limit``) at 5 assembled states."""
    code, report, _ = _check(tmp_path, name, (FIXTURES / name).read_text())
    assert code == 0 and report["passed"], report
    row = _row(report, MUJOCO)
    assert row["name"] == HARD_LIMIT and row["status"] == "pass", row
    assert row["residual"] < 1e-9 and row["method"].startswith("numeric, 5 states, relative"), row


def test_a_connect_between_sites_is_compared_too(tmp_path):
    """``connect site1 site2``: the rows' Jdot qvel is taken at the sites' origins."""
    import mujoco

    text = (FIXTURES / "loop.xml").read_text()
    second = " ".join(repr(float(v)) for v in mujoco.MjModel.from_xml_string(text).eq_data[0, 3:6])
    text = text.replace('<joint name="jb"', '<site name="pin" pos="0.2391 -0.0127 0.0183"/>\n        <joint name="jb"')
    text = text.replace('<joint name="je"', f'<site name="hole" pos="{second}"/>\n          <joint name="je"')
    text = text.replace('body1="b" body2="e" anchor="0.2391 -0.0127 0.0183"', 'site1="pin" site2="hole"')
    code, report, _ = _check(tmp_path, "loop_sites.xml", text)
    assert code == 0 and report["passed"], report
    row = _row(report, MUJOCO)
    assert (row["name"], row["status"]) == (HARD_LIMIT, "pass") and row["residual"] < 1e-9, row


@pytest.mark.parametrize(("replace", "reason"), [
    (('active="false"', ""), "MuJoCo's weld equality 'equality0' is not modelled here: constrained accelerations "
                             "not compared"),
    (("</equality>", '  <connect body1="rod" anchor="0 0 -0.4"/>\n  </equality>'),
     "1 of MuJoCo's 3 connect equalities are not loops here (to the world or within one rigid body): constrained "
     "accelerations not compared"),
], ids=["weld", "connect to the world"])
def test_an_equality_not_closed_here_skips_the_mujoco_row_saying_which(tmp_path, replace, reason):
    """An active weld (not modelled), or a connect to the world (not a loop here) that MuJoCo
    enforces: MuJoCo's constrained accelerations are not ours, so the row says why it is skipped;
    the rest of the table still passes."""
    code, report, stderr = _check(tmp_path, "loop.xml", TWO_CONNECTS.replace(*replace))
    assert code == 0 and report["passed"], report
    row = _row(report, MUJOCO)
    assert (row["name"], row["status"], row["method"]) == (HARD_LIMIT, "skip", reason)
    assert "is not modelled" in stderr   # the reader's note at the equality's line


def test_the_hard_limit_row_fails_on_a_module_whose_loops_are_open():
    """The open tree's accelerations (the loops' forces left out), or a mass matrix 1 % off,
    fail the row."""
    derivation = dynderive.derive(dynderive.load_robot(FIXTURES / "floating_loop.xml"))
    module = generated_module(dynderive.render_code(derivation), derivation.robot.name)
    values = {p.name: p.value for p in derivation.robot.parameters}

    def open_tree(q, qd, u, **p):
        tau = np.zeros(len(qd))
        tau[list(module.EFFORT_COLUMNS)] = u
        return np.linalg.solve(module.mass_matrix(q, **p), tau - module.inverse_dynamics(q, qd, 0 * qd, **p))

    for name, wrong in (("forward_dynamics", open_tree),
                        ("mass_matrix", lambda q, **p: 1.01 * module.mass_matrix(q, **p))):
        off = types.SimpleNamespace(**vars(module))
        setattr(off, name, wrong)
        (row,) = mujoco_rows(derivation, off, values, 2, np.random.default_rng(0))
        assert row.status == "FAIL" and row.residual > 1e-3, (name, row)
    (row,) = mujoco_rows(derivation, module, values, 2, np.random.default_rng(0))
    assert row.status == "pass" and row.residual < 1e-9, row


def test_each_explicit_contact_pair_and_exclude_has_its_note(tmp_path):
    text = """<mujoco model="pairs">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="a">
      <joint name="j" type="hinge"/>
      <geom name="ga" size="0.1" contype="0" conaffinity="0"/>
      <body name="b" pos="0 0 -0.3">
        <joint name="k" type="hinge"/>
        <geom name="gb" size="0.1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <contact>
    <pair name="foot" geom1="gb" geom2="floor"/>
    <pair geom1="ga" geom2="floor"/>
    <exclude body1="a" body2="b"/>
  </contact>
</mujoco>
"""
    robot = tmp_path / "pairs.xml"
    robot.write_text(text)
    result = runner.invoke(app, ["solve", str(robot), "--json", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if ": note: contact " in line]
    hint = "is not modelled (declare contacts: in a YAML robot file made by import to hold chosen frames)"
    assert notes == [f"{robot}:14:5: note: contact pair 'foot' of geoms 'gb' and 'floor' {hint}",
                     f"{robot}:15:5: note: contact pair of geoms 'ga' and 'floor' {hint}",
                     f"{robot}:16:5: note: contact exclude of bodies 'a' and 'b' changes nothing here: contacts "
                     "are not modelled"]
