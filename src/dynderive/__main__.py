"""The ``dynderive`` command (console script and ``python -m dynderive``).

Signals are taken over before anything heavy is imported (Typer, SymPy), so Ctrl-C or
SIGTERM at any moment ends the run with exit code 130 and one line, never a traceback.
Once the command has finished (its outputs written, its messages printed), SIGINT and SIGTERM
are ignored for the interpreter's shutdown, where Python no longer handles them: a signal
then changes nothing, and the exit code is the command's. An interrupt after some outputs
were written says which (each is complete).
"""

from __future__ import annotations

import os
import signal
import sys

from .errors import Interrupted

#: Results SymPy keeps per cached function (its default: 1000). A derivation asks for the same
#: products, sums and powers again across Lagrange's equations, the checks and the printers, and
#: 1000 is too few to keep them: 16384 takes a few per cent off a run (about 5 % on the Panda),
#: for a few MB (docs/development/benchmarks.md). SymPy reads it once, when it is imported.
SYMPY_CACHE_SIZE = "16384"

#: Set once the command has finished (or been interrupted): a signal after it changes nothing.
_finishing = False
#: Set when a signal interrupted the run (an import it broke may surface as an ImportError).
_signalled = False


def _interrupt(signum: int, frame: object) -> None:
    global _signalled
    if not _finishing:
        _signalled = True
        raise Interrupted


def _interrupted() -> int:
    output = sys.modules.get("dynderive.commands.output")   # not imported: nothing was written
    message = output.interrupted_message() if output is not None else "dynderive: interrupted; no output was changed"
    sys.stderr.write(message + "\n")
    return 130


def use_command_line_sympy_cache() -> None:
    """Give SymPy the command line's cache size, unless SymPy is imported already or the
    environment sets ``SYMPY_CACHE_SIZE`` (the user's value wins). The variable stays set,
    so ``build``'s worker processes get the same."""
    if "sympy" not in sys.modules:
        os.environ.setdefault("SYMPY_CACHE_SIZE", SYMPY_CACHE_SIZE)


def run() -> None:
    """Console-script entry point."""
    global _finishing
    use_command_line_sympy_cache()
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    code: int | str | None = 0
    try:
        try:
            from .commands.cli import app

            app(prog_name="dynderive")
        except SystemExit as exc:
            code = exc.code
        _finishing = True
    except Interrupted:
        _finishing = True
        code = _interrupted()
    except Exception:
        # a signal that arrived during an import surfaces as what that import raised: NumPy's
        # ImportError with the Interrupted as its cause, or a TypeError of the import machinery
        if not _signalled:
            raise
        _finishing = True
        code = _interrupted()
    # During the interpreter's shutdown Python hands signals back to the default action
    # (killed, status -15), yet an ignored signal it leaves ignored.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.exit(code)


if __name__ == "__main__":
    run()
