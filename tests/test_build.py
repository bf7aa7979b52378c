"""`dynderive build`: incremental, --check, reproducible, custom templates, examples current."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

from conftest import ROBOTS

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def robots(tmp_path):
    folder = tmp_path / "robots"
    folder.mkdir()
    for name in ("rp_arm", "cart_pole"):
        shutil.copy(ROBOTS / f"{name}.yaml", folder)
    return folder


def _build(*args):
    return runner.invoke(app, ["build", *map(str, args)])


def test_second_build_is_up_to_date_and_fast(robots, tmp_path):
    out = tmp_path / "out"
    start = time.perf_counter()
    first = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    first_time = time.perf_counter() - start
    assert first.exit_code == 0, first.output
    assert "2 built" in first.stdout
    start = time.perf_counter()
    second = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    assert second.exit_code == 0
    assert "2 up to date" in second.stdout
    assert time.perf_counter() - start < first_time / 10
    # editing one robot rebuilds that robot only
    path = robots / "cart_pole.yaml"
    path.write_text(path.read_text().replace("mp: {value: 0.1", "mp: {value: 0.2"))
    third = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    assert "1 built, 1 up to date" in third.stdout
    statuses = {line.split()[0]: line.split()[1] for line in third.stdout.splitlines()[1:-1]}
    assert statuses == {str(robots / "cart_pole.yaml"): "built", str(robots / "rp_arm.yaml"): "up"}


def test_check_passes_when_current_and_fails_after_edits(robots, tmp_path):
    out = tmp_path / "out"
    templates = tmp_path / "templates"
    templates.mkdir()
    shutil.copy(ROOT / "templates" / "preamble.tex.j2", templates)
    assert _build(robots, "--out", out, "--latex", "--template-dir", templates).exit_code == 0
    check = _build(robots, "--out", out, "--latex", "--template-dir", templates, "--check")
    assert check.exit_code == 0, check.output
    assert "2 current" in check.stdout
    before = sorted(p.name for p in out.iterdir())
    # a template edit: every sheet differs
    preamble = templates / "preamble.tex.j2"
    preamble.write_text(preamble.read_text() + "% edited\n")
    check = _build(robots, "--out", out, "--latex", "--template-dir", templates, "--check")
    assert check.exit_code == 1
    assert f"{out / 'rp_arm.tex'}: differs" in check.stdout
    preamble.write_text(preamble.read_text().replace("% edited\n", ""))
    # a robot edit: that robot's sheet differs; --check wrote nothing
    path = robots / "rp_arm.yaml"
    path.write_text(path.read_text().replace("title: Two-link RP arm", "title: An RP arm"))
    check = _build(robots, "--out", out, "--latex", "--template-dir", templates, "--check")
    assert check.exit_code == 1
    assert f"{out / 'rp_arm.tex'}: differs" in check.stdout
    assert f"{out / 'cart_pole.tex'}" not in check.stdout
    assert sorted(p.name for p in out.iterdir()) == before
    # a missing output is reported as missing
    (out / "cart_pole.tex").unlink()
    check = _build(robots, "--out", out, "--latex", "--template-dir", templates, "--check")
    assert f"{out / 'cart_pole.tex'}: missing" in check.stdout


def test_failed_robot_does_not_stop_the_others(robots, tmp_path):
    (robots / "broken.yaml").write_text("name: broken\nplanar: true\n")
    result = _build(robots, "--out", tmp_path / "out", "--code")
    assert result.exit_code == 1
    assert "2 built, 1 failed" in result.stdout
    assert "missing required key 'links'" in result.stderr
    assert (tmp_path / "out" / "rp_arm_dynamics.py").is_file()


def test_duplicate_robot_names_are_refused_before_anything_is_built(tmp_path):
    folder = tmp_path / "robots"
    folder.mkdir()
    text = (ROBOTS / "rp_arm.yaml").read_text()
    (folder / "a.yaml").write_text(text.replace("name: rp_arm", "name: arm"))
    (folder / "b.yaml").write_text("name: arm\n" + text.replace("name: rp_arm\n", ""))
    shutil.copy(ROBOTS / "double_pendulum.yaml", folder)
    urdf = folder / "c.urdf"  # a URDF whose <robot name> becomes the same identifier
    urdf.write_text('<?xml version="1.0"?>\n<robot\n   name="arm">\n  <link name="base"/>\n</robot>\n')
    out = tmp_path / "out"
    for extra in ((), ("--check",)):
        result = _build(folder, "--out", out, "--code", *extra)
        assert result.exit_code == 2, result.output
        assert (f"{folder / 'b.yaml'}:1:7: robot name 'arm' is also used by {folder / 'a.yaml'} "
                "(outputs would overwrite each other)") in result.stderr
        assert f"{folder / 'c.urdf'}:3:10: robot name 'arm' is also used by {folder / 'a.yaml'}" in result.stderr
        assert not out.exists()


def test_check_compares_bytes_not_the_manifest(tmp_path):
    folder = tmp_path / "robots"
    folder.mkdir()
    for name in ("rp_arm", "double_pendulum"):
        shutil.copy(ROBOTS / f"{name}.yaml", folder)
    out = tmp_path / "out"
    assert _build(folder, "--out", out, "--code", "-j", "1").exit_code == 0
    manifest = out / ".dynderive-build.json"
    # tamper with an output and forge its hash in the manifest: the manifest alone looks current
    tampered = out / "rp_arm_dynamics.py"
    tampered.write_text(tampered.read_text() + "# tampered\n")
    document = json.loads(manifest.read_text())
    document["robots"]["../robots/rp_arm.yaml"]["outputs"]["rp_arm_dynamics.py"] = (   # keyed from out/
        hashlib.sha256(tampered.read_bytes()).hexdigest())
    manifest.write_text(json.dumps(document, indent=2) + "\n")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    check = _build(folder, "--out", out, "--code", "--check", "-j", "1")
    assert check.exit_code == 1, check.output
    assert f"{tampered}: differs" in check.stdout
    assert "1 current, 1 differs" in check.stdout
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # --check wrote nothing
    # a plain build believes the forged record; --check still catches it afterwards
    assert "2 up to date" in _build(folder, "--out", out, "--code", "-j", "1").stdout
    assert _build(folder, "--out", out, "--code", "--check", "-j", "1").exit_code == 1


def test_concurrent_builds_into_one_directory_keep_every_record(tmp_path):
    out = tmp_path / "out"
    sources = []
    for name in ("rp_arm", "double_pendulum"):
        folder = tmp_path / name
        folder.mkdir()
        sources.append(folder / f"{name}.yaml")
        shutil.copy(ROBOTS / f"{name}.yaml", sources[-1])
    command = [sys.executable, "-c", "from dynderive.__main__ import run; run()", "build"]
    processes = [subprocess.Popen([*command, str(source), "--out", str(out), "--code", "-j", "1"],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for source in sources]
    for process in processes:
        stdout, stderr = process.communicate(timeout=300)
        assert process.returncode == 0, stdout + stderr
    records = json.loads((out / ".dynderive-build.json").read_text())["robots"]
    assert sorted(records) == [f"../{name}/{name}.yaml" for name in ("double_pendulum", "rp_arm")]
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    # both records are real: a second build of both is up to date
    again = _build(*sources, "--out", out, "--code", "-j", "1")
    assert "2 up to date" in again.stdout, again.output


@pytest.mark.pdf
def test_two_builds_are_byte_identical(robots, tmp_path):
    if shutil.which("latexmk") is None:
        pytest.skip("no TeX engine")
    for name in ("a", "b"):
        result = _build(robots, "--out", tmp_path / name, "--latex", "--code", "--json", "--pdf", "-j", "2")
        assert result.exit_code == 0, result.output
    files = sorted(p.name for p in (tmp_path / "a").iterdir() if not p.name.startswith("."))
    assert {"rp_arm.pdf", "rp_arm.tex", "rp_arm.json", "rp_arm_dynamics.py"} <= set(files)
    for name in files:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


@pytest.mark.pdf
def test_custom_preamble_changes_the_sheet_and_compiles(tmp_path):
    if shutil.which("latexmk") is None:
        pytest.skip("no TeX engine")
    templates = tmp_path / "templates"
    templates.mkdir()
    preamble = (ROOT / "templates" / "preamble.tex.j2").read_text()
    (templates / "preamble.tex.j2").write_text(preamble.replace("[11pt]", "[12pt]") + "\\usepackage{xcolor}\n")
    result = runner.invoke(app, ["solve", "rp_arm", "--latex", "--pdf", "--template-dir", str(templates),
                                 "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    tex = (tmp_path / "out" / "rp_arm.tex").read_text()
    assert "\\documentclass[12pt]{article}" in tex and "\\usepackage{xcolor}" in tex
    assert (tmp_path / "out" / "rp_arm.pdf").read_bytes().startswith(b"%PDF")


@pytest.mark.pdf
def test_committed_examples_are_current(monkeypatch):
    """examples/ holds the outputs of every bundled robot; an output-changing commit must regenerate them."""
    if shutil.which("latexmk") is None:
        pytest.skip("no TeX engine")
    monkeypatch.chdir(ROOT)  # the manifest records paths as given: robots/<file>
    result = runner.invoke(app, ["build", "robots", "--out", "examples", "--latex", "--code", "--pdf", "--c", "--check"])
    assert result.exit_code == 0, result.stdout + (
        "\nregenerate with: dynderive build robots --out examples --latex --code --pdf --c")


def test_build_c_writes_the_c_target_and_tracks_its_templates(robots, tmp_path):
    """``build --c`` writes what ``solve --c`` writes, is up to date the second time, and a C
    template edit makes ``--check`` report the C files (not the others)."""
    from dynderive.render.c import render_c

    from conftest import derivation_of

    out = tmp_path / "out"
    templates = tmp_path / "templates"
    (templates / "c").mkdir(parents=True)
    shutil.copy(ROOT / "templates" / "c" / "dynamics.c.j2", templates / "c")
    first = _build(robots, "--out", out, "--c", "--code", "--template-dir", templates, "-j", "1")
    assert first.exit_code == 0, first.output
    header, source = render_c(derivation_of("rp_arm"))
    assert (out / "rp_arm_dynamics.h").read_text() == header
    assert (out / "rp_arm_dynamics.c").read_text() == source
    assert (out / "cart_pole_dynamics.c").is_file() and (out / "cart_pole_dynamics.py").is_file()
    second = _build(robots, "--out", out, "--c", "--code", "--template-dir", templates, "-j", "1")
    assert "2 up to date" in second.stdout
    edited = templates / "c" / "dynamics.c.j2"
    edited.write_text(edited.read_text() + "/* edited */\n")
    check = _build(robots, "--out", out, "--c", "--code", "--template-dir", templates, "--check")
    assert check.exit_code == 1
    assert f"{out / 'rp_arm_dynamics.c'}: differs" in check.stdout
    assert "rp_arm_dynamics.h" not in check.stdout and "rp_arm_dynamics.py" not in check.stdout
    rebuilt = _build(robots, "--out", out, "--c", "--code", "--template-dir", templates, "-j", "1")
    assert "2 built" in rebuilt.stdout
    assert (out / "rp_arm_dynamics.c").read_text().endswith("/* edited */\n")


def test_build_c_extension_compiles_imports_and_is_tracked(robots, tmp_path, monkeypatch):
    """``build --c-extension`` writes an extension that imports and agrees with the NumPy
    module; the second build is up to date; ``--check`` compiles it but does not compare its
    machine-specific bytes (the C sources are compared with ``--c``)."""
    import importlib.util
    import os

    import numpy as np

    from dynderive.commands.build import EXTENSION_SUFFIX

    from conftest import module_of

    if shutil.which("cc") is None and shutil.which("gcc") is None:
        if os.environ.get("CI"):
            raise RuntimeError("CI must build the C extension, but no C compiler was found")
        pytest.skip("no C compiler")
    out = tmp_path / "out"
    first = _build(robots, "--out", out, "--c-extension", "--c", "-j", "1")
    assert first.exit_code == 0, first.output
    path = out / f"rp_arm_dynamics_c{EXTENSION_SUFFIX}"
    spec = importlib.util.spec_from_file_location("rp_arm_dynamics_c", path)
    compiled = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compiled)
    (tmp_path / "numpy").mkdir()
    reference = module_of("rp_arm", tmp_path / "numpy")
    q, qd, u = np.array([0.3, 0.7]), np.array([-0.4, 0.25]), np.array([0.5, -1.5])
    assert np.allclose(compiled.forward_dynamics(q, qd, u), reference.forward_dynamics(q, qd, u), rtol=1e-12, atol=0)
    second = _build(robots, "--out", out, "--c-extension", "--c", "-j", "1")
    assert "2 up to date" in second.stdout, second.output
    check = _build(robots, "--out", out, "--c-extension", "--c", "--check")
    assert check.exit_code == 0 and "2 current" in check.stdout, check.output
    (out / "rp_arm_dynamics.c").write_text("/* edited */\n")
    check = _build(robots, "--out", out, "--c-extension", "--c", "--check")
    assert check.exit_code == 1 and f"{out / 'rp_arm_dynamics.c'}: differs" in check.stdout
    # no compiler: exit 2 at the option, before any work
    monkeypatch.setenv("CC", "/nonexistent/cc")
    refused = _build(robots, "--out", tmp_path / "other", "--c-extension")
    assert refused.exit_code == 2 and "--c-extension:1:1:" in refused.output
    assert not (tmp_path / "other").exists()


def _apt_packages(text: str) -> set[str]:
    """The packages of every ``apt-get install`` in a shell script or a Markdown page's code
    span (continued lines joined; options and redirections left out)."""
    packages: set[str] = set()
    joined = re.sub(r"\\\n", " ", text)
    for command in re.findall(r"apt-get install\b([^`;&|>]*)", joined):
        if "`" not in joined:   # a script: the command ends with its line
            command = command.split("\n")[0]
        packages |= {word for word in command.split() if not word.startswith("-")}
    return packages


def _tex(packages: set[str]) -> set[str]:
    return {p for p in packages if p == "latexmk" or p.startswith("texlive-")}


def test_the_sample_workflow_installs_the_tex_that_ci_and_the_install_guide_install():
    """The sample CI workflow, ``.ci/run``, docs/install.md and the missing-TeX message name
    the same TeX packages (TikZ's ``texlive-pictures`` among them: every sheet draws);
    ``.ci/run`` and docs/install.md both install Chromium for the HTML tests."""
    import yaml

    from dynderive.render.pdf import TEX_PACKAGES

    workflow = yaml.safe_load((ROOT / "examples" / "ci" / "regenerate-sheets.yml").read_text())
    steps = "\n".join(step.get("run", "") for job in workflow["jobs"].values() for step in job["steps"])
    ci = _apt_packages((ROOT / ".ci" / "run").read_text())
    install = _apt_packages((ROOT / "docs" / "install.md").read_text())
    assert "texlive-pictures" in _tex(ci)
    assert _tex(_apt_packages(steps)) == _tex(ci) == _tex(install) == set(TEX_PACKAGES.split())
    assert "chromium" in ci and ci == install   # docs/install.md lists what .ci/run installs
