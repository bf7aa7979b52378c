"""Atomic output: every file is written to a temporary sibling, then renamed into place.

All outputs of a run are rendered in memory first; ``write_all`` then writes each to a
temporary file and renames them only once all are written, so a failed or interrupted run
leaves earlier outputs untouched and no stray temporaries.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .errors import OutputError


def write_all(files: dict[Path, bytes]) -> None:
    """Write every file or none; an OS failure becomes ``OutputError`` (nothing replaced)."""
    try:
        _write_all(files)
    except OSError as exc:
        where = exc.filename or next(iter(files), "")
        raise OutputError(f"cannot write {where}: {exc.strerror or exc}") from None


def _write_all(files: dict[Path, bytes]) -> None:
    staged: list[tuple[str, Path]] = []
    try:
        for path, data in files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            staged.append((temp, path))
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
                handle.flush()
                os.fsync(handle.fileno())
        for temp, path in staged:
            os.chmod(temp, 0o644)
            os.replace(temp, path)
        staged.clear()
    finally:
        for temp, _ in staged:
            try:
                os.unlink(temp)
            except FileNotFoundError:
                pass
