"""The ``dynderive`` command line. The only place where errors become exit codes.

Exit codes: 0 success; 1 internal error or missing tool; 2 bad input
(``FILE:LINE:COL: message``); 130 interrupted.
"""

from __future__ import annotations

import functools
import json
import os
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
import typer

from .._version import __version__
from ..errors import DynderiveError, InputError, Interrupted
from ..render.targets import COLUMNS, TARGETS, reference
from .help import Command as _Command
from .help import Group as _Group
from .options import backend_target, finite, problem, require_scipy, tolerances, vector, with_parameters
from .output import WRITTEN, check_frames, check_output_paths, echo_notes, interrupted_message, write_all
from .progress import Progress
from .target_options import option_help, target_flags, target_needs, target_notes, target_options

app = typer.Typer(cls=_Group, add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Derive a robot's equations of motion symbolically and render them as a LaTeX "
                       "solution sheet, a PDF, a NumPy module or JSON.")

F = TypeVar("F", bound=Callable[..., Any])
#: Options several commands share.
FloatingBase = Annotated[bool, typer.Option("--floating-base", help="URDF: join the world to the root link by a "
                                            "floating joint 'root_joint' (legged robots, humanoids).")]
Symbolic = Annotated[str | None, typer.Option("--symbolic", help="URDF: LINK.FIELD[,...] (wildcards: "
                     "panda_hand.mass, *.mass; FIELD mass, com or inertia): those inertial values become "
                     "parameters m_<link>, c_<link>_x, I_<link>_xx..., the file's values their defaults.")]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress on stderr.")]
Params = Annotated[list[str] | None, typer.Option("--param", help="NAME=VALUE: a parameter's value "
                   "(repeatable; required for parameters without a default).")]


def _fail(message: str, code: int) -> typer.Exit:
    typer.echo(message, err=True)
    return typer.Exit(code)


def _terminate(signum: int, frame: object) -> None:
    raise Interrupted


def handle_errors(function: F) -> F:
    """Map dynderive's errors to exit codes and one-line messages, never a traceback."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        previous = signal.signal(signal.SIGTERM, _terminate)
        WRITTEN.clear()   # the outputs of this command, for the message of an interrupt
        try:
            return function(*args, **kwargs)
        except InputError as exc:
            raise _fail(str(exc), 2) from None
        except DynderiveError as exc:   # a missing tool, a tool's failure, an output that cannot be written
            raise _fail(f"dynderive: {exc}", 1) from None
        except (KeyboardInterrupt, Interrupted):
            raise _fail(interrupted_message(), 130) from None
        except typer.Exit:
            raise
        except Exception as exc:  # an internal error: say so plainly, traceback on request
            if os.environ.get("DYNDERIVE_DEBUG"):
                raise
            raise _fail(f"dynderive: internal error: {type(exc).__name__}: {exc} "
                        "(set DYNDERIVE_DEBUG=1 for a traceback, and please report it)", 1) from None
        finally:
            Progress.close_all()
            signal.signal(signal.SIGTERM, previous)

    return wrapper  # type: ignore[return-value]


def require_matplotlib(option: str) -> None:
    """``--plot`` and ``--animate`` draw with matplotlib, an optional dependency (the ``plot``
    extra): refused at the option when it is not installed, before any work."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError(problem(option, 'needs matplotlib, which is not installed: pip install "dynderive[plot]" '
                                 "(or leave out the option: --csv needs no matplotlib)")) from None


