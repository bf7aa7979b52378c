"""From the new-user trial (issue 13, item 8): parameters on the command line, a PDF that
cannot be built does not cost the other outputs, bundled names for ``import``, reader notes."""

from __future__ import annotations

import textwrap

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

runner = CliRunner()

NO_DEFAULT = textwrap.dedent("""\
    name: np
    planar: true
    parameters: {m: 1.0, k: ~}
    gravity: [0, -9.81]
    links:
      - {name: link1, mass: m*k, com: [0.5, 0], inertia: 0.1}
    joints:
      - {name: q1, type: revolute, parent: world, child: link1}
    """)


@pytest.fixture
def no_default(tmp_path):
    path = tmp_path / "np.yaml"
    path.write_text(NO_DEFAULT)
    return path


def test_simulate_names_a_parameter_without_default(no_default):
    result = runner.invoke(app, ["simulate", str(no_default), "--duration", "0.1"])
    assert result.exit_code == 2
    assert result.stderr == f"{no_default}:3:22: parameter 'k' has no default value: give one with --param k=VALUE\n"


def test_simulate_takes_parameters(no_default, tmp_path):
    csv = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", str(no_default), "--duration", "0.2", "--param", "k=2",
                                 "--param", "m=pi/4", "--csv", str(csv), "-q"])
    assert result.exit_code == 0, result.output
    assert "largest relative energy change" in result.stdout and csv.is_file()


@pytest.mark.parametrize("args, message", [
    (["--param", "z=2"], "--param:1:1: unknown parameter 'z' (parameters of np: m, k)"),
    (["--param", "k"], "--param:1:1: expected NAME=VALUE, got 'k'"),
    (["--param", "k=sqrt(-1)"], "--param:1:3: k:"),   # column of the value
    (["--param", "k=__import__('os')"], "--param:1:3: k:"),
])
def test_bad_parameters_are_exit_2(no_default, args, message):
    result = runner.invoke(app, ["simulate", str(no_default), "--duration", "0.1", *args])
    assert result.exit_code == 2
    assert result.stderr.splitlines()[0].startswith(message), result.stderr


def test_check_takes_parameters(no_default):
    result = runner.invoke(app, ["check", str(no_default), "--param", "k=3", "--json", "-q"])
    assert result.exit_code == 0, result.output
    assert '"passed": true' in result.stdout


def test_pdf_without_tex_still_writes_the_other_outputs(tmp_path, monkeypatch):
    import dynderive.render.sheets.pdf as pdf

    monkeypatch.setattr(pdf, "latex_engine_available", lambda: False)
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", "rp_arm", "--latex", "--pdf", "--code", "--out", str(out), "-q"])
    assert result.exit_code == 1
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.tex", "rp_arm_dynamics.py"]
    assert "rp_arm.pdf skipped: --pdf needs latexmk" in result.stderr


def test_pdf_without_tikz_says_which_package(tmp_path, monkeypatch):
    """TeX without texlive-pictures: the drawing's TikZ is named before LaTeX fails on it."""
    import dynderive.render.sheets.pdf as pdf

    monkeypatch.setattr(pdf, "latex_engine_available", lambda: True)
    monkeypatch.setattr(pdf, "tikz_available", lambda: False)
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", "rp_arm", "--pdf", "--code", "--out", str(out), "-q"])
    assert result.exit_code == 1
    assert "rp_arm.pdf skipped: --pdf: the sheet's drawing needs TikZ" in result.stderr
    assert "apt-get install texlive-pictures" in result.stderr
    assert "rp_arm_dynamics.py" in [p.name for p in out.iterdir()]


def test_import_accepts_bundled_names(tmp_path):
    result = runner.invoke(app, ["import", "ur5", "-o", str(tmp_path / "ur5.yaml")])
    assert result.exit_code == 0, result.output
    assert "name: ur5" in (tmp_path / "ur5.yaml").read_text()
    refused = runner.invoke(app, ["import", "rp_arm", "-o", str(tmp_path / "x.yaml")])
    assert refused.exit_code == 2 and "already a YAML robot file" in refused.stderr


def test_reader_notes_are_shown(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(textwrap.dedent("""\
        <robot name="arm">
          <link name="base"/>
          <link name="tool"/>
          <link name="l1"><inertial><mass value="1.5"/><origin xyz="0.1 0 0"/>
            <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
          <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>
          <joint name="weld" type="fixed"><parent link="l1"/><child link="tool"/><mimic joint="j1"/></joint>
        </robot>
        """))
    result = runner.invoke(app, ["solve", str(urdf), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "note: <mimic> on fixed joint 'weld' ignored" in result.stderr
