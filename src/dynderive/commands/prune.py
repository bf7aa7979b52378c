"""What ``build --prune`` may delete: decided file by file, from what is on disk now.

The manifest is committed beside the outputs, so a hand edit, a bad merge or a hostile pull
request can put any name in a record. A record is therefore only a list of candidates: an
orphaned output is removed only when all of these hold, and otherwise kept with its reason:

- its name is one ``build`` gives an output of the record's robot: the robot's name (the stem
  most of the record's files share) plus a suffix of a known output kind, taken from the
  output kinds and the code targets' registry (``OUTPUT_NAMES``), or a ``.m`` file in the
  robot's MATLAB package folder ``+<name>/``;
- neither it nor the folder it is in below ``--out`` is a symbolic link, and it is a regular
  file;
- its content now hashes (SHA-256) to what the record says ``build`` wrote: an output edited
  since the build is the user's.

``--prune`` is refused outright when ``--out`` is a filesystem root, the user's home folder
or a folder holding it.
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
from collections import Counter
from pathlib import Path

from ..errors import InputError, Problem

#: A robot name as every input format makes it: word characters, not starting with a digit.
_STEM = re.compile(r"(?!\d)\w+\Z")
#: A file of a MATLAB package folder ``+<name>/``: one function per file.
_PACKAGE_FILE = re.compile(r"(?!\d)\w+\.m\Z")


def stems_of(file: str, patterns: tuple[str, ...]) -> set[str]:
    """The robot names for which ``build`` could give an output the name ``file``; ``patterns``:
    the output names, ``{}`` standing for the robot's name (``build.OUTPUT_NAMES``)."""
    parts = file.split("/")
    if len(parts) == 2:
        stem = parts[0][1:]
        return {stem} if parts[0].startswith("+") and _STEM.match(stem) and _PACKAGE_FILE.match(parts[1]) else set()
    stems = set()
    for pattern in patterns:
        prefix, _, suffix = pattern.partition("{}")
        if "/" not in pattern and file.startswith(prefix) and file.endswith(suffix):
            stem = file[len(prefix):len(file) - len(suffix)]
            if _STEM.match(stem):
                stems.add(stem)
    return stems


def record_stem(files: list[str] | dict[str, str], patterns: tuple[str, ...]) -> str | None:
    """The robot name a record's outputs are named after: the one most of them share (ties:
    the first in sorted order, so the choice does not depend on the record's order)."""
    counts = Counter(stem for file in files for stem in stems_of(file, patterns))
    if not counts:
        return None
    return min(counts, key=lambda stem: (-counts[stem], stem))


def keep_reason(out: Path, file: str, digest: str, stem: str | None, patterns: tuple[str, ...]) -> str:
    """Why ``--prune`` keeps the orphaned output ``file`` recorded with hash ``digest``, or ""
    when it is what ``build`` wrote for robot ``stem`` and may be removed."""
    if stem is None or stem not in stems_of(file, patterns):
        return "not a name build gives an output" + (f" of robot '{stem}'" if stem else "")
    parts = file.split("/")
    if len(parts) == 2 and os.path.islink(out / parts[0]):
        return f"its folder {parts[0]} is a symbolic link"
    path = out / file
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return "cannot be read"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return "cannot be read"
    digest_now = hashlib.sha256()
    with os.fdopen(descriptor, "rb") as handle:
        if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
            return "not a regular file"
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest_now.update(chunk)
    if digest_now.hexdigest() != digest:
        return "edited since it was built"
    return ""


def sort_orphans(out: Path, outputs: dict[str, str], files: list[str], patterns: tuple[str, ...],
                 ) -> list[tuple[str, str]]:
    """Each of a record's orphaned ``files`` with the reason ``--prune`` keeps it ("" when it
    removes it); ``outputs``: the record's file names and hashes."""
    stem = record_stem(outputs, patterns)
    return [(file, keep_reason(out, file, outputs[file], stem, patterns)) for file in files]


def check_prune_folder(out: Path) -> None:
    """Refuse ``--prune`` into a filesystem root, the home folder or a folder above it (exit 2
    at ``--out``): a build's own output folder is never one of them."""
    folder = Path(os.path.realpath(out))
    home = Path(os.path.realpath(os.path.expanduser("~")))
    if folder.parent == folder or out.resolve().parent == out.resolve():
        what = "a filesystem root"
    elif folder == home:
        what = "the home folder"
    elif folder in home.parents:
        what = f"a folder holding the home folder {home}"
    else:
        return
    raise InputError(Problem("--out", 1, 1, f"--prune does not remove files from {out} ({what}): build into a "
                             "folder of its own, e.g. --out build"))
