"""What ``dynderive simulate`` writes: the plot (in the format its suffix names), the CSV table
and the animated GIF of a planar robot, each as bytes made the same way on every run."""

from __future__ import annotations

import io
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..derivation import Derivation
from ..errors import InputError
from .options import problem
from .simulate import Trajectory


def _segments(derivation: Derivation, poses: list[tuple[np.ndarray, float]]) -> list[np.ndarray]:
    """Polylines drawing each link: frame origin to its children's joints, or to 2 x COM."""
    robot, table = derivation.robot, derivation.symbols
    values = table.defaults(robot)

    def point(texts: Any) -> np.ndarray:   # (x, y) of a position in the robot file
        return np.array([float(table.expr(text).xreplace(values)) for text in texts[:2]])

    lines = []
    for (origin, angle), link in zip(poses, robot.links):
        rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        ends = [point(j.origin) for j in robot.joints if j.parent == link.name]
        ends += [point(lp.origin) for lp in robot.loops if lp.parent == link.name]
        ends += [point(lp.child_origin) for lp in robot.loops if lp.child == link.name]   # drawn closed
        com = point(link.com)
        if not ends:
            ends = [2 * com] if np.any(com) else [np.array([0.0, 0.0])]
        for end in ends:
            lines.append(np.array([origin, origin + rotation @ end]))
    return lines


#: ``--plot``'s formats by suffix, and the metadata that would make two runs' files differ
#: (a date, the library's version), left out so that the same run writes the same bytes.
PLOT_FORMATS = {".png": ("png", {"Software": None}), ".pdf": ("pdf", {"Creator": None, "Producer": None,
                                                                      "CreationDate": None}),
                ".svg": ("svg", {"Creator": None, "Date": None}), ".jpg": ("jpeg", {}),
                ".jpeg": ("jpeg", {})}


def plot_format(path: Path) -> str:
    """``--plot``'s format, named by its suffix (any case); another suffix is refused at the
    option before any work (the file would hold bytes its name does not promise)."""
    if path.suffix.lower() not in PLOT_FORMATS:
        given = f"'{path.suffix}'" if path.suffix else "no suffix"
        raise InputError(problem("--plot", f"{path} has {given}: the plot is written in the format its suffix "
                                 f"names, one of {', '.join(PLOT_FORMATS)}"))
    return path.suffix.lower()


def animation_format(path: Path) -> None:
    """``--animate`` writes a GIF: another suffix is refused at the option before any work."""
    if path.suffix.lower() != ".gif":
        given = f"'{path.suffix}'" if path.suffix else "no suffix"
        raise InputError(problem("--animate", f"{path} has {given}: the animation is a GIF, so its file name "
                                 "ends in .gif"))


def plot_image(derivation: Derivation, trajectory: Trajectory, suffix: str = ".png") -> bytes:
    """The plot, in the format ``suffix`` names (``PLOT_FORMATS``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = 3 if trajectory.drift is not None else 2
    figure, axes = plt.subplots(panels, 1, figsize=(8, 2.6 * panels), sharex=True)
    for i, name in enumerate(trajectory.names):
        axes[0].plot(trajectory.times, trajectory.position[:, i], label=name)
    axes[0].set_ylabel("coordinate")
    axes[0].legend(loc="upper right", fontsize="small", ncol=min(len(trajectory.names), 6))
    axes[0].set_title(f"{derivation.robot.title}: simulation")
    axes[1].plot(trajectory.times, trajectory.energy - trajectory.energy[0], color="tab:red",
                 label="E(t) - E(0)")
    if trajectory.dissipated is not None:
        axes[1].plot(trajectory.times, trajectory.energy - trajectory.energy[0] + trajectory.dissipated,
                     color="tab:blue", linestyle="--", label="E(t) - E(0) + W_diss(t)")
    axes[1].set_ylabel("total energy change")
    axes[1].legend(loc="upper right", fontsize="small")
    if trajectory.drift is not None:
        axes[2].semilogy(trajectory.times, np.maximum(trajectory.drift, 1e-18), color="tab:green",
                         label="max |a_g(q)|" if derivation.robot.loops else "max |a(q_m)|")
        axes[2].set_ylabel("constraint drift")
        axes[2].legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    figure.tight_layout()
    buffer = io.BytesIO()
    kind, metadata = PLOT_FORMATS[suffix]
    with matplotlib.rc_context({"svg.hashsalt": "dynderive"}):   # SVG ids: the same on every run
        figure.savefig(buffer, format=kind, dpi=100, metadata=metadata or None)
    plt.close(figure)
    return buffer.getvalue()


def csv_text(trajectory: Trajectory) -> str:
    """t, the coordinates, the velocities, the energy (and the constraint drift, the work
    dissipated by damping and friction)."""
    header = ["t", *trajectory.names, *trajectory.velocity_names, "energy"]
    columns = [trajectory.times[:, None], trajectory.position, trajectory.velocity, trajectory.energy[:, None]]
    if trajectory.drift is not None:
        header.append("constraint_drift")
        columns.append(trajectory.drift[:, None])
    if trajectory.dissipated is not None:
        header.append("dissipated")
        columns.append(trajectory.dissipated[:, None])
    table = np.hstack(columns)
    lines = [",".join(header)] + [",".join(f"{v:.12g}" for v in row) for row in table]
    return "\n".join(lines) + "\n"


def animation_gif(derivation: Derivation, trajectory: Trajectory, fps: int = 20) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    assert trajectory.link_poses is not None
    frames = [_segments(derivation, trajectory.link_poses(s)) for s in trajectory.position]
    points = np.concatenate([np.concatenate(f) for f in frames])
    low, high = points.min(axis=0), points.max(axis=0)
    span = max(float(np.max(high - low)), 1e-3) * 0.6
    centre = (low + high) / 2
    figure, axis = plt.subplots(figsize=(5, 5))
    axis.set(xlim=(centre[0] - span, centre[0] + span), ylim=(centre[1] - span, centre[1] + span),
             aspect="equal", title=derivation.robot.title)
    axis.grid(True, alpha=0.3)
    artists = [axis.plot([], [], "o-", lw=3)[0] for _ in frames[0]]
    label = axis.text(0.02, 0.95, "", transform=axis.transAxes)

    def draw(index: int) -> list[Any]:
        for artist, segment in zip(artists, frames[index]):
            artist.set_data(segment[:, 0], segment[:, 1])
        label.set_text(f"t = {trajectory.times[index]:.2f} s")
        return [*artists, label]

    animation = FuncAnimation(figure, draw, frames=len(frames), blit=True)
    with tempfile.TemporaryDirectory(prefix="dynderive-gif-") as folder:
        path = Path(folder) / "animation.gif"
        animation.save(str(path), writer=PillowWriter(fps=fps))
        data = path.read_bytes()
    plt.close(figure)
    return data
