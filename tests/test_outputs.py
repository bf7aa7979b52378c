"""All-or-nothing outputs and quiet interrupts (issue 13, item 5)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dynderive.commands.output import write_all
from dynderive.errors import OutputError


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("failing", [1, 2, 3])
def test_a_failed_rename_restores_every_output(tmp_path, monkeypatch, failing):
    (tmp_path / "a.tex").write_bytes(b"old a")
    (tmp_path / "b.py").write_bytes(b"old b")
    before = _listing(tmp_path)
    real = os.replace
    calls = []

    def replace(src, dst):
        if str(src).endswith(".tmp"):
            calls.append(dst)
            if len(calls) == failing:
                raise PermissionError(13, "Permission denied", str(dst))
        return real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OutputError):
        write_all({tmp_path / "a.tex": b"new a", tmp_path / "b.py": b"new b", tmp_path / "c.json": b"new c"})
    assert _listing(tmp_path) == before   # old contents back, no new file, no temporaries


def test_an_interrupt_during_the_renames_restores_every_output(tmp_path, monkeypatch):
    (tmp_path / "a.tex").write_bytes(b"old a")
    real = os.replace
    count = [0]

    def replace(src, dst):
        count[0] += 1
        if count[0] == 2:
            raise KeyboardInterrupt
        return real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        write_all({tmp_path / "a.tex": b"new a", tmp_path / "b.py": b"new b"})
    assert _listing(tmp_path) == {"a.tex": b"old a"}


def test_success_replaces_all_and_leaves_nothing_else(tmp_path):
    (tmp_path / "a.tex").write_bytes(b"old a")
    write_all({tmp_path / "a.tex": b"new a", tmp_path / "sub" / "b.py": b"new b"})
    assert _listing(tmp_path / "sub") == {"b.py": b"new b"}
    assert (tmp_path / "a.tex").read_bytes() == b"new a"
    assert not [p for p in tmp_path.rglob(".*")]


def _wait_for_handlers(pid: int, timeout: float = 30.0) -> None:
    """Until the process catches SIGTERM (``SigCgt`` in /proc): dynderive's first line has run.
    Before that the interpreter's own handling applies (about 40 ms on an idle machine, far
    longer on a loaded one), which no program can change."""
    status = Path(f"/proc/{pid}/status")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            caught = next(line for line in status.read_text().splitlines() if line.startswith("SigCgt:"))
        except (OSError, StopIteration):
            return
        if int(caught.split()[1], 16) >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.005)


#: From Python's start until dynderive's first line runs the interpreter's own handling
#: applies; from then on every moment of the run is covered (the delays count from there).
@pytest.mark.parametrize("delay", [0.0, 0.1, 0.2, 0.3, 0.6])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_early_interrupt_exits_130_without_a_traceback(tmp_path, delay, sig):
    process = subprocess.Popen([sys.executable, "-m", "dynderive", "solve", "rp_arm", "--code", "--out", str(tmp_path)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_handlers(process.pid)
    time.sleep(delay)
    process.send_signal(sig)
    out, err = process.communicate(timeout=120)
    if process.returncode == 0:   # finished before the signal arrived
        return
    assert process.returncode == 130, err
    assert "Traceback" not in err and err.strip().endswith("interrupted; no output was changed")
    assert not list(tmp_path.iterdir())
