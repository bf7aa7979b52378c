"""What a code target is to the commands: one frozen ``Target`` per target, its registry entry
(``render/targets/<folder>/__init__.py``), listed in ``render/targets/__init__.py``.

The commands loop over the registry and name no target: ``solve`` and ``build`` render each
requested target (``render``), ``build`` hashes the templates it reads (``templates``) and
knows its files by name (``outputs``), ``render/offered.py`` reads which functions it generates
(``offered``) and gathers what it does not build, with the reasons (``not_built``). A target
renders a fixed-base and a floating-base robot alike: it picks its printer inside.

The entry holds its own functions, imported with it; how ``check --backend`` and ``simulate
--backend`` run the module it writes belongs to a later layer (``verify/backends.py``,
``HARNESSES``), so the registry, in ``render/``, imports nothing after it.
"""

from __future__ import annotations

import ast
import contextlib
import importlib
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ...derivation import Derivation
from ...errors import InputError, Problem
from ..api import group


def public(source: str) -> set[str]:
    """The public functions a Python module's source defines at its top level (what a Python
    target offers)."""
    return {node.name for node in ast.parse(source).body
            if isinstance(node, ast.FunctionDef) and not node.name.startswith("_")}


@dataclass(frozen=True)
class NotBuilt:
    """Functions of the generated API a target does not build, for which robots, and why (the
    reason's one line is the table of offered functions' footnote and ``check --backend``'s
    "not built" row)."""

    functions: tuple[str, ...]
    #: The robots it concerns: "vector_space" (no quaternion in the configuration), "quaternions"
    #: (a floating or spherical joint), "quaternion_loops" (those with closed loops),
    #: "frameless" (a robot that declares no frames), "any" (every robot that has them).
    kind: str
    reason: str

    def concerns(self, floating: bool, frames: bool, loops: bool = False) -> bool:
        """Whether it applies to a robot with a ``floating`` base (or not), ``frames`` (or none)
        and closed ``loops`` (or none)."""
        return {"vector_space": not floating, "quaternions": floating, "quaternion_loops": floating and loops,
                "frameless": not frames, "any": True}[self.kind]


#: The row of every target that does not print a planar robot's maximal-coordinate form (its
#: entries share it: one reason, one footnote of the table).
MAXIMAL_NOT_PRINTED = NotBuilt(group("maximal"), "vector_space",
                               "the maximal-coordinate form of a planar robot is printed for the Python modules only")

#: The row of the compiled targets and MATLAB, which print the configuration maps of a robot with
#: quaternion joints only: a robot of vector-space joints integrates as q + v dt.
VECTOR_SPACE_MAPS = NotBuilt(group("configuration"), "vector_space",
                             "a robot of vector-space joints: q + v dt and q_to - q_from, printed for the Python "
                             "modules only")


@dataclass(frozen=True)
class OptionalPackage:
    """A package a target's module imports that ``pip install dynderive`` leaves out: the
    module is written without it (``solve`` notes it, ``missing_note``), and running the
    module (``check``, ``simulate --backend``) is refused before any work (``require``). Its
    registry entry names ``missing_note`` (``note``), its harness ``require`` (``needs``)."""

    #: Its import name, which is also its pip extra and its target's name (``--jax``,
    #: ``--backend jax``).
    name: str
    #: Its name in the note ("JAX"), the module's too.
    title: str
    #: What the note says must be installed for the module to import (the title when empty).
    imports: str = ""
    #: How ``--backend``'s refusal says to install it (``pip install "dynderive[NAME]"`` when empty).
    install: str = ""

    def missing_note(self) -> str | None:
        """A note when it is not importable here, else None."""
        with contextlib.suppress(ImportError, ValueError):
            if importlib.util.find_spec(self.name) is not None:
                return None
        return (f"note: --{self.name}: {self.title} is not installed here; the {self.title} module is written, "
                f'and imports once {self.imports or self.title} is installed: pip install "dynderive[{self.name}]"')

    def require(self) -> None:
        """``InputError`` at ``--backend`` when it cannot be imported."""
        try:
            importlib.import_module(self.name)
        except ImportError:
            install = self.install or f'pip install "dynderive[{self.name}]"'
            raise InputError(Problem("--backend", 1, 1, f"--backend {self.name} needs the {self.name} package "
                                     f"({install})")) from None


