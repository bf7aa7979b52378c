"""MJCF (MuJoCo) files as robot files, through every command.

* Bad MJCF (not XML, schema violations, MuJoCo's compile errors, errors inside an
  ``<include>``d file) and our own validator's refusals: one ``FILE:LINE:COL:`` line at the
  element, exit code 2, no traceback, nothing written.
* Without the mujoco package: one line saying what to install.
* What the equations leave out (tendons, limits, contacts, fluid, other equalities, actuators
  that are not joint motors): a ``note:`` at the element's line.
* solve (sheet, code, C, MATLAB, JSON), check, simulate, linearize, identify, build and import
  read MJCF; M and the bias forces agree with MuJoCo's own (mj_fullM, qfrc_bias); the imported
  YAML gives the same M; a URDF named ``.xml`` is still a URDF.
* Outputs are byte-identical across processes; hostile names and titles change no program.
"""

from __future__ import annotations

import ast
import html
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.input.sources import kind_of
from dynderive.render.encode import escape_tex

from conftest import import_code

mujoco = pytest.importorskip("mujoco")
from conftest import compiled_model  # noqa: E402  (MjSpec: no MUJOCO_LOG.TXT)

HERE = Path(__file__).resolve().parent
FIXTURES = HERE / "mjcf_input"
ARM = FIXTURES / "arm.xml"
NOTES = FIXTURES / "notes.xml"
runner = CliRunner()


def _line_col(path: Path, text: str) -> tuple[int, int]:
    """Line and column (1-based) of the first occurrence of ``text`` in the file."""
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if text in line:
            return number, line.index(text) + 1
    raise AssertionError(f"{text!r} not in {path}")


def _refused(path: Path, tmp_path: Path, command: str = "solve") -> str:
    """Run ``command`` on ``path``: exit 2, exactly one positioned line besides ``note:`` lines,
    no traceback, nothing written. Returns the line."""
    out = tmp_path / "out"
    args = [command, str(path)] + (["--json", "--code", "--out", str(out)] if command == "solve" else ["-q"])
    result = runner.invoke(app, args)
    assert result.exit_code == 2, (result.exit_code, result.output)
    lines = result.stderr.strip().splitlines()
    assert all(re.match(r"^\S.*?:\d+:\d+: ", line) for line in lines), result.stderr
    lines = [line for line in lines if not re.match(r"^\S.*?:\d+:\d+: note: ", line)]
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.output and "internal error" not in result.output
    assert not out.exists() or not any(out.iterdir())
    return lines[0]


def _model(body: str, extra: str = "", name: str = "bad") -> str:
    """An MJCF text: ``body`` in the worldbody, ``extra`` after it (line 3 is the worldbody's first)."""
    return f'<mujoco model="{name}">\n  <worldbody>\n{body}  </worldbody>\n{extra}</mujoco>\n'


HINGE = '    <body name="a">\n      <joint name="j" type="hinge"{attrs}/>\n      <geom size="0.1"/>\n    </body>\n'

