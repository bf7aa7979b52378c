"""`dynderive build` as a careless or hostile user runs it: `--prune` removes only what build
wrote and nobody changed since, a manifest cannot make it write or delete outside `--out`,
a bad `--out` is refused before any derivation, an empty robot folder is an error, no lock
file is left behind, and `-q` keeps quiet."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

from conftest import ROBOTS

runner = CliRunner()
MANIFEST = ".dynderive-build.json"


def _build(*args):
    return runner.invoke(app, ["build", *map(str, args)])


def _solve(*args):
    return runner.invoke(app, ["solve", *map(str, args)])


def _tree(folder: Path) -> dict[str, bytes | str]:
    """Every entry under ``folder`` by relative path: a file's bytes, a link's target."""
    found: dict[str, bytes | str] = {}
    for path in sorted(folder.rglob("*")):
        key = path.relative_to(folder).as_posix()
        if path.is_symlink():
            found[key] = "-> " + os.readlink(path)
        elif path.is_file():
            found[key] = path.read_bytes()
        else:
            found[key] = "folder"
    return found


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture()
def course(tmp_path):
    """Two robot files, built once into ``out`` (sheet, NumPy module, MATLAB package), then
    one of them deleted: its outputs are orphaned."""
    robots = tmp_path / "robots"
    robots.mkdir()
    for name in ("rp_arm", "cart_pole"):
        shutil.copy(ROBOTS / f"{name}.yaml", robots)
    out = tmp_path / "out"
    built = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1")
    assert built.exit_code == 0, built.output
    (robots / "cart_pole.yaml").unlink()
    return robots, out


def _prune(robots, out):
    return _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1", "--prune")


def _edit_manifest(out: Path, change) -> None:
    manifest = out / MANIFEST
    document = json.loads(manifest.read_text())
    change(document["robots"])
    manifest.write_text(json.dumps(document, indent=2) + "\n")


# --- --prune removes only what build wrote, unchanged since ---------------------------------------


def test_prune_keeps_a_users_file_hand_added_to_a_record(course, tmp_path):
    """A name no output of the record's robot has is kept, even with its hash forged right."""
    robots, out = course
    thesis = out / "thesis.tex"
    thesis.write_bytes(b"\\documentclass{book} % two years of work\n")
    before = thesis.read_bytes()
    _edit_manifest(out, lambda records: records["../robots/cart_pole.yaml"]["outputs"].update(
        {"thesis.tex": _sha(thesis)}))
    result = _prune(robots, out)
    assert result.exit_code == 0, result.output
    assert thesis.read_bytes() == before
    assert f"  {thesis}: kept (not a name build gives an output of robot 'cart_pole')" in result.stdout
    assert f"  {out / 'cart_pole.tex'}: removed" in result.stdout
    assert not (out / "cart_pole.tex").exists() and not (out / "+cart_pole").exists()
    assert list(json.loads((out / MANIFEST).read_text())["robots"]) == ["../robots/rp_arm.yaml"]


def test_prune_keeps_a_forged_record_of_a_users_file(course, tmp_path):
    """A whole record made up for a user's file: its hash does not match (kept), and without
    --prune it is listed, saying --prune keeps it."""
    robots, out = course
    notes = out / "notes.tex"
    notes.write_text("my notes\n")
    _edit_manifest(out, lambda records: records.update(
        {"../robots/gone.yaml": {"key": "x", "outputs": {"notes.tex": "0" * 64}}}))
    listed = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1")
    assert f"  {notes}: orphaned (--prune keeps it: edited since it was built)" in listed.stdout, listed.output
    result = _prune(robots, out)
    assert result.exit_code == 0, result.output
    assert f"  {notes}: kept (edited since it was built)" in result.stdout
    assert notes.read_text() == "my notes\n"


def test_prune_keeps_an_output_edited_since_the_build(course):
    robots, out = course
    sheet = out / "cart_pole.tex"
    sheet.write_text(sheet.read_text() + "% my corrections\n")
    before = sheet.read_bytes()
    result = _prune(robots, out)
    assert result.exit_code == 0, result.output
    assert f"  {sheet}: kept (edited since it was built)" in result.stdout
    assert f"  {out / 'cart_pole_dynamics.py'}: removed" in result.stdout
    assert sheet.read_bytes() == before and not (out / "cart_pole_dynamics.py").exists()
    # the record is gone: the kept file is the user's, no longer reported
    check = _build(robots, "--out", out, "--latex", "--code", "--matlab", "--check", "-j", "1")
    assert check.exit_code == 0 and "orphaned" not in check.stdout, check.output
    assert sheet.read_bytes() == before


