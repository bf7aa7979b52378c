"""Stage-by-stage progress on stderr, for runs that take long enough to wonder about.

Quick runs print nothing. Once a run has taken 1 s, every stage is printed as it starts (with
the stages before it), and a watchdog thread prints the current stage once it has run for
3 s, so a single long stage is never silent; a stage still running after a minute gets a
line each minute with its time so far. Loading is not watched: it is bounded by the file
limits, and a file that a loaded machine takes seconds to parse and then refuses must end in
its one-line error alone.

>>> progress = Progress(quiet=True)
>>> progress("kinematics (2 links)")   # quiet: nothing is printed
"""

from __future__ import annotations

import sys
import threading
import time

#: A run is silent until it has taken this long (seconds).
SHOW_AFTER = 1.0
#: The watchdog shows a stage (and those before it) once it has run this long (seconds).
WATCH_AFTER = 3.0
#: Stages the watchdog leaves alone (reading and validating the file).
UNWATCHED = frozenset({"loading"})
#: A stage still running is reported again after each of these intervals (seconds).
STILL_EVERY = 60.0


class Progress:
    """Callable with the name of each stage as it starts (``Derivation``'s ``report``)."""

    #: Every progress with a running watchdog, for ``close_all`` at the end of a command.
    running: list[Progress] = []

    def __init__(self, quiet: bool, stream=None):
        self.quiet = quiet
        self.stream = stream
        self.start = time.monotonic()
        self.pending: list[str] = []
        self.shown = False
        self.stage: str | None = None
        self.stage_start = self.start
        self.stage_reported = 0.0   # seconds into the stage of its last "still" line
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._watchdog: threading.Thread | None = None

    def __call__(self, stage: str) -> None:
        if self.quiet:
            return
        now = time.monotonic()
        with self._lock:
            self.stage, self.stage_start, self.stage_reported = stage, now, 0.0
            self.pending.append(self._line(now, stage))
            if self.shown or now - self.start >= SHOW_AFTER:
                self._flush()
        if self._watchdog is None:
            self._watchdog = threading.Thread(target=self._watch, name="dynderive-progress", daemon=True)
            Progress.running.append(self)
            self._watchdog.start()

    def close(self) -> None:
        """Stop the watchdog: the run is over, nothing more is printed."""
        with self._lock:
            self._stop.set()
            self.stage = None

    @classmethod
    def close_all(cls) -> None:
        """Stop every watchdog (the command's end, however it ends)."""
        while cls.running:
            cls.running.pop().close()

    def _line(self, now: float, text: str) -> str:
        return f"  [{now - self.start:6.1f} s] {text}"

    def _flush(self) -> None:
        self.shown = True
        stream = self.stream or sys.stderr
        for line in self.pending:
            print(line, file=stream, flush=True)
        self.pending.clear()

    def _watch(self) -> None:
        while not self._stop.wait(0.2):
            now = time.monotonic()
            with self._lock:
                if self.stage is None or self.stage in UNWATCHED:
                    continue
                running = now - self.stage_start
                if self.pending and running >= WATCH_AFTER:
                    self._flush()
                elif running - self.stage_reported >= STILL_EVERY:
                    self.stage_reported = running
                    self.pending.append(self._line(now, f"{self.stage}: still running ({running:.0f} s so far)"))
                    self._flush()
