"""``dynderive copy NAME [DEST]``: a bundled robot's file copied out for editing, so that a
user who starts from ``rp_arm`` has a file of their own (the bundled one stays as shipped)."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError, Problem
from ..input.loader import ROBOT_SUFFIXES, bundled_robot_names, bundled_robots_dir
from ..model.naming import did_you_mean

_YAML, _XML = (".yaml", ".yml"), (".urdf", ".xml")


def bundled_file(name: str) -> Path:
    """The file of the bundled robot ``name``; an unknown name is refused at ``NAME:1:1`` with
    the closest name and the list of bundled robots."""
    names = bundled_robot_names()
    if name in names:
        return next(bundled_robots_dir() / f"{name}{suffix}" for suffix in ROBOT_SUFFIXES
                    if (bundled_robots_dir() / f"{name}{suffix}").is_file())
    raise InputError(Problem(name, 1, 1, f"no bundled robot of that name{did_you_mean(name, names)} "
                             f"(bundled: {', '.join(names)})"))


def copy_target(source: Path, dest: Path | None, force: bool) -> Path:
    """Where the copy of ``source`` goes: ``dest`` (a folder: the file's name in it; none: the
    current folder). An existing file there is refused unless ``force``, and so is a folder
    that does not exist: ``DEST:1:1``, exit 2, nothing written."""
    target = Path(source.name) if dest is None else dest / source.name if dest.is_dir() else dest
    if target.is_dir():
        raise InputError(Problem(str(target), 1, 1, "is a folder: give a file name or another folder"))
    if os.path.lexists(target) and not force:
        raise InputError(Problem(str(target), 1, 1, "already exists: give another name, or --force to replace it"))
    if not target.parent.is_dir() and str(target.parent) not in ("", "."):
        raise InputError(Problem(str(target), 1, 1, f"the folder {target.parent} does not exist"))
    family = _YAML if source.suffix.lower() in _YAML else _XML
    if target.suffix.lower() not in family:
        raise InputError(Problem(str(target), 1, 1, f"the copy of a {source.suffix} robot file must end in "
                                 f"{' or '.join(family)} (robot files are read by their suffix)"))
    return target
