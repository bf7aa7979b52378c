"""How dynderive scales with the robot's size, beside sympy.physics.mechanics.

    python benchmarks/scaling.py                # every row (about 15 minutes on 2 cores)
    python benchmarks/scaling.py --quick        # planar 2-12, 3-D 3 and 7, no KanesMethod
    python benchmarks/scaling.py --json out.json

Robots (``benchmarks/models.py``, fixed seeds, every number at full precision as CAD
exporters write it): planar chains of 2, 4, 8, 12, 20, 30 joints and generic 3-D chains
(arbitrary axes and rpy, full inertia tensors) of 3, 7, 12, 20 joints, plus the Panda.
Each row runs in its own subprocess (so peak memory is that robot's alone):

1. ``solve --code``: load, derive what the module needs, render and verify it (s, peak MB);
2. all outputs, ``--latex --code --json`` (s), in a fresh process of its own, where a goal
   is set or it is cheap;
3. the generated code per state (a batch of 10 k states): ``mass_matrix`` and
   ``forward_dynamics`` (ns per state); for the Panda also the module generated before the scaling work
   (``benchmarks/baseline/panda_dynamics.py``), measured in the same run;
4. KanesMethod (``kanes_equations``, unsimplified) on the same model, within ``--kane-timeout``.

Then the goals, each with its measured figure, met or not. No figure is typed in.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import planar_chain_yaml, spatial_chain_yaml  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PLANAR = [2, 4, 8, 12, 20, 30]
SPATIAL = [3, 7, 12, 20]
#: Rows that also render every output (the goals: 12-DOF planar, 7-DOF 3-D).
ALL_OUTPUTS = {"chain2", "chain4", "chain8", "chain12", "spatial_chain3", "spatial_chain7", "panda"}


def _batch_ns(function, arrays: list, repeats: int = 3) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function(*arrays)
        samples.append(time.perf_counter() - start)
    return min(samples) / len(arrays[0]) * 1e9


def _module_timings(module, n: int, batch: int) -> dict:
    import numpy as np

    rng = np.random.default_rng(0)
    q, qd = rng.uniform(-1, 1, (2, batch, n))
    u = rng.uniform(-1, 1, (batch, len(module.EFFORTS)))
    return {"mass_matrix_ns": _batch_ns(module.mass_matrix, [q]),
            "forward_dynamics_ns": _batch_ns(module.forward_dynamics, [q, qd, u])}


def measure(robot: str, batch: int) -> dict:
    """In a subprocess: one robot's `--code` run and its module's timings."""
    import dynderive
    from dynderive.verify.checks import generated_module

    row: dict = {}
    start = time.perf_counter()
    model = dynderive.load_robot(robot)
    derivation = dynderive.derive(model)
    source = dynderive.render_code(derivation)
    row["code_s"] = time.perf_counter() - start
    row["code_peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    row["dof"] = n = len(model.coordinates)
    row["intermediate_form"] = derivation.intermediate_form
    row.update(_module_timings(generated_module(source, "scaling_module"), n, batch))
    if Path(robot).stem == "panda":
        baseline = generated_module((ROOT / "benchmarks" / "baseline" / "panda_dynamics.py").read_text(), "baseline")
        row.update({f"baseline_{k}": v for k, v in _module_timings(baseline, n, batch).items()})
    return row


def measure_outputs(robot: str) -> dict:
    """In a fresh subprocess (no cache warmed by the `--code` run): every output,
    ``--latex --code --json``, from loading the file to the last rendered string (wall and
    CPU seconds: on a shared machine the CPU time is the steadier figure), with the command
    line's SymPy cache (``main``)."""
    import dynderive
    from dynderive.render.sheets.json import render_json

    start, cpu = time.perf_counter(), time.process_time()
    derivation = dynderive.derive(dynderive.load_robot(robot))
    dynderive.render_latex(derivation)
    dynderive.render_code(derivation)
    render_json(derivation)
    return {"all_s": time.perf_counter() - start, "all_cpu_s": time.process_time() - cpu,
            "all_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "checks_failed": [c.name for c in derivation.checks if not c.passed and not c.skipped]}


def measure_kane(robot: str) -> dict:
    """In a subprocess: KanesMethod's unsimplified equations of the same model (numbers in)."""
    import anchors

    import dynderive

    result = anchors.kane_equations(dynderive.load_robot(robot), floats=True)
    return {"kane_s": result["setup_s"] + result["kane_s"],
            "kane_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _child(flag: str, robot: str, extra: list[str], timeout: float) -> dict | None:
    command = [sys.executable, __file__, flag, robot, *extra]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"timed_out": timeout}
    if result.returncode != 0:
        print(f"{Path(robot).stem} ({flag}): failed\n{result.stderr[-2000:]}", file=sys.stderr)
        return None
    return json.loads(result.stdout.strip().splitlines()[-1])


def _cell(value, fmt: str) -> str:
    return "-" if value is None else fmt.format(value)


def table(rows: list[dict]) -> str:
    columns = [("robot", "{}", "robot"), ("dof", "{}", "dof"), ("form", "{}", "form"),
               ("--code s", "{:.1f}", "code_s"), ("peak MB", "{:.0f}", "code_peak_mb"),
               ("all outputs s", "{:.1f}", "all_s"), ("M ns/state", "{:.0f}", "mass_matrix_ns"),
               ("FD ns/state", "{:.0f}", "forward_dynamics_ns"), ("Kane s", "{}", "kane")]
    cells = [[c[0] for c in columns]]
    for row in rows:
        row = dict(row, form="intermediate" if row.get("intermediate_form") else "expanded")
        if "kane_s" in row:
            row["kane"] = f"{row['kane_s']:.1f} ({row['kane_s'] / row['code_s']:.1f}x ours)"
        elif "kane_timed_out" in row:
            row["kane"] = f"> {row['kane_timed_out']:.0f}"
        cells.append([_cell(row.get(key), fmt) for _, fmt, key in columns])
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in cells]
    return "\n".join([lines[0], "-" * len(lines[0]), *lines[1:]])


