"""``dynderive simulate`` of a floating-base robot: SciPy's integrator on the state
``(q, v)`` (NQ + NV entries) with ``dq/dt`` from the module's ``configuration_rate`` (the
base's quaternion moves by ``1/2 quaternion * (w, 0)``, tangent to the unit sphere), run
from output frame to output frame; at each frame the quaternions are normalized (the
integrator's own error moves them off the sphere by about its tolerance) and the run goes on
from there, as closed loops are projected back onto their constraints. The right-hand side
evaluates the dynamics at normalized quaternions too. ``--force`` applies wrenches at frames
and ``--friction-smoothing`` smooths Coulomb friction as for a fixed-base run; with damping or
friction the work they dissipate rides along (``Trajectory.dissipated``). Outputs: the plot and
the CSV of fixed-base runs, the coordinates of ``q`` and the velocities of ``v``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..derivation import Derivation
from ..errors import InputError
from ..verify.checks import generated_module
from .integrate import DEFAULT_METHOD, Integrator
from .options import BACKENDS, problem, vector
from .simulate import Trajectory, _finite_start, friction_hint, progress_ticker

#: How far from unit a quaternion of ``--q0`` may be (then normalized): four decimals typed.
QUATERNION_TOLERANCE = 1e-3


def floating_options(robot: Any, coordinates: str, animate: object, backend: str) -> None:
    """Refuse what a floating-base run does not do (exit 2, before any work)."""
    if coordinates != "generalized":
        raise InputError(problem("--coordinates", "a floating-base robot is simulated in its coordinates (q, v) only"))
    if animate is not None:
        raise InputError(problem("--animate", "--animate draws planar robots only"))
    if backend not in BACKENDS:
        raise InputError(problem("--backend", f"--backend {backend}: not built for simulate"))


def floating_quaternions(robot: Any) -> list[int]:
    """Where each floating or spherical joint's quaternion starts in q."""
    return list(robot.quaternion_starts)


def normalized(q: np.ndarray, starts: list[int]) -> np.ndarray:
    q = np.array(q, dtype=float)
    for start in starts:
        q[..., start:start + 4] /= np.linalg.norm(q[..., start:start + 4], axis=-1, keepdims=True)
    return q


def floating_initial(robot: Any, q0: np.ndarray | None) -> np.ndarray:
    """``--q0`` with its quaternions normalized (refused if one is off unit by more than
    QUATERNION_TOLERANCE); without it the neutral configuration (base at the origin of its
    parent, identity quaternions) with revolute joints at 0.5 rad and prismatic at 0.2 m."""
    starts = floating_quaternions(robot)
    if q0 is None:
        where_q, _ = robot.offsets()
        q0 = np.zeros(len(robot.configuration_names))
        for joint in (j for j in robot.joints if j.owns):
            if joint.multi:   # the identity quaternion
                q0[where_q[joint.name] + joint.sizes[0] - 1] = 1.0
            else:
                q0[where_q[joint.name]] = 0.5 if joint.type == "revolute" else 0.2
        return q0
    names = robot.configuration_names
    for start in starts:
        norm = float(np.linalg.norm(q0[start:start + 4]))
        if abs(norm - 1.0) > QUATERNION_TOLERANCE:
            raise InputError(problem("--q0", f"the quaternion {', '.join(names[start:start + 4])} must be unit "
                                             f"(within {QUATERNION_TOLERANCE:g}), its norm is {norm:.6g}"))
    return normalized(q0, starts)


