"""The documentation cannot rot: every tutorial's commands and Python snippets run, the site
builds with ``mkdocs build --strict``, and the generated reference parts are complete.

Conventions of the tutorial pages (docs/tutorials/*.md and the README's tour), documented in
docs/development/index.md ("Documentation"):

- a fenced block with a title (```` ```yaml title="arm.yaml" ````) is a file: it is written
  into the page's working folder, where the later blocks run;
- ```` ```console ````: each line starting with ``$ `` is a command (a trailing ``\\``
  continues it); the lines after it, up to the next command, are what the command prints
  (stdout and stderr together, as a terminal shows them), whole: compared line by line,
  trailing spaces and trailing blank lines aside, where a line ``...`` stands for any run
  of lines (none included) and ``...`` within a line for any text: what varies by machine
  (timings, paths) or is too long to show;
  the command must exit 0 (write ``cmd || echo "exit $?"`` to show a failure);
- ```` ```bash ````: the block runs as one script (``set -euo pipefail``);
- ```` ```python ````: the block runs as a script of its own;
- other blocks without a title are not run;
- an HTML comment on the line before a block qualifies it: ``<!-- docs-test: skip -->``
  (never run: e.g. installing), ``<!-- docs-test: needs latexmk gcc -->`` (run when every
  program is on PATH, ``python-headers`` meaning Python's C headers; skipped otherwise, and a
  failure when ``CI=true``, as for the other PDF and compiler tests).

Every page's blocks run in order in one temporary folder, with ``dynderive`` the checkout's
(``python -m dynderive`` with ``src/`` on ``PYTHONPATH``) and ``python`` this interpreter.
"""

from __future__ import annotations

import difflib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
TUTORIALS = sorted((DOCS / "tutorials").glob("*.md"))
PAGES = [p for p in TUTORIALS if p.name != "index.md"] + [ROOT / "README.md"]
IN_CI = bool(os.environ.get("CI"))

FENCE = re.compile(r"^(?:<!-- docs-test: (?P<directive>[^>]*?) -->\n)?```(?P<info>[^\n]*)\n(?P<body>.*?)^```$",
                   re.S | re.M)


@dataclass
class Block:
    language: str
    body: str
    line: int
    title: str | None = None
    skip: bool = False
    needs: list[str] = field(default_factory=list)


def blocks(page: Path) -> list[Block]:
    text = page.read_text()
    found = []
    for match in FENCE.finditer(text):
        info = match["info"].strip()
        language = info.split()[0] if info else ""
        title = re.search(r'title="([^"]+)"', info)
        directive = (match["directive"] or "").split()
        block = Block(language, match["body"], text.count("\n", 0, match.start()) + 1,
                      title[1] if title else None)
        if directive[:1] == ["skip"]:
            block.skip = True
        elif directive[:1] == ["needs"]:
            block.needs = directive[1:]
        elif directive:
            raise AssertionError(f"{page}:{block.line}: unknown docs-test directive {directive}")
        found.append(block)
    return found


