"""Floating-base robots: solo12 and talos_reduced from example-robot-data with a
free-flyer root (``--floating-base``), beside Pinocchio.

    python benchmarks/floating.py                 # both robots (about 2 minutes on 2 cores)
    python benchmarks/floating.py --batch 1000    # fewer states per batch
    python benchmarks/floating.py --c-extension solo12 talos_reduced   # both compiled (talos: long)

Per robot:

1. ``dynderive solve <urdf> --floating-base --code`` as a user runs it, in a fresh process:
   CPU seconds (user + system; the steadier figure on a shared machine), wall seconds and
   peak memory (MB), from that process's own resource usage (``os.wait4``);
2. in another fresh process, the module it wrote: ``forward_dynamics`` on a batch of random
   states (random unit quaternions, joints in [-1, 1], normal velocities and efforts), ns per
   state, beside ``pin.aba`` called in a Python loop over the same states (the model built by
   ``pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())``), their ratio, and the largest
   difference between the two accelerations (over the first 200 states, relative to the
   state's largest acceleration);
3. ``solve <urdf> --floating-base --c-extension`` (wall seconds, the -O2 compile included) and,
   in the process of 2., the compiled ``forward_dynamics`` on the same batch (one thread:
   ``DYNDERIVE_THREADS=1``), ns per state and its ratio to ``pin.aba``'s loop, and its largest
   difference from the NumPy module's accelerations (relative, as above), for the robots
   named by ``--c-extension`` (default solo12: talos_reduced's 4.4 MB of C did not compile
   within the compiler's 600 s limit at -O2 on the shared 2-core machine; ``--c-extension``
   alone: none).

Then the goals, each with its measured figure, met or not. No figure is typed in.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = {"solo12": "solo_description/robots/solo12.urdf", "talos_reduced": "talos_data/robots/talos_reduced.urdf"}


def example_robot(relative: str) -> Path | None:
    """A URDF of example-robot-data (the cmeel package), as the tests locate it."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    paths = [Path(str(dist.locate_file(f))) for f in dist.files or () if str(f).endswith(relative)]
    return paths[0] if paths else None


def measure_code(urdf: Path, out: Path) -> dict:
    """``solve --code --floating-base`` in a fresh process, its own CPU time and peak memory."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])))
    command = [sys.executable, "-m", "dynderive", "solve", str(urdf), "--floating-base", "--code", "--out", str(out), "-q"]
    start = time.perf_counter()
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        print(f"{urdf.name}: solve --code failed\n{process.stderr.read().decode()[-2000:]}", file=sys.stderr)
        return {}
    return {"code_cpu_s": usage.ru_utime + usage.ru_stime, "code_wall_s": wall, "code_peak_mb": usage.ru_maxrss / 1024}


def measure_extension(urdf: Path, out: Path) -> dict:
    """``solve --c-extension --floating-base`` in a fresh process: its wall seconds and the file."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])))
    command = [sys.executable, "-m", "dynderive", "solve", str(urdf), "--floating-base", "--c-extension", "--out",
               str(out), "-q"]
    start = time.perf_counter()
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    if result.returncode != 0:
        print(f"{urdf.name}: solve --c-extension failed\n{result.stderr[-2000:]}", file=sys.stderr)
        return {}
    return {"ext_build_s": time.perf_counter() - start}


def _best(function, repeats: int = 3) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return min(samples)


