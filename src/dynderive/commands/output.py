"""Atomic output: every file is written to a temporary sibling, then renamed into place.

All outputs of a run are rendered in memory first; ``write_all`` then writes each to a
temporary file, keeps a hard link to every output it will replace, and renames the new files
into place only once all are written. If a rename fails or the run is interrupted, the files
already replaced are put back from those links: a run changes all of its outputs or none.
SIGINT and SIGTERM are held back while the renames run, so a signal lands before them
(nothing changed) or after (all changed), and the message says which.

An output that is a symbolic link is written through: the file it points to is replaced
(atomically, in the link target's folder) and the link is kept; ``replace_links`` replaces
the link itself instead (``build``'s manifest: a link in a committed folder may point
anywhere, and what it points to is left alone). An output that is not a
regular file (``/dev/null``, a pipe, a terminal, ``/proc/self/fd/1`` behind a link) is
written to directly, after the regular files are in place; it cannot be put back.

Also here: the checks on output paths the commands share (one path given for two outputs,
an output that is an input) and the limits on output sizes (``--frames``).
"""

from __future__ import annotations

import os
import shutil
import signal
import stat
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

from ..errors import InputError, OutputError, Problem
from ..model.robot import Robot

#: ``simulate --frames``: samples of the trajectory (CSV rows, plot points), and of them
#: frames of an ``--animate`` GIF (each one drawn by matplotlib).
MAX_FRAMES = 100_000
MAX_ANIMATION_FRAMES = 2_000

#: The outputs this process has finished writing (for the message of a later interrupt).
WRITTEN: list[Path] = []

_SIGNALS = {signal.SIGINT, signal.SIGTERM}


class _Failed(Exception):
    """An OS error while writing ``path`` (the output as the caller named it)."""

    def __init__(self, path: Path, error: OSError, detail: str = ""):
        super().__init__(str(path))
        self.path, self.error, self.detail = path, error, detail


@contextmanager
def _failing(path: Path) -> Iterator[None]:
    """An OS error in the block becomes ``_Failed`` naming ``path``."""
    try:
        yield
    except OSError as exc:
        raise _Failed(path, exc) from None


def write_all(files: dict[Path, bytes], remove: tuple[Path, ...] | list[Path] = (),
              replace_links: bool = False) -> None:
    """Write every file or none, and remove the files ``remove`` names that exist (outputs that
    no longer hold: a PDF older than its sheet, a log of a failure since fixed), in the same
    step; an OS failure becomes ``OutputError`` naming the output that failed (nothing
    replaced, nothing removed). ``replace_links``: an output that is a symbolic link is
    replaced by the file, never written through."""
    try:
        _write_all(files, [path for path in remove if path not in files and os.path.lexists(path) and not path.is_dir()],
                   replace_links)
    except _Failed as failed:
        reason = failed.detail or failed.error.strerror or str(failed.error)
        what = "remove" if failed.path in remove and failed.path not in files else "write"
        raise OutputError(f"cannot {what} {failed.path}: {reason}") from None
    WRITTEN.extend(files)


def interrupted_message() -> str:
    """What an interrupt did to the outputs: nothing, or which were written (each complete)."""
    if not WRITTEN:
        return "dynderive: interrupted; no output was changed"
    shown = ", ".join(str(p) for p in WRITTEN[:3]) + (f" and {len(WRITTEN) - 3} more" if len(WRITTEN) > 3 else "")
    return f"dynderive: interrupted; the outputs written before it are complete ({shown})"


def _kind(path: Path, replace_links: bool = False) -> tuple[str, Path]:
    """("file", where to write atomically) or ("stream", what to write to directly);
    ``replace_links``: a link is itself the file to replace."""
    if replace_links and path.is_symlink():
        return "file", path
    try:
        mode = os.stat(path).st_mode   # follows links
    except (FileNotFoundError, NotADirectoryError):   # a file in the way is reported when writing
        return "file", Path(os.path.realpath(path)) if path.is_symlink() else path
    except OSError as exc:
        raise _Failed(path, exc) from None
    if stat.S_ISDIR(mode):
        raise _Failed(path, IsADirectoryError(21, os.strerror(21)), "it is a folder")
    if stat.S_ISREG(mode):
        return "file", Path(os.path.realpath(path)) if path.is_symlink() else path
    return "stream", path


