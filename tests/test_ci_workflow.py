"""The sample CI workflow works as the tutorial (docs/tutorials/ci-solutions.md) sets it up, in
its default setup: a fork of dynderive's repository (``DYNDERIVE_SOURCE: .``), with the
project's ``.gitignore`` and the bundled robots in ``robots/``.

In a fresh git repository laid out so: the tutorial's robot files, its commit step (build,
``git add -A``, commit), then the workflow's shell steps in order (the install step left out:
dynderive is the one under test) for a pull request, for the push to main, and for a second
pull request that changes a robot file. Every ``--check`` must pass.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "tutorials" / "ci-solutions.md"
WORKFLOW = ROOT / "examples" / "ci" / "regenerate-sheets.yml"

pytestmark = [pytest.mark.pdf, pytest.mark.skipif(shutil.which("git") is None, reason="needs git")]


def _robot_files() -> dict[str, str]:
    """The tutorial's robot files (its titled YAML blocks) by path."""
    text = TUTORIAL.read_text()
    return dict(re.findall(r'^```yaml title="([^"]+)"\n(.*?)^```$', text, re.S | re.M))


def _commit_steps() -> str:
    """The tutorial's shell block that builds and commits the outputs."""
    blocks = re.findall(r"^```sh\n(.*?)^```$", TUTORIAL.read_text(), re.S | re.M)
    steps = [block for block in blocks if "git add" in block]
    assert len(steps) == 1, blocks
    return steps[0]


def _workflow_steps(event: str) -> list[str]:
    """The workflow's shell steps that run on ``event``, in order, but the install step."""
    workflow = yaml.safe_load(WORKFLOW.read_text())
    steps = []
    for step in workflow["jobs"]["sheets"]["steps"]:
        condition = step.get("if")
        if "run" not in step or "pip install" in step["run"]:
            continue
        if condition is None or condition == f"github.event_name == '{event}'":
            steps.append(step["run"])
    assert steps, event
    return steps


@pytest.fixture()
def fork(tmp_path):
    """A fresh repository laid out as a fork: the project's .gitignore and bundled robots,
    the tutorial's robot files; and the environment the steps run in."""
    repo = tmp_path / "course"
    repo.mkdir()
    shutil.copy(ROOT / ".gitignore", repo / ".gitignore")
    shutil.copytree(ROOT / "robots", repo / "robots")
    for name, text in _robot_files().items():
        (repo / name).parent.mkdir(parents=True, exist_ok=True)
        (repo / name).write_text(text)
    shims = tmp_path / "bin"
    shims.mkdir()
    shim = shims / "dynderive"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m dynderive "$@"\n')
    shim.chmod(0o755)
    import dynderive

    env = dict(os.environ)
    env["PATH"] = f"{shims}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(Path(dynderive.__file__).parents[1]), env.get("PYTHONPATH"))
                                        if p)
    env.update({"DYNDERIVE_SOURCE": ".", "GIT_AUTHOR_NAME": "TA", "GIT_AUTHOR_EMAIL": "ta@example.org",
                "GIT_COMMITTER_NAME": "TA", "GIT_COMMITTER_EMAIL": "ta@example.org"})
    _git(repo, env, "init", "-q", "-b", "main")
    _git(repo, env, "add", "-A")
    _git(repo, env, "commit", "-q", "-m", "The course, forked")
    return repo, env


def _git(repo: Path, env: dict[str, str], *args: str) -> str:
    return subprocess.run(["git", *args], cwd=repo, env=env, check=True, capture_output=True, text=True).stdout


def _run(script: str, repo: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=repo, env=env, capture_output=True,
                          text=True, timeout=900)


def _steps(event: str, repo: Path, env: dict[str, str]) -> str:
    """Run the workflow's steps for ``event``; each must pass. Their stdout."""
    printed = ""
    for script in _workflow_steps(event):
        result = _run(script, repo, env)
        assert result.returncode == 0, f"{event}: {script}\n{result.stdout}\n{result.stderr}"
        printed += result.stdout
    return printed


def test_the_sample_workflow_passes_in_a_fork_as_the_tutorial_sets_it_up(fork):
    if shutil.which("latexmk") is None:
        pytest.skip("no TeX engine")
    repo, env = fork
    robots = sorted(p.name for p in (repo / "robots").iterdir())
    committed = _run(_commit_steps(), repo, env)
    assert committed.returncode == 0, committed.stdout + committed.stderr
    tracked = _git(repo, env, "ls-files").split()
    outputs = sorted(name for name in tracked if not name.startswith(("robots/", "problems/")))
    assert outputs == sorted(["sheets/.dynderive-build.json", ".gitignore"] + [
        f"sheets/{name}{suffix}" for name in ("pendulum", "slider")
        for suffix in (".tex", ".pdf", "_dynamics.py")])   # the outputs, the manifest, no lock file
    assert not _git(repo, env, "status", "--porcelain", "--ignored")   # nothing left untracked or ignored
    # the pull request: --check is green; the push to main: regenerates nothing new
    pull = _steps("pull_request", repo, env)
    assert "2 current" in pull
    push = _steps("push", repo, env)
    assert "2 up to date" in push
    assert not _git(repo, env, "status", "--porcelain", "--ignored")
    assert sorted(p.name for p in (repo / "sheets").glob("*.pdf")) == ["pendulum.pdf", "slider.pdf"]  # uploaded
    assert sorted(p.name for p in (repo / "robots").iterdir()) == robots   # the bundled robots: not built
    # a second pull request: a robot file changed, rebuilt and committed as the tutorial says
    pendulum = repo / "problems" / "pendulum.yaml"
    pendulum.write_text(pendulum.read_text().replace("value: 0.5, unit: m", "value: 0.6, unit: m"))
    stale = _run(_workflow_steps("pull_request")[0], repo, env)
    assert stale.returncode == 1 and "sheets/pendulum.tex: differs" in stale.stdout, stale.stdout + stale.stderr
    committed = _run(_commit_steps(), repo, env)
    assert committed.returncode == 0, committed.stdout + committed.stderr
    assert "sheets/pendulum.pdf" in _git(repo, env, "show", "--name-only", "--format=", "HEAD").split()
    second = _steps("pull_request", repo, env)
    assert "2 current" in second
