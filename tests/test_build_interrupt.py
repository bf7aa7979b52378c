"""An interrupt of `dynderive build -j 2` (SIGTERM to it, Ctrl-C's SIGINT to its process
group) cancels the robots still queued and stops the workers at once: exit 130 with one line,
nothing written into `--out`, no worker left running.

Linux only (the workers are found through /proc). The bound on the time is relative to an
uninterrupted run of the same build, so a slow or loaded machine does not fail it.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROBOTS

pytestmark = pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux's /proc")

ROBOT_NAMES = ("rp_arm", "cart_pole", "double_pendulum", "cart_pole_damped", "elbow_arm", "slider_crank")
SRC = Path(__file__).resolve().parents[1] / "src"


def _command(robots: Path, out: Path) -> list[str]:
    return [sys.executable, "-c", "from dynderive.__main__ import run; run()", "build", str(robots),
            "--out", str(out), "--latex", "--code", "-j", "2"]


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SRC), env.get("PYTHONPATH")) if p)
    return env


def _children() -> dict[int, list[int]]:
    """Every process's children, from /proc."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            parent = int(stat.rsplit(")", 1)[1].split()[1])
            children.setdefault(parent, []).append(int(entry))
    return children


def _descendants(pid: int) -> list[int]:
    children, found, todo = _children(), [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def _ignores_sigint(pid: int) -> bool:
    """Whether ``pid`` ignores SIGINT: a build worker does once it is set up to take robots."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    ignored = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigIgn:")), 16)
    return bool(ignored & (1 << (signal.SIGINT - 1)))


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    """The robots, and the seconds an uninterrupted build of them takes."""
    folder = tmp_path_factory.mktemp("interrupt")
    robots = folder / "robots"
    robots.mkdir()
    for name in ROBOT_NAMES:
        shutil.copy(ROBOTS / f"{name}.yaml", robots)
    start = time.monotonic()
    result = subprocess.run(_command(robots, folder / "full"), env=_environment(), capture_output=True, text=True,
                            timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    return robots, time.monotonic() - start


@pytest.mark.parametrize("how", ["SIGTERM to build", "SIGINT to the process group"])
def test_an_interrupt_stops_a_parallel_build_at_once(how, full_run, tmp_path):
    robots, full_seconds = full_run
    before = {p.name: p.read_bytes() for p in robots.iterdir()}
    out = tmp_path / "out"
    process = subprocess.Popen(_command(robots, out), env=_environment(), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        # both workers are set up (they ignore SIGINT from then on) and have taken a robot each
        deadline = time.monotonic() + 300   # a hang guard, not a measure
        workers: list[int] = []
        while len(workers) < 2:
            assert process.poll() is None and time.monotonic() < deadline, "the build ended before its workers began"
            workers = [pid for pid in _descendants(process.pid) if _ignores_sigint(pid)]
            time.sleep(0.05)
        signalled = time.monotonic()
        if how.startswith("SIGTERM"):
            process.send_signal(signal.SIGTERM)
        else:
            os.killpg(process.pid, signal.SIGINT)
        stdout, stderr = process.communicate(timeout=300)
        seconds = time.monotonic() - signalled
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, stdout + stderr
    assert stderr.splitlines() == ["dynderive: interrupted; no output was changed"]
    # each worker had 3 robots; an uninterrupted run took full_seconds: stopping is far quicker
    assert seconds < full_seconds / 2, (seconds, full_seconds)
    deadline = time.monotonic() + 30
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [pid for pid in workers if _alive(pid)], "a worker is still running"
    assert not out.exists() or list(out.iterdir()) == []   # nothing written, no lock file
    assert {p.name: p.read_bytes() for p in robots.iterdir()} == before
