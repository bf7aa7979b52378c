"""Compiling the C target into a CPython extension (``solve --c-extension``, ``check`` and
``simulate --backend c``).

The compiler is ``$CC`` when set (a command with options, e.g. ``"clang -march=native"``),
else the one Python was built with (sysconfig's ``CC``) when it is on this machine, else
``cc`` or ``gcc`` on ``PATH``. It compiles ``<name>_dynamics.c`` and the binding
(``render/targets/c_extension/c_extension.py``) in a temporary folder with ``-O2 -shared -fPIC`` against Python's
and NumPy's headers (no setuptools); the caller writes the bytes (all or nothing). No compiler
or no ``Python.h``: ``InputError`` at ``--c-extension`` (exit 2). A compiler that fails on the
generated code (a bug of ours) is ``ExtensionCompileError``, with its log to keep.
"""

from __future__ import annotations

import functools
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import types
from collections.abc import Callable
from pathlib import Path

from ....derivation import Derivation
from ....errors import ExternalToolError, InputError, Problem

OPTION = "--c-extension"
#: Seconds a compilation may take (the Panda takes about 10 s at -O2).
TIMEOUT = 600


def _problem(option: str, message: str) -> Problem:
    return Problem(option, 1, 1, message)


class ExtensionCompileError(ExternalToolError):
    """The C compiler ran and failed: ``detail`` is its first error line, ``log`` the command
    and its whole output."""

    def __init__(self, detail: str, log: str):
        self.detail, self.log = detail, log
        super().__init__(f"the C compiler failed to build the extension: {detail}")

    def __reduce__(self):   # pickled between build's worker processes
        return type(self), (self.detail, self.log)


def find_compiler(option: str = OPTION) -> list[str]:
    """The compiler command (program and options); ``InputError`` at ``option`` when there is
    none."""
    given = os.environ.get("CC", "").strip()
    if given:
        command = shlex.split(given)
        if not shutil.which(command[0]):
            raise InputError(_problem(option, f"the C compiler CC={given!r} was not found (set CC to a C compiler, "
                                             "or unset it to use cc or gcc)"))
        return command
    configured = shlex.split(sysconfig.get_config_var("CC") or "")
    if configured and shutil.which(configured[0]):
        return configured
    for name in ("cc", "gcc"):
        if shutil.which(name):
            return [name]
    raise InputError(_problem(option, "no C compiler found (cc or gcc on PATH, or CC): the extension is compiled on "
                                     "this machine; install one (e.g. apt install gcc) or use --c or --code"))


def include_dirs(option: str = OPTION) -> list[str]:
    """Python's and NumPy's C headers; ``InputError`` when ``Python.h`` is not installed."""
    import numpy

    python = sysconfig.get_paths()["include"]
    if not (Path(python) / "Python.h").is_file():
        raise InputError(_problem(option, f"Python's C headers (Python.h) are not in {python}: install them (e.g. apt "
                                         "install python3-dev) to compile the extension"))
    return [python, numpy.get_include()]


