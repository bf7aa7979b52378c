"""The ``dynderive`` command (console script and ``python -m dynderive``).

Signals are taken over before anything heavy is imported (Typer, SymPy), so Ctrl-C or
SIGTERM at any moment ends the run with exit code 130 and one line, never a traceback.
"""

from __future__ import annotations

import signal
import sys

from .errors import Interrupted


def _interrupt(signum: int, frame: object) -> None:
    raise Interrupted


def run() -> None:
    """Console-script entry point."""
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        from .commands.cli import app

        app(prog_name="dynderive")
    except Interrupted:
        sys.stderr.write("dynderive: interrupted; no output was changed\n")
        sys.exit(130)


if __name__ == "__main__":
    run()
