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


def _full(value: float) -> str:
    """A number as CAD exporters write it: every digit of the double."""
    return repr(float(value))


def _round(value: float) -> str:
    """A number as a person writes it: two significant digits."""
    return f"{float(value):.2g}"


#: Directions with round components (unit vectors), for the round-number chains' prismatic axes.
_ROUND_AXES = [(1, 0), (0, 1), (-1, 0), (0, -1)] + [(x * a, y * b) for a, b in ((0.6, 0.8), (0.8, 0.6))
                                                     for x in (1, -1) for y in (1, -1)]


def _vector(values) -> str:
    return "[" + ", ".join(_full(v) for v in values) + "]"


def planar_chain_yaml(n: int, seed: int = 0, round_numbers: bool = False) -> str:
    """A planar serial chain of ``n`` joints with full-precision random numbers (link lengths,
    masses, COM offsets off the link line, inertias); every fourth joint is prismatic along a
    random direction, the others revolute. Fixed ``seed``: the same file every run.

    With ``round_numbers``, the same chain written as a person would: every number to two
    significant digits, each prismatic axis the nearest of a few unit vectors with round
    components (``[0.6, -0.8]``), so that both files differ only in their digits."""
    import math
    import random

    rng = random.Random(seed * 1000 + n)
    number = _round if round_numbers else _full

    def _vector(values) -> str:
        return "[" + ", ".join(number(v) for v in values) + "]"

    lines = [f"name: chain{n}", f"title: Planar {n}-joint chain (seed {seed})", "planar: true",
             f"gravity: [0, -{number(9.80665)}]", "links:"]
    for k in range(1, n + 1):
        com = (rng.uniform(0.1, 0.6), rng.uniform(-0.1, 0.1))
        lines.append(f"  - {{name: b{k}, mass: {number(rng.uniform(0.5, 3.0))}, com: {_vector(com)}, "
                     f"inertia: {number(rng.uniform(0.01, 0.3))}}}")
    lines.append("joints:")
    for k in range(1, n + 1):
        parent = "world" if k == 1 else f"b{k - 1}"
        origin = [0.0, 0.0, 0.0] if k == 1 else [rng.uniform(0.3, 1.0), rng.uniform(-0.1, 0.1), rng.uniform(-0.5, 0.5)]
        if k % 4 == 0:
            angle = rng.uniform(-math.pi, math.pi)
            axis = (math.cos(angle), math.sin(angle))
            if round_numbers:
                axis = min(_ROUND_AXES, key=lambda a: (a[0] - axis[0]) ** 2 + (a[1] - axis[1]) ** 2)
            kind = f"prismatic, axis: {_vector(axis)}"
        else:
            kind = "revolute"
        lines.append(f"  - {{name: q{k}, type: {kind}, parent: {parent}, child: b{k}, "
                     f"origin: {_vector(origin)}, effort: u{k}}}")
    return "\n".join(lines) + "\n"


def spatial_chain_yaml(n: int, seed: int = 0) -> str:
    """A generic 3-D serial chain of ``n`` joints, as a CAD exporter writes it: arbitrary
    (non-unit) axes, arbitrary ``rpy``, full inertia tensors (a random rotation of random
    principal moments), every number at full precision; every fifth joint prismatic."""
    import math
    import random

    rng = random.Random(seed * 1000 + n)

    def rotation():
        w, x, y, z = (rng.gauss(0.0, 1.0) for _ in range(4))
        s = math.sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / s, x / s, y / s, z / s
        return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]

    lines = [f"name: spatial_chain{n}", f"title: Generic 3-D {n}-joint chain (seed {seed})", "planar: false",
             "gravity: [0, 0, -9.80665]", "links:"]
    for k in range(1, n + 1):
        a, b = rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.3)
        c = rng.uniform(abs(a - b) + 0.02, a + b - 0.02)
        R = rotation()
        full = [[sum(R[i][m] * (a, b, c)[m] * R[j][m] for m in range(3)) for j in range(3)] for i in range(3)]
        inertia = (full[0][0], full[1][1], full[2][2], full[0][1], full[0][2], full[1][2])
        com = [rng.uniform(-0.2, 0.2) for _ in range(3)]
        lines.append(f"  - {{name: b{k}, mass: {_full(rng.uniform(0.5, 3.0))}, com: {_vector(com)}, "
                     f"inertia: {_vector(inertia)}}}")
    lines.append("joints:")
    for k in range(1, n + 1):
        parent = "world" if k == 1 else f"b{k - 1}"
        xyz = [rng.uniform(-0.3, 0.3) for _ in range(3)]
        rpy = [rng.uniform(-math.pi, math.pi) for _ in range(3)]
        axis = [rng.uniform(-1.0, 1.0) for _ in range(3)]
        kind = "prismatic" if k % 5 == 0 else "revolute"
        lines.append(f"  - {{name: q{k}, type: {kind}, parent: {parent}, child: b{k}, "
                     f"origin: {{xyz: {_vector(xyz)}, rpy: {_vector(rpy)}}}, axis: {_vector(axis)}, effort: u{k}}}")
    return "\n".join(lines) + "\n"