def test_prune_never_removes_through_a_symbolic_link(course, tmp_path):
    """An output that is a link, and a MATLAB package folder that is a link, are kept with the
    files they point to, although their content is exactly what build wrote."""
    robots, out = course
    mine = tmp_path / "mine"
    mine.mkdir()
    module = out / "cart_pole_dynamics.py"
    shutil.move(module, mine / "module.py")
    module.symlink_to(mine / "module.py")
    shutil.move(out / "+cart_pole", mine / "package")
    (out / "+cart_pole").symlink_to(mine / "package")
    before = _tree(mine)
    result = _prune(robots, out)
    assert result.exit_code == 0, result.output
    assert f"  {module}: kept (a symbolic link)" in result.stdout
    assert f"  {out / '+cart_pole' / 'parameters.m'}: kept (its folder +cart_pole is a symbolic link)" in result.stdout
    assert _tree(mine) == before
    assert module.is_symlink() and (out / "+cart_pole").is_symlink()
    assert not (out / "cart_pole.tex").exists()   # a plain output of the same record is removed


def test_a_manifest_that_is_a_link_is_never_written_through(course, tmp_path):
    """Neither read (its records could name any file) nor written through: the link itself is
    replaced, the file it points to outside --out is byte-identical."""
    robots, out = course
    precious = tmp_path / "precious.json"
    precious.write_text('{"robots": {"../robots/gone.yaml": {"key": "x", "outputs": {"rp_arm.tex": "0"}}}}\n')
    before = precious.read_bytes()
    for extra in ((), ("--prune",)):
        (out / MANIFEST).unlink()
        (out / MANIFEST).symlink_to(precious)
        result = _build(robots, "--out", out, "--latex", "--code", "--matlab", "-j", "1", *extra)
        assert result.exit_code == 0, result.output
        assert f"note: {out / MANIFEST} is a symbolic link, not a build manifest" in result.stderr
        assert precious.read_bytes() == before
        assert (out / "rp_arm.tex").is_file()   # the link's record was never read
        assert not (out / MANIFEST).is_symlink()
        assert list(json.loads((out / MANIFEST).read_text())["robots"]) == ["../robots/rp_arm.yaml"]


@pytest.mark.parametrize("where", ["/", "home", "above home", "link to home"])
def test_prune_is_refused_at_a_filesystem_root_or_the_home_folder(where, tmp_path, monkeypatch):
    home = tmp_path / "users" / "me"
    home.mkdir(parents=True)
    (home / "thesis.tex").write_text("mine\n")
    monkeypatch.setenv("HOME", str(home))
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = {"/": Path("/"), "home": home, "above home": tmp_path / "users", "link to home": tmp_path / "link"}[where]
    if where == "link to home":
        out.symlink_to(home)
    before = _tree(tmp_path)
    result = _build(robots, "--out", out, "--code", "-j", "1", "--prune")
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(f"--out:1:1: --prune does not remove files from {out} (")
    assert len(result.stderr.splitlines()) == 1 and not result.stdout
    assert _tree(tmp_path) == before   # nothing built, nothing removed


# --- a bad --out is refused before any derivation --------------------------------------------------


@pytest.fixture()
def no_derivation(monkeypatch):
    """Fail the test if a robot is derived."""
    import dynderive

    def derive(*args, **kwargs):
        raise AssertionError("derived before the output folder was checked")

    monkeypatch.setattr(dynderive, "derive", derive)


@pytest.mark.parametrize("case", ["out is a file", "a file above out", "an output is a folder"])
def test_solve_refuses_a_bad_out_before_deriving(case, tmp_path, monkeypatch, no_derivation):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("mine\n")
    out, expected = {
        "out is a file": ("notes.txt", "--out:1:1: notes.txt is a file, not a folder"),
        "a file above out": ("notes.txt/sheets", "--out:1:1: notes.txt is a file, not a folder (in the way of "
                             "notes.txt/sheets)"),
        "an output is a folder": ("sheets", "--out:1:1: sheets/rp_arm.tex is a folder: the output rp_arm.tex "
                                  "cannot be written"),
    }[case]
    (tmp_path / "sheets" / "rp_arm.tex").mkdir(parents=True)
    before = _tree(tmp_path)
    result = _solve("rp_arm", "--latex", "--code", "--out", out)
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [expected]
    assert _tree(tmp_path) == before


def test_solve_refuses_a_folder_it_cannot_create_or_write(tmp_path, monkeypatch, no_derivation):
    monkeypatch.chdir(tmp_path)
    cases = []
    if Path("/proc/self").is_dir():   # cannot be created, even by root
        cases.append(("/proc/dynderive-sheets", "--out:1:1: cannot create /proc/dynderive-sheets in /proc: "))
    if os.geteuid() != 0:   # root writes anyway
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o555)
        cases += [(str(locked), f"--out:1:1: cannot write into {locked}: Permission denied"),
                  (str(locked / "sub"), f"--out:1:1: cannot create {locked / 'sub'} in {locked}: Permission denied")]
    if not cases:
        pytest.skip("no folder here that cannot be written")
    for out, expected in cases:
        result = _solve("rp_arm", "--latex", "--out", out)
        assert result.exit_code == 2, result.output
        assert len(result.stderr.splitlines()) == 1 and result.stderr.startswith(expected), result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == (["locked"] if os.geteuid() != 0 else [])


