"""Hardening: JSON Schema, atomic outputs under SIGTERM, no execution, LaTeX escaping."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from dynderive.commands.cli import app

from conftest import ROBOTS

runner = CliRunner()


def test_schema_validates_every_bundled_yaml_robot():
    jsonschema = pytest.importorskip("jsonschema")
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0
    schema = json.loads(result.stdout)
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    for path in sorted(ROBOTS.glob("*.yaml")):
        errors = list(validator.iter_errors(yaml.safe_load(path.read_text())))
        assert not errors, (path.name, [e.message for e in errors])
    assert list(validator.iter_errors({"name": "x", "gravity": [0, -1], "links": [], "joints": [], "mas": 1}))


def test_imported_urdf_validates_against_schema(tmp_path):
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(runner.invoke(app, ["schema"]).stdout)
    runner.invoke(app, ["import", str(ROBOTS / "ur5.urdf"), "-o", str(tmp_path / "ur5.yaml")])
    assert not list(jsonschema.Draft202012Validator(schema).iter_errors(yaml.safe_load((tmp_path / "ur5.yaml").read_text())))


#: ``dynderive`` run with its derivation held once done: the function ``solve`` calls derives
#: the robot, then prints PAUSED to stdout and waits for a signal (nothing is rendered or
#: written yet). The test sends SIGTERM once it has read that line, so the signal lands in the
#: middle of the run however fast the machine is; no hook in the program itself.
PAUSED_RUN = """\
import signal, sys
import dynderive
from dynderive.__main__ import run

derive = dynderive.derive

def held(*args, **kwargs):
    derivation = derive(*args, **kwargs)
    sys.__stdout__.write("PAUSED\\n")
    sys.__stdout__.flush()
    while True:
        signal.pause()   # the SIGTERM handler raises; a signal before this line raises too
    return derivation

dynderive.derive = held
sys.argv = ["dynderive", *sys.argv[1:]]
run()
"""


def test_sigterm_midway_leaves_previous_outputs_untouched(tmp_path):
    """SIGTERM after the derivation, before any output is made: the outputs of the run
    before are kept, byte for byte, and nothing else is left in the directory."""
    out = tmp_path / "out"
    first = runner.invoke(app, ["solve", "rp_arm", "--latex", "--code", "--out", str(out), "-q"])
    assert first.exit_code == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    # another robot (a 3-link pendulum) named rp_arm: it would overwrite them
    robot = tmp_path / "slow" / "rp_arm.yaml"
    robot.parent.mkdir()
    links = "".join(f"  - {{name: b{k}, mass: 1, com: [0.5, 0], inertia: 0.1}}\n" for k in range(1, 4))
    joints = "".join(f"  - {{name: q{k}, type: revolute, parent: {'world' if k == 1 else f'b{k - 1}'}, "
                     f"child: b{k}, origin: [{0 if k == 1 else 1}, 0]}}\n" for k in range(1, 4))
    robot.write_text(f"name: rp_arm\nplanar: true\ngravity: [0, -9.81]\nlinks:\n{links}joints:\n{joints}")
    process = subprocess.Popen([sys.executable, "-c", PAUSED_RUN, "solve", str(robot), "--latex", "--code",
                                "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()   # blocks until the derivation is done and held
        assert line == "PAUSED\n", (line, process.stderr.read() if process.poll() is not None else "")
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130, stderr
    assert stderr.strip().endswith("dynderive: interrupted; no output was changed")
    assert "Traceback" not in stderr
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after == before  # same files, same bytes, no stray temporaries


def test_injection_in_free_text_is_escaped_and_nothing_runs(tmp_path):
    marker = tmp_path / "marker"
    text = (ROBOTS / "rp_arm.yaml").read_text().replace(
        "title: Two-link RP arm (revolute + prismatic)",
        f"title: '\\input{{/etc/passwd}} \\write18{{touch {marker}}} 100% #1 & $x$ _ {{}} ~ ^'")
    text = text.replace("description: mass of each link", "description: '\\immediate\\write18{rm -rf /}'")
    path = tmp_path / "evil.yaml"
    path.write_text(text)
    result = runner.invoke(app, ["solve", str(path), "--latex", "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 0, result.output
    tex = (tmp_path / "out" / "rp_arm.tex").read_text()
    assert "\\textbackslash{}input\\{/etc/passwd\\}" in tex
    assert "\\textbackslash{}write18" in tex and "100\\%" in tex and "\\#1" in tex and "\\&" in tex
    assert "\\input{/etc" not in tex and "\\write18{" not in tex
    if os.environ.get("CI") or __import__("shutil").which("latexmk"):
        result = runner.invoke(app, ["solve", str(path), "--pdf", "--out", str(tmp_path / "pdf"), "-q"])
        assert result.exit_code == 0, result.output
    assert not marker.exists()


def test_expression_attack_in_robot_file_runs_nothing(tmp_path):
    marker = tmp_path / "marker"
    text = (ROBOTS / "rp_arm.yaml").read_text().replace("mass: m\n", f"mass: \"__import__('os').system('touch {marker}')\"\n", 1)
    path = tmp_path / "attack.yaml"
    path.write_text(text)
    start = time.perf_counter()
    result = runner.invoke(app, ["solve", str(path), "--code", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "only calls of plain function names are allowed" in result.stderr
    assert time.perf_counter() - start < 30   # a bound on runaway work, not a speed test
    assert not marker.exists() and not (tmp_path / "out").exists()


def test_yaml_alias_bomb_is_refused_fast(tmp_path):
    lines = ["a: &a [x, x, x, x, x, x, x, x, x]"]
    for previous, name in zip("abcdef", "bcdefg"):
        lines.append(f"{name}: &{name} [{', '.join(['*' + previous] * 9)}]")
    path = tmp_path / "bomb.yaml"
    path.write_text("\n".join(lines) + "\n")
    start = time.perf_counter()
    result = runner.invoke(app, ["solve", str(path)])
    assert result.exit_code == 2
    assert "document expands to more than 50000 values" in result.stderr
    assert time.perf_counter() - start < 30   # a bound on runaway work, not a speed test


def test_outputs_are_written_atomically_without_temporaries(tmp_path):
    out = tmp_path / "out"
    assert runner.invoke(app, ["solve", "cart_pole", "--latex", "--code", "--json", "--out", str(out)]).exit_code == 0
    assert sorted(p.name for p in out.iterdir()) == ["cart_pole.json", "cart_pole.tex", "cart_pole_dynamics.py"]
    assert all(not p.name.startswith(".") for p in Path(out).iterdir())


def test_output_directory_that_is_a_file_is_a_clear_error(tmp_path):
    blocker = tmp_path / "out"
    blocker.write_text("not a folder")
    result = runner.invoke(app, ["solve", "rp_arm", "--code", "--out", str(blocker), "-q"])
    assert result.exit_code == 2   # bad input, found before any derivation
    assert result.stderr == f"--out:1:1: {blocker} is a file, not a folder\n"
    assert "internal error" not in result.stderr and "Traceback" not in result.output
    assert blocker.read_text() == "not a folder"
