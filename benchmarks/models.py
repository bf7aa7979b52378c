"""The robots the benchmarks and their anchors share: the bundled ones, and planar N-link
pendulums written with their numbers (no parameters), so that dynderive and the
``sympy.physics.mechanics`` anchor derive exactly the same model. Imported by both
``run.py`` and ``anchors.py``, which import nothing from each other but this."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

import dynderive
from dynderive.model import Robot


def pendulum_yaml(n: int) -> str:
    """A planar n-link pendulum: uniform rods of 1 kg and 1 m, a torque at each joint. The numbers
    are written into the file (no parameters) so that both tools derive exactly the same model:
    the KanesMethod anchor substitutes numbers too."""
    lines = [f"name: pendulum{n}", f"title: Planar {n}-link pendulum", "planar: true", "gravity: [0, -9.81]", "links:"]
    lines += [f"  - {{name: b{k}, mass: 1, com: [1/2, 0], inertia: 1/12}}" for k in range(1, n + 1)]
    lines.append("joints:")
    for k in range(1, n + 1):
        parent = "world" if k == 1 else f"b{k - 1}"
        origin = "[0, 0]" if k == 1 else "[1, 0]"
        lines.append(f"  - {{name: q{k}, type: revolute, parent: {parent}, child: b{k}, origin: {origin}, effort: tau{k}}}")
    return "\n".join(lines) + "\n"


def load(robot: str | Path) -> Robot:
    """``dynderive.load_robot``, plus ``pendulumN`` for the planar N-link pendulum."""
    match = re.fullmatch(r"pendulum(\d+)", str(robot))
    if match is None:
        return dynderive.load_robot(robot)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{robot}.yaml"
        path.write_text(pendulum_yaml(int(match.group(1))))
        return dynderive.load_robot(path)