def goals(rows: list[dict]) -> list[tuple[str, str, bool | None]]:
    by = {r["robot"]: r for r in rows}
    out = []

    def goal(text: str, robot: str, key: str, limit: float, unit: str = "s") -> None:
        value = by.get(robot, {}).get(key)
        out.append((text, "not measured" if value is None else f"{value:.1f} {unit}",
                    None if value is None else value <= limit))

    goal("generic 7-DOF 3-D solve --code <= 10 s", "spatial_chain7", "code_s", 10)
    goal("generic 7-DOF 3-D --latex --code --json <= 30 s", "spatial_chain7", "all_s", 30)
    goal("12-DOF planar, all outputs <= 15 s", "chain12", "all_s", 15)
    goal("30-DOF planar --code <= 120 s", "chain30", "code_s", 120)
    goal("generic 20-DOF 3-D --code <= 120 s", "spatial_chain20", "code_s", 120)
    goal("30-DOF planar peak memory <= 2048 MB", "chain30", "code_peak_mb", 2048, "MB")
    goal("generic 20-DOF 3-D peak memory <= 2048 MB", "spatial_chain20", "code_peak_mb", 2048, "MB")
    panda = by.get("panda", {})
    for key, label in (("mass_matrix_ns", "mass_matrix"), ("forward_dynamics_ns", "forward_dynamics")):
        if key in panda and f"baseline_{key}" in panda:
            ratio = panda[key] / panda[f"baseline_{key}"]
            out.append((f"Panda {label} per state within 1.5x of the module before the scaling work",
                        f"{panda[key]:.0f} vs {panda[f'baseline_{key}']:.0f} ns ({ratio:.2f}x)", ratio <= 1.5))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="planar 2-12 and 3-D 3, 7; no KanesMethod")
    parser.add_argument("--batch", type=int, default=10_000, help="states per batch for the generated code")
    parser.add_argument("--kane-timeout", type=float, default=120.0, help="seconds for KanesMethod per robot")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds for dynderive per robot")
    parser.add_argument("--no-kane", action="store_true", help="skip KanesMethod")
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "scaling.json")
    parser.add_argument("--measure", help=argparse.SUPPRESS)
    parser.add_argument("--kane", help=argparse.SUPPRESS)
    parser.add_argument("--outputs", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure or args.outputs:   # a child measures what the command line runs: its SymPy cache
        try:
            from dynderive.__main__ import use_command_line_sympy_cache
        except ImportError:   # an earlier dynderive (--baseline) left SymPy's default
            pass
        else:
            use_command_line_sympy_cache()
    if args.measure:
        print(json.dumps(measure(args.measure, args.batch)))
        return
    if args.outputs:
        print(json.dumps(measure_outputs(args.outputs)))
        return
    if args.kane:
        print(json.dumps(measure_kane(args.kane)))
        return
    planar = [n for n in PLANAR if n <= 12] if args.quick else PLANAR
    spatial = [n for n in SPATIAL if n <= 7] if args.quick else SPATIAL
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        robots = []
        for n in planar:
            robots.append((f"chain{n}", planar_chain_yaml(n)))
        for n in spatial:
            robots.append((f"spatial_chain{n}", spatial_chain_yaml(n)))
        paths = [("panda", str(ROOT / "robots" / "panda.urdf"))]
        for name, text in robots:
            path = Path(folder) / f"{name}.yaml"
            path.write_text(text)
            paths.append((name, str(path)))
        for name, path in paths:
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            row = _child("--measure", path, ["--batch", str(args.batch)], args.timeout)
            if row is None:
                continue
            row["robot"] = name
            if name in ALL_OUTPUTS:
                outputs = _child("--outputs", path, [], args.timeout) or {}
                row.update({"all_timed_out": outputs["timed_out"]} if "timed_out" in outputs else outputs)
            if not args.no_kane and not args.quick and name != "panda":
                kane = _child("--kane", path, [], args.kane_timeout)
                if kane is not None and "timed_out" in kane:
                    row["kane_timed_out"] = kane["timed_out"]
                elif kane is not None:
                    row.update(kane)
            rows.append(row)
    print(table(rows))
    print()
    verdict = {True: "met", False: "NOT MET", None: "not measured"}
    width = max(len(g[0]) for g in goals(rows))
    for text, measured, met in goals(rows):
        print(f"{text:<{width}}  {measured:>28}  {verdict[met]}")
    print(f"\n({len(rows)} robots, {time.perf_counter() - started:.0f} s; Python {sys.version.split()[0]})")
    args.json.write_text(json.dumps({"rows": rows, "goals": goals(rows)}, indent=2) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