#: (MJCF text, line, column, words of the message after ``MuJoCo: ``)
BAD = {
    "unclosed element": (_model('    <body name="a">\n'), 3, 5, "XML parse error: mismatched element (<body>)"),
    "unclosed quote": (_model('    <body name="a>\n    </body>\n'), 3, 5, "XML parse error: parsing attribute"),
    "not XML": ("just some text\n", 1, 1, "XML parse error"),
    "unknown attribute": (_model(HINGE.format(attrs=' bogus="1"')), 4, 7,
                          "Schema violation: unrecognized attribute: 'bogus' (<joint>)"),
    "unknown element": (_model("    <bogus/>\n"), 3, 5, "Schema violation: unrecognized element (<bogus>)"),
    "not a number": (_model('    <body pos="1 x 2"><joint/><geom size=".1"/></body>\n'), 3, 5,
                     "bad format in attribute 'pos' (<body>)"),
    "reversed range": (_model(HINGE.format(attrs=' range="1 -1" limited="true"')), 4, 7,
                       "range[0] should be smaller than range[1] in joint (element 'j')"),
    "zero axis": (_model(HINGE.format(attrs=' axis="0 0 0"')), 4, 7, "axis too small in joint (element 'j')"),
    "massless moving body": (_model('    <body name="a">\n      <joint name="j"/>\n    </body>\n'), 3, 5,
                             "mass and inertia of moving bodies must be larger than mjMINVAL (element 'a')"),
    "missing include": ('<mujoco model="bad">\n  <include file="missing.xml"/>\n</mujoco>\n', 2, 3,
                        "Error opening file 'missing.xml' (<include>)"),
    "unknown joint of an actuator": (_model(HINGE.format(attrs=""), '  <actuator>\n    <motor joint="nope"/>\n'
                                            "  </actuator>\n"), 9, 5, "unknown transmission target 'nope'"),
    "repeated name": (_model(HINGE.format(attrs="") + HINGE.format(attrs="").replace('"a"', '"b"')), 8, 7,
                      "repeated name 'j' in joint"),
    "not a MuJoCo model": ("<foo>\n</foo>\n", 1, 1, "Unrecognized XML model type: 'foo'"),
    "empty": ("", 1, 1, "empty file"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_mjcf_is_one_positioned_line_and_writes_nothing(case, tmp_path):
    text, line, column, words = BAD[case]
    path = tmp_path / "bad.xml"
    path.write_text(text)
    message = _refused(path, tmp_path)
    assert message.startswith(f"{path}:{line}:{column}: MuJoCo: "), message
    assert words in message, message


def test_a_model_without_joints_is_one_line_at_the_worldbody(tmp_path):
    path = tmp_path / "still.xml"
    path.write_text(_model('    <body name="fixed" pos="0 0 1">\n      <geom size="0.1"/>\n    </body>\n'))
    assert _refused(path, tmp_path) == (f"{path}:2:3: the model has no joint: every body is welded to the world "
                                        "and nothing moves")


def test_check_refuses_bad_mjcf_the_same_way(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text(BAD["reversed range"][0])
    assert _refused(path, tmp_path, "check").startswith(f"{path}:4:7: MuJoCo: range[0]")


PART = '<mujoco>\n  <worldbody>\n    <body name="b">\n      <joint name="k" type="hinge"{attrs}/>\n{geom}' \
       '    </body>\n  </worldbody>\n</mujoco>\n'
GEOM = '      <geom size="0.1"/>\n'


@pytest.mark.parametrize("part, line, column, words", [
    (PART.format(attrs=' range="2 1" limited="true"', geom=GEOM), 4, 7, "range[0] should be smaller than range[1]"),
    (PART.format(attrs=' bogus="2"', geom=GEOM), 4, 7, "unrecognized attribute: 'bogus' (<joint>)"),
    (PART.format(attrs="", geom=""), 3, 5, "mass and inertia of moving bodies must be larger than mjMINVAL"),
    # the quote left open ends on the next line, where TinyXML stops
    (PART.format(attrs="", geom=GEOM).replace('name="b"', 'name="b'), 4, 7, "XML parse error: parsing attribute"),
])
def test_an_error_in_an_included_file_is_placed_in_that_file(part, line, column, words, tmp_path):
    """MuJoCo gives an included element line 0 (or, for a file it cannot parse, the line of the
    ``<include>``): the message is placed in the included file (found by the element's name or
    attribute) and names the ``<include>`` that brought it."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "part.xml").write_text(part)
    main = tmp_path / "main.xml"
    main.write_text('<mujoco model="m">\n  <option timestep="0.01"/>\n  <include file="sub/part.xml"/>\n</mujoco>\n')
    message = _refused(main, tmp_path)
    assert message.startswith(f"{tmp_path / 'sub' / 'part.xml'}:{line}:{column}: MuJoCo: "), message
    assert words in message and message.endswith(f"(included from {main}:3)"), message


def test_an_included_element_that_cannot_be_found_is_placed_at_the_include(tmp_path):
    """Two included files both hold a ``<joint bogus>``: which one MuJoCo means is not known,
    so the message stands at the first ``<include>``."""
    for name in ("p1.xml", "p2.xml"):
        (tmp_path / name).write_text(PART.format(attrs=' bogus="2"', geom=GEOM).replace('"b"', f'"{name[:2]}"')
                                     .replace('"k"', f'"k{name[1]}"'))
    main = tmp_path / "main.xml"
    main.write_text('<mujoco model="m">\n  <include file="p1.xml"/>\n  <include file="p2.xml"/>\n</mujoco>\n')
    message = _refused(main, tmp_path)
    assert message.startswith(f"{main}:2:3: MuJoCo: Schema violation: unrecognized attribute"), message
    assert message.endswith("(in an included file)")


@pytest.mark.parametrize("inertial, words", [
    # two hinges about one axis: their difference moves nothing
    (None, "the motion -j1 + j2 of coordinates 'j1', 'j2' moves no mass or inertia"),
    # a point mass on the axis of its hinge (MuJoCo accepts an inertia above 1e-15)
    ('<inertial pos="0 0 0" mass="1" diaginertia="1 1 1e-13"/>', "coordinate 'j2' moves no mass or inertia"),
])
def test_our_validator_on_mjcf_data_is_positioned_at_the_joint(inertial, words, tmp_path):
    """MuJoCo compiles these models; their mass matrix is singular, which our validator refuses
    at the joint's XML element."""
    if inertial is None:
        body = ('    <body name="a">\n      <joint name="j1" axis="0 0 1"/>\n      <joint name="j2" axis="0 0 1"/>\n'
                '      <geom size="0.1" pos="0.3 0 0"/>\n    </body>\n')
        line, column = 4, 7
    else:
        body = ('    <body name="a">\n      <joint name="j1" type="slide" axis="1 0 0"/>\n      <geom size="0.1"/>\n'
                f'      <body name="b">\n        <joint name="j2" axis="0 0 1"/>\n        {inertial}\n'
                '      </body>\n    </body>\n')
        line, column = 7, 9
    path = tmp_path / "singular.xml"
    path.write_text(_model(body))
    message = _refused(path, tmp_path)
    assert message.startswith(f"{path}:{line}:{column}: "), message
    assert "the mass matrix is singular" in message and words in message, message


# -- without the mujoco package ----------------------------------------------------------------

def test_without_mujoco_an_mjcf_file_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)   # import mujoco raises ImportError
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(ARM), "--json", "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip().splitlines() == [
        f'{ARM}:1:1: reading an MJCF file needs the mujoco package, which is not installed: '
        'pip install "dynderive[mjcf]"']
    assert not out.exists()
    # YAML and URDF files need no mujoco
    assert runner.invoke(app, ["solve", "rp_arm", "--json", "--out", str(out), "-q"]).exit_code == 0
    urdf = tmp_path / "elbow.xml"
    shutil.copy(HERE / "floating_elbow.urdf", urdf)
    assert dynderive.load_robot(urdf).name == "two_link"


def test_without_mujoco_in_a_fresh_process(tmp_path):
    """The same from ``python -m dynderive`` (nothing of mujoco imported before)."""
    script = ("import sys; sys.modules['mujoco'] = None; sys.argv = ['dynderive', 'check', sys.argv[1], '-q']\n"
              "from dynderive.commands.cli import app\napp()")
    done = subprocess.run([sys.executable, "-c", script, str(ARM)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == "", done
    assert done.stderr.strip().splitlines() == [
        f'{ARM}:1:1: reading an MJCF file needs the mujoco package, which is not installed: '
        'pip install "dynderive[mjcf]"']


# -- notes ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def notes_check():
    """``check`` on the model with everything the equations leave out (notes on stderr)."""
    result = runner.invoke(app, ["check", str(NOTES), "--states", "2"])
    assert result.exit_code == 0, result.output
    return result


@pytest.mark.parametrize("element, words", [
    ('<spatial name="cable">', "tendon 'cable' is not modelled"),
    ('<joint name="j1"', "joint limits (1 joint: j1) are not modelled"),
    ('<geom name="g1"', "contacts of 1 colliding geom are not modelled"),
    ("<option ", "fluid forces (option viscosity, density) are not modelled"),
    ('<weld name="glue"', "equality 'glue'"),
    ('<motor name="pull"', "actuator 'pull': its transmission (not a joint) is not modelled"),
    ('<position name="servo"', "actuator 'servo': its force depends on the state (a servo): not modelled"),
    ('<joint name="j3"', "joint 'j3': frictionloss 0.2 becomes Coulomb friction"),
])
def test_what_the_equations_leave_out_is_a_note_at_its_element(element, words, notes_check):
    result = notes_check
    line, column = _line_col(NOTES, element)
    notes = [n for n in result.stderr.splitlines() if n.startswith(f"{NOTES}:{line}:{column}: note: ")]
    assert any(words in n for n in notes), result.stderr


def test_notes_are_shown_by_solve_and_import_too(tmp_path):
    for args in (["solve", str(NOTES), "--json", "--out", str(tmp_path)], ["import", str(NOTES), "-o",
                                                                           str(tmp_path / "n.yaml")]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        assert "note: tendon 'cable' is not modelled" in result.stderr


# -- every command ---------------------------------------------------------------------------------

def test_urdf_named_xml_is_read_as_urdf(tmp_path):
    urdf = tmp_path / "elbow.xml"
    shutil.copy(HERE / "floating_elbow.urdf", urdf)
    assert kind_of(urdf) == "urdf" and kind_of(ARM) == "mjcf" and kind_of(HERE / "floating_elbow.urdf") == "urdf"
    as_xml, as_urdf = dynderive.load_robot(urdf), dynderive.load_robot(HERE / "floating_elbow.urdf")
    assert as_xml.links == as_urdf.links and as_xml.joints == as_urdf.joints


@pytest.fixture(scope="module")
def arm_module(tmp_path_factory):
    derivation = dynderive.derive(dynderive.load_robot(ARM))
    return derivation, import_code(dynderive.render_code(derivation), tmp_path_factory.mktemp("arm"), "mj_arm_dyn")


def test_arm_agrees_with_mujoco(arm_module):
    """M (armature on its diagonal) and the bias forces (Coriolis, gravity, the spring, damping)
    equal MuJoCo's at random full-precision states: q is MuJoCo's qpos (``ref`` folded in)."""
    derivation, module = arm_module
    assert list(module.COORDINATES) == ["shoulder", "reach", "fore_joint2"]
    model = compiled_model(str(ARM))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, qd = rng.uniform(-1.5, 1.5, 3), rng.uniform(-2, 2, 3)
        data.qpos[:], data.qvel[:] = q, qd
        mujoco.mj_forward(model, data)
        M = np.zeros((3, 3))
        mujoco.mj_fullM(model, data, M)
        np.testing.assert_allclose(module.mass_matrix(q), M, rtol=0, atol=1e-13 * np.abs(M).max())
        bias = data.qfrc_bias - data.qfrc_spring - data.qfrc_damper
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, np.zeros(3)), bias, rtol=0, atol=1e-12)
    # the effort is the generalized force: gear x the motor's control
    data.ctrl[:] = [0.7, -0.4]
    mujoco.mj_forward(model, data)
    assert [j.effort for j in derivation.robot.joints] == ["tau_shoulder", "f_reach", None]
    np.testing.assert_allclose(data.qfrc_actuator[:2], [3 * 0.7, -0.4], rtol=1e-15)


def _rotation(wxyz: np.ndarray) -> np.ndarray:
    w, x, y, z = wxyz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_free_joint_conventions_map_onto_mujoco(tmp_path):
    """The MJCF page's formulas: q = [p, q_xyz, q_w, ...] against MuJoCo's [p, q_w, q_xyz, ...];
    qd = T qd_mj with T = diag(R^T, I); M_mj = T^T M T; qfrc_bias = T^T inverse_dynamics(q, qd, c)
    and qacc = T^-1 (forward_dynamics(q, qd) - c), c = [-w x v_local, 0, ...]."""
    path = FIXTURES / "floating.xml"
    module = import_code(dynderive.render_code(dynderive.derive(dynderive.load_robot(path))), tmp_path, "mj_float_dyn")
    assert module.NQ == 8 and module.NV == 7
    model = compiled_model(str(path))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    for _ in range(4):
        quaternion = rng.normal(size=4)
        quaternion /= np.linalg.norm(quaternion)
        qpos = np.concatenate([rng.uniform(-1, 1, 3), quaternion, rng.uniform(-1.5, 1.5, 1)])
        qvel = rng.uniform(-2, 2, 7)
        data.qpos[:], data.qvel[:] = qpos, qvel
        mujoco.mj_forward(model, data)
        R = _rotation(quaternion)
        T = np.eye(7)
        T[:3, :3] = R.T
        q = np.concatenate([qpos[:3], quaternion[1:], quaternion[:1], qpos[7:]])
        qd = T @ qvel
        c = np.zeros(7)
        c[:3] = -np.cross(qd[3:6], qd[:3])
        M = np.zeros((7, 7))
        mujoco.mj_fullM(model, data, M)
        np.testing.assert_allclose(T.T @ module.mass_matrix(q) @ T, M, rtol=0, atol=1e-13)
        np.testing.assert_allclose(T.T @ module.inverse_dynamics(q, qd, c), data.qfrc_bias, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.linalg.solve(T, module.forward_dynamics(q, qd) - c), data.qacc,
                                   rtol=0, atol=1e-10)


def test_check_passes_on_an_mjcf_file():
    result = runner.invoke(app, ["check", str(ARM), "--states", "2"])
    assert result.exit_code == 0, result.output
    assert re.search(r"\n\d+ passed, 0 failed", result.stdout), result.stdout


def test_simulate_csv(tmp_path):
    csv = tmp_path / "arm.csv"
    result = runner.invoke(app, ["simulate", str(ARM), "--duration", "0.2", "--frames", "5", "--q0", "0.1,0.2,0.3",
                                 "--csv", str(csv), "-q"])
    assert result.exit_code == 0, result.output
    rows = csv.read_text().splitlines()
    assert rows[0].startswith("t,shoulder,reach,fore_joint2,") and len(rows) == 6
    assert [float(v) for v in rows[1].split(",")[1:4]] == [0.1, 0.2, 0.3]
    assert all(np.isfinite([float(v) for v in row.split(",")]).all() for row in rows[1:])


def test_linearize_and_identify(tmp_path):
    result = runner.invoke(app, ["linearize", str(ARM), "-q"])
    assert result.exit_code == 0, result.output
    assert "mj_arm" in result.stdout and "A =" in result.stdout and "B =" in result.stdout
    result = runner.invoke(app, ["identify", str(ARM), "-q"])
    assert result.exit_code == 0, result.output
    assert "m_fore" in result.stdout and "m_upper" in result.stdout


def test_build_names_outputs_after_the_model(tmp_path):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ARM, robots / "some_file.xml")
    result = runner.invoke(app, ["build", str(robots), "--out", str(tmp_path / "out"), "--json", "--code"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir() if not p.name.startswith(".")) == [
        "mj_arm.json", "mj_arm_dynamics.py"]


def test_imported_yaml_gives_the_same_mass_matrix(tmp_path, arm_module):
    _, module = arm_module
    out = tmp_path / "arm.yaml"
    result = runner.invoke(app, ["import", str(ARM), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text().startswith("# Imported by dynderive")
    yaml_module = import_code(dynderive.render_code(dynderive.derive(dynderive.load_robot(out))), tmp_path,
                              "mj_arm_yaml_dyn")
    rng = np.random.default_rng(11)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, 3))
        np.testing.assert_allclose(yaml_module.mass_matrix(q), module.mass_matrix(q), rtol=0, atol=1e-14)
        np.testing.assert_allclose(yaml_module.inverse_dynamics(q, qd, qdd), module.inverse_dynamics(q, qd, qdd),
                                   rtol=0, atol=1e-13)


@pytest.mark.parametrize("option, words", [
    (["--floating-base"], "--floating-base:1:1: --floating-base floats a URDF's root link"),
    (["--symbolic", "*.mass"], "--symbolic:1:1: --symbolic makes a URDF's inertial values parameters"),
])
def test_urdf_only_options_are_refused_on_mjcf(option, words, tmp_path):
    result = runner.invoke(app, ["solve", str(ARM), "--json", "--out", str(tmp_path / "out"), *option])
    assert result.exit_code == 2 and result.stderr.startswith(words), result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.pdf
def test_the_sheet_of_an_mjcf_file_compiles(tmp_path):
    if shutil.which("latexmk") is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must run the PDF tests, but latexmk is missing")
        pytest.skip("no TeX engine")
    result = runner.invoke(app, ["solve", str(ARM), "--latex", "--pdf", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "mj_arm.pdf").read_bytes().startswith(b"%PDF")


# -- determinism -----------------------------------------------------------------------------------

def test_solve_outputs_are_named_after_the_model_and_byte_identical_across_processes(tmp_path):
    """The sheet, the NumPy and C code and the JSON of two processes with different hash seeds."""
    outputs = []
    for seed in ("1", "2"):
        out = tmp_path / seed
        done = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(ARM), "--latex", "--code", "--c",
                               "--json", "--out", str(out), "-q"], capture_output=True, text=True,
                              timeout=300, env={**os.environ, "PYTHONHASHSEED": seed})
        assert done.returncode == 0, done.stderr
        outputs.append({p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert sorted(outputs[0]) == ["mj_arm.json", "mj_arm.tex", "mj_arm_dynamics.c", "mj_arm_dynamics.h",
                                  "mj_arm_dynamics.py"]
    assert b"\\begin{document}" in outputs[0]["mj_arm.tex"] and b"fore\\_joint2" in outputs[0]["mj_arm.tex"]
    for name in outputs[0]:
        assert outputs[0][name] == outputs[1][name], name


# -- hostile text ----------------------------------------------------------------------------------

MARKER = "dynderive_pwned"
#: A model title (``<mujoco model>``) and names that break naive encoders: C comment ends,
#: trigraphs, LaTeX specials, quotes, backslashes, a Python statement; one line (the robot's name,
#: made from the title, names MATLAB's package: at most 63 characters). Long names: 90 and 500.
TITLE = 'T */ \\input{/x} $x$ %"q" \' ??/ """;open("dynderive_pwned","w")#'
NAMES = {"body": 'a\\b$c{d}*/e"f', "joint": 'j$1{x}*/"', "site": 's\\"{*/}'}


def _hostile_model(directory: Path) -> Path:
    def attr(text: str) -> str:
        return html.escape(text, quote=True)

    path = directory / "hostile.xml"
    path.write_text(f"""<mujoco model="{attr(TITLE)}">
  <worldbody>
    <body name="{attr(NAMES['body'])}" pos="0 0 1">
      <joint name="{attr(NAMES['joint'])}" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1.25"/>
      <site name="{attr(NAMES['site'])}" pos="0.5 0 0"/>
      <body name="{'b' * 500}" pos="0.5 0 0">
        <joint name="{'k' * 90}" axis="0 1 0"/>
        <geom type="sphere" size="0.05" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="{attr(NAMES['joint'])}"/></actuator>
</mujoco>
""", encoding="utf-8")
    return path


def _solve_hostile(tmp_path: Path, *targets: str) -> tuple[Path, str]:
    path = _hostile_model(tmp_path)
    robot = dynderive.load_robot(path)
    assert robot.title == TITLE and len(TITLE) <= 63
    names = [j.name for j in robot.joints] + [link.name for link in robot.links]
    assert all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", n) for n in names), names
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), *targets, "--out", str(out), "-q"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    return out, robot.name


def test_hostile_names_and_title_change_no_program(tmp_path):
    from test_matlab_script import _matlab_problems

    out, name = _solve_hostile(tmp_path, "--latex", "--code", "--matlab", "--json")
    # the NumPy module: imported in a child process, nothing runs, the title reads back
    script = (f"import sys; sys.path.insert(0, {str(out)!r}); import {name}_dynamics as m; "
              "print(m.__doc__); print(m.mass_matrix([0.3, 0.2])[0][0])")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert TITLE in run.stdout and not (tmp_path / MARKER).exists()
    ast.parse((out / f"{name}_dynamics.py").read_text(encoding="utf-8"))
    # the sheet: the title escaped, nothing opens a command
    tex = (out / f"{name}.tex").read_text(encoding="utf-8")
    assert escape_tex(TITLE) in tex and "\\input{/x}" not in tex
    # MATLAB: the text only ever inside comments
    matlab = (out / f"{name}_derivation.m").read_text(encoding="utf-8")
    assert "open(" in matlab and _matlab_problems(matlab) == []
    for line in matlab.splitlines():
        if "input{" in line or "open(" in line:
            assert line.lstrip().startswith("%"), line
    assert not (tmp_path / MARKER).exists()


def test_hostile_title_in_c(tmp_path):
    from test_c_target import _compile, _decode

    out, name = _solve_hostile(tmp_path, "--c")
    header = (out / f"{name}_dynamics.h").read_text()
    _compile(out / f"{name}_dynamics.c")
    assert not [ln for ln in header.splitlines() if ln.startswith("#include")]
    assert all(ln.count("/*") == ln.count("*/") <= 1 for ln in header.splitlines())
    assert _decode(header.splitlines()[0].split("equations of motion of ", 1)[1][:-3]) == TITLE


def test_names_in_other_scripts_are_read(tmp_path):
    path = tmp_path / "unicode.xml"
    path.write_text('<mujoco model="bras_é">\n  <worldbody>\n    <body name="épaule">\n      <joint name="機械"/>\n'
                    '      <geom size="0.1" pos="0.3 0 0"/>\n    </body>\n  </worldbody>\n</mujoco>\n', encoding="utf-8")
    robot = dynderive.load_robot(path)
    assert robot.title == "bras_é" and len(robot.joints) == 1
    assert (robot.name, robot.links[0].name, robot.joints[0].name) == ("bras_e", "epaule", "epaule_joint1")
