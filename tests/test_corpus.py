"""The bad-input corpus: every file in ``tests/corpus`` must be refused with exit code 2.

Each corpus file holds one bad input and starts with the exact stderr it must produce, one
line per problem, with the file's path written as ``FILE``::

    # expect: FILE:14:11: links[0].mass: must be positive (got -1)        (YAML)
    <!-- expect: FILE:18:3: joint 'shoulder': floating joints are not supported (...) -->   (URDF)

For every case: exit code 2, stderr equal to those lines, no traceback, no output directory.
Files that try to run code (``__import__('os').system('touch MARKER')``, ``open('MARKER')``,
a ``!!python/object/apply`` tag) are copied into ``tmp_path`` with ``MARKER`` replaced by a
path there, and the test checks that nothing created it. Resource attacks (``9**9**9``,
10 000 nested parentheses, a 1 MB expression, 5 000 nested YAML lists, an alias bomb) must be
refused fast: every case in well under 2 s.

``KNOWN_GAPS`` lists the cases where the tool's answer is not yet the expected one (wrong or
imprecise message or position); they are strict xfails, so fixing one makes its test fail
until it is removed from the list.
"""

from __future__ import annotations

import re
import signal
import threading
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

CORPUS = Path(__file__).resolve().parent / "corpus"
CASES = sorted(p for p in CORPUS.iterdir() if p.suffix in {".yaml", ".urdf"})

#: Cases whose current output is wrong or imprecise: file name -> what is wrong now.
KNOWN_GAPS: dict[str, str] = {}

#: Per-case budget (CPU seconds): resource attacks must be refused fast.
CASE_SECONDS = 2.0
#: Budget for the whole corpus (seconds).
CORPUS_SECONDS = 60.0
#: Hard stop for one run, so that a hang fails instead of blocking the suite.
HARD_STOP_SECONDS = 20.0

_EXPECT = re.compile(r"^(?:# expect: (?P<yaml>.*)|<!-- expect: (?P<urdf>.*) -->)$")

runner = CliRunner()


def expectations(case: Path) -> list[str]:
    """The ``expect:`` lines at the top of a corpus file (bytes: some files are not UTF-8)."""
    lines = []
    for raw in case.read_bytes().splitlines():
        match = _EXPECT.match(raw.decode("utf-8", "replace"))
        if match is None:
            break
        lines.append(match.group("yaml") if match.group("yaml") is not None else match.group("urdf"))
    return lines


def prepare(case: Path, tmp_path: Path) -> tuple[Path, Path | None]:
    """The file to run (a copy with ``MARKER`` replaced, for code-execution cases) and the marker."""
    data = case.read_bytes()
    if b"MARKER" not in data:
        return case, None
    marker = tmp_path / "marker" / "created"
    marker.parent.mkdir()
    copy = tmp_path / "case" / case.name
    copy.parent.mkdir()
    copy.write_bytes(data.replace(b"MARKER", str(marker).encode()))
    return copy, marker


class _HardStop(BaseException):
    """Raised by SIGALRM; a BaseException so that the CLI's error handling lets it through."""


def solve(path: Path, out: Path, seconds: float = HARD_STOP_SECONDS):
    """``dynderive solve PATH --latex --code --json --out OUT`` in-process, stopped after ``seconds``."""
    args = ["solve", str(path), "--latex", "--code", "--json", "--out", str(out)]
    if threading.current_thread() is not threading.main_thread():  # no signals here: no hard stop
        return runner.invoke(app, args)

    def stop(signum, frame):
        raise _HardStop

    previous = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        return runner.invoke(app, args)
    except _HardStop:
        pytest.fail(f"{path.name}: still running after {seconds} s (resource attack not refused)")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _param(case: Path):
    marks = [pytest.mark.xfail(strict=True, reason=KNOWN_GAPS[case.name])] if case.name in KNOWN_GAPS else []
    return pytest.param(case, id=case.name, marks=marks)


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_bad_input_is_refused_with_positioned_message(case, tmp_path):
    path, marker = prepare(case, tmp_path)
    out = tmp_path / "out"
    expected = [str(path) + line[len("FILE"):] for line in expectations(case)]
    result = solve(path, out)
    try:
        assert "Traceback" not in result.output
        assert "Traceback" not in result.stderr
        assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
        assert (result.exit_code, result.stderr.splitlines()) == (2, expected)
        assert not out.exists(), "an output directory was created for a bad input"
    finally:
        if marker is not None:
            assert not marker.exists(), "text from the robot file was executed"


def test_every_case_is_refused_fast(tmp_path):
    """Resource attacks must be refused fast: each case under 2 s, the corpus under 60 s, of
    this process's CPU time (the cases run in-process; wall time would count the other jobs
    of a loaded machine: the hard stop above still bounds the wall time)."""
    solve(CASES[0], tmp_path / "warm-up")  # imports (SymPy, NumPy) are not the cases' cost
    times = {}
    for index, case in enumerate(CASES):
        (tmp_path / f"case{index}").mkdir()
        path, _ = prepare(case, tmp_path / f"case{index}")
        start = time.process_time()
        solve(path, tmp_path / f"out{index}")
        times[case.name] = time.process_time() - start
    slow = {name: round(t, 2) for name, t in times.items() if t >= CASE_SECONDS}
    assert not slow, f"cases taking {CASE_SECONDS} s or more: {slow}"
    assert sum(times.values()) < CORPUS_SECONDS


def test_corpus_is_complete():
    assert len(CASES) >= 40
    assert sorted(p.name for p in CORPUS.iterdir()) == [c.name for c in CASES], "corpus files must be .yaml or .urdf"
    for case in CASES:
        assert expectations(case), f"{case.name} has no expect: line"
        assert all(line.startswith("FILE:") for line in expectations(case)), case.name
    assert set(KNOWN_GAPS) <= {c.name for c in CASES}, "KNOWN_GAPS names a file that is not in the corpus"