def simulate_floating(derivation: Derivation, source: str, duration: float, q0: np.ndarray, v0: np.ndarray,
                      efforts: Callable[..., np.ndarray], rtol: float, atol: float, frames: int,
                      progress: Callable[[str], None], method: str = DEFAULT_METHOD,
                      note: Callable[[str], None] = lambda text: None,
                      values: dict[str, float] | None = None, friction_smoothing: float = 0.0,
                      wrenches: Callable[..., dict[str, np.ndarray] | None] = lambda time, q, v: None,
                      compiled: Any = None) -> Trajectory:
    """Integrate the floating-base module's forward dynamics on the manifold (module docstring);
    ``Trajectory.position`` holds q (NQ columns), ``velocity`` v (NV columns). ``values``: the
    parameters (default: the robot's); ``wrenches(t, q, v)``: the wrenches at frames (``--force``);
    ``compiled``: the C extension (``--backend c``), whose ``forward_dynamics``,
    ``configuration_rate`` and ``friction_forces`` the integrator calls instead of the module's."""
    robot = derivation.robot
    module = generated_module(source, robot.name)
    fast = compiled if compiled is not None else module
    if values is None:
        values = {p.name: p.value for p in robot.parameters if p.value is not None}
    starts = floating_quaternions(robot)
    nq, nv = len(q0), len(v0)
    tick = progress_ticker(duration, progress)
    dissipative = robot.dissipative
    hint = friction_hint(robot, friction_smoothing)

    def rhs(time: float, y: np.ndarray) -> np.ndarray:
        tick(time)
        q, v = normalized(y[:nq], starts), y[nq:nq + nv]
        qdd = fast.forward_dynamics(q, v, efforts(time, q, v), wrenches(time, q, v),
                                    friction_smoothing=friction_smoothing, **values)
        rates = [fast.configuration_rate(q, v), qdd]
        if dissipative:   # the dissipated work W rides along
            rates.append([v @ fast.friction_forces(v, friction_smoothing=friction_smoothing, **values)])
        return np.concatenate(rates)

    y = np.concatenate([q0, v0] + ([[0.0]] if dissipative else []))
    _finite_start(rhs, y, nq, q0, v0)
    times = np.linspace(0.0, duration, frames)
    integrator = Integrator(rhs, method, rtol, atol, duration, note, hint)
    states = [y]
    for start, end in zip(times[:-1], times[1:]):
        y = integrator.run(start, end, y, np.array([end]))[-1]
        y = np.concatenate([normalized(y[:nq], starts), y[nq:]])
        states.append(y)
    tick(duration)
    states_array = np.array(states)
    position, velocity = states_array[:, :nq], states_array[:, nq:nq + nv]
    energy = module.kinetic_energy(position, velocity, **values) + module.potential_energy(position, **values)
    return Trajectory(list(robot.configuration_names), times, position, velocity, np.asarray(energy), None, None,
                      states_array[:, nq + nv] if dissipative else None)


def floating_csv(derivation: Derivation, source: str, trajectory: Trajectory) -> str:
    """The CSV of a floating-base run: t, the NQ coordinates, the NV velocities, the energy (and
    the work dissipated by damping and friction, as a fixed-base run's)."""
    module = generated_module(source, derivation.robot.name)
    header = ["t", *module.COORDINATES, *module.VELOCITIES, "energy"]
    columns = [trajectory.times[:, None], trajectory.position, trajectory.velocity, trajectory.energy[:, None]]
    if trajectory.dissipated is not None:
        header.append("dissipated")
        columns.append(trajectory.dissipated[:, None])
    table = np.hstack(columns)
    return "\n".join([",".join(header)] + [",".join(f"{v:.12g}" for v in row) for row in table]) + "\n"



def run_floating(model: Any, duration: float, q0: str | None, qd0: str | None, effort: list[str],
                 plot: Path | None, csv: Path | None, method: str, rtol: float, atol: float, frames: int,
                 quiet: bool, progress: Callable[[str], None], force: list[str] | None = None,
                 friction_smoothing: float = 0.0, backend: str = "numpy") -> None:
    """``dynderive simulate`` of a floating-base robot, after the options common to every run
    are checked: ``--q0`` takes NQ numbers, ``--qd0`` NV; writes ``--plot`` and ``--csv``."""
    import typer

    from .. import derive
    from ..render.targets import reference
    from .output import write_all
    from .simulate import parse_efforts, parse_wrenches, plot_png

    start_q = vector(q0, len(model.configuration_names), "--q0")
    start_v = vector(qd0, model.velocity_count, "--qd0")
    start_q = floating_initial(model, start_q)
    derivation = derive(model, progress=progress)
    efforts = parse_efforts(derivation, effort, False)
    wrenches = parse_wrenches(derivation, force or [])
    progress("generating code (floating base)")
    source = reference(derivation)   # the NumPy module (floating base)
    compiled = None
    if backend != "numpy":   # a target simulate can load (the C extension)
        from ..render.targets import by_name, resolve

        compiled = resolve(by_name(backend).load)(derivation, progress=progress)
    trajectory = simulate_floating(derivation, source, duration, start_q,
                                   np.zeros(model.velocity_count) if start_v is None else start_v, efforts, rtol,
                                   atol, frames, progress, method,
                                   lambda text: None if quiet else typer.echo(f"note: {text}", err=True),
                                   friction_smoothing=friction_smoothing, wrenches=wrenches, compiled=compiled)
    files: dict[Path, bytes] = {}
    if plot is not None:
        progress("plotting")
        files[plot] = plot_png(derivation, trajectory)
    if csv is not None:
        files[csv] = floating_csv(derivation, source, trajectory).encode()
    write_all(files)
    relative = float(np.max(np.abs(trajectory.energy - trajectory.energy[0])) / max(abs(trajectory.energy[0]), 1e-12))
    kind = ("floating base" if model.floating_base else "floating joints"
            if any(j.type == "floating" for j in model.joints) else "spherical joints")
    typer.echo(f"simulated {duration:g} s of {model.name} ({kind}, on the manifold): "
               f"largest relative energy change {relative:.3g}"
               + (f", energy dissipated by damping and friction {trajectory.dissipated[-1]:.6g}"
                  if trajectory.dissipated is not None else ""))
    for path in files:
        typer.echo(f"wrote {path}", err=True)
