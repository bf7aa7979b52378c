"""Careless and hostile outputs, build manifests and templates (issue 27, items 5, 6 and 7):
each case exits 2 with a positioned one-line message, or 0 with a correct result."""

from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from dynderive.commands import output
from dynderive.commands.cli import app
from dynderive.commands.output import MAX_ANIMATION_FRAMES, MAX_FRAMES, write_all
from dynderive.errors import OutputError

from conftest import ROBOTS

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ROOT / "templates"
SRC = str(ROOT / "src")

URDF = ('<?xml version="1.0"?>\n<robot name="swing">\n  <link name="base"/>\n'
        '  <link name="a">\n    <inertial><origin xyz="0.5 0 0"/><mass value="1"/>'
        '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>\n  </link>\n'
        '  <joint name="j1" type="revolute">\n    <parent link="base"/><child link="a"/>\n'
        '    <axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-1" upper="1"/>\n  </joint>\n</robot>\n')


def _run(*args: object):
    return runner.invoke(app, [str(a) for a in args])


def _refused(result, prefix: str) -> str:
    """The one line of a refusal (exit 2, no traceback), which starts with ``prefix``."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and "internal error" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(prefix), result.stderr
    return lines[0]


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


# -- item 5: one path for two outputs, discovery, the manifest's key, the CI example ---------------

@pytest.mark.parametrize("plot,csv", [("run.png", "run.png"), ("run.png", "./run.png"), ("sub/../run.png", "run.png")])
def test_one_path_for_two_outputs_is_refused(tmp_path, monkeypatch, plot, csv):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("simulate", "rp_arm", "--plot", plot, "--csv", csv), "--csv:1:1: ")
    assert "is also the --plot output" in line
    assert not (tmp_path / "run.png").exists()


def test_an_output_that_is_the_robot_file_is_refused(tmp_path):
    robot = tmp_path / "rp_arm.yaml"
    shutil.copy(ROBOTS / "rp_arm.yaml", robot)
    before = robot.read_bytes()
    line = _refused(_run("simulate", robot, "--csv", robot), "--csv:1:1: ")
    assert "is the robot file" in line
    assert robot.read_bytes() == before


def test_build_finds_extensions_in_any_case(tmp_path):
    robots = tmp_path / "robots"
    robots.mkdir()
    (robots / "ARM.URDF").write_text(URDF)
    shutil.copy(ROBOTS / "rp_arm.yaml", robots / "RP.YML")
    result = _run("build", robots, "--out", tmp_path / "out", "--json")
    assert result.exit_code == 0, result.output
    assert "2 built" in result.stdout
    assert json.loads((tmp_path / "out" / "swing.json").read_text())["robot"] == "swing"
    assert (tmp_path / "out" / "rp_arm.json").is_file()


def test_the_manifest_knows_the_same_files_however_they_are_named(tmp_path, monkeypatch):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = tmp_path / "out"
    monkeypatch.chdir(tmp_path)
    first = _run("build", "robots", "--out", out, "--json")
    assert first.exit_code == 0 and "1 built" in first.stdout, first.output
    for spelling in (str(robots), "./robots", "robots/", "robots/../robots"):
        again = _run("build", spelling, "--out", out, "--json")
        assert again.exit_code == 0 and "1 up to date" in again.stdout, (spelling, again.output)
    monkeypatch.chdir(robots)
    inside = _run("build", ".", "--out", "../out", "--json")
    assert inside.exit_code == 0 and "1 up to date" in inside.stdout, inside.output
    records = json.loads((out / ".dynderive-build.json").read_text())["robots"]
    assert list(records) == ["../robots/rp_arm.yaml"]


def test_the_ci_example_installs_dynderive_from_the_checkout():
    """dynderive is on no package index: the workflow installs it from source in its checkout."""
    workflow = yaml.safe_load((ROOT / "examples" / "ci" / "regenerate-sheets.yml").read_text())
    steps = workflow["jobs"]["sheets"]["steps"]
    installs = [line.split("pip install", 1)[1].split()[-1].strip("'\"")
                for step in steps for line in step.get("run", "").splitlines() if "pip install" in line]
    assert installs == ["$DYNDERIVE_SOURCE"]
    source = workflow["env"]["DYNDERIVE_SOURCE"]
    assert source == "."   # the checkout itself (this repository, or a course's fork of it)
    assert 'name = "dynderive"' in (ROOT / source / "pyproject.toml").read_text()
    assert steps[0]["uses"].startswith("actions/checkout") and steps[0]["with"]["submodules"] is True


# -- item 6: import onto its input, outputs across runs, malformed manifests, included templates ----

@pytest.mark.parametrize("spelling", ["src.urdf", "./src.urdf", "sub/../src.urdf"])
def test_import_onto_its_own_input_is_refused(tmp_path, monkeypatch, spelling):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "src.urdf").write_text(URDF)
    line = _refused(_run("import", "src.urdf", "-o", spelling), "--output:1:1: ")
    assert "is the robot file" in line
    assert (tmp_path / "src.urdf").read_text() == URDF


def _named(folder: Path, name: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "arm.yaml"
    path.write_text((ROBOTS / "rp_arm.yaml").read_text().replace("name: rp_arm", f"name: {name}"))
    return path


def test_outputs_another_robot_file_wrote_are_refused_across_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _named(tmp_path / "ba", "arm")
    second = _named(tmp_path / "bc", "arm")
    assert _run("build", "ba", "--out", "OUT", "--json").exit_code == 0
    before = _listing(tmp_path / "OUT")
    line = _refused(_run("build", "bc", "--out", "OUT", "--json"), "bc/arm.yaml:")
    row = next(i for i, text in enumerate(second.read_text().splitlines(), 1) if text.startswith("name:"))
    assert line.startswith(f"bc/arm.yaml:{row}:7: robot name 'arm' is also used by ba/arm.yaml")
    assert _listing(tmp_path / "OUT") == before
    # once ba's robot is renamed, bc may take the name
    _named(tmp_path / "ba", "arm_a")
    assert _run("build", "bc", "--out", "OUT", "--json").exit_code == 0


@pytest.mark.parametrize("record", [
    {"key": "x", "outputs": "<<<<<<< HEAD"},
    {"key": "x", "outputs": ["rp_arm.json"]},
    {"key": "x", "outputs": {"rp_arm.json": 3}},
    {"key": "x", "outputs": {"../../etc/passwd": "0" * 64}},
    {"key": 1, "outputs": {"rp_arm.json": "0" * 64}},
    {"key": "x", "outputs": {"rp_arm.json": "0" * 64}, "sheet": "7 pages"},
    "conflict",
])
def test_a_malformed_manifest_record_is_ignored_with_a_note(tmp_path, record):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = tmp_path / "out"
    assert _run("build", robots, "--out", out, "--json").exit_code == 0
    manifest = out / ".dynderive-build.json"
    document = json.loads(manifest.read_text())
    (name,) = document["robots"]
    document["robots"][name] = record
    manifest.write_text(json.dumps(document))
    result = _run("build", robots, "--out", out, "--json")
    assert result.exit_code == 0, result.output
    assert "1 built" in result.stdout
    assert f"the record of {name} is malformed and ignored" in result.stderr
    assert json.loads(manifest.read_text())["robots"][name]["outputs"].keys() == {"rp_arm.json"}
    assert "1 up to date" in _run("build", robots, "--out", out, "--json").stdout


@pytest.mark.parametrize("text", ["<<<<<<< HEAD\n{}\n=======\n{}\n>>>>>>> b\n", "[1, 2]", '{"robots": 3}'])
def test_a_manifest_that_is_not_one_is_replaced_with_a_note(tmp_path, text):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = tmp_path / "out"
    out.mkdir()
    (out / ".dynderive-build.json").write_text(text)
    result = _run("build", robots, "--out", out, "--json")
    assert result.exit_code == 0 and "1 built" in result.stdout, result.output
    assert "is not a build manifest" in result.stderr
    assert "1 up to date" in _run("build", robots, "--out", out, "--json").stdout


SHEET = (TEMPLATES / "sheet.tex.j2").read_text()


@pytest.mark.parametrize("how", ["include", "import", "extends", "nested include"])
def test_editing_a_template_a_user_template_loads_rebuilds(tmp_path, how):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    templates = tmp_path / "templates"
    (templates / "parts").mkdir(parents=True)
    edited = templates / "parts" / "extra.tex.j2"
    if how == "include":
        (templates / "sheet.tex.j2").write_text(SHEET + '% \\BLOCK{include "parts/extra.tex.j2"}\n')
        edited.write_text("version one\n")
    elif how == "nested include":
        (templates / "sheet.tex.j2").write_text(SHEET + '% \\BLOCK{include "middle.tex.j2"}\n')
        (templates / "middle.tex.j2").write_text('\\BLOCK{include "parts/extra.tex.j2"}\n')
        edited.write_text("version one\n")
    elif how == "import":
        (templates / "sheet.tex.j2").write_text(
            '\\BLOCK{import "parts/extra.tex.j2" as extra}\n' + SHEET + "% \\VAR{extra.note()}\n")
        edited.write_text("\\BLOCK{macro note()}version one\\BLOCK{endmacro}\n")
    else:
        (templates / "sheet.tex.j2").write_text('\\BLOCK{extends "parts/extra.tex.j2"}\n')
        edited.write_text(SHEET + "% version one\n")
    args = ("build", robots, "--out", tmp_path / "out", "--latex", "--template-dir", templates)
    first = _run(*args)
    assert first.exit_code == 0 and "1 built" in first.stdout, first.output
    assert "version one" in (tmp_path / "out" / "rp_arm.tex").read_text()
    assert "1 up to date" in _run(*args).stdout
    edited.write_text(edited.read_text().replace("version one", "version two"))
    again = _run(*args)
    assert again.exit_code == 0 and "1 built" in again.stdout, again.output
    assert "version two" in (tmp_path / "out" / "rp_arm.tex").read_text()


def test_a_template_named_by_a_variable_counts_every_file_of_the_folder(tmp_path):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    templates = tmp_path / "templates"
    templates.mkdir()
    (templates / "sheet.tex.j2").write_text(SHEET + '\\BLOCK{set part = "extra"}% \\BLOCK{include part ~ ".tex.j2"}\n')
    (templates / "extra.tex.j2").write_text("version one\n")
    args = ("build", robots, "--out", tmp_path / "out", "--latex", "--template-dir", templates)
    assert "1 built" in _run(*args).stdout
    (templates / "extra.tex.j2").write_text("version two\n")
    assert "1 built" in _run(*args).stdout
    assert "version two" in (tmp_path / "out" / "rp_arm.tex").read_text()


def test_a_write_failure_names_the_output_that_failed(tmp_path, monkeypatch):
    (tmp_path / "first.json").write_bytes(b"old")
    real = os.fsync
    calls = []

    def fsync(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(OutputError) as error:
        write_all({tmp_path / "first.json": b"new", tmp_path / "second.json": b"new"})
    assert str(error.value) == f"cannot write {tmp_path / 'second.json'}: No space left on device"
    assert _listing(tmp_path) == {"first.json": b"old"}
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("make,reason", [
    (lambda d: (d / "second").mkdir(), "it is a folder"),
    (lambda d: (d / "blocker").write_text("x"), "is a file, not a folder"),
])
def test_a_path_that_cannot_be_written_is_named(tmp_path, make, reason):
    make(tmp_path)
    target = tmp_path / "second" if reason == "it is a folder" else tmp_path / "blocker" / "second.json"
    with pytest.raises(OutputError) as error:
        write_all({tmp_path / "first.json": b"a", target: b"b"})
    assert str(error.value).startswith(f"cannot write {target}: ") and reason in str(error.value)
    assert ".tmp" not in str(error.value)
    assert not (tmp_path / "first.json").exists()


def test_a_link_to_a_file_is_written_through_and_kept(tmp_path):
    (tmp_path / "shared").mkdir()
    target = tmp_path / "shared" / "sheet.tex"
    target.write_text("old")
    link = tmp_path / "sheet.tex"
    link.symlink_to(target)
    write_all({link: b"new"})
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new"
    assert sorted(p.name for p in (tmp_path / "shared").iterdir()) == ["sheet.tex"]


def test_a_device_or_a_link_to_one_is_written_to_not_replaced(tmp_path):
    link = tmp_path / "null"
    link.symlink_to("/dev/null")
    write_all({link: b"data", Path("/dev/null"): b"more"})
    assert link.is_symlink() and stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_simulate_csv_to_a_link_to_stdout_writes_to_stdout(tmp_path):
    folder = tmp_path / "D"
    folder.mkdir()
    (folder / "stdout").symlink_to("/proc/self/fd/1")
    process = subprocess.run([sys.executable, "-m", "dynderive", "simulate", "rp_arm", "--duration", "0.1",
                              "--frames", "3", "--csv", str(folder / "stdout"), "-q"], capture_output=True,
                             text=True, env={**os.environ, "PYTHONPATH": SRC}, timeout=300)
    assert process.returncode == 0, process.stderr
    assert process.stdout.startswith("t,q1,q2,qd1,qd2,energy\n0,0.5,0.2,0,0,")
    assert os.readlink(folder / "stdout") == "/proc/self/fd/1"


@pytest.mark.parametrize("delay", [0.0, 0.005, 0.02, 0.05])
def test_a_signal_just_after_the_outputs_are_written_is_never_a_silent_kill(tmp_path, delay):
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "dynderive", "solve", "rp_arm", "--code", "--json",
                                "--out", str(out)], stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONPATH": SRC})
    assert process.stderr is not None
    seen = []
    for line in process.stderr:
        seen.append(line)
        if line.startswith("wrote"):
            break
    time.sleep(delay)
    process.send_signal(signal.SIGTERM)
    rest = process.stderr.read()
    process.wait(timeout=60)
    assert "Traceback" not in rest
    assert process.returncode in (0, 130), (process.returncode, rest)
    if process.returncode == 130:   # it says what it left: both outputs, complete
        assert rest.strip().splitlines()[-1].startswith("dynderive: interrupted; the outputs written before it "
                                                         "are complete")
    assert json.loads((out / "rp_arm.json").read_text())["robot"] == "rp_arm"
    compile((out / "rp_arm_dynamics.py").read_text(), "rp_arm_dynamics.py", "exec")


def test_an_interrupt_before_the_renames_changes_nothing_and_says_so(tmp_path, monkeypatch):
    (tmp_path / "a.tex").write_bytes(b"old")
    monkeypatch.setattr(output, "WRITTEN", [])

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(output, "_hold_signals", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_all({tmp_path / "a.tex": b"new", tmp_path / "b.py": b"new"})
    assert _listing(tmp_path) == {"a.tex": b"old"}
    assert output.interrupted_message() == "dynderive: interrupted; no output was changed"


@pytest.mark.parametrize("extra,limit", [([], MAX_FRAMES), (["--animate", "run.gif"], MAX_ANIMATION_FRAMES)])
def test_frames_are_bounded(tmp_path, monkeypatch, extra, limit):
    monkeypatch.chdir(tmp_path)
    line = _refused(_run("simulate", "rp_arm", "--frames", 1_000_000_000, *extra), "--frames:1:1: ")
    assert f"exceed the limit of {limit}" in line
    assert not list(tmp_path.iterdir())


# -- item 7: user templates: positioned errors, the sandbox ----------------------------------------

def _code_template(tmp_path: Path, edit, name: str = "dynamics.py.j2") -> Path:
    """A template folder with the built-in template ``name`` edited (the others built in)."""
    templates = tmp_path / "templates"
    templates.mkdir(exist_ok=True)
    (templates / name).write_text(edit((TEMPLATES / name).read_text()))
    return templates


def _line_of(path: Path, text: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if text in line)


def test_a_template_that_makes_the_module_unparseable_is_positioned(tmp_path):
    # the module's constants are written by a macro the NumPy and JAX modules share
    templates = _code_template(tmp_path, lambda s: s.replace("EFFORTS = {{ efforts_tuple }}\n",
                                                             "EFFORTS = {{ efforts_tuple }} (\n"), "python_api.j2")
    template = templates / "python_api.j2"
    result = _run("solve", "rp_arm", "--code", "--out", tmp_path / "out", "--template-dir", templates, "-q")
    line = _refused(result, f"{template}:{_line_of(template, 'EFFORTS = ')}:1: ")
    assert "the generated module does not parse" in line and "'(' was never closed" in line
    assert not (tmp_path / "out").exists()


def test_a_template_that_adds_a_statement_is_positioned(tmp_path):
    templates = _code_template(tmp_path, lambda s: s.replace("import math\n", "import math\nprint({{ dof }})\n"))
    template = templates / "dynamics.py.j2"
    result = _run("solve", "rp_arm", "--code", "--out", tmp_path / "out", "--template-dir", templates, "-q")
    line = _refused(result, f"{template}:{_line_of(template, 'print(')}:1: ")
    assert "unexpected Expr" in line


def test_a_template_syntax_error_is_positioned(tmp_path):
    templates = tmp_path / "templates"
    templates.mkdir()
    (templates / "preamble.tex.j2").write_text("\\documentclass{article}\n\\BLOCK{if}\n")
    result = _run("solve", "rp_arm", "--latex", "--out", tmp_path / "out", "--template-dir", templates, "-q")
    assert "template syntax error" in _refused(result, f"{templates / 'preamble.tex.j2'}:2:1: ")


def test_a_misspelt_variable_in_a_template_is_positioned(tmp_path):
    templates = _code_template(tmp_path, lambda s: s.replace("{{ efforts_tuple }}", "{{ effort_tuple }}", 1),
                               "python_api.j2")
    template = templates / "python_api.j2"
    result = _run("solve", "rp_arm", "--code", "--out", tmp_path / "out", "--template-dir", templates, "-q")
    line = _refused(result, f"{template}:{_line_of(template, 'effort_tuple')}:")
    assert "'effort_tuple' is undefined" in line


ATTACKS = {
    "lipsum": "{{% set _ = lipsum.__globals__['os'].system('touch {marker}') %}}",
    "sympy": "{{% set _ = functions[0].arguments[0].symbols[0].diff(\"__import__('os').system('touch {marker}')\") %}}",
    "format": "{{{{ '{{0.__class__.__mro__[1].__subclasses__}}'.format(dof) }}}}",
    "power": "{{{{ 10 ** 1000000 }}}}",
    "repeat": "{{{{ 'x' * 10 ** 9 }}}}",
}


@pytest.mark.parametrize("attack", ATTACKS)
@pytest.mark.parametrize("command", ["solve", "build", "build --check"])
def test_a_code_template_cannot_reach_python(tmp_path, attack, command):
    marker = tmp_path / "marker"
    line = ATTACKS[attack].format(marker=marker)
    templates = _code_template(tmp_path, lambda s: s.replace("import math\n", f"import math\n{line}\n"))
    template = templates / "dynamics.py.j2"
    if command == "solve":
        args = ["solve", "rp_arm", "--code", "--out", tmp_path / "out", "-q"]
    else:
        (tmp_path / "robots").mkdir()
        shutil.copy(ROBOTS / "rp_arm.yaml", tmp_path / "robots")
        args = ["build", tmp_path / "robots", "--out", tmp_path / "out", "--code", *command.split()[1:]]
    result = _run(*args, "--template-dir", templates)
    refusal = _refused(result, f"{template}:{_line_of(template, line[:12])}:")
    assert "template" in refusal
    assert not marker.exists()
    assert not (tmp_path / "out" / "rp_arm_dynamics.py").exists()


@pytest.mark.parametrize("command", ["solve", "build --check"])
def test_a_latex_preamble_cannot_reach_python(tmp_path, command):
    marker = tmp_path / "marker"
    templates = tmp_path / "templates"
    templates.mkdir()
    preamble = (TEMPLATES / "preamble.tex.j2").read_text()
    attack = f"\\VAR{{cycler.__init__.__globals__.os.system('touch {marker}')}}\n"
    (templates / "preamble.tex.j2").write_text(attack + preamble)
    if command == "solve":
        args = ["solve", "rp_arm", "--latex", "--out", tmp_path / "out", "-q"]
    else:
        (tmp_path / "robots").mkdir()
        shutil.copy(ROBOTS / "rp_arm.yaml", tmp_path / "robots")
        args = ["build", tmp_path / "robots", "--out", tmp_path / "out", "--latex", "--check"]
    result = _run(*args, "--template-dir", templates)
    refusal = _refused(result, f"{templates / 'preamble.tex.j2'}:1:")
    assert "refused by the template sandbox" in refusal and "__init__" in refusal
    assert not marker.exists()


def test_what_templates_may_still_do(tmp_path):
    """Macros, loops, string methods, filters and Jinja's globals work in the sandbox."""
    templates = tmp_path / "templates"
    templates.mkdir()
    extra = ("\\BLOCK{macro shout(x)}\\VAR{x.upper()}\\BLOCK{endmacro}\n"
             "% \\VAR{shout(robot.name)} \\VAR{', '.join(coordinates)} \\VAR{dict(a=1).items() | list}"
             " \\VAR{range(3) | sum} \\VAR{'%s-%s' | format(dof, 2 * dof)}\\BLOCK{set c = cycler('x', 'y')}"
             " \\VAR{c.next()}\\VAR{c.next()} \\VAR{'{}!'.format(dof)}\n")
    (templates / "sheet.tex.j2").write_text(SHEET + extra)
    result = _run("solve", "rp_arm", "--latex", "--out", tmp_path / "out", "--template-dir", templates, "-q")
    assert result.exit_code == 0, result.output
    last = (tmp_path / "out" / "rp_arm.tex").read_text().splitlines()[-1]
    assert last == "% RP\\_ARM q_{1}, q_{2} [('a', 1)] 3 2-4 xy 2!"


def test_an_interrupt_names_only_this_commands_outputs(tmp_path, monkeypatch):
    import dynderive

    assert _run("solve", "rp_arm", "--json", "--out", tmp_path, "-q").exit_code == 0
    assert output.WRITTEN == [tmp_path / "rp_arm.json"]

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(dynderive, "load_robot", interrupted)
    result = _run("solve", "rp_arm", "--json", "--out", tmp_path, "-q")
    assert result.exit_code == 130
    assert result.stderr.strip() == "dynderive: interrupted; no output was changed"