def _missing(needs: list[str]) -> list[str]:
    missing = []
    for need in needs:
        if need == "python-headers":
            if not (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file():
                missing.append(need)
        elif shutil.which(need) is None:
            missing.append(need)
    return missing


def _environment(tmp_path: Path) -> dict[str, str]:
    shims = tmp_path / ".shims"
    shims.mkdir()
    for name, command in (("dynderive", f'"{sys.executable}" -m dynderive'), ("python", f'"{sys.executable}"')):
        shim = shims / name
        shim.write_text(f'#!/bin/sh\nexec {command} "$@"\n')
        shim.chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{shims}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    env["MPLBACKEND"] = "Agg"
    env["PYTHONUNBUFFERED"] = "1"   # stdout and stderr in the order printed
    env["COLUMNS"] = "80"           # line wrapping as in an 80-column terminal
    return env


def _commands(body: str) -> list[tuple[str, list[str]]]:
    """A console block's commands, each with the output lines shown after it."""
    commands: list[tuple[str, list[str]]] = []
    continued = False
    for line in body.splitlines():
        if continued:
            commands[-1] = (commands[-1][0] + "\n" + line, [])
            continued = line.endswith("\\")
        elif line.startswith("$ "):
            commands.append((line[2:], []))
            continued = line.endswith("\\")
        elif commands:
            commands[-1][1].append(line.rstrip())
    for _, expected in commands:
        while expected and not expected[-1]:
            expected.pop()
    return commands


ELISION = "..."


def output_matches(expected: list[str], got: list[str]) -> bool:
    """Whether the printed lines ``got`` are the ``expected`` ones, where an ``ELISION`` line
    stands for any run of lines (none included). Lines compare without trailing spaces;
    trailing blank lines do not count."""
    got = [line.rstrip() for line in got]
    while got and not got[-1]:
        got.pop()

    @cache
    def match(i: int, j: int) -> bool:   # expected[i:] against got[j:]
        if i == len(expected):
            return j == len(got)
        if expected[i] == ELISION:
            return any(match(i + 1, k) for k in range(j, len(got) + 1))
        return j < len(got) and _line_matches(expected[i], got[j]) and match(i + 1, j + 1)

    return match(0, 0)


def _line_matches(expected: str, got: str) -> bool:
    """One line: equal, or with each ``...`` inside it standing for any text (a timing)."""
    if ELISION not in expected:
        return expected == got
    return re.fullmatch(".*".join(map(re.escape, expected.split(ELISION))), got) is not None


def _difference(expected: list[str], output: str) -> str:
    diff = difflib.unified_diff(expected, [line.rstrip() for line in output.splitlines()],
                                "the page", "printed", lineterm="", n=2)
    return "\n".join(diff) + f"\n\nprinted:\n{output}"


def _run(script: list[str], where: str, cwd: Path, env: dict[str, str]) -> str:
    """Run ``script``; its stdout and stderr interleaved as a terminal shows them."""
    result = subprocess.run(script, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, timeout=600)
    output = result.stdout
    assert result.returncode == 0, f"{where}: exit {result.returncode}\n{output[-3000:]}"
    return output


@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_tutorial_blocks_run(page, tmp_path):
    env = _environment(tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    ran = skipped = 0
    for block in blocks(page):
        where = f"{page.relative_to(ROOT)}:{block.line}"
        if block.skip:
            continue
        missing = _missing(block.needs)
        if missing:
            assert not IN_CI, f"{where}: needs {', '.join(missing)} (required when CI=true)"
            skipped += 1
            continue
        if block.title:
            target = work / block.title
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.body)
        elif block.language == "console":
            commands = _commands(block.body)
            assert commands, f"{where}: a console block without a '$ ' command"
            for command, expected in commands:
                output = _run(["bash", "-euo", "pipefail", "-c", command], f"{where}: {command}", work, env)
                assert output_matches(expected, output.splitlines()), \
                    f"{where}: {command}: the output differs ('...' lines elide):\n{_difference(expected, output)}"
            ran += 1
        elif block.language == "bash":
            _run(["bash", "-euo", "pipefail", "-c", block.body], where, work, env)
            ran += 1
        elif block.language == "python":
            script = work / f".block_{block.line}.py"
            script.write_text(block.body)
            _run([sys.executable, str(script)], where, work, env)
            ran += 1
    if skipped and not ran:
        pytest.skip(f"every block of {page.name} needs a missing program")
    assert ran, f"{page}: no block ran"


def test_block_conventions_are_read():
    """The extraction itself: titled files, commands with continuations and expected output,
    and directives are found where the pages put them."""
    page = DOCS / "tutorials" / "first-robot.md"
    found = blocks(page)
    assert any(b.title == "arm.yaml" and b.language == "yaml" for b in found)
    assert any(b.needs == ["latexmk"] for b in found)
    commands = _commands("$ dynderive solve a \\\n    --code\n  wrote x  \n...\n\n$ ls\n")
    assert commands == [("dynderive solve a \\\n    --code", ["  wrote x", "..."]), ("ls", [])]


def test_console_output_is_compared_whole_with_elisions():
    printed = ["a", "b", "c", "", "d  ", ""]
    assert output_matches(["a", "b", "c", "", "d"], printed)
    assert output_matches(["a", "...", "d"], printed)
    assert output_matches(["...", "c", "...", "d"], printed)
    assert output_matches(["a", "b", "...", "c", "", "d", "..."], printed)   # a run of none
    assert output_matches(["..."], []) and output_matches([], ["", ""])
    assert not output_matches(["a", "b", "c"], printed)        # a line left out
    assert not output_matches(["b", "...", "d"], printed)      # the first line differs
    assert not output_matches(["a", "...", "x", "d"], printed)
    assert not output_matches([" a", "..."], printed)          # leading spaces count
    assert not output_matches([], ["a"])
    timed = ["robots/arm.yaml  built  1.3  9", "1 built"]
    assert output_matches(["robots/arm.yaml  built  ...  9", "1 built"], timed)   # within a line
    assert not output_matches(["robots/arm.yaml  current  ...", "1 built"], timed)
    assert not output_matches(["robots/arm.yaml  built  ...  8", "1 built"], timed)


def test_readme_keeps_the_two_set_up_commands():
    """The README's install-and-run and install-and-test commands, byte for byte; .ci/run runs
    the second literally."""
    readme = (ROOT / "README.md").read_text()
    test_command = 'python -m pip install ".[test]" && python -m pytest'
    assert f"```sh\n{test_command}\n```" in readme
    assert f"\n{test_command}\n" in (ROOT / ".ci" / "run").read_text()
    assert "```sh\npython -m pip install . && dynderive solve rp_arm --latex --code --json --out out\n```" in readme
    assert len(readme.splitlines()) <= 200


def test_every_tutorial_is_in_the_navigation():
    config = (ROOT / "mkdocs.yml").read_text()
    for page in TUTORIALS:
        assert f"tutorials/{page.name}" in config, page


# ----------------------------------------------------------------------------- the site


def _hooks():
    sys.path.insert(0, str(DOCS / "hooks"))
    try:
        import generated
    finally:
        sys.path.remove(str(DOCS / "hooks"))
    return generated


def test_cli_reference_lists_every_command_and_option():
    import click
    import typer

    from dynderive.commands.cli import app

    text = _hooks().cli_markdown()
    group = typer.main.get_command(app)
    context = click.Context(group, info_name="dynderive")
    for name in group.list_commands(context):
        assert f"### `dynderive {name}`" in text
        options = [p for p in group.get_command(context, name).params if p.param_type_name == "option"]
        assert options or name == "schema", name
        for param in options:
            assert any(f"`{opt}" in text or f", {opt}" in text for opt in param.opts), (name, param.opts)
    assert "--friction-smoothing" in text and "`ROBOT`" in text
    assert "<name>" not in text   # escaped: it would be an HTML tag


def test_robot_format_reference_lists_every_key():
    from dynderive.input.json_schema import robot_schema

    text = _hooks().schema_markdown()

    def keys(node, path):
        for key, value in node.get("properties", {}).items():
            yield key, path
            items = value.get("items") if value.get("type") == "array" else None
            if isinstance(items, dict) and "properties" in items:
                yield from keys(items, f"{path}.{key}[]")
            elif "properties" in value:
                yield from keys(value, f"{path}.{key}")

    listed = list(keys(robot_schema(), ""))
    assert len(listed) == text.count(" | yes | ") + text.count(" | no | ")   # one row per key
    for key, path in listed:
        assert f"| `{key}` |" in text, (path, key)
    for section in ("Each entry of `joints`", "Each entry of `loops`", "Each entry of `frames`", "`maximal`",
                    "Each entry of `parameters`"):
        assert section in text
    assert "`revolute` \\| `prismatic` \\| `fixed`" in text


def test_generated_references_are_current():
    """The committed reference pages hold the generated tables as the code makes them now."""
    hooks = _hooks()
    stale = hooks.stale_pages()
    assert not stale, f"not current: {', '.join(stale)}; update with: {hooks.UPDATE}"


def test_a_stale_generated_region_is_found_and_rewritten():
    hooks = _hooks()
    page = "intro\n<!-- generated: robot-schema -->\nold table\n<!-- end generated -->\nafter\n"
    new = hooks.regenerate(page)
    assert new != page and "old table" not in new
    assert new.startswith("intro\n<!-- generated: robot-schema -->\n### Top level\n")
    assert new.endswith("\n<!-- end generated -->\nafter\n")
    assert hooks.regenerate(new) == new
    with pytest.raises(ValueError, match="unknown generated region 'bogus'"):
        hooks.regenerate("<!-- generated: bogus -->\n<!-- end generated -->\n")


def test_mkdocs_build_strict(tmp_path):
    try:
        import material  # noqa: F401
        import mkdocs  # noqa: F401
    except ImportError:
        if IN_CI:
            raise
        pytest.skip("mkdocs and mkdocs-material are not installed (pip install '.[test]')")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                             "-d", str(tmp_path / "site")], cwd=ROOT, env=env, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text()
    assert "dynderive simulate" in cli and "--friction-smoothing" in cli
    robot = (tmp_path / "site" / "reference" / "robot-format" / "index.html").read_text()
    assert "child_origin" in robot and "armature" in robot
    assert "generated: " not in cli + robot and "end generated" not in cli + robot   # markers dropped
