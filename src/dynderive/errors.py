"""Error classes of dynderive.

Inner code raises these; only the CLI maps them to exit codes (2 for bad input, 1 for a
missing tool or an internal error), so the library never prints or exits.
"""

from __future__ import annotations

from dataclasses import dataclass


class DynderiveError(Exception):
    """Base class of every error dynderive raises on purpose."""


@dataclass(frozen=True)
class Problem:
    """One thing wrong with an input file, with its 1-based position."""

    file: str
    line: int
    column: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}: {self.message}"


class InputError(DynderiveError):
    """Bad input: one or more positioned problems (exit code 2).

    The validator collects every problem of a file and raises once, so a user can fix a file
    in one pass. ``str(error)`` is one ``FILE:LINE:COL: message`` line per problem.
    """

    def __init__(self, problems: list[Problem] | Problem):
        self.problems = [problems] if isinstance(problems, Problem) else list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))

    def __reduce__(self):   # pickled between build's worker processes
        return type(self), (self.problems,)


class ToolMissingError(DynderiveError):
    """An external program (a TeX engine) is needed but not installed (exit code 1)."""


class ExternalToolError(DynderiveError):
    """An external program ran and failed, e.g. LaTeX could not compile a sheet (exit 1)."""


class LatexError(ExternalToolError):
    """LaTeX ran and could not compile a sheet: ``detail`` is the log's first error line (or
    why it stopped), ``log`` the log's text, for the caller to keep beside the ``.tex``."""

    def __init__(self, detail: str, log: str):
        self.detail, self.log = detail, log
        super().__init__(f"LaTeX failed to compile the sheet: {detail}")

    def __reduce__(self):   # pickled between build's worker processes
        return type(self), (self.detail, self.log)


class OutputError(DynderiveError):
    """An output could not be written (a file where a folder should be, no permission; exit 1)."""


class Interrupted(BaseException):
    """Ctrl-C or SIGTERM (exit code 130). A ``BaseException`` that is not a
    ``KeyboardInterrupt``, so that nothing on the way (Click's "Aborted!") swallows it."""
