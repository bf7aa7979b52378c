"""``dynderive solve`` for a floating-base robot: the NumPy module
(``render/floating_code.py``), its C, compiled extension, MATLAB package and JAX module
(``render/floating_jax.py``), its sheet (LaTeX, PDF, HTML) and JSON dump (``floating_outputs.py``) and one note
saying what is not built yet; every other output is
refused (exit 2) before any work."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from ..errors import InputError
from ..model.robot import Robot
from .options import problem

#: The message of an output or command not built yet for floating-base robots.
NOT_BUILT = "not built yet for floating-base robots"
#: The output flags (besides --code) a floating-base robot has.
BUILT = ("c", "c_extension", "matlab", "jax", "latex", "pdf", "json", "html")


def floating_note(robot: Robot) -> str:
    """The note ``solve`` prints for a floating-base robot: what its module has and what not."""
    what = ("has a floating base" if robot.floating_base else "has floating joints"
            if any(j.type == "floating" for j in robot.joints) else "has spherical joints")
    return (f"note: {robot.name} {what} (NQ = {len(robot.configuration_names)}, NV = {robot.velocity_count}): "
            "every output is built except the MATLAB derivation script (--matlab writes its +package only)")


def solve_floating(robot: Robot, argument: str, flags: dict[str, bool], code: bool, out: Path,
                   template_dir: Path | None, quiet: bool, echo: Callable[[str], None],
                   progress: Callable[[str], None], tests: bool = False) -> None:
    """Write the outputs the flags ask for (``--code`` the module, ``--tests`` its checks, the
    other targets, the sheets and the JSON), or, with none, print the equations
    (``render_floating_terminal``)."""
    from .. import derive
    from ..render.floating_code import render_floating_code, render_floating_code_tests
    from .output import write_all

    if not quiet:
        echo(floating_note(robot))
    flags = dict(flags)
    digits = flags.pop("digits", None)   # --digits: the sheet's numbers
    refused = [problem(f"--{flag.replace('_', '-')}", f"--{flag.replace('_', '-')}: {NOT_BUILT}")
               for flag, wanted in flags.items() if wanted and flag not in BUILT]
    if refused:
        raise InputError(refused)
    derivation = derive(robot, progress)   # M(q) regular at the defaults; the programs, never Lagrange's
    if not (code or any(flags.get(flag) for flag in BUILT)):   # no output flag: print the equations
        import typer

        from ..render.terminal import render_floating_terminal

        typer.echo(render_floating_terminal(derivation, digits), nl=False)
        return
    files = {}
    if flags.get("jax"):
        from ..render.floating_jax import render_floating_jax

        progress("generating JAX (floating base)")
        files[out / f"{robot.name}_dynamics_jax.py"] = render_floating_jax(derivation, template_dir).encode()
    progress("generating code (floating base)")
    if code:
        files[out / f"{robot.name}_dynamics.py"] = render_floating_code(derivation, template_dir).encode()
    if flags.get("c"):
        from ..render.c_floating import render_floating_c

        header, source = render_floating_c(derivation, template_dir)
        files[out / f"{robot.name}_dynamics.h"] = header.encode()
        files[out / f"{robot.name}_dynamics.c"] = source.encode()
    if flags.get("matlab"):
        from ..render.matlab_floating import render_floating_matlab

        files |= {out / path: text.encode() for path, text in render_floating_matlab(derivation, template_dir).items()}
    if tests and code:
        files[out / f"test_{robot.name}_dynamics.py"] = render_floating_code_tests(derivation, template_dir).encode()
    failures = _extension(derivation, flags, out, template_dir, files, progress) if flags.get("c_extension") else []
    # the extension built: an earlier failure's compiler log is stale
    removed = [out / f"{robot.name}_dynamics_c.log"] if flags.get("c_extension") and not failures else []
    from .floating_outputs import SHEET_KINDS, failure_text, floating_sheet_files

    sheets, failure = floating_sheet_files(derivation, {k for k in SHEET_KINDS if flags.get(k)}, template_dir, digits,
                                           progress)
    files |= {out / name: data for name, data in sheets.items()}
    if failure is not None:
        failures.append(failure_text(out, robot.name, failure))
    if flags.get("pdf"):   # an earlier failure's log, or an earlier PDF beside a new sheet (as solve_outputs)
        from ..render.pdf import stale_beside

        stale, said = stale_beside(out, robot.name, made=out / f"{robot.name}.pdf" in files)
        removed += stale
        failures[-1:] = [failures[-1] + said] if said else failures[-1:]
    removed = [path for path in removed if os.path.lexists(path)]
    write_all(files, remove=removed)
    if not quiet:
        for path in files:
            echo(f"wrote {path}")
        for path in removed:
            echo(f"removed {path}")
    for message in failures:   # the extension the compiler rejected, the PDF LaTeX did not make
        echo(f"dynderive: {message}")   # (the other outputs are written)
    if failures:
        import typer

        raise typer.Exit(1)


def _extension(derivation, flags: dict[str, bool], out: Path, template_dir: Path | None, files: dict[Path, bytes],
               progress: Callable[[str], None]) -> list[str]:
    """``--c-extension``: the compiled extension into ``files`` (on the C files ``--c`` wrote),
    or its compiler's log and the failure message (``commands/compile.py``)."""
    from .compile import ExtensionCompileError, build_extension, failure_message, failure_outputs

    name = derivation.robot.name
    c_files = (files[out / f"{name}_dynamics.h"].decode(), files[out / f"{name}_dynamics.c"].decode()) \
        if flags.get("c") else None
    try:
        filename, data = build_extension(derivation, template_dir, c_files=c_files, progress=progress)
    except ExtensionCompileError as exc:
        files |= {out / log: text for log, text in failure_outputs(name, exc).items()}
        return [failure_message(out, name, exc)]
    files[out / filename] = data
    return []