def _write_all(files: dict[Path, bytes], remove: list[Path], replace_links: bool = False) -> None:
    regular: dict[Path, tuple[Path, bytes]] = {}   # target -> (the output as named, data)
    streams: list[tuple[Path, bytes]] = []
    for path, data in files.items():
        kind, target = _kind(path, replace_links)
        if kind == "stream":
            streams.append((path, data))
        elif target in regular and regular[target][1] != data:
            raise _Failed(path, OSError(17, "same file"), f"it is the same file as {regular[target][0]}")
        else:
            regular[target] = (path, data)
    staged: list[tuple[str, Path, Path]] = []
    backups: dict[Path, str] = {}
    done: list[Path] = []
    try:
        for target, (path, data) in regular.items():
            _stage(target, path, data, staged)
        for _, target, path in staged:   # keep the current outputs until every new one is in place
            if target.is_symlink():   # replace_links: the link is put back as it was
                backup = str(target.parent / f".{target.name}.{uuid.uuid4().hex}.old")
                with _failing(path):
                    os.symlink(os.readlink(target), backup)
                backups[target] = backup
            elif target.is_file():
                backup = str(target.parent / f".{target.name}.{uuid.uuid4().hex}.old")
                with _failing(path):
                    try:
                        os.link(target, backup)
                    except OSError:   # a file system without hard links
                        shutil.copy2(target, backup)
                backups[target] = backup
        try:
            with _hold_signals():
                for temp, target, path in staged:
                    with _failing(path):
                        os.replace(temp, target)
                    done.append(target)
                for path in remove:   # moved aside (put back on failure), deleted at the end
                    backup = str(path.parent / f".{path.name}.{uuid.uuid4().hex}.old")
                    with _failing(path):
                        os.rename(path, backup)
                    backups[path] = backup
                    done.append(path)
            staged.clear()
            for path, data in streams:   # not under the hold: a pipe may block until its reader reads
                with _failing(path), open(path, "wb") as handle:
                    handle.write(data)
        except BaseException:
            _restore(done, backups)
            raise
    finally:
        for temp, _, _ in staged:
            _unlink(temp)
        for backup in backups.values():
            _unlink(backup)


def _stage(target: Path, path: Path, data: bytes, staged: list[tuple[str, Path, Path]]) -> None:
    """Write ``data`` to a temporary file beside ``target``; ``path``: the output as named."""
    blocker = next((p for p in target.parents if p.exists() or p.is_symlink()), None)
    if blocker is not None and not blocker.is_dir():
        raise _Failed(path, NotADirectoryError(20, os.strerror(20)), f"{blocker} is a file, not a folder")
    with _failing(path):
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, temp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    staged.append((temp, target, path))
    with _failing(path):
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(temp, 0o644)


@contextmanager
def _hold_signals() -> Iterator[None]:
    """Block SIGINT and SIGTERM (they stay pending) while outputs are replaced."""
    try:
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    except (AttributeError, OSError, ValueError):   # not POSIX
        previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _restore(done: list[Path], backups: dict[Path, str]) -> None:
    """Put back what a failed or interrupted run had already replaced."""
    for path in reversed(done):
        if path in backups:
            os.replace(backups.pop(path), path)
        else:
            _unlink(str(path))


def _unlink(name: str) -> None:
    with suppress(FileNotFoundError):
        os.unlink(name)