@functools.lru_cache(maxsize=1)
def toolchain() -> str:
    """What the compiled bytes depend on besides the sources: the compiler (its command and
    the first line of its ``--version``), Python's extension suffix and NumPy's version (a
    build's manifest key)."""
    import numpy

    compiler = find_compiler()
    try:
        version = subprocess.run([*compiler, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.TimeoutExpired):
        version = ""
    return "\n".join([shlex.join(compiler), (version.splitlines() or [""])[0],
                      sysconfig.get_config_var("EXT_SUFFIX") or "", numpy.__version__])


def require_compiler(option: str = OPTION) -> None:
    """``InputError`` at ``option``, before any work, when this machine cannot compile the
    extension (no compiler, or no Python headers)."""
    find_compiler(option)
    include_dirs(option)


def extension_filename(robot_name: str) -> str:
    """``<name>_dynamics_c`` with this Python's suffix for extensions (``.cpython-311-x86_64-linux-gnu.so``)."""
    from .c_extension import module_name

    return module_name(robot_name) + (sysconfig.get_config_var("EXT_SUFFIX") or ".so")


def build_extension(derivation: Derivation, template_dir: str | Path | None = None, *,
                    c_files: tuple[str, str] | None = None, optimization: str = "-O2",
                    progress: Callable[[str], None] | None = None, option: str = OPTION) -> tuple[str, bytes]:
    """(file name, bytes) of the compiled extension ``<name>_dynamics_c``; ``c_files`` are
    the C target's header and source when the caller has them already."""
    from .. import by_name
    from .c_extension import module_name, render_extension

    compiler = find_compiler(option)
    includes = include_dirs(option)
    binding = render_extension(derivation, template_dir)   # refuses what the C target refuses, before the C is printed
    name = derivation.robot.name
    if c_files is None:   # the C target's files, through the registry as the commands ask for them
        files = by_name("c").files(derivation, template_dir)
        c_files = (files[f"{name}_dynamics.h"].decode(), files[f"{name}_dynamics.c"].decode())
    header, source = c_files
    filename = extension_filename(name)
    if progress is not None:
        progress(f"compiling the C extension ({Path(compiler[0]).name} {optimization})")
    with tempfile.TemporaryDirectory(prefix="dynderive-ext-") as folder:
        work = Path(folder)
        (work / f"{name}_dynamics.h").write_text(header)
        (work / f"{name}_dynamics.c").write_text(source)
        (work / f"{module_name(name)}.c").write_text(binding)
        command = [*compiler, optimization, "-fno-math-errno", "-shared", "-fPIC", "-pthread", "-Ulinux", "-Uunix",
                   *(f"-I{d}" for d in includes), f"{name}_dynamics.c", f"{module_name(name)}.c",
                   "-o", filename, "-lm"]
        if sys.platform == "darwin":
            command[1:1] = ["-undefined", "dynamic_lookup"]
        try:
            run = subprocess.run(command, cwd=work, capture_output=True, text=True, timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            raise ExtensionCompileError(f"no result after {TIMEOUT} s", shlex.join(command) + "\n") from None
        except OSError as exc:
            raise ExtensionCompileError(str(exc), shlex.join(command) + "\n") from None
        output = work / filename
        if run.returncode != 0 or not output.is_file():
            log = f"{shlex.join(command)}\n(in a temporary folder; exit status {run.returncode})\n{run.stdout}{run.stderr}"
            raise ExtensionCompileError(_first_error(run.stderr or run.stdout), log)
        return filename, output.read_bytes()


def _first_error(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    errors = [line for line in lines if "error" in line.lower()]
    return (errors or lines or ["no message"])[0][:300]


def compiled_module(derivation: Derivation, progress: Callable[[str], None] | None = None,
                    option: str = "--backend") -> types.ModuleType:
    """The extension of ``derivation``'s robot, compiled for this process and imported (for
    ``check --backend c`` and ``simulate --backend c``); its file is removed once loaded."""
    import importlib.util

    from .c_extension import module_name

    filename, data = build_extension(derivation, progress=progress, option=option)
    with tempfile.TemporaryDirectory(prefix="dynderive-ext-") as folder:
        path = Path(folder) / filename
        path.write_bytes(data)
        spec = importlib.util.spec_from_file_location(module_name(derivation.robot.name), path)
        if spec is None or spec.loader is None:   # pragma: no cover - a file with the extension suffix always has one
            raise ExtensionCompileError(f"{filename} cannot be imported", "")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    return module


def extension_files(derivation: Derivation, template_dir: str | Path | None, made: dict[str, bytes],
                    progress: Callable[[str], None] | None = None, **options: object) -> dict[str, bytes]:
    """The target's render (``render/targets/c_extension``): the compiled extension by file
    name, on the C files this run made (``made``) when ``--c`` is asked too."""
    name = derivation.robot.name
    header, source = f"{name}_dynamics.h", f"{name}_dynamics.c"
    c_files = (made[header].decode(), made[source].decode()) if header in made and source in made else None
    filename, data = build_extension(derivation, template_dir, c_files=c_files, progress=progress)
    return {filename: data}


def failure_files(error: Exception, folder: Path, robot_name: str) -> tuple[dict[str, bytes], str]:
    """A compiler that failed: its log (by file name), left beside the other outputs, and one line
    saying which extension failed, the compiler's first error and where the log is; any other
    error raised again."""
    if not isinstance(error, ExtensionCompileError):
        raise error
    log = f"{robot_name}_dynamics_c.log"
    return {log: error.log.encode()}, (f"{folder / extension_filename(robot_name)} not made: the C compiler failed: "
                                       f"{error.detail}; the log is {folder / log} (please report it: the generated "
                                       "code should always compile)")
