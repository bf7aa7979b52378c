"""`dynderive build`: incremental, --check, reproducible, custom templates, examples current."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app
from dynderive.render.targets import TARGETS, by_name

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


def test_second_build_is_up_to_date_and_derives_nothing(robots, tmp_path, monkeypatch):
    """The second build is fast because it derives nothing (counted, not timed: a loaded
    machine must not fail it)."""
    import dynderive

    derived = []
    derive = dynderive.derive
    monkeypatch.setattr(dynderive, "derive", lambda robot, *a, **k: derived.append(robot.name) or derive(robot, *a, **k))
    out = tmp_path / "out"
    first = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    assert first.exit_code == 0, first.output
    assert "2 built" in first.stdout
    assert sorted(derived) == ["cart_pole", "rp_arm"]
    derived.clear()
    second = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    assert second.exit_code == 0
    assert "2 up to date" in second.stdout
    assert derived == []
    # editing one robot rebuilds that robot only
    path = robots / "cart_pole.yaml"
    path.write_text(path.read_text().replace("mp: {value: 0.1", "mp: {value: 0.2"))
    third = _build(robots, "--out", out, "--latex", "--code", "--json", "-j", "1")
    assert "1 built, 1 up to date" in third.stdout
    assert derived == ["cart_pole"]
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
    from dynderive.render.targets.c.c import render_c

    from conftest import derivation_of

    out = tmp_path / "out"
    templates = tmp_path / "templates"
    (templates / "c").mkdir(parents=True)
    shutil.copy(ROOT / "src" / "dynderive" / "render" / "targets" / "c" / "dynamics.c.j2", templates / "c")
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

    from dynderive.render.sheets.pdf import TEX_PACKAGES

    workflow = yaml.safe_load((ROOT / "examples" / "ci" / "regenerate-sheets.yml").read_text())
    steps = "\n".join(step.get("run", "") for job in workflow["jobs"].values() for step in job["steps"])
    ci = _apt_packages((ROOT / ".ci" / "run").read_text())
    install = _apt_packages((ROOT / "docs" / "install.md").read_text())
    assert "texlive-pictures" in _tex(ci)
    assert _tex(_apt_packages(steps)) == _tex(ci) == _tex(install) == set(TEX_PACKAGES.split())
    assert "chromium" in ci and ci == install   # docs/install.md lists what .ci/run installs


# ---- the outputs of a robot agree after every run ---------------------------------------------

@pytest.fixture()
def fake_latex(monkeypatch):
    """LaTeX replaced by a switch: ``fake_latex["fail"] = True`` makes every sheet fail, as
    a sheet TeX rejects does (no TeX needed; build runs in this process with -j 1)."""
    from dynderive.errors import LatexError
    from dynderive.render.sheets import pdf

    state = {"fail": False}

    def compile_pdf_report(tex, jobname="sheet", timeout=300):
        if state["fail"]:
            raise LatexError("Double subscript. (line 3)", "! Double subscript.\nl.3 $x_1_\n")
        return b"%PDF-1.5 " + hashlib.sha256(tex.encode()).hexdigest().encode(), 2, []

    monkeypatch.setattr(pdf, "compile_pdf_report", compile_pdf_report)
    return state


def test_a_failed_pdf_removes_the_older_pdf_and_a_built_one_the_failures_log(robots, tmp_path, fake_latex):
    out = tmp_path / "out"
    args = (robots, "--out", out, "--latex", "--pdf", "--code", "-j", "1")
    assert _build(*args).exit_code == 0
    assert (out / "rp_arm.pdf").is_file() and not (out / "rp_arm.log").exists()
    # the robot changes and LaTeX fails: the new .tex is written, the older PDF removed (said so)
    path = robots / "rp_arm.yaml"
    path.write_text(path.read_text().replace("title: Two-link RP arm", "title: An RP arm"))
    fake_latex["fail"] = True
    failed = _build(*args)
    assert failed.exit_code == 1
    assert "1 up to date, 1 failed" in failed.stdout
    assert (f"{path}: LaTeX failed to compile {out / 'rp_arm.tex'}: Double subscript. (line 3); the log is "
            f"{out / 'rp_arm.log'}; {out / 'rp_arm.pdf'} from an earlier run was removed (it would not match "
            "the new sheet)") in failed.stderr
    assert "An RP arm" in (out / "rp_arm.tex").read_text()
    assert not (out / "rp_arm.pdf").exists() and (out / "rp_arm.log").is_file()
    assert (out / "cart_pole.pdf").is_file()   # the robot that was up to date keeps its PDF
    # LaTeX works again: the PDF is built and the failure's log removed
    fake_latex["fail"] = False
    again = _build(*args)
    assert again.exit_code == 0 and "1 built, 1 up to date" in again.stdout, again.output
    assert (out / "rp_arm.pdf").is_file() and not (out / "rp_arm.log").exists()
    # a log left beside current outputs (by hand, or a solve) is what --check reports, and a build removes
    (out / "rp_arm.log").write_text("left over\n")
    check = _build(*args, "--check")
    assert check.exit_code == 1
    assert f"{out / 'rp_arm.log'}: the log of a failed build (a build removes it)" in check.stdout
    assert "1 current, 1 differs" in check.stdout


def test_solve_pdf_follows_the_same_rule(tmp_path, fake_latex):
    out = tmp_path / "out"
    args = ["solve", "rp_arm", "--latex", "--pdf", "--out", str(out)]
    assert runner.invoke(app, args).exit_code == 0
    fake_latex["fail"] = True
    failed = runner.invoke(app, args)
    assert failed.exit_code == 1
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.log", "rp_arm.tex"]
    assert f"removed {out / 'rp_arm.pdf'}" in failed.stderr
    assert failed.stderr.strip().splitlines()[-1].endswith(
        f"the log is {out / 'rp_arm.log'}; {out / 'rp_arm.pdf'} from an earlier run was removed "
        "(it would not match the new sheet)")
    fake_latex["fail"] = False
    result = runner.invoke(app, args)
    assert result.exit_code == 0 and f"removed {out / 'rp_arm.log'}" in result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["rp_arm.pdf", "rp_arm.tex"]


def test_missing_tikz_names_each_robot_and_writes_its_other_outputs(robots, tmp_path, monkeypatch):
    from dynderive.render.sheets import pdf

    monkeypatch.setattr(pdf, "latex_engine_available", lambda: True)
    monkeypatch.setattr(pdf, "tikz_available", lambda: False)
    out = tmp_path / "out"
    result = _build(robots, "--out", out, "--pdf", "--code", "-j", "1")
    assert result.exit_code == 1 and "2 failed" in result.stdout
    for name in ("cart_pole", "rp_arm"):
        assert (f"{robots / (name + '.yaml')}: {out / (name + '.pdf')} skipped: --pdf: the sheet's drawing needs "
                "TikZ") in result.stderr
        assert (out / f"{name}_dynamics.py").is_file()
    assert not list(out.glob("*.pdf"))


def test_orphaned_outputs_are_reported_checked_and_pruned(robots, tmp_path):
    out = tmp_path / "out"
    assert _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1").exit_code == 0
    again = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1")
    assert "2 up to date" in again.stdout, again.output   # MATLAB's +<name>/ files are recorded
    # a renamed robot file (same robot name) owns its outputs: nothing is orphaned
    (robots / "rp_arm.yaml").rename(robots / "arm.yaml")
    renamed = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1")
    assert renamed.exit_code == 0 and "orphaned" not in renamed.stdout.split() and not renamed.stderr
    # a deleted robot file: its outputs are reported by build, fail --check, and --prune removes them
    (robots / "cart_pole.yaml").unlink()
    orphans = [out / "cart_pole.tex", out / "cart_pole_dynamics.py", out / "cart_pole_derivation.m",
               out / "+cart_pole" / "parameters.m"]
    result = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1")
    assert result.exit_code == 0, result.output
    assert "1 up to date, 1 orphaned" in result.stdout
    row = next(line.split() for line in result.stdout.splitlines() if line.split()[1:2] == ["orphaned"])
    assert row == [os.path.relpath(robots / "cart_pole.yaml"), "orphaned", "-"]   # the robot file, as from here
    for path in orphans:
        assert f"  {path}: orphaned" in result.stdout
    assert f"build --prune --out {out} removes them" in result.stderr
    for extra in ((), ("--check",)):   # the record stays: a later run reports them again
        check = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1", *extra)
        assert f"{out / 'cart_pole.tex'}: orphaned" in check.stdout
        assert check.exit_code == (1 if extra else 0)
    refused = _build(robots, "--out", out, "--check", "--prune")
    assert refused.exit_code == 2 and refused.output.startswith("--prune:1:1: ")
    pruned = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1", "--prune")
    assert pruned.exit_code == 0 and "1 up to date, 1 pruned" in pruned.stdout, pruned.output
    assert f"  {out / 'cart_pole.tex'}: removed" in pruned.stdout
    assert not any(path.exists() for path in orphans) and not (out / "+cart_pole").exists()
    assert (out / "rp_arm.tex").is_file() and (out / "+rp_arm" / "parameters.m").is_file()
    records = json.loads((out / ".dynderive-build.json").read_text())["robots"]
    assert list(records) == ["../robots/arm.yaml"]
    check = _build(robots, "--out", out, "--latex", "--code", "--matlab", "--check")
    assert check.exit_code == 0 and "1 current" in check.stdout and "orphaned" not in check.stdout.split()


def test_a_record_cannot_make_prune_remove_a_file_outside_the_output_folder(robots, tmp_path):
    out = tmp_path / "out"
    assert _build(robots, "--out", out, "--code", "-j", "1").exit_code == 0
    keep = tmp_path / "keep.txt"
    keep.write_text("mine\n")
    manifest = out / ".dynderive-build.json"
    document = json.loads(manifest.read_text())
    document["robots"]["../robots/gone.yaml"] = {"key": "x", "outputs": {"../keep.txt": "0" * 64}}
    manifest.write_text(json.dumps(document))
    result = _build(robots, "--out", out, "--code", "-j", "1", "--prune")
    assert result.exit_code == 0 and "malformed" in result.stderr and "pruned" not in result.stdout
    assert keep.read_text() == "mine\n"


def test_write_all_removes_nothing_when_a_write_fails(tmp_path):
    from dynderive.commands.output import write_all
    from dynderive.errors import OutputError

    stale = tmp_path / "old.pdf"
    stale.write_bytes(b"old")
    (tmp_path / "blocker").write_text("a file where a folder should be\n")
    with pytest.raises(OutputError, match="blocker is a file"):
        write_all({tmp_path / "new.tex": b"new", tmp_path / "blocker" / "x": b"x"}, remove=[stale])
    assert stale.read_bytes() == b"old" and not (tmp_path / "new.tex").exists()
    write_all({tmp_path / "new.tex": b"new"}, remove=[stale, tmp_path / "absent.log"])
    assert not stale.exists() and (tmp_path / "new.tex").read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker", "new.tex"]


def test_prune_keeps_the_outputs_of_a_renamed_robot_file_that_fails(robots, tmp_path):
    """The outputs' robot still has a file (renamed, now failing to build): they are not orphans."""
    out = tmp_path / "out"
    assert _build(robots, "--out", out, "--code", "-j", "1").exit_code == 0
    (robots / "cart_pole.yaml").unlink()
    (robots / "cp.yaml").write_text("name: cart_pole\nplanar: true\n")   # no links: it fails
    result = _build(robots, "--out", out, "--code", "-j", "1", "--prune")
    assert result.exit_code == 1 and "1 up to date, 1 failed" in result.stdout.splitlines()[-1], result.output
    assert (out / "cart_pole_dynamics.py").is_file()