@dataclass(frozen=True)
class Target:
    """One code target's registry entry."""

    #: The target's name: ``--backend`` of ``check`` (if it has a harness) and the column of
    #: the table of offered functions (``render/offered.py``).
    name: str
    #: The option of ``solve`` and ``build`` that asks for it.
    flag: str
    #: The key of ``build``'s output kinds (and of the manifest's input key): the flag's name.
    kind: str
    #: The column's heading in the table of offered functions.
    title: str
    #: The table's column order (the NumPy module, the reference, first).
    column: int
    #: The help of ``solve``'s option and of ``build``'s.
    help: str
    build_help: str
    #: Its output files, ``{}`` for the robot's name (``+{}/parameters.m``: a MATLAB package).
    outputs: tuple[str, ...]
    #: The templates its code renders by name; what they include, extend or import is found
    #: from their syntax (``render/environment.py``, ``templates_in_use``), so only these are
    #: listed. A change in any of them invalidates ``build``'s records.
    templates: tuple[str, ...]
    #: (derivation, template_dir, made, **options) -> {file name: bytes}; ``made``: the files of
    #: the targets before it in this run (the extension reuses the C).
    render: Callable[..., dict[str, bytes]]
    #: (derivation) -> the API functions it generates.
    offered: Callable[[Derivation], set[str]]
    #: Said before it renders ("": nothing).
    progress: str
    #: () -> None, raising an InputError before any work when it cannot be made here (no
    #: compiler), or None.
    needs: Callable[[], None] | None = None
    #: () -> a note (str) or None, printed when it is asked for (JAX not installed: the module
    #: is written all the same).
    note: Callable[[], str | None] | None = None
    #: (exception, folder, robot name) -> (log files, message) for an output that could not be
    #: made while the others are written, or None (the error stops).
    failure: Callable[..., tuple[dict[str, bytes], str]] | None = None
    #: () -> text: what its bytes depend on besides the sources (the compiler), part of
    #: ``build``'s input key, or None.
    fingerprint: Callable[[], str] | None = None
    #: What it reads from the derivation (``derivation.WANTS``), derived before any target renders.
    reads: tuple[str, ...] = ("code",)
    #: Files of an earlier failure that a successful run removes (``{}``: the robot's name).
    stale: tuple[str, ...] = ()
    #: What it is to the options of other commands that name it, as (option, help) pairs:
    #: ``"check --backend"``, ``"simulate --backend"`` (the help after ``NAME:``), ``"--tests"``
    #: (``solve``'s checks of the module it writes: the help after ``With FLAG:``).
    option_help: tuple[tuple[str, str], ...] = ()
    #: The functions of the NumPy module's API it does not build, with the reasons. What the
    #: NumPy module (the reference) does not build is expected of no target: its rows are
    #: every target's (a target may build such a function all the same).
    not_built: tuple[NotBuilt, ...] = ()

    def help_for(self, option: str) -> str | None:
        """Its help in ``option`` (``"check --backend"``), or None when it is not one of its choices."""
        return dict(self.option_help).get(option)

    @property
    def folder(self) -> str:
        """Its folder under ``render/targets/`` (its name as a Python identifier)."""
        return self.name.replace("-", "_")

    def files(self, derivation: Derivation, template_dir: Any, made: dict[str, bytes] | None = None,
              **options: Any) -> dict[str, bytes]:
        """Its output files for ``derivation``'s robot (fixed or floating base), by name."""
        return self.render(derivation, template_dir, made or {}, **options)