def _same(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(os.path.realpath(a)) == Path(os.path.realpath(b))


def check_output_paths(outputs: dict[str, Path | None], inputs: tuple[Path, ...] = ()) -> None:
    """Refuse one path given for two outputs (``--plot run.png --csv run.png``, or
    ``run.png`` and ``./run.png``) and an output that is an input file (``import a.urdf -o
    a.urdf``): ``--option:1:1: message``, exit 2, before any work."""
    problems: list[Problem] = []
    seen: list[tuple[str, Path]] = []
    inputs = tuple(i for i in inputs if i.is_file())   # a bundled robot's name is no file here
    for option, path in outputs.items():
        if path is None:
            continue
        other = next((o for o, p in seen if _same(p, path)), None)
        source = next((i for i in inputs if _same(i, path)), None)
        if other is not None:
            problems.append(Problem(option, 1, 1, f"{path} is also the {other} output: one file cannot "
                                    "hold both (give each its own path)"))
        elif source is not None:
            what = "the robot file" if source == inputs[0] else f"a file the robot file {inputs[0]} reads"
            problems.append(Problem(option, 1, 1, f"{path} is {what} ({source}): writing it would "
                                    "replace it (give the output another path)"))
        seen.append((option, path))
    if problems:
        raise InputError(problems)


def check_output_folder(out: Path, files: tuple[str, ...] | list[str] = (), writable: bool = True,
                        option: str = "--out") -> None:
    """Refuse an output folder that cannot hold the outputs, before any work (``--out:1:1:``,
    exit 2): a file where the folder (or a folder above it) should be, a folder that cannot be
    created or written (tried: a temporary folder made and removed, so permissions, read-only
    file systems and ``/proc`` answer as they will when writing), or an output among ``files``
    (names relative to ``out``) that is a folder. ``writable``: False for ``build --check``,
    which writes nothing."""
    problems: list[Problem] = []
    blocker = next((p for p in (out, *out.parents) if p.exists() or p.is_symlink()), None)
    if blocker is not None and not blocker.is_dir():
        where = "" if blocker == out else f" (in the way of {out})"
        problems.append(Problem(option, 1, 1, f"{blocker} is a file, not a folder{where}"))
    elif blocker is not None and writable:
        try:
            os.rmdir(tempfile.mkdtemp(prefix=".dynderive-", dir=blocker))
        except OSError as exc:
            what = f"cannot write into {out}" if blocker == out else f"cannot create {out} in {blocker}"
            problems.append(Problem(option, 1, 1, f"{what}: {exc.strerror or exc}"))
    if not problems:
        for name in files:
            path = out / name
            if path.is_dir():
                problems.append(Problem(option, 1, 1, f"{path} is a folder: the output {name} cannot be written"))
            elif len(path.relative_to(out).parts) > 1 and (path.parent.exists() or path.parent.is_symlink()) \
                    and not path.parent.is_dir():
                problems.append(Problem(option, 1, 1, f"{path.parent} is a file, not a folder (in the way of {path})"))
    if problems:
        raise InputError(problems)


def check_frames(frames: int, animate: bool) -> None:
    """``--frames`` within the documented limits (at least 2; at most ``MAX_FRAMES``, with
    ``--animate`` ``MAX_ANIMATION_FRAMES``): exit 2 before any work."""
    if frames < 2:
        raise InputError(Problem("--frames", 1, 1, f"expected at least 2 frames, got {frames}"))
    limit = MAX_ANIMATION_FRAMES if animate else MAX_FRAMES
    if frames > limit:
        what = "frames of an --animate GIF" if animate else "output samples"
        raise InputError(Problem("--frames", 1, 1, f"{frames} {what} exceed the limit of {limit}: "
                                 "ask for fewer"))


def quaternion_kind(robot: Robot) -> str:
    """What gives ``robot``'s configuration its quaternions: "floating base", "floating joints"
    or "spherical joints" (for ``solve``'s note and ``simulate``'s summary)."""
    return ("floating base" if robot.floating_base else "floating joints"
            if any(j.kind.free for j in robot.joints) else "spherical joints")


def echo_notes(model: Any, quiet: bool) -> None:
    """The notes of a loaded robot or a derivation (accepted input that was changed or
    ignored) on stderr, unless ``quiet``."""
    if not quiet:
        import typer

        for note in model.notes:
            typer.echo(note, err=True)