def _version(value: bool) -> None:
    if value:
        typer.echo(f"dynderive {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """dynderive: equations of motion from a YAML robot description."""


@app.command(cls=_Command)
@target_options(after="pdf")   # --code, --c, --c-extension, --matlab, --jax (render/targets)
@handle_errors
def solve(
    robot: Annotated[str, typer.Argument(help="Robot file (YAML or URDF) or the name of a bundled robot, e.g. rp_arm.")],
    latex: Annotated[bool, typer.Option("--latex", help="Write DIR/<name>.tex, the solution sheet.")] = False,
    pdf: Annotated[bool, typer.Option("--pdf", help="Write DIR/<name>.pdf (needs latexmk; if LaTeX fails, DIR/<name>.tex and .log instead).")] = False,
    json_: Annotated[bool, typer.Option("--json", help="Write DIR/<name>.json, every quantity.")] = False,
    html: Annotated[bool, typer.Option("--html", help="Write DIR/<name>.html, the solution sheet as one self-contained "
                                       "web page (MathML equations, SVG drawing, no script).")] = False,
    tests: Annotated[bool, typer.Option("--tests", help=option_help("--tests"))] = False,
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("."),
    template_dir: Annotated[Path | None, typer.Option("--template-dir",
                            help="Directory of templates that override the built-in ones by file name.")] = None,
    sections: Annotated[str | None, typer.Option("--sections", help="Sections of the sheet, comma-separated: "
                        "generalized, maximal, checks, or all (default: maximal coordinates only for planar "
                        "robots of at most 2 links).")] = None,
    floating_base: FloatingBase = False,
    symbolic: Symbolic = None,
    digits: Annotated[str | None, typer.Option("--digits", help="N: the sheet's numbers (and the printed equations') "
                      "to N significant digits (default: as many as the robot file wrote, at most 6).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary on stderr.")] = False,
    **targets: bool,
) -> None:
    """Derive the equations of motion of ROBOT. With no output flag, print them."""
    from .. import derive, load_robot
    from ..render.sheets.terminal import render_terminal
    from .options import maximal_section_applies, sheet_digits_option, sheet_sections_option
    from .output import check_output_folder
    from .solve import form_note, output_wants, planned_files, solve_outputs

    if template_dir is not None and not template_dir.is_dir():
        raise InputError(problem(str(template_dir), "template directory does not exist"))
    targets = target_flags(targets)
    kinds = {kind for kind, asked in (("latex", latex), ("pdf", pdf), ("json", json_), ("html", html),
                                      *targets.items()) if asked}
    chosen = sheet_sections_option(sections, latex or pdf or html)
    printed = not kinds
    shortened = sheet_digits_option(digits, latex or pdf or html or printed)
    tested = next(target for target in TARGETS if target.help_for("--tests"))   # the module --tests checks
    if tests and not targets[tested.kind]:
        raise InputError(problem("--tests", f"--tests writes checks of the generated module: use it with {tested.flag}"))
    target_needs(targets)   # no compiler: stop before any work
    if not printed:   # an --out that cannot hold the outputs: refused before the derivation
        check_output_folder(out)
    progress = Progress(quiet)
    progress("loading")
    model = load_robot(robot, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    if not printed:
        check_output_folder(out, planned_files(model.name, kinds))
    maximal_section_applies(sections, model.planar, model.floating)
    echo_notes(model, quiet)
    if not quiet:
        target_notes(targets)
    derivation = derive(model, wants={"sheet"} if printed else output_wants(kinds), progress=progress)
    echo_notes(derivation, quiet)
    if (note := form_note(model)) and not quiet:
        typer.echo(note, err=True)
    if printed:
        typer.echo(render_terminal(derivation, shortened), nl=False)
        return
    files, failures, stale = solve_outputs(derivation, kinds, tests, out, template_dir, chosen, progress,
                                           shortened)
    removed = [path for path in stale if os.path.lexists(path)]
    write_all(files, remove=removed)
    if not quiet:
        failed = [c.description for c in derivation.checks_run if not c.passed and not c.skipped]
        for line in [*(f"wrote {path}" for path in files), *(f"removed {path}" for path in removed),
                     *(f"warning: check failed: {description}" for description in failed)]:
            typer.echo(line, err=True)
    for message in failures:   # outputs that could not be made (the others are written)
        typer.echo(f"dynderive: {message}", err=True)
    if failures:
        raise typer.Exit(1)


@app.command(cls=_Command)
@handle_errors
def check(
    robot: Annotated[str, typer.Argument(help="Robot file (YAML or URDF) or the name of a bundled robot.")],
    json_: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    states: Annotated[int, typer.Option("--states", help="Random states for the numeric checks.")] = 12,
    param: Annotated[list[str] | None, typer.Option("--param", help="NAME=VALUE: a parameter's value "
                     "(repeatable; parameters without a default take 1.0).")] = None,
    backend: Annotated[str, typer.Option("--backend", help=option_help("check --backend"))] = "numpy",
    floating_base: FloatingBase = False,
    symbolic: Symbolic = None,
    quiet: Quiet = False,
) -> None:
    """Run every check that applies to ROBOT's derivation and generated code.

    Exit code 1 if any check fails, 0 otherwise (skipped checks are listed, not failed).
    """
    from .. import derive, load_robot
    from ..verify.checks import run_checks

    if states < 1:
        raise InputError(problem("--states", f"expected a number of random states >= 1, got {states}"))
    harness = backend_target(backend)   # None: the NumPy module, its own checks only
    progress = Progress(quiet)
    model = load_robot(robot, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    model = with_parameters(model, robot, param or [], required=False, command="check",
                            load={"floating_base": floating_base, "symbolic": symbolic})
    echo_notes(model, quiet)
    derivation = derive(model, wants={"code"}, progress=progress)
    echo_notes(derivation, quiet)
    progress("generating code")
    source = reference(derivation)
    progress("checking")
    rows = run_checks(derivation, source, states=states)
    if harness is not None:   # the target's module, against the NumPy module
        rows += harness.compare(derivation, source, progress, states=states)
    failed = [r for r in rows if r.status == "FAIL"]
    if json_:
        typer.echo(json.dumps({"robot": model.name, "passed": not failed,
                               "checks": [r.as_dict() for r in rows]}, indent=2, allow_nan=False))
    else:
        width = max(len(r.name) for r in rows)
        typer.echo(f"{'check':<{width}}  result  {'worst residual':>14}  method")
        for r in rows:
            residual = "-" if r.residual != r.residual else f"{r.residual:.3g}"
            typer.echo(f"{r.name:<{width}}  {r.status:<6}  {residual:>14}  {r.method}")
        passed, skipped = (sum(r.status == status for r in rows) for status in ("pass", "skip"))
        typer.echo(f"\n{passed} passed, {len(failed)} failed, {skipped} skipped")
    if failed:
        raise typer.Exit(1)


@app.command(cls=_Command)
@handle_errors
def simulate(
    robot: Annotated[str, typer.Argument(help="Robot file (YAML or URDF) or the name of a bundled robot.")],
    duration: Annotated[float, typer.Option("--duration", help="Simulated time in seconds.")] = 5.0,
    q0: Annotated[str | None, typer.Option("--q0", help="Initial coordinates, e.g. '0.5,0.1' (default: 0.5 rad / 0.2 m).")] = None,
    qd0: Annotated[str | None, typer.Option("--qd0", help="Initial velocities (default: 0).")] = None,
    effort: Annotated[list[str] | None, typer.Option("--effort", help="NAME=EXPR(t, q, qd), repeatable; others are 0.")] = None,
    force: Annotated[list[str] | None, typer.Option("--force", help="FRAME=EXPR,EXPR,..(t, q, qd): a wrench at a frame "
                     "in world axes (planar fx,fy,n; 3-D fx,fy,fz,nx,ny,nz), repeatable.")] = None,
    coordinates: Annotated[str, typer.Option("--coordinates", help="generalized or maximal (planar robots).")] = "generalized",
    contacts: Annotated[str | None, typer.Option("--contacts", help="FRAME[:point|surface][,...]: frames held (3-D), "
                        "anchored where they start; 'none': none (default: the robot file's contacts).")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Image of the coordinates, energy (and constraint "
                                  "drift), in the format its suffix names: .png, .pdf, .svg, .jpg; needs "
                                  "matplotlib (the plot extra).")] = None,
    csv: Annotated[Path | None, typer.Option("--csv", help="CSV of the trajectory.")] = None,
    animate: Annotated[Path | None, typer.Option("--animate", help="GIF animation (planar robots); needs matplotlib "
                                     "(the plot extra).")] = None,
    method: Annotated[str, typer.Option("--method", help="SciPy integrator: LSODA (switches to a stiff method "
                      "when needed), Radau, BDF (stiff), RK45, DOP853 (explicit: slow on stiff robots).")] = "LSODA",
    rtol: Annotated[float, typer.Option("--rtol", help="Relative tolerance of the integrator.")] = 1e-9,
    atol: Annotated[float, typer.Option("--atol", help="Absolute tolerance of the integrator.")] = 1e-9,
    baumgarte: Annotated[float, typer.Option("--baumgarte", help="Baumgarte gain b: alpha = beta = b for maximal runs and "
                         "loops; contacts take kp = b**2, kd = 2 b.")] = 10.0,
    frames: Annotated[int, typer.Option("--frames", help="Output samples (and animation frames).")] = 101,
    param: Params = None,
    friction_smoothing: Annotated[float, typer.Option("--friction-smoothing", help="Coulomb friction: sign(qd) "
                                  "becomes tanh(qd / EPS) (a velocity; 0 = the exact sign, as the generated "
                                  "module's default, which integrators cannot step through).")] = 1e-3,
    backend: Annotated[str, typer.Option("--backend", help=option_help("simulate --backend"))] = "numpy",
    floating_base: FloatingBase = False,
    symbolic: Symbolic = None,
    quiet: Quiet = False,
) -> None:
    """Integrate ROBOT's generated forward dynamics; plot, tabulate and animate the motion."""
    from .. import derive, load_robot
    from ..input.input_files import input_files
    from ..model.naming import did_you_mean
    from . import simulate as simulation
    from . import simulation_files
    from .contacts import parse_contacts
    from .integrate import method_name

    check_output_paths({"--plot": plot, "--csv": csv, "--animate": animate}, input_files(Path(robot)))
    check_frames(frames, animate is not None)
    if coordinates not in ("generalized", "maximal"):
        raise InputError(problem("--coordinates", f"expected generalized or maximal, got {coordinates!r}"
                                 + did_you_mean(coordinates, ("generalized", "maximal"))))
    finite(duration, "--duration", "a duration in seconds", 0.0, strict=True)
    finite(friction_smoothing, "--friction-smoothing", "a velocity", 0.0)
    finite(baumgarte, "--baumgarte", "a gain", 0.0)
    tolerances(rtol, atol)
    method = method_name(method)
    loaded = backend_target(backend)   # None: the NumPy module; else a target's module (the C extension)
    if loaded is not None and coordinates == "maximal":
        raise InputError(problem("--backend", "the compiled module has no maximal-coordinate functions: "
                                 "use --backend numpy with --coordinates maximal"))
    for option, path in (("--plot", plot), ("--animate", animate)):
        if path is not None:
            require_matplotlib(option)
    if plot is not None:
        simulation_files.plot_format(plot)
    if animate is not None:
        simulation_files.animation_format(animate)
    require_scipy("simulate")
    progress = Progress(quiet)
    model = load_robot(robot, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    model = with_parameters(model, robot, param or [], required=True,
                            load={"floating_base": floating_base, "symbolic": symbolic})
    echo_notes(model, quiet)
    simulation.refuse_options(model, coordinates, animate)
    maximal = coordinates == "maximal"
    loop_q = simulation.loop_numbers(q0, model) if model.loops and not maximal and not model.floating else None
    start_q = None if loop_q is not None else vector(q0, len(model.configuration_names), "--q0")
    start_qd = vector(qd0, model.velocity_count, "--qd0")
    start_q = simulation.initial_configuration(model, start_q)
    derivation = derive(model, wants={"code"}, progress=progress)
    echo_notes(derivation, quiet)
    start_q = simulation.loop_start(loop_q, q0, derivation, start_q)   # loops: the independent ones may do
    held = parse_contacts(model, contacts, coordinates, loaded is not None)
    efforts = simulation.parse_efforts(derivation, effort or [], maximal)
    if force and maximal:
        raise InputError(problem("--force", "wrenches at frames are applied in generalized coordinates only"))
    wrenches = simulation.parse_wrenches(derivation, force or [])
    progress("generating code")
    source = reference(derivation)
    compiled = loaded.load(derivation, progress=progress) if loaded is not None else None
    trajectory = simulation.simulate(derivation, source, duration, start_q,
                     np.zeros(model.velocity_count) if start_qd is None else start_qd, efforts, maximal, rtol, atol,
                     baumgarte, frames, progress, friction_smoothing, wrenches, method,
                     lambda text: None if quiet else typer.echo(f"note: {text}", err=True), compiled, held,
                     declared=contacts is None)
    files: dict[Path, bytes] = {}
    if plot is not None:
        progress("plotting")
        files[plot] = simulation_files.plot_image(derivation, trajectory, plot.suffix.lower())
    if csv is not None:
        files[csv] = simulation_files.csv_text(trajectory).encode()
    if animate is not None:
        progress("animating")
        files[animate] = simulation_files.animation_gif(derivation, trajectory)
    write_all(files)
    typer.echo(simulation.run_summary(model, coordinates, duration, trajectory))
    for path in files:
        typer.echo(f"wrote {path}", err=True)


@app.command(cls=_Command)
@handle_errors
def linearize(
    robot: Annotated[str, typer.Argument(help="Robot file (YAML or URDF) or the name of a bundled robot.")],
    at: Annotated[list[str] | None, typer.Option("--at", help="The operating point: q=V,V,..,qd=V,..,u=V,.. or "
                  "NAME=V per coordinate, velocity or effort (repeatable; the rest is 0); u=equilibrium: the "
                  "efforts that hold the state.")] = None,
    param: Annotated[list[str] | None, typer.Option("--param", help="NAME=VALUE: a parameter's value for the "
                     "numbers (repeatable; parameters without a default take 1.0).")] = None,
    json_: Annotated[bool, typer.Option("--json", help="Print A and B as JSON.")] = False,
    latex: Annotated[bool, typer.Option("--latex", help="Print a LaTeX document of A and B.")] = False,
    floating_base: FloatingBase = False,
    symbolic: Symbolic = None,
    quiet: Quiet = False,
) -> None:
    """Linearize ROBOT's dynamics about a state: xdot = A dx + B du, x = (q, qd).

    Small robots: A and B in closed form over the parameters, and their values; large robots
    and closed loops: the values, from the generated module's linearize (Newton-Euler
    differentiated line by line; with loops, the constrained solve).
    """
    from .. import derive, load_robot
    from ..verify.checks import generated_module
    from . import linearize as linear

    def note(*texts: str | None) -> None:
        for text in texts:
            if text is not None and not quiet:
                typer.echo(f"note: {text}", err=True)

    progress = Progress(quiet)
    model = load_robot(robot, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    model = with_parameters(model, robot, param or [], required=False, command="linearize",
                            load={"floating_base": floating_base, "symbolic": symbolic})
    echo_notes(model, quiet)
    derivation = derive(model, wants={"code"}, progress=progress)
    table = derivation.symbols
    point, given, equilibrium = linear.parse_at(at or [], [str(s) for s in table.q],
                                                [str(s) for s in table.qd], list(table.efforts))
    progress("generating code")
    module = generated_module(reference(derivation), model.name)   # the NumPy module, any base
    if model.floating:
        point["q"], manifold_notes = linear.on_the_manifold(model, module, point["q"], given)
        note(*manifold_notes)
    values = {p.name: (p.value if p.value is not None else 1.0) for p in model.parameters}
    if model.loops:   # the state on the constraints: independent coordinates kept, the rest assembled
        point, loop_notes = linear.on_the_loops(module, point, given, values)
        note(*loop_notes)
    remark = None
    if equilibrium:
        point["u"], remark = linear.equilibrium_efforts(module, point, values)
    note(remark or linear.equilibrium_note(module, point, values))
    progress("linearizing")
    result = linear.linearization(derivation, module, point, values, equilibrium)
    if result["skipped"]:
        note(f"closed form skipped: {result['skipped']}; A and B are the generated linearize's numbers")
    kind = "json" if json_ else "latex" if latex else "text"
    typer.echo(linear.render_linearization(derivation, point, values, result, kind), nl=False)


@app.command(cls=_Command)
@handle_errors
def identify(
    robot: Annotated[str, typer.Argument(help="Robot file (YAML or URDF) or the name of a bundled robot.")],
    json_: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    param: Params = None,
    states: Annotated[int | None, typer.Option("--states", help="Random states sampled (at least the number of "
                                               "regressor parameters).", show_default="4 per parameter, at least "
                                               "100")] = None,
    floating_base: FloatingBase = False,
    symbolic: Symbolic = None,
    quiet: Quiet = False,
) -> None:
    """The regressor's parameter vector pi and ROBOT's base parameters: how the parameters group
    into the combinations the joint forces determine (Y pi = Y_base pi_base)."""
    from .. import derive, load_robot
    from ..verify.checks import generated_module

    require_scipy("identify")
    from ..verify.identification import base_parameters, fewest_states

    progress = Progress(quiet)
    model = load_robot(robot, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    model = with_parameters(model, robot, param or [], required=True,
                            load={"floating_base": floating_base, "symbolic": symbolic})
    echo_notes(model, quiet)
    if states is not None and states < (least := fewest_states(model)):
        raise InputError(problem("--states", f"expected at least {least} states for {model.name} (one per "
                                 "regressor parameter: fewer can make the rank, and so the base parameters, "
                                 f"come out too small), got {states}"))
    derivation = derive(model, wants={"code"}, progress=progress)
    progress("generating code")
    module = generated_module(reference(derivation), model.name)
    progress("sampling the regressor")
    values = {p.name: float(p.value) for p in model.parameters}
    result = base_parameters(derivation, module, values, states)
    if json_:
        typer.echo(json.dumps({"robot": model.name, **result.as_dict()}, indent=2, allow_nan=False))
        return
    rows = len(derivation.symbols.qd)
    per_link = "4 per link (planar)" if model.planar else "10 per link"
    typer.echo(f"{model.name}: regressor Y(q, qd, qdd) of shape ({rows}, {len(result.names)}), "
               f"parameters {per_link} then drives\n\nParameter vector pi:")
    width = max(len(name) for name in result.names)
    for name, value in zip(result.names, result.values):
        typer.echo(f"  {name:<{width}}  {value:.10g}")
    typer.echo(f"\nBase parameters: {result.rank} of {len(result.names)} (rank of Y at {result.states} "
               "random states; Y pi = Y_base pi_base):")
    for k, grouping in enumerate(result.groupings, 1):
        typer.echo(f"  {k:>3}  {grouping.text}  =  {grouping.value:.10g}")
    if result.unidentifiable:
        unidentifiable = ", ".join(result.names[i] for i in result.unidentifiable)
        typer.echo(f"\nNot identifiable (zero columns): {unidentifiable}")
    if model.loops:
        typer.echo("\nNote: the regressor is the spanning tree's (no loop forces).")


@app.command(cls=_Command)
@target_options(after="pdf", build=True)   # --code, --c, --c-extension, --matlab, --jax (render/targets)
@handle_errors
def build(
    paths: Annotated[list[Path] | None, typer.Argument(help="Robot files or folders to search (default: .).")] = None,
    out: Annotated[Path, typer.Option("--out", help="Output directory (holds the build manifest).")] = Path("build"),
    latex: Annotated[bool, typer.Option("--latex", help="Write <name>.tex.")] = False,
    pdf: Annotated[bool, typer.Option("--pdf", help="Write <name>.pdf.")] = False,
    json_: Annotated[bool, typer.Option("--json", help="Write <name>.json.")] = False,
    html: Annotated[bool, typer.Option("--html", help="Write <name>.html, the sheet as a web page.")] = False,
    jobs: Annotated[int | None, typer.Option("-j", "--jobs", help="Robots built in parallel (default: CPUs).")] = None,
    check_only: Annotated[bool, typer.Option("--check", help="Write nothing; exit 1 listing outputs that are "
                                             "missing or differ from what would be generated, and orphaned "
                                             "outputs.")] = False,
    prune: Annotated[bool, typer.Option("--prune", help="Remove orphaned outputs: those the manifest records for "
                                        "robot files that no longer exist.")] = False,
    template_dir: Annotated[Path | None, typer.Option("--template-dir",
                            help="Templates that override the built-in ones by file name.")] = None,
    floating_base: Annotated[bool, typer.Option("--floating-base", help="URDF files: float the root link.")] = False,
    symbolic: Annotated[str | None, typer.Option("--symbolic", help="URDF files: LINK.FIELD[,...] "
                        "(wildcards; FIELD mass, com or inertia): those inertial values become "
                        "parameters.")] = None,
    digits: Annotated[str | None, typer.Option("--digits", help="N: the sheets' numbers to N significant "
                      "digits (default: as many as each robot file wrote, at most 6).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No notes on stderr, and of the table only the "
                                        "robots that failed, differ or are orphaned (nothing when all is well); "
                                        "errors are still printed.")] = False,
    **targets: bool,
) -> None:
    """Build the outputs of every robot file under PATHS, only where inputs changed."""
    from .build import build as run_build
    from .build_report import report
    from .options import sheet_digits_option, symbolic_kind

    targets = target_flags(targets)
    kinds = tuple(kind for kind, wanted in (("latex", latex), ("pdf", pdf),
                                            *((t.kind, targets[t.kind]) for t in COLUMNS),
                                            ("json", json_), ("html", html)) if wanted) or ("latex", "code")
    if prune and check_only:
        raise InputError(problem("--prune", "--check writes nothing, so it cannot prune: run build --prune "
                                 "without --check"))
    shortened = sheet_digits_option(digits, any(kind in kinds for kind in ("latex", "pdf", "html")))
    target_needs(targets)   # no compiler: stop before any work
    kinds += ("floating_base",) if floating_base else ()
    kinds += symbolic_kind(symbolic)
    kinds += (f"digits:{shortened}",) if shortened else ()
    if template_dir is not None and not template_dir.is_dir():
        raise InputError(problem(str(template_dir), "template directory does not exist"))
    if not quiet:
        target_notes(targets)
    outcomes = run_build(paths or [Path(".")], out, kinds, jobs or os.cpu_count() or 1, check_only,
                         template_dir, (lambda text: None) if quiet else lambda text: typer.echo(text, err=True), prune)
    if report(outcomes, out, quiet, check_only):
        raise typer.Exit(1)


@app.command(cls=_Command)
@handle_errors
def schema() -> None:
    """Print the JSON Schema of the robot file format (for editors such as VS Code's YAML extension)."""
    from ..input.json_schema import robot_schema

    typer.echo(json.dumps(robot_schema(), indent=2))


@app.command("import", cls=_Command)
@handle_errors
def import_(
    urdf: Annotated[str, typer.Argument(help="URDF or MJCF file to convert, or a bundled URDF robot (ur5, panda).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="YAML file to write.")],
    floating_base: Annotated[bool, typer.Option("--floating-base", help="Join the world to the root link by a "
                             "floating joint 'root_joint'.")] = False,
) -> None:
    """Convert a URDF or MJCF file into the equivalent dynderive YAML robot file."""
    from ..input.input_files import input_files
    from ..input.loader import resolve_robot_path
    from ..input.schema import validate
    from ..input.sources import read_source
    from ..input.urdf import to_yaml

    path = resolve_robot_path(urdf)   # a file or a bundled robot's name
    check_output_paths({"--output": output}, input_files(path))   # never over a file the model reads
    if path.suffix.lower() in (".yaml", ".yml"):
        raise InputError(problem(str(path), "is already a YAML robot file (import converts URDF and MJCF files)"))
    document = read_source(path, floating_base)
    for note in document.notes:
        typer.echo(note, err=True)
    validate(document)  # the same checks as any robot file, before anything is written
    if document.impossible_inertias:   # a robot file's inertias must be physical: it would not load
        message = ("inertia: not imported: it misses the triangle inequality (see the note), which a YAML "
                   "robot file may not; correct it in the URDF, or use the URDF itself")
        raise InputError([document.problem(where + ("inertia",), f"{document.labels[where]} {message}")
                          for where in sorted(document.impossible_inertias)])
    write_all({output: to_yaml(document.data, path.name).encode()})
    typer.echo(f"wrote {output}", err=True)


@app.command(cls=_Command)
@handle_errors
def copy(
    name: Annotated[str, typer.Argument(help="A bundled robot's name, e.g. rp_arm.")],
    dest: Annotated[Path | None, typer.Argument(help="File or folder to copy it to (default: NAME.yaml or "
                                                "NAME.urdf in the current folder).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace DEST if it exists.")] = False,
) -> None:
    """Copy a bundled robot's file out, to edit it (an unknown NAME lists the bundled robots)."""
    from .copy import bundled_file, copy_target

    source = bundled_file(name)
    target = copy_target(source, dest, force)
    write_all({target: source.read_bytes()})
    typer.echo(f"wrote {target}", err=True)
