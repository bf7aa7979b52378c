"""Benchmarks of dynderive: derivation time per stage, size of M/C/N, generated-code speed.

    python benchmarks/run.py --quick        # bundled robots + planar pendulums n = 2..4
    python benchmarks/run.py                # also pendulums up to n = 8
    python benchmarks/run.py --json out.json

Each robot is derived in its own subprocess (so peak memory is that robot's alone). Prints a
table; writes the rows as JSON. Figures are medians over ``--repeats`` for the code timings.
Not built yet (issue 8): the sympy.physics.mechanics KanesMethod and KanesMethod + trigsimp
anchors measured in the same run.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def pendulum_yaml(n: int) -> str:
    lines = [f"name: pendulum{n}", f"title: Planar {n}-link pendulum", "planar: true", "parameters:"]
    lines += [f"  m{k}: 1.0\n  l{k}: 1.0" for k in range(1, n + 1)] + ["  g: 9.81", "gravity: [0, -g]", "links:"]
    lines += [f"  - {{name: b{k}, mass: m{k}, com: [l{k}/2, 0], inertia: m{k}*l{k}**2/12}}" for k in range(1, n + 1)]
    lines.append("joints:")
    for k in range(1, n + 1):
        parent = "world" if k == 1 else f"b{k - 1}"
        origin = "[0, 0]" if k == 1 else f"[l{k - 1}, 0]"
        lines.append(f"  - {{name: q{k}, type: revolute, parent: {parent}, child: b{k}, origin: {origin}, effort: tau{k}}}")
    return "\n".join(lines) + "\n"


def nodes(value) -> int:
    import sympy

    entries = list(value) if isinstance(value, sympy.MatrixBase) else [value]
    return sum(sum(1 for _ in sympy.preorder_traversal(e)) for e in entries)


def measure_one(robot: str, repeats: int, batch: int) -> dict:
    """Runs in a subprocess: one robot's derivation, rendering and code timings."""
    import numpy as np

    import dynderive
    from dynderive.render.code import render_code

    row: dict = {"robot": robot}
    start = time.perf_counter()
    model = dynderive.load_robot(robot)
    row["load_s"] = time.perf_counter() - start
    stamps: dict[str, float] = {}
    start = time.perf_counter()
    derivation = dynderive.derive(model, progress=lambda stage: stamps.setdefault(stage, time.perf_counter() - start))
    total = time.perf_counter() - start
    order = list(stamps) + ["end"]
    stamps["end"] = total
    for a, b in zip(order, order[1:]):
        row[f"{a}_s"] = stamps[b] - stamps[a]
    row["derive_s"] = total
    start = time.perf_counter()
    source = render_code(derivation)
    row["code_s"] = time.perf_counter() - start
    if model.planar or len(model.coordinates) <= 3:
        start = time.perf_counter()
        dynderive.render_latex(derivation)
        row["latex_s"] = time.perf_counter() - start
    row["dof"] = len(model.coordinates)
    for name in ("M_g", "C_g", "N_g"):
        row[f"{name}_nodes"] = nodes(derivation[name])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench_dynamics.py"
        path.write_text(source)
        spec = importlib.util.spec_from_file_location("bench_dynamics", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        n = row["dof"]
        rng = np.random.default_rng(0)
        q1, qd1, u1 = rng.uniform(-1, 1, (3, n))
        qb, qdb = rng.uniform(-1, 1, (2, batch, n))
        ub = rng.uniform(-1, 1, (batch, len(module.EFFORTS)))

        def timed(function, *args, number=1):
            samples = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                for _ in range(number):
                    function(*args)
                samples.append((time.perf_counter() - t0) / number)
            return statistics.median(samples)

        row["mass_matrix_call_us"] = timed(module.mass_matrix, q1, number=200) * 1e6
        row["forward_dynamics_call_us"] = timed(module.forward_dynamics, q1, qd1, u1[: len(module.EFFORTS)], number=200) * 1e6
        row["mass_matrix_batch_ns"] = timed(module.mass_matrix, qb) / batch * 1e9
        row["forward_dynamics_batch_ns"] = timed(module.forward_dynamics, qb, qdb, ub) / batch * 1e9
        urdf = ROOT / "robots" / f"{robot}.urdf"
        try:
            import pinocchio as pin
        except ImportError:
            pin = None
        if pin is not None and urdf.is_file():
            pmodel = pin.buildModelFromUrdf(str(urdf))
            pdata = pmodel.createData()
            row["pin_crba_call_us"] = timed(pin.crba, pmodel, pdata, q1, number=200) * 1e6
            row["pin_aba_call_us"] = timed(pin.aba, pmodel, pdata, q1, qd1, u1, number=200) * 1e6
            loop = min(batch, 20000)

            def crba_loop():
                for k in range(loop):
                    pin.crba(pmodel, pdata, qb[k])

            row["pin_crba_python_loop_ns"] = timed(crba_loop) / loop * 1e9
    row["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="bundled robots and pendulums n = 2..4")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batch", type=int, default=100_000)
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results.json")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure_one(args.one, args.repeats, args.batch)))
        return
    robots = ["rp_arm", "double_pendulum", "cart_pole", "elbow_arm", "ur5", "panda"]
    sizes = range(2, 5) if args.quick else range(2, 9)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for n in sizes:
            path = Path(folder) / f"pendulum{n}.yaml"
            path.write_text(pendulum_yaml(n))
            robots.append(str(path))
        for robot in robots:
            result = subprocess.run([sys.executable, __file__, "--one", robot, "--repeats", str(args.repeats),
                                     "--batch", str(args.batch if not args.quick else 20_000)],
                                    capture_output=True, text=True)
            if result.returncode != 0:
                print(f"{robot}: failed\n{result.stderr[-2000:]}", file=sys.stderr)
                continue
            row = json.loads(result.stdout.strip().splitlines()[-1])
            row["robot"] = Path(row["robot"]).stem
            rows.append(row)
            print_row(row, header=len(rows) == 1)
    args.json.write_text(json.dumps(rows, indent=2) + "\n")
    print(f"\nwrote {args.json}")


COLUMNS = [("robot", "{:<16}"), ("dof", "{:>3}"), ("derive_s", "{:>8.2f}"), ("code_s", "{:>7.2f}"),
           ("M_g_nodes", "{:>9}"), ("C_g_nodes", "{:>9}"), ("N_g_nodes", "{:>8}"),
           ("mass_matrix_call_us", "{:>8.1f}"), ("mass_matrix_batch_ns", "{:>9.0f}"),
           ("forward_dynamics_call_us", "{:>8.1f}"), ("forward_dynamics_batch_ns", "{:>9.0f}"),
           ("pin_crba_call_us", "{:>8}"), ("pin_crba_python_loop_ns", "{:>9}"), ("peak_rss_mb", "{:>7.0f}")]
TITLES = ["robot", "dof", "derive s", "code s", "M nodes", "C nodes", "N nodes", "M 1x us", "M batch ns",
          "FD 1x us", "FD batch ns", "pin M us", "pin loop ns", "RSS MB"]


def print_row(row: dict, header: bool) -> None:
    if header:
        print(" ".join(TITLES))
    cells = []
    for key, fmt in COLUMNS:
        value = row.get(key, "-")
        if isinstance(value, float) and "{:>8}" == fmt:
            value = f"{value:.1f}"
        elif isinstance(value, float) and "{:>9}" == fmt:
            value = f"{value:.0f}"
        cells.append(fmt.format(value) if value != "-" else fmt.replace(".2f", "").replace(".1f", "").replace(".0f", "").format("-"))
    print(" ".join(cells), flush=True)


if __name__ == "__main__":
    main()
