"""``dynderive simulate``: integrate the generated dynamics, plot, tabulate and animate.

Integrates with SciPy (a dependency); ``--plot`` and ``--animate`` draw with matplotlib, the
``plot`` extra (``pip install "dynderive[plot]"``), imported only when they are asked for.
Efforts are expressions of ``t``, the coordinates, their velocities and the parameters, parsed
by the same whitelist as robot files. Maximal-coordinate runs use Baumgarte stabilisation and accept efforts of
``t`` only (the generalized coordinates are not state there).

A robot whose configuration holds unit quaternions (floating and spherical joints) is
integrated in ``(q, v)``, NQ + NV entries, with ``dq/dt`` from the module's
``configuration_rate`` (a quaternion moves by ``1/2 quaternion * (w, 0)``, tangent to the unit
sphere), from output frame to output frame: at each frame the quaternions are normalized (the
integrator's own error moves them off the sphere by about its tolerance) and the run goes on
from there, as closed loops are projected back onto their constraints; the right-hand side
evaluates the dynamics at normalized quaternions too.

``--contacts`` (3-D robots; default: the robot file's ``contacts:``, ``none`` for
none) holds frames with the module's ``constrained_forward_dynamics``: the start velocity is
first made to respect them (``impulse_dynamics``, a plastic impact at t = 0), and the contacts
are anchored where they start, held by Baumgarte stabilisation with kp = b**2, kd = 2 b
(b = ``--baumgarte``: critically damped position and velocity errors).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy

from ..derivation import Derivation
from ..errors import InputError, Problem
from ..mechanics import joint_types
from ..model.expressions import ExpressionError, parse_expression
from ..model.naming import velocity_name
from ..model.robot import Robot
from ..verify.checks import allowed_velocity, generated_module
from .contacts import held_contacts as _held
from .integrate import DEFAULT_METHOD, Culprit, Integrator, at_duration, checked, singular_problem
from .options import problem, split_top_level, vector_any
from .output import quaternion_kind

#: Singular values below this fraction of the largest count as zero in ``singular_start``
#: (a configuration that close to singular makes the integrator stall).
SINGULAR = 1e-9
#: How far from unit a quaternion of ``--q0`` may be (then normalized): four decimals typed.
QUATERNION_TOLERANCE = 1e-3


@dataclass
class Trajectory:
    names: list[str]           # coordinate names of the state (generalized or maximal)
    times: np.ndarray
    position: np.ndarray       # (frames, n)
    velocity: np.ndarray
    energy: np.ndarray
    drift: np.ndarray | None   # max |a(qm)| per frame (maximal runs)
    link_poses: Callable[[np.ndarray], list[tuple[np.ndarray, float]]] | None  # planar drawing
    #: work done by damping and friction since t = 0, integral of qd . F dt (generalized runs of
    #: robots with damping or friction; None otherwise): E + W changes only by the efforts' work
    dissipated: np.ndarray | None = None
    #: the velocities' names (the CSV's columns after the coordinates)
    velocity_names: list[str] = field(default_factory=list)
    #: the contacts held (frame, kind), and the largest distance of a contact from its anchor
    contacts: list[tuple[str, str]] = field(default_factory=list)
    contact_drift: float = 0.0


def parse_efforts(derivation: Derivation, specs: list[str], maximal: bool) -> Callable[..., np.ndarray]:
    """``NAME=EXPR`` options -> u(t, q, qd) for the effort vector (missing efforts are 0)."""
    table, robot = derivation.symbols, derivation.robot
    t = sympy.Symbol("t")
    scope: dict[str, sympy.Expr] = {"t": t, **table.parameters}
    if not maximal:
        scope |= {str(s): s for s in (*table.q, *table.qd)}
    exprs: dict[str, tuple[sympy.Expr, str, int]] = {}
    for spec in specs:
        name, sep, text = spec.partition("=")
        where = f"--effort {spec}"
        if not sep or name.strip() not in robot.efforts:
            raise InputError(Problem(where, 1, 1, f"expected NAME=EXPR with NAME one of "
                                     f"{', '.join(robot.efforts) or '(this robot has no efforts)'}"))
        try:
            exprs[name.strip()] = (parse_expression(text, scope), where, len(name) + 2)
        except ExpressionError as exc:
            hint = " (maximal runs take efforts of t only)" if maximal else ""
            raise InputError(Problem(where, 1, len(name) + 2 + exc.offset, f"{exc}{hint}")) from None
    values = table.defaults(robot)
    options = [(name, where, column, sympy.lambdify([t, table.q, table.qd], expr.xreplace(values), modules="numpy"))
               for name, (expr, where, column) in exprs.items()]
    indices = [(robot.efforts.index(name), checked(function, where, column, f"effort {name}"))
               for name, where, column, function in options]

    def efforts(time: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        u = np.zeros(len(robot.efforts))
        for index, function in indices:
            u[index] = function(time, q, qd).reshape(-1)[0]
        return u
    efforts.options = options  # type: ignore[attr-defined]
    return efforts


def culprit(efforts: Callable[..., np.ndarray], nq: int, nv: int, maximal: bool = False) -> Culprit:
    """The option to blame for a motion that stops being computable at (time, state): the
    ``--effort`` whose value is largest there (the state's first ``nq`` entries are q, the next
    ``nv`` qd; maximal runs' efforts are of t only), else ``--duration``."""
    options = getattr(efforts, "options", [])

    def blame(time: float, state: np.ndarray, body: str) -> Problem:
        q, qd = (np.zeros(nq), np.zeros(nv)) if maximal else (state[:nq], state[nq:nq + nv])
        sizes = []
        for name, where, column, function in options:
            try:
                with np.errstate(all="ignore"):
                    value = float(np.asarray(function(time, q, qd), dtype=float).reshape(-1)[0])
            except (ArithmeticError, ValueError, TypeError):
                value = math.inf
            sizes.append((abs(value) if not math.isnan(value) else math.inf, name, where, column, value))
        if not sizes:
            return at_duration(time, state, body)
        _, name, where, column, value = max(sizes, key=lambda item: item[0])
        return Problem(where, 1, column, f"effort {name} reaches {value:.3g}: {body}")
    return blame


def singular_start(matrix: np.ndarray, rank: int, what: str, names: list[str] | tuple[str, ...],
                   q: np.ndarray) -> None:
    """Refuse a start where ``matrix`` (a constraint Jacobian) has fewer than ``rank``
    independent rows: the constrained dynamics cannot be solved there (at --q0)."""
    with np.errstate(all="ignore"):
        values = np.linalg.svd(matrix, compute_uv=False) if np.all(np.isfinite(matrix)) else None
    found = 0 if values is None or not len(values) else int(np.sum(values > SINGULAR * values[0]))
    if found < rank:
        shown = ", ".join(f"{name} = {value:.6g}" for name, value in zip(names, q))
        raise InputError(singular_problem(
            f"the configuration {shown} is singular: {what} ({matrix.shape[0]} x {matrix.shape[1]}) has rank "
            f"{found}, not {rank} (its rows are dependent there), so the constrained accelerations cannot be "
            "solved for; choose another --q0"))


def parse_wrenches(derivation: Derivation, specs: list[str]) -> Callable[..., dict[str, np.ndarray] | None]:
    """``FRAME=EXPR,EXPR,..`` options -> w(t, q, qd): the wrench at each named frame, in world
    axes (planar ``fx, fy, n``; 3-D ``fx, fy, fz, nx, ny, nz``, the moment about the frame's
    origin), expressions of t, the coordinates, their velocities and the parameters."""
    table, robot = derivation.symbols, derivation.robot
    t = sympy.Symbol("t")
    scope: dict[str, sympy.Expr] = {"t": t, **table.parameters} | {str(s): s for s in (*table.q, *table.qd)}
    size = 3 if robot.planar else 6
    frames = [f.name for f in robot.frames]
    exprs: dict[str, list[tuple[sympy.Expr, str, int]]] = {}
    for spec in specs:
        name, sep, text = spec.partition("=")
        where = f"--force {spec}"
        if not sep or name.strip() not in frames:
            raise InputError(Problem(where, 1, 1, "expected FRAME=EXPR,EXPR,.. with FRAME one of "
                                     + (", ".join(frames) or "(this robot declares no frames)")))
        parts = split_top_level(text)
        if len(parts) != size:
            what = "fx, fy, n" if robot.planar else "fx, fy, fz, nx, ny, nz"
            raise InputError(Problem(where, 1, len(name) + 2, f"expected {size} components ({what}), got {len(parts)}"))
        column = len(name) + 2
        values = []
        for part in parts:
            try:
                values.append((parse_expression(part, scope), where, column))
            except ExpressionError as exc:
                raise InputError(Problem(where, 1, column + exc.offset, str(exc))) from None
            column += len(part) + 1
        exprs[name.strip()] = values
    if not exprs:
        return lambda time, q, qd: None
    defaults = table.defaults(robot)
    functions = {name: [checked(sympy.lambdify([t, table.q, table.qd], expr.xreplace(defaults), modules="numpy"),
                                where, column, f"the force at {name}") for expr, where, column in values]
                 for name, values in exprs.items()}
    return lambda time, q, qd: {name: np.array([f(time, q, qd).reshape(-1)[0] for f in parts])
                                for name, parts in functions.items()}


def normalized(q: np.ndarray, starts: tuple[int, ...]) -> np.ndarray:
    """``q`` (a copy) with its quaternions, starting at ``starts``, made unit."""
    q = np.array(q, dtype=float)
    for start in starts:
        q[..., start:start + 4] /= np.linalg.norm(q[..., start:start + 4], axis=-1, keepdims=True)
    return q


def initial_configuration(robot: Robot, q0: np.ndarray | None) -> np.ndarray:
    """``--q0`` with its quaternions normalized (refused if one is off unit by more than
    QUATERNION_TOLERANCE); without it a meaningful start: revolute joints at 0.5 rad,
    prismatic at 0.2 m, floating and spherical joints at identity quaternions (a floating
    base at the origin of its parent)."""
    starts = robot.quaternion_starts
    if q0 is None:
        where_q, _ = robot.offsets()
        q0 = np.zeros(len(robot.configuration_names))
        for joint in (j for j in robot.joints if j.owns):   # its joint type's typical configuration
            start = where_q[joint.name]
            q0[start:start + joint.sizes[0]] = joint_types.of(joint).typical()
        return q0
    names = robot.configuration_names
    for start in starts:
        norm = float(np.linalg.norm(q0[start:start + 4]))
        if abs(norm - 1.0) > QUATERNION_TOLERANCE:
            raise InputError(problem("--q0", f"the quaternion {', '.join(names[start:start + 4])} must be unit "
                                             f"(within {QUATERNION_TOLERANCE:g}), its norm is {norm:.6g}"))
    return normalized(q0, starts)


def loop_numbers(text: str | None, robot: Robot) -> list[float] | None:
    """``--q0`` of a closed-loop robot in generalized coordinates: every coordinate, or only the
    independent ones (the others are assembled from them). Their number is checked against the
    derivation's choice by ``loop_start``; here only the numbers themselves (before any work)."""
    if text is None:
        return None
    coordinates = len(robot.configuration_names)
    fewest = len(robot.independent) if robot.independent is not None else 1
    values = vector_any(text, "--q0")
    if values is not None and len(values) == coordinates:
        return values
    if values is None or (robot.independent is not None and len(values) != fewest) \
            or not fewest <= len(values) < coordinates:
        named = f" or {fewest} (the independent coordinates {', '.join(robot.independent)})" \
            if robot.independent is not None else " or the independent ones"
        raise InputError(problem("--q0", f"expected {coordinates} numbers (every coordinate: "
                                 f"{', '.join(robot.configuration_names)}){named}, separated by commas, got {text!r}"))
    return values


def loop_start(values: list[float] | None, text: str | None, derivation: Derivation,
               default: np.ndarray) -> np.ndarray:
    """The start configuration of a closed-loop robot: ``--q0`` with every coordinate as given,
    or its independent coordinates set in the default assembly (the run assembles the others
    from them); without ``--q0``, ``default``."""
    if values is None or len(values) == len(default):
        return default if values is None else np.array(values)
    loops = derivation.loop_model
    names = [derivation.robot.coordinates[i] for i in loops.independent]
    if len(values) != len(names):
        raise InputError(problem("--q0", f"expected {len(default)} numbers (every coordinate: "
                                 f"{', '.join(derivation.robot.coordinates)}) or {len(names)} (the independent "
                                 f"coordinates {', '.join(names)}), separated by commas, got {text!r}"))
    start = np.array(loops.assembled, dtype=float) if loops.assembled is not None else default.copy()
    start[loops.independent] = values
    return start


def refuse_options(robot: Robot, coordinates: str, animate: object) -> None:
    """Refuse what a run of ``robot`` does not do (exit 2, before any work): maximal
    coordinates and the animation beyond planar robots (a robot with quaternions is run in
    ``(q, v)`` only)."""
    if coordinates == "maximal" and robot.floating:
        raise InputError(problem("--coordinates", "a floating-base robot is simulated in its coordinates (q, v) only"))
    if coordinates == "maximal" and not robot.planar:
        raise InputError(problem(robot.source, "maximal coordinates are planar-only for now"))
    if animate is not None and not robot.planar:
        raise InputError(problem("--animate" if robot.floating else robot.source, "--animate draws planar robots only"))


def run_summary(robot: Robot, coordinates: str, duration: float, trajectory: Trajectory) -> str:
    """The line ``simulate`` prints: the run, its largest relative energy change, and the
    constraint drift and the work of damping and friction where they apply."""
    energy = trajectory.energy
    relative = float(np.max(np.abs(energy - energy[0])) / max(abs(energy[0]), 1e-12))
    where = f"({quaternion_kind(robot)}, on the manifold)" if robot.floating else f"in {coordinates} coordinates"
    held = ", ".join(f"{frame} ({kind})" for frame, kind in trajectory.contacts)
    return (f"simulated {duration:g} s of {robot.name} {where}"
            + (f" holding {held} (largest contact drift {trajectory.contact_drift:.3g})" if held else "")
            + f": largest relative energy change {relative:.3g}"
            + (f", largest constraint drift {np.max(trajectory.drift):.3g}" if trajectory.drift is not None else "")
            + (f", energy dissipated by damping and friction {trajectory.dissipated[-1]:.6g}"
               if trajectory.dissipated is not None else ""))


def progress_ticker(duration: float, progress: Callable[[str], None]) -> Callable[[float], None]:
    """A right-hand side's clock: reports "simulated 10 % ..." each tenth of ``duration`` once."""
    reported = [-1]

    def tick(time: float) -> None:
        percent = int(100 * time / duration) // 10 * 10
        if percent > reported[0]:
            reported[0] = percent
            progress(f"simulated {percent:3d} % of {duration:g} s")

    return tick


def simulate(derivation: Derivation, source: str, duration: float, q0: np.ndarray, qd0: np.ndarray,
             efforts: Callable[..., np.ndarray], maximal: bool, rtol: float, atol: float,
             baumgarte: float, frames: int, progress: Callable[[str], None],
             friction_smoothing: float = 0.0,
             wrenches: Callable[..., dict[str, np.ndarray] | None] = lambda time, q, qd: None,
             method: str = DEFAULT_METHOD, note: Callable[[str], None] = lambda text: None,
             compiled: Any = None, contacts: list[tuple[str, str]] | None = None,
             declared: bool = False) -> Trajectory:
    """Integrate the generated dynamics with SciPy's ``method`` (see ``integrate``), from ``q0``
    (NQ entries) and ``qd0`` (NV), on the manifold for a robot with quaternions (module
    docstring). Robots with Coulomb friction use the module's smoothed sign
    (``friction_smoothing``, a velocity; 0 = exact) in generalized coordinates; with damping or
    friction the work they dissipate rides along (``Trajectory.dissipated``). ``note`` receives
    one line if the integrator struggles; a state or an effort that stops being finite stops
    the run (InputError). ``compiled``: the C extension (``--backend c``), whose forward
    dynamics, ``configuration_rate`` and friction the integrator calls instead of the NumPy
    module's (generalized coordinates only). ``contacts``: (frame, kind) held (module
    docstring; generalized coordinates of a 3-D robot); ``declared``: they are
    the robot file's (no ``--contacts``), so a refusal of them is placed at its ``contacts:``."""
    robot = derivation.robot
    module = generated_module(source, robot.name)
    fast = compiled if compiled is not None else module
    values = {p.name: p.value for p in robot.parameters if p.value is not None}
    nq, nv = len(q0), len(qd0)
    tick = progress_ticker(duration, progress)

    exact_friction = friction_smoothing == 0 and any(j.friction is not None for j in robot.joints if j.moves)
    hint = ("Coulomb friction with --friction-smoothing 0 has no slope at rest: try 1e-3"
            if exact_friction and not maximal else "")   # what the note of a struggling run adds
    loops = bool(robot.loops) and not maximal
    dissipative = robot.dissipative and not maximal and not loops
    starts = () if maximal else robot.quaternion_starts
    drift: list[float] = []
    held = list(contacts or ()) if not maximal else []
    if not maximal:
        rate = fast.configuration_rate if starts else lambda q, qd: qd   # dq/dt
        gains = {"alpha": baumgarte, "beta": baumgarte} if loops else {}
        forward = fast.forward_dynamics
        if loops:   # start on the constraints (before the contacts anchor); at every frame the state goes back onto them
            project = (_tangent_projection(module, values, starts) if robot.floating
                       else _loop_projection(module, values, q0))
            y0 = project(q0, qd0)
            q0, qd0 = y0[:nq], y0[nq:]
            if not robot.floating:   # with quaternions the rank is taken at each state (allowed_velocity)
                with np.errstate(all="ignore"):
                    singular_start(module.loop_jacobian(q0, **values), nq - len(module.INDEPENDENT_COORDINATES),
                                   "the loop constraint Jacobian A_g(q)", module.COORDINATES, q0)
            drift.append(float(np.max(np.abs(module.loop_constraints(q0, **values)))))
        if held:   # anchored where they start; the start velocity made to respect them (and the loops)
            at = (robot.source, *robot.positions.get("contacts", (1, 1))) if declared else None
            qd0, forward = _held(module, held, q0, qd0, baumgarte, values, at)

        def rhs(time: float, y: np.ndarray) -> np.ndarray:
            tick(time)
            q, qd = normalized(y[:nq], starts), y[nq:nq + nv]
            qdd = forward(q, qd, efforts(time, q, qd), wrenches(time, q, qd),
                          friction_smoothing=friction_smoothing, **gains, **values)
            if not dissipative:
                return np.concatenate([rate(q, qd), qdd])
            power = qd @ fast.friction_forces(qd, friction_smoothing=friction_smoothing, **values)
            return np.concatenate([rate(q, qd), qdd, [power]])   # the dissipated work W rides along
        y0 = np.concatenate([q0, qd0] + ([[0.0]] if dissipative else []))
        names, rates = list(robot.configuration_names), [str(s) for s in derivation.symbols.qd]
    else:
        with np.errstate(all="ignore"):
            qm0 = module.to_maximal(q0, **values)
            singular_start(module.constraint_jacobian(qm0, **values),
                           len(qm0) - len(getattr(module, "INDEPENDENT_COORDINATES", q0)),
                           "the maximal coordinates' constraint Jacobian A(qm)", robot.coordinates, q0)
            y0 = np.concatenate([qm0, module.to_maximal_jacobian(q0, **values) @ qd0])
        zero_q = np.zeros(nq)
        nq = nv = len(qm0)

        def rhs(time: float, y: np.ndarray) -> np.ndarray:
            tick(time)
            qm, qmd = y[:nq], y[nq:]
            u = efforts(time, zero_q, zero_q)
            return np.concatenate([qmd, module.maximal_forward_dynamics(qm, qmd, u, alpha=baumgarte,
                                                                         beta=baumgarte, **values)])
        names = [str(s) for s in derivation.symbols.qm]
        rates = [velocity_name(name) for name in names]
    _finite_start(rhs, y0, nq, nv, q0, qd0)
    times = np.linspace(0.0, duration, frames)
    integrator = Integrator(rhs, method, rtol, atol, duration, note, hint, culprit(efforts, len(q0), len(qd0), maximal))
    if starts or loops:   # frame to frame, the quaternions normalized (the loops closed) at each
        runs = [y0]
        for start, end in zip(times[:-1], times[1:]):
            y = integrator.run(start, end, runs[-1], np.array([end]))[-1]
            if loops:   # the drift before the projection
                drift.append(float(np.max(np.abs(module.loop_constraints(y[:nq], **values)))))
            runs.append(project(y[:nq], y[nq:]) if loops else np.concatenate([normalized(y[:nq], starts), y[nq:]]))
        states = np.array(runs)
    else:
        states = integrator.run(0.0, duration, y0, times)
    tick(duration)
    position, velocity = states[:, :nq], states[:, nq:nq + nv]
    dissipated = states[:, nq + nv] if dissipative else None
    if maximal:
        energy = module.maximal_kinetic_energy(position, velocity, **values) + module.maximal_potential_energy(position, **values)
        drift += list(np.max(np.abs(module.constraints(position, **values)), axis=-1))
    else:
        energy = module.kinetic_energy(position, velocity, **values) + module.potential_energy(position, **values)
    contact_drift = 0.0
    for frame, _ in held:
        origins = module.frame_transform(position, frame, **values)[:, :3, 3]
        contact_drift = max(contact_drift, float(np.max(np.linalg.norm(origins - origins[0], axis=-1))))
    return Trajectory(names, times, position, velocity, np.asarray(energy), np.array(drift) if len(drift) else None,
                      _link_poses(derivation, maximal) if robot.planar else None, dissipated, rates, held,
                      contact_drift)


def _finite_start(rhs: Callable[[float, np.ndarray], np.ndarray], y0: np.ndarray, nq: int, nv: int,
                  q0: np.ndarray, qd0: np.ndarray) -> None:
    """Refuse an initial state whose accelerations are not finite (``--qd0 1e200`` overflows
    the velocity products), at the option to blame: ``--qd0`` if the same coordinates at rest
    are fine, else ``--q0``."""
    def finite(y: np.ndarray) -> bool:
        try:
            with np.errstate(all="ignore"):
                return bool(np.all(np.isfinite(y)) and np.all(np.isfinite(rhs(0.0, y))))
        except np.linalg.LinAlgError:
            raise InputError(singular_problem(
                f"the configuration {', '.join(f'{v:g}' for v in q0)} is singular: the mass matrix (or the "
                "constraint Jacobian) cannot be inverted there; choose another --q0")) from None
        except (ArithmeticError, ValueError):
            return False

    if finite(y0):
        return
    at_rest = y0.copy()
    at_rest[nq:nq + nv] = 0.0
    if np.any(qd0) and len(y0) >= nq + nv and finite(at_rest):
        raise InputError(Problem("--qd0", 1, 1, "the accelerations at the initial velocities "
                                 f"{', '.join(f'{v:g}' for v in qd0)} are not finite (they overflow a double)"))
    raise InputError(Problem("--q0", 1, 1, "the accelerations at the initial coordinates "
                             f"{', '.join(f'{v:g}' for v in q0)} are not finite (they overflow a double, or the "
                             "robot is singular there)"))


def _loop_projection(module: Any, values: dict[str, float],
                     q0: np.ndarray) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A closed-loop mechanism's state (q, qd) put on the constraints: ``assemble`` keeps the
    independent coordinates (of ``q0``: those of the default assembly for the others), qd is
    projected onto the allowed motions."""
    independent = [module.COORDINATES.index(c) for c in module.INDEPENDENT_COORDINATES]

    def project(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        guess = np.array(module.ASSEMBLED_CONFIGURATION) if q is q0 else q.copy()
        guess[independent] = q[independent]
        try:
            with np.errstate(all="ignore"):
                q = module.assemble(guess, **values)
        except (ValueError, np.linalg.LinAlgError):
            raise InputError(Problem("--q0", 1, 1, "the loops cannot be closed with independent coordinates "
                                     + ", ".join(f"{module.COORDINATES[i]} = {q[i]:g}" for i in independent))) from None
        try:
            with np.errstate(all="ignore"):
                return np.concatenate([q, allowed_velocity(module, q, qd, values)])
        except (ValueError, np.linalg.LinAlgError):
            raise InputError(singular_problem("the configuration " + ", ".join(
                f"{name} = {value:.6g}" for name, value in zip(module.COORDINATES, q)) + " is singular: the loop "
                "constraint Jacobian A_g(q) cannot be decomposed there; the run stops there")) from None

    return project


def _tangent_projection(module: Any, values: dict[str, float],
                        starts: tuple[int, ...]) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The state of a robot with quaternions in q and closed loops put on the constraints: q
    normalized and assembled from itself (``assemble``'s least-norm steps on the tangent space),
    qd projected onto the motions the loops allow there (their rank found at the state)."""

    def project(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        try:
            with np.errstate(all="ignore"):
                q = module.assemble(normalized(q, starts), **values)
                return np.concatenate([q, allowed_velocity(module, q, qd, values)])
        except (ValueError, np.linalg.LinAlgError):
            raise InputError(Problem("--q0", 1, 1, "the loops cannot be closed near the configuration "
                                     + ", ".join(f"{name} = {value:.6g}" for name, value in
                                                 zip(module.COORDINATES, q)))) from None

    return project


def _link_poses(derivation: Derivation, maximal: bool) -> Callable[[np.ndarray], list[tuple[np.ndarray, float]]]:
    """state -> [(link frame origin, angle)] per link, for drawing."""
    table, robot = derivation.symbols, derivation.robot
    values = table.defaults(robot)
    if maximal:
        poses = []
        for k, link in enumerate(robot.links):
            x, y, phi = table.qm[3 * k: 3 * k + 3]
            cx, cy = (table.expr(e) for e in link.com)
            origin = sympy.Matrix([x - sympy.cos(phi) * cx + sympy.sin(phi) * cy,
                                   y - sympy.sin(phi) * cx - sympy.cos(phi) * cy])
            poses.append((origin, phi))
        state = table.qm
    else:
        poses = [(kin.joint_origin, kin.angle) for kin in derivation.link_kinematics]
        state = table.q
    flat = sympy.Matrix([e for origin, angle in poses for e in (*origin, angle)]).xreplace(values)
    function = sympy.lambdify([state], flat, modules="numpy")

    def evaluate(s: np.ndarray) -> list[tuple[np.ndarray, float]]:
        numbers = np.asarray(function(s), dtype=float).reshape(-1, 3)
        return [(row[:2], float(row[2])) for row in numbers]

    return evaluate