def floating_outputs(robot: Robot, source: str, kinds: tuple[str, ...], template_dir: str | None,
                     ) -> tuple[dict[str, bytes], Exception | None]:
    """``build``'s outputs of a floating-base robot (its modules, sheet and JSON dump) and the
    PDF's failure, if any; any other kind refused."""
    from .. import derive
    from ..render.floating_code import render_floating_code
    from ..render.floating_jax import render_floating_jax

    refused = [kind for kind in kinds if kind not in ("code", "floating_base", *BUILT) and not kind.startswith("digits:")]
    if refused:
        raise InputError(problem(source, f"{', '.join(refused)}: {NOT_BUILT}; build --code writes its NumPy module, "
                                         "--c its C, --c-extension its compiled extension, --matlab its MATLAB/Octave package, "
                                         "--jax its JAX module"))
    derivation = derive(robot)
    files = {}
    if "code" in kinds:
        files[f"{robot.name}_dynamics.py"] = render_floating_code(derivation, template_dir).encode()
    if "c" in kinds:
        from ..render.c_floating import render_floating_c

        header, source_text = render_floating_c(derivation, template_dir)
        files |= {f"{robot.name}_dynamics.h": header.encode(), f"{robot.name}_dynamics.c": source_text.encode()}
    if "matlab" in kinds:
        from ..render.matlab_floating import render_floating_matlab

        files |= {path: text.encode() for path, text in render_floating_matlab(derivation, template_dir).items()}
    if "c_extension" in kinds:
        from .compile import build_extension

        c_files = (files[f"{robot.name}_dynamics.h"].decode(), files[f"{robot.name}_dynamics.c"].decode()) \
            if "c" in kinds else None
        filename, data = build_extension(derivation, template_dir, c_files=c_files)
        files[filename] = data
    if "jax" in kinds:
        files[f"{robot.name}_dynamics_jax.py"] = render_floating_jax(derivation, template_dir).encode()
    from .floating_outputs import floating_sheet_files

    digits = next((int(kind.split(":")[1]) for kind in kinds if kind.startswith("digits:")), None)   # --digits
    sheets, failure = floating_sheet_files(derivation, kinds, template_dir, digits)
    return files | sheets, failure   # no TeX, or LaTeX failed: the other outputs are still made