def measure_forward_dynamics(urdf: str, module_path: str, batch: int, extension: str | None = None) -> dict:
    """In a fresh process: the generated ``forward_dynamics`` on a batch, and ``pin.aba`` in a
    Python loop over the same states; the compiled extension's at ``extension`` too, if given."""
    import numpy as np
    import pinocchio as pin

    import dynderive
    from dynderive.input.urdf import identifier
    from dynderive.mechanics.tree import offsets

    spec = importlib.util.spec_from_file_location("floating_module", module_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot = dynderive.load_robot(urdf, floating_base=True)
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    data = model.createData()
    where = offsets(robot)
    qp, vp = [], []   # where Pinocchio's q and v entries are in ours
    for name, joint in zip(model.names[1:], model.joints[1:]):
        ours = identifier(name)
        qp.extend(range(where.q[ours], where.q[ours] + joint.nq))
        vp.extend(range(where.v[ours], where.v[ours] + joint.nv))
    rng = np.random.default_rng(0)
    Q = rng.uniform(-1, 1, (batch, module.NQ))
    for q_at in (where.q[j.name] for j in robot.joints if j.type == "floating"):
        quaternion = rng.normal(size=(batch, 4))
        Q[:, q_at + 3:q_at + 7] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    V = rng.normal(size=(batch, module.NV))
    U = rng.normal(size=(batch, len(module.EFFORTS)))
    applied = np.zeros((batch, module.NV))   # the efforts at their joints' columns; the base unactuated
    applied[:, [where.v[j.name] for j in robot.joints if j.effort]] = U
    Q_pin, V_pin, T_pin = (np.ascontiguousarray(Q[:, qp]), np.ascontiguousarray(V[:, vp]),
                           np.ascontiguousarray(applied[:, vp]))

    def ours():
        return module.forward_dynamics(Q, V, U)

    def pinocchio_loop():
        for k in range(batch):
            pin.aba(model, data, Q_pin[k], V_pin[k], T_pin[k])

    ours_s, pin_s = _best(ours), _best(pinocchio_loop)
    qdd = ours()
    difference = max(float(np.abs(pin.aba(model, data, Q_pin[k], V_pin[k], T_pin[k]) - qdd[k][vp]).max()
                           / np.abs(qdd[k]).max()) for k in range(min(batch, 200)))
    row = {"fd_ns": ours_s / batch * 1e9, "pin_aba_ns": pin_s / batch * 1e9, "fd_max_diff": difference,
           "nq": module.NQ, "nv": module.NV}
    if extension:
        spec = importlib.util.spec_from_file_location(Path(extension).name.split(".")[0], extension)
        compiled = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(compiled)
        ext_s = _best(lambda: compiled.forward_dynamics(Q, V, U))
        got = compiled.forward_dynamics(Q, V, U)
        row |= {"ext_fd_ns": ext_s / batch * 1e9,
                "ext_max_diff": float(np.max(np.abs(got - qdd).max(axis=1) / np.abs(qdd).max(axis=1)))}
    return row


def _cell(value, fmt: str) -> str:
    return "-" if value is None else fmt.format(value)


def table(rows: list[dict]) -> str:
    columns = [("robot", "{}", "robot"), ("nq", "{}", "nq"), ("nv", "{}", "nv"),
               ("--code CPU s", "{:.1f}", "code_cpu_s"), ("wall s", "{:.1f}", "code_wall_s"),
               ("peak MB", "{:.0f}", "code_peak_mb"), ("FD ns/state", "{:.0f}", "fd_ns"),
               ("pin.aba loop ns/state", "{:.0f}", "pin_aba_ns"), ("ratio", "{:.2f}", "ratio"),
               ("largest relative difference", "{:.0e}", "fd_max_diff"), ("--c-extension s", "{:.0f}", "ext_build_s"),
               ("C ext FD ns/state", "{:.0f}", "ext_fd_ns"), ("C ratio", "{:.2f}", "ext_ratio"),
               ("C vs NumPy", "{:.0e}", "ext_max_diff")]
    cells = [[c[0] for c in columns]]
    for row in rows:
        row = dict(row, ratio=row["fd_ns"] / row["pin_aba_ns"] if "fd_ns" in row else None,
                   ext_ratio=row["ext_fd_ns"] / row["pin_aba_ns"] if "ext_fd_ns" in row else None)
        cells.append([_cell(row.get(key), fmt) for _, fmt, key in columns])
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in cells]
    return "\n".join([lines[0], "-" * len(lines[0]), *lines[1:]])