@pytest.mark.parametrize("target", [t.name for t in TARGETS])
def test_build_hashes_every_template_a_target_loads(target, robots, tmp_path, monkeypatch):
    """A target's entry names only the templates its code renders; ``build`` adds what they
    include (read from their syntax), so every template ``solve`` loads for it, for a robot
    with loops too, is one whose edit makes the record stale."""
    import jinja2

    from dynderive.commands.build import TEMPLATES
    from dynderive.errors import InputError
    from dynderive.render import environment

    entry = by_name(target)
    if entry.needs:
        try:
            entry.needs()
        except InputError as exc:   # no compiler here: nothing is rendered to compare
            pytest.skip(str(exc))
    loaded: set[str] = set()
    get_source = jinja2.FileSystemLoader.get_source

    def recording(self, env, name):
        loaded.add(name)
        return get_source(self, env, name)

    monkeypatch.setattr(jinja2.FileSystemLoader, "get_source", recording)
    environment.environment.cache_clear()   # fresh environments: no template served from memory
    try:
        for robot in ("rp_arm", "four_bar"):
            result = runner.invoke(app, ["solve", robot, entry.flag, "--out", str(tmp_path / robot), "-q"])
            assert result.exit_code == 0, result.output
    finally:
        environment.environment.cache_clear()
    hashed = {name for name, _ in environment.templates_in_use(TEMPLATES[entry.kind], None)}
    assert loaded and loaded <= hashed, sorted(loaded - hashed)
