"""Read MuJoCo models (MJCF) into the same plain data as a robot YAML file.

The ``mujoco`` package (the ``mjcf`` extra) compiles the file: it resolves ``<include>``,
``<default>`` classes, ``childclass``, ``<compiler angle eulerseq>``, ``fromto``, inertias
inferred from geoms and frames; nothing here reads MJCF syntax. The compiled model's body tree
becomes robot-file data (``mjcf_tree``), with every entry placed at the line of the XML element
it came from (``mjcf_positions``), and goes through the same validator as YAML and URDF.

Conventions (the docs' MJCF page says more): ``hinge`` -> revolute, ``slide`` -> prismatic,
``ball`` -> spherical, ``free`` -> floating; coordinates are MuJoCo's ``qpos`` (a joint's
``ref`` goes into its origin, so ``q = 0`` is MuJoCo's ``qpos = 0``), quaternions w-last and a
free joint's linear velocity in the body frame (Pinocchio's, section 10 of the design).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import InputError, Problem
from .loader import SourceDocument


@contextmanager
def mujoco_messages(mujoco: Any) -> Iterator[list[str]]:
    """MuJoCo's warnings (``mju_warning``: "XML contains a 'NaN'", unstable simulations) and
    its compiler's, collected into the list yielded: by default MuJoCo prints them and appends
    them to ``MUJOCO_LOG.TXT`` in the working directory, and no command writes outside ``--out``."""
    said: list[str] = []
    before = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: said.append(" ".join(str(message).split())))
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield said
    finally:
        mujoco.set_mju_user_warning(before)
    said += [" ".join(str(w.message).split()) for w in caught]


def read_mjcf(path: Path, text: str, file: str) -> SourceDocument:
    """MJCF file -> the data of an equivalent robot file, with positions and notes.

    MuJoCo's own compile errors come back as ``FILE:LINE:COL: MuJoCo: message`` (the line
    MuJoCo names, or the file's first line); whatever the model holds that the robot file
    cannot (tendons, contacts, other equalities, actuator dynamics) is a ``note:``.
    """
    try:
        import mujoco
    except ImportError:
        raise InputError(Problem(file, 1, 1, "reading an MJCF file needs the mujoco package, which is not "
                                 'installed: pip install "dynderive[mjcf]"')) from None
    from .mjcf_positions import Locator, compile_problem
    from .mjcf_tree import robot_document
    from .mjcf_xml import check_mjcf_files

    check_mjcf_files(path, text, file)   # before MuJoCo's reader, which trusts its input
    locator = Locator(text, path)
    try:
        with mujoco_messages(mujoco) as said:   # MuJoCo's warnings: notes
            spec = mujoco.MjSpec.from_file(str(path))
            model = spec.compile()
    except ValueError as exc:
        raise InputError(compile_problem(str(exc), file, locator)) from None
    if model.njnt == 0:   # one line, not the validator's two about empty links and joints
        raise InputError(Problem(file, *(locator._first("worldbody", default=None) or locator.root),
                                 "the model has no joint: every body is welded to the world and nothing moves"))
    doc = SourceDocument(file=file, data=None)
    for message in said:
        doc.note(locator._first("compiler") if "compiler" in message else locator.root, f"MuJoCo: {message}")
    return robot_document(mujoco, spec, model, doc, locator)