def goals(rows: list[dict]) -> list[tuple[str, str, bool | None]]:
    by = {r["robot"]: r for r in rows}
    out = []

    def goal(text: str, robot: str, key: str, limit: float, unit: str) -> None:
        value = by.get(robot, {}).get(key)
        out.append((text, "not measured" if value is None else f"{value:.1f} {unit}",
                    None if value is None else value <= limit))

    goal("solo12 floating --code <= 10 s (CPU)", "solo12", "code_cpu_s", 10, "s")
    goal("talos_reduced floating --code <= 60 s (CPU)", "talos_reduced", "code_cpu_s", 60, "s")
    goal("talos_reduced floating --code <= 2048 MB", "talos_reduced", "code_peak_mb", 2048, "MB")
    for name, row in by.items():
        if "fd_ns" in row:
            ratio = row["fd_ns"] / row["pin_aba_ns"]
            out.append((f"{name} forward_dynamics per state within 2x of pin.aba (Python loop)",
                        f"{row['fd_ns']:.0f} vs {row['pin_aba_ns']:.0f} ns ({ratio:.2f}x)", ratio <= 2))
        else:
            out.append((f"{name} forward_dynamics per state within 2x of pin.aba (Python loop)", "not measured", None))
        if "ext_fd_ns" in row:
            ratio = row["ext_fd_ns"] / row["pin_aba_ns"]
            out.append((f"{name} forward_dynamics per state within 2x of pin.aba (C extension)",
                        f"{row['ext_fd_ns']:.0f} vs {row['pin_aba_ns']:.0f} ns ({ratio:.2f}x)", ratio <= 2))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--batch", type=int, default=10_000, help="states per batch")
    parser.add_argument("--json", type=Path, help="also write the rows and goals here")
    parser.add_argument("--c-extension", nargs="*", default=["solo12"], choices=list(ROBOTS), metavar="ROBOT",
                        help="the robots whose compiled extension is measured too (default: solo12)")
    parser.add_argument("--forward-dynamics", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--extension", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.forward_dynamics:
        print(json.dumps(measure_forward_dynamics(*args.forward_dynamics, args.batch, args.extension)))
        return
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, relative in ROBOTS.items():
            urdf = example_robot(relative)
            if urdf is None:
                print(f"{name}: example-robot-data's {relative} is not installed", file=sys.stderr)
                continue
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            out = Path(folder) / name
            row = {"robot": name, **measure_code(urdf, out)}
            written = sorted(out.glob("*_dynamics.py"))
            if name in args.c_extension:
                row |= measure_extension(urdf, out)
            extension = sorted(out.glob("*_dynamics_c.*"))
            if written:
                result = subprocess.run([sys.executable, __file__, "--forward-dynamics", str(urdf), str(written[0]),
                                         "--batch", str(args.batch), *(["--extension", str(extension[0])] if extension
                                                                       else [])], capture_output=True, text=True,
                                        env=dict(os.environ, PYTHONPATH=str(ROOT / "src"), DYNDERIVE_THREADS="1"))
                if result.returncode == 0:
                    row.update(json.loads(result.stdout.strip().splitlines()[-1]))
                else:
                    print(f"{name}: forward dynamics failed\n{result.stderr[-2000:]}", file=sys.stderr)
            rows.append(row)
    print(table(rows))
    print()
    verdict = {True: "met", False: "NOT MET", None: "not measured"}
    items = goals(rows)
    width = max(len(g[0]) for g in items)
    for text, measured, met in items:
        print(f"{text:<{width}}  {measured:>24}  {verdict[met]}")
    print(f"\n(batch {args.batch} states; {time.perf_counter() - started:.0f} s; Python {sys.version.split()[0]}; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "goals": items}, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
