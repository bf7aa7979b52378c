"""Atomic output: every file is written to a temporary sibling, then renamed into place.

All outputs of a run are rendered in memory first; ``write_all`` then writes each to a
temporary file, keeps a hard link to every output it will replace, and renames the new files
into place only once all are written. If a rename fails or the run is interrupted, the files
already replaced are put back from those links: a run changes all of its outputs or none.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from pathlib import Path

from ..errors import OutputError


def write_all(files: dict[Path, bytes]) -> None:
    """Write every file or none; an OS failure becomes ``OutputError`` (nothing replaced)."""
    try:
        _write_all(files)
    except OSError as exc:
        where = exc.filename or next(iter(files), "")
        raise OutputError(f"cannot write {where}: {exc.strerror or exc}") from None


def _write_all(files: dict[Path, bytes]) -> None:
    staged: list[tuple[str, Path]] = []
    backups: dict[Path, str] = {}
    done: list[Path] = []
    try:
        for path, data in files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            staged.append((temp, path))
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
                handle.flush()
                os.fsync(handle.fileno())
            os.chmod(temp, 0o644)
        for _, path in staged:   # keep the current outputs until every new one is in place
            if path.is_file():
                backup = str(path.parent / f".{path.name}.{uuid.uuid4().hex}.old")
                try:
                    os.link(path, backup)
                except OSError:   # a file system without hard links
                    shutil.copy2(path, backup)
                backups[path] = backup
        try:
            for temp, path in staged:
                os.replace(temp, path)
                done.append(path)
        except BaseException:
            _restore(done, backups)
            raise
        staged.clear()
    finally:
        for temp, _ in staged:
            _unlink(temp)
        for backup in backups.values():
            _unlink(backup)


def _restore(done: list[Path], backups: dict[Path, str]) -> None:
    """Put back what a failed or interrupted run had already replaced."""
    for path in reversed(done):
        if path in backups:
            os.replace(backups.pop(path), path)
        else:
            _unlink(str(path))


def _unlink(name: str) -> None:
    try:
        os.unlink(name)
    except FileNotFoundError:
        pass