@pytest.mark.parametrize("extra", [(), ("--check",)])
def test_build_refuses_an_out_that_is_a_file_before_anything_else(extra, tmp_path, no_derivation):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = tmp_path / "notes.txt"
    out.write_text("mine\n")
    result = _build(robots, "--out", out, "--code", "-j", "1", *extra)
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [f"--out:1:1: {out} is a file, not a folder"]   # no manifest note
    assert out.read_text() == "mine\n" and not result.stdout


def test_build_refuses_an_output_that_is_a_folder_before_deriving(tmp_path, no_derivation):
    robots = tmp_path / "robots"
    robots.mkdir()
    for name in ("rp_arm", "cart_pole"):
        shutil.copy(ROBOTS / f"{name}.yaml", robots)
    out = tmp_path / "out"
    (out / "cart_pole_dynamics.py").mkdir(parents=True)
    result = _build(robots, "--out", out, "--latex", "--code", "-j", "1")
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [f"--out:1:1: {out / 'cart_pole_dynamics.py'} is a folder: the output "
                                          "cart_pole_dynamics.py cannot be written"]
    assert _tree(out) == {"cart_pole_dynamics.py": "folder"}


# --- an empty robot folder, the lock, -q ----------------------------------------------------------


@pytest.mark.parametrize("extra", [(), ("--check",)])
def test_build_on_a_folder_without_robot_files_is_an_error(extra, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    notes = tmp_path / "notes"
    notes.mkdir()
    (notes / "README.md").write_text("robots go elsewhere\n")
    out = tmp_path / "out"
    for folder in (empty, notes):
        result = _build(folder, "--out", out, *extra)
        assert result.exit_code == 2, result.output
        assert result.stderr.splitlines() == [f"{folder}:1:1: no robot files in this folder (*.yaml, *.yml, "
                                              "*.urdf, *.xml, in any subfolder)"]
    assert not out.exists()


def test_build_leaves_no_lock_file_and_removes_an_old_one(tmp_path):
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(ROBOTS / "rp_arm.yaml", robots)
    out = tmp_path / "out"
    assert _build(robots, "--out", out, "--code", "-j", "1").exit_code == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "rp_arm_dynamics.py"]
    (out / ".dynderive-build.lock").write_bytes(b"")   # left by an earlier version
    assert "1 up to date" in _build(robots, "--out", out, "--code", "-j", "1").stdout
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "rp_arm_dynamics.py"]
    (out / ".dynderive-build.lock").write_text("not empty: not an old lock\n")
    assert _build(robots, "--out", out, "--code", "-j", "1").exit_code == 0
    assert (out / ".dynderive-build.lock").read_text() == "not empty: not an old lock\n"


def test_quiet_build_prints_only_what_needs_the_user(tmp_path):
    robots = tmp_path / "robots"
    robots.mkdir()
    for name in ("rp_arm", "cart_pole"):
        shutil.copy(ROBOTS / f"{name}.yaml", robots)
    out = tmp_path / "out"
    for option in ("-q", "--quiet"):
        built = _build(robots, "--out", out, "--code", "-j", "1", option)
        assert built.exit_code == 0 and built.stdout == "" and built.stderr == "", built.output
        assert (out / "rp_arm_dynamics.py").is_file()
    module = out / "cart_pole_dynamics.py"
    module.write_text(module.read_text() + "# edited\n")
    check = _build(robots, "--out", out, "--code", "--check", "-q")
    assert check.exit_code == 1 and check.stderr == ""
    lines = check.stdout.splitlines()
    assert len(lines) == 3 and lines[0].split()[:2] == ["robot", "status"], check.stdout
    assert lines[1].split()[:2] == [str(robots / "cart_pole.yaml"), "differs"]
    assert lines[2] == f"  {module}: differs"


def test_the_build_guide_lists_every_name_prune_may_remove():
    """docs/guides/build.md says exactly what --prune may delete: every suffix of the registry."""
    from dynderive.commands.build import EXTENSION_SUFFIX, OUTPUT_NAMES

    text = (Path(__file__).resolve().parents[1] / "docs" / "guides" / "build.md").read_text()
    section = " ".join(text.split("### What `--prune` may delete", 1)[1].split("\n## ", 1)[0].split())
    for pattern in OUTPUT_NAMES:
        if pattern.startswith("+"):
            assert "`.m` file in the robot's MATLAB package folder `+<name>/`" in section
        elif pattern.endswith(EXTENSION_SUFFIX):
            assert "`_dynamics_c<extension suffix>`" in section
        else:
            assert f"`{pattern.replace('{}', '')}`" in section, pattern
