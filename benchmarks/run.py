"""Benchmarks of dynderive beside sympy.physics.mechanics (KanesMethod) and Pinocchio.

    python benchmarks/run.py --quick        # bundled robots + planar pendulums n = 2..4 (a few minutes)
    python benchmarks/run.py                # pendulums up to n = 8, trigsimp anchors up to 6 links
    python benchmarks/run.py --json out.json

Every figure is measured in the same run, each robot in its own subprocess (so peak memory
is that robot's alone), the anchors in subprocesses of their own:

1. derivation time per stage and operation counts of M, C, N, beside KanesMethod's
   unsimplified equations (``kanes_equations``) on the same model;
2. readable form: total operations of M, C, N beside KanesMethod + ``trigsimp`` (planar
   pendulums, within a time limit);
3. generated code: one call (us) and a batch of 100 k states (ns per state) of
   ``mass_matrix`` and ``forward_dynamics`` beside Pinocchio (``crba``, ``aba``) called from
   Python, once and in a Python loop over the batch;
4. peak memory (RSS) of the derivation;

then the goals with their measured figures, met or not. Times are medians over
``--repeats``. Operations are counted by one function for both tools (``dynderive.mechanics.tidy.operation_count``).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import pendulum_yaml  # noqa: E402  (shared with anchors.py)

ROOT = Path(__file__).resolve().parents[1]
BUNDLED = ["rp_arm", "double_pendulum", "cart_pole", "elbow_arm", "ur5", "panda"]
URDF = {"ur5": ROOT / "robots" / "ur5.urdf", "panda": ROOT / "robots" / "panda.urdf"}


def _median_time(function, *args, repeats: int, number: int = 1) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(number):
            function(*args)
        samples.append((time.perf_counter() - start) / number)
    return statistics.median(samples)


def measure_dynderive(robot: str, repeats: int, batch: int, loop: int) -> dict:
    """Runs in a subprocess: one robot's derivation, rendering and generated-code timings."""
    import numpy as np

    import dynderive
    from dynderive.mechanics.tidy import operation_count
    from dynderive.render.targets.numpy.code import render_code
    from dynderive.verify.checks import generated_module

    row: dict = {}
    start = time.perf_counter()
    model = dynderive.load_robot(robot)
    row["load_s"] = time.perf_counter() - start
    stamps: dict[str, float] = {}
    start = time.perf_counter()
    derivation = dynderive.derive(model, progress=lambda stage: stamps.setdefault(stage, time.perf_counter() - start))
    row["checks"] = len(derivation.checks)   # derivation is lazy: the checks need every quantity
    stamps["end"] = time.perf_counter() - start
    order = list(stamps)
    row["stages_s"] = {a: stamps[b] - stamps[a] for a, b in zip(order, order[1:])}
    row["derive_s"] = stamps["end"]
    # M, C, N: everything up to (not including) the maximal coordinates and the checks
    row["mcn_s"] = next(stamps[s] for s in order if s.startswith(("maximal coordinates", "checks", "end")))
    start = time.perf_counter()
    source = render_code(derivation)
    row["code_s"] = time.perf_counter() - start
    row["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    start = time.perf_counter()
    dynderive.render_latex(derivation)
    row["latex_s"] = time.perf_counter() - start
    row["dof"] = n = len(model.coordinates)
    for name in ("M_g", "C_g", "N_g"):
        row[f"{name}_ops"] = operation_count(derivation[name])
    if model.planar:   # the readable-form comparison uses sympy.count_ops, as for the anchor
        import sympy

        row["mcn_count_ops"] = sum(sympy.count_ops(e) for name in ("M_g", "C_g", "N_g") for e in derivation[name])

    module = generated_module(source, "bench")
    mass_matrix, forward_dynamics = module.mass_matrix, module.forward_dynamics
    efforts = len(module.EFFORTS)
    rng = np.random.default_rng(0)
    q1, qd1 = rng.uniform(-1, 1, (2, n))
    u1 = rng.uniform(-1, 1, efforts)
    qb, qdb = rng.uniform(-1, 1, (2, batch, n))
    ub = rng.uniform(-1, 1, (batch, efforts))
    row["mass_matrix_call_us"] = _median_time(mass_matrix, q1, repeats=repeats, number=500) * 1e6
    row["forward_dynamics_call_us"] = _median_time(forward_dynamics, q1, qd1, u1, repeats=repeats, number=500) * 1e6
    row["mass_matrix_batch_ns"] = _median_time(mass_matrix, qb, repeats=repeats) / batch * 1e9
    row["forward_dynamics_batch_ns"] = _median_time(forward_dynamics, qb, qdb, ub, repeats=repeats) / batch * 1e9
    row.update(_measure_pinocchio(model, module, q1, qd1, u1, qb, qdb, repeats, loop))
    return row


def _measure_pinocchio(model, module, q1, qd1, u1, qb, qdb, repeats: int, loop: int) -> dict:
    """Pinocchio's crba / aba on the same robot (built from the robot file, default parameters),
    and the largest relative difference from the generated code (the same model, checked)."""
    import numpy as np

    try:
        import pinocchio as pin
    except ImportError:
        return {}
    from dynderive.verify.pinocchio_model import pinocchio_model

    values = {p.name: p.value for p in model.parameters if p.value is not None}
    if len(values) != len(model.parameters):
        return {}
    pmodel, perm = pinocchio_model(model, values)
    data = pmodel.createData()
    tau = module.generalized_forces(q1, u1)   # Y_g: the efforts on their joints
    q_pin, v_pin, tau_pin = q1[perm], qd1[perm], tau[perm]
    row = {
        "pin_crba_call_us": _median_time(pin.crba, pmodel, data, q_pin, repeats=repeats, number=2000) * 1e6,
        "pin_aba_call_us": _median_time(pin.aba, pmodel, data, q_pin, v_pin, tau_pin, repeats=repeats, number=2000) * 1e6,
    }
    count = min(loop, len(qb))
    qs, vs = qb[:count][:, perm], qdb[:count][:, perm]

    def crba_loop():
        for k in range(count):
            pin.crba(pmodel, data, qs[k])

    def aba_loop():
        for k in range(count):
            pin.aba(pmodel, data, qs[k], vs[k], tau_pin)

    row["pin_crba_loop_ns"] = _median_time(crba_loop, repeats=repeats) / count * 1e9
    row["pin_aba_loop_ns"] = _median_time(aba_loop, repeats=repeats) / count * 1e9
    M = pin.crba(pmodel, data, q_pin)
    M = np.triu(M) + np.triu(M, 1).T
    inverse = np.argsort(perm)
    ours = module.mass_matrix(q1)
    row["pin_M_rel_diff"] = float(np.abs(M[np.ix_(inverse, inverse)] - ours).max() / np.abs(ours).max())
    qdd = pin.aba(pmodel, data, q_pin, v_pin, tau_pin)[inverse]
    ours_qdd = module.forward_dynamics(q1, qd1, u1)
    row["pin_qdd_rel_diff"] = float(np.abs(qdd - ours_qdd).max() / np.abs(ours_qdd).max())
    return row


def measure_kane(robot: str, trigsimp_timeout: float) -> dict:
    """Runs in a subprocess: KanesMethod on the same model (benchmarks/anchors.py)."""
    sys.path.insert(0, str(Path(__file__).parent))
    import anchors

    import dynderive
    from dynderive.mechanics.tidy import operation_count

    model = dynderive.load_robot(robot)
    result = anchors.kane_equations(model)
    row = {"kane_setup_s": result["setup_s"], "kane_s": result["kane_s"],
           "kane_M_ops": operation_count(result["mass_matrix"]), "kane_forcing_ops": operation_count(result["forcing"]),
           "kane_count_ops": result["mass_matrix_ops"] + result["forcing_ops"],
           "kane_peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
    if trigsimp_timeout > 0:
        simplified = anchors.kane_trigsimp(model, trigsimp_timeout)
        row["trigsimp_s"] = simplified["trigsimp_s"]
        row["trigsimp_timeout_s"] = trigsimp_timeout
        row["trigsimp_timed_out"] = simplified["timed_out"]
        if not simplified["timed_out"]:
            row["trigsimp_ops"] = simplified["mass_matrix_ops"] + simplified["forcing_ops"]
    return row


def _child(kind: str, robot: str, args: argparse.Namespace, extra: list[str]) -> dict | None:
    command = [sys.executable, __file__, f"--{kind}", robot, "--repeats", str(args.repeats),
               "--batch", str(args.batch), "--loop", str(args.loop), *extra]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        print(f"{Path(robot).stem} ({kind}): failed\n{result.stderr[-3000:]}", file=sys.stderr)
        return None
    return json.loads(result.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------------------------------------
# tables

def _cell(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return fmt.format(value)


def _table(title: str, columns: list[tuple[str, str, object]], rows: list[dict]) -> str:
    """``columns``: (heading, format, key or function of the row)."""
    cells = [[heading for heading, _, _ in columns]]
    for row in rows:
        cells.append([_cell(key(row) if callable(key) else row.get(key), fmt) for _, fmt, key in columns])
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    lines = [title, ""]
    for k, r in enumerate(cells):
        lines.append("  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))))
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _ratio(a, b):
    return a / b if a is not None and b else None


def _stage(row: dict, *names: str) -> float | None:
    stages = row.get("stages_s", {})
    found = [stages[n] for n in names if n in stages]
    return sum(found) if found else None


def derivation_table(rows: list[dict]) -> str:
    return _table("1. Derivation (seconds; operations) beside KanesMethod's unsimplified equations", [
        ("robot", "{}", "robot"), ("dof", "{}", "dof"),
        ("load", "{:.2f}", "load_s"), ("kinem.", "{:.2f}", lambda r: _stage(r, "kinematics", "energies")),
        ("Lagrange", "{:.2f}", lambda r: _stage(r, "Lagrange's equations")),
        ("M", "{:.2f}", lambda r: _stage(r, "mass matrix")), ("C", "{:.2f}", lambda r: _stage(r, "Coriolis matrix")),
        ("N+EOM", "{:.2f}", lambda r: _stage(r, "gravity vector", "equations of motion")),
        ("maximal", "{:.2f}", lambda r: _stage(r, "maximal coordinates")), ("checks", "{:.2f}", lambda r: _stage(r, "checks")),
        ("code", "{:.2f}", "code_s"), ("LaTeX", "{:.2f}", "latex_s"),
        ("M,C,N+code", "{:.2f}", lambda r: r["mcn_s"] + r["code_s"]),
        ("Kane", "{:.2f}", "kane_s"), ("Kane/ours", "{:.1f}x", lambda r: _ratio(r.get("kane_s"), r["mcn_s"] + r["code_s"])),
        ("M ops", "{}", "M_g_ops"), ("C ops", "{}", "C_g_ops"), ("N ops", "{}", "N_g_ops"),
        ("Kane M ops", "{}", "kane_M_ops"), ("Kane F ops", "{}", "kane_forcing_ops"),
        ("peak MB", "{:.0f}", "peak_rss_mb"),
    ], rows)


def readable_table(rows: list[dict]) -> str:
    rows = [r for r in rows if "trigsimp_timeout_s" in r]
    return _table("2. Readable form: sympy.count_ops of M, C, N beside KanesMethod (+ trigsimp) of M and forcing", [
        ("robot", "{}", "robot"), ("ours ops", "{}", "mcn_count_ops"), ("ours M,C,N s", "{:.2f}", "mcn_s"),
        ("Kane ops", "{}", "kane_count_ops"),
        ("Kane+trigsimp ops", "{}", "trigsimp_ops"),
        ("trigsimp s", "{}", lambda r: f"> {r['trigsimp_timeout_s']:.0f}" if r.get("trigsimp_timed_out")
         else (f"{r['trigsimp_s']:.1f}" if r.get("trigsimp_s") is not None else None)),
        ("ours/trigsimp ops", "{:.2f}", lambda r: _ratio(r.get("mcn_count_ops"), r.get("trigsimp_ops"))),
    ], rows)


def code_table(rows: list[dict], batch: int) -> str:
    return _table(f"3. Generated NumPy code (one call in us; batch of {batch} states in ns per state) beside Pinocchio", [
        ("robot", "{}", "robot"), ("dof", "{}", "dof"),
        ("M 1x us", "{:.1f}", "mass_matrix_call_us"), ("M batch ns", "{:.0f}", "mass_matrix_batch_ns"),
        ("FD 1x us", "{:.1f}", "forward_dynamics_call_us"), ("FD batch ns", "{:.0f}", "forward_dynamics_batch_ns"),
        ("pin crba us", "{:.2f}", "pin_crba_call_us"), ("pin aba us", "{:.2f}", "pin_aba_call_us"),
        ("pin crba loop ns", "{:.0f}", "pin_crba_loop_ns"), ("pin aba loop ns", "{:.0f}", "pin_aba_loop_ns"),
        ("loop/ours M", "{:.1f}x", lambda r: _ratio(r.get("pin_crba_loop_ns"), r.get("mass_matrix_batch_ns"))),
        ("loop/ours FD", "{:.1f}x", lambda r: _ratio(r.get("pin_aba_loop_ns"), r.get("forward_dynamics_batch_ns"))),
        ("diff vs pin", "{:.1e}", lambda r: max(r["pin_M_rel_diff"], r["pin_qdd_rel_diff"]) if "pin_M_rel_diff" in r else None),
    ], rows)


def goals(rows: list[dict]) -> list[dict]:
    """The goals, each with the measured figure and whether it is met."""
    by_name = {r["robot"]: r for r in rows}
    out = []

    def goal(text: str, measured: str, met: bool | None) -> None:
        out.append({"goal": text, "measured": measured, "met": met})

    arm = by_name.get("panda")
    if arm:
        total = arm["derive_s"] + arm["code_s"]
        goal("7-DOF arm (panda): M, C, N and NumPy module <= 10 s", f"{total:.2f} s (whole derivation + code)", total <= 10)
        if "kane_s" in arm:
            ratio = arm["kane_s"] / total
            goal("7-DOF arm: >= 2x faster than KanesMethod's unsimplified EOM",
                 f"{ratio:.1f}x (Kane {arm['kane_s']:.2f} s)", ratio >= 2)
        goal("7-DOF arm: derivation peak memory < 1 GiB", f"{arm['peak_rss_mb']:.0f} MB", arm["peak_rss_mb"] < 1024)
        goal("7-DOF code: mass_matrix <= 1 us per state (batch)", f"{arm['mass_matrix_batch_ns']:.0f} ns",
             arm["mass_matrix_batch_ns"] <= 1000)
        goal("7-DOF code: forward_dynamics <= 3 us per state (batch)", f"{arm['forward_dynamics_batch_ns']:.0f} ns",
             arm["forward_dynamics_batch_ns"] <= 3000)
        goal("7-DOF code: one mass_matrix call <= 30 us", f"{arm['mass_matrix_call_us']:.1f} us",
             arm["mass_matrix_call_us"] <= 30)
        if "pin_aba_loop_ns" in arm:
            goal("7-DOF code: batch faster than a Python loop over Pinocchio (M and FD)",
                 f"M {arm['pin_crba_loop_ns'] / arm['mass_matrix_batch_ns']:.1f}x, "
                 f"FD {arm['pin_aba_loop_ns'] / arm['forward_dynamics_batch_ns']:.1f}x",
                 arm["pin_crba_loop_ns"] > arm["mass_matrix_batch_ns"]
                 and arm["pin_aba_loop_ns"] > arm["forward_dynamics_batch_ns"])
    six = by_name.get("pendulum6")
    if six:
        goal("6-link pendulum: compact M, C, N in <= 10 s", f"{six['mcn_s']:.2f} s", six["mcn_s"] <= 10)
        ours = six["mcn_count_ops"]
        if six.get("trigsimp_ops") is not None:
            goal("6-link pendulum: ops of M, C, N <= KanesMethod + trigsimp",
                 f"{ours} vs {six['trigsimp_ops']}", ours <= six["trigsimp_ops"])
        elif "trigsimp_timeout_s" in six:
            unsimplified = six.get("kane_count_ops")
            goal("6-link pendulum: ops of M, C, N <= KanesMethod + trigsimp",
                 f"{ours}; trigsimp did not finish in {six['trigsimp_timeout_s']:.0f} s "
                 f"(unsimplified Kane: {unsimplified})", None)
    return out


def goals_table(items: list[dict]) -> str:
    verdict = {True: "met", False: "NOT MET", None: "undecided"}
    return _table("4. Goals", [("goal", "{}", "goal"), ("measured", "{}", "measured"),
                                         ("", "{}", lambda g: verdict[g["met"]])], items)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="bundled robots and pendulums n = 2..4")
    parser.add_argument("--repeats", type=int, default=5, help="samples per timing (median)")
    parser.add_argument("--batch", type=int, default=100_000, help="states per batch for the generated code")
    parser.add_argument("--loop", type=int, default=20_000, help="states in the Python loop over Pinocchio")
    parser.add_argument("--trigsimp-timeout", type=float, default=None,
                        help="seconds for KanesMethod + trigsimp per pendulum (default 60 quick, 400 full)")
    parser.add_argument("--no-kane", action="store_true", help="skip the KanesMethod anchors")
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results.json")
    parser.add_argument("--dynderive", help=argparse.SUPPRESS)
    parser.add_argument("--kane", help=argparse.SUPPRESS)
    parser.add_argument("--trigsimp", type=float, default=0.0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.dynderive:
        print(json.dumps(measure_dynderive(args.dynderive, args.repeats, args.batch, args.loop)))
        return
    if args.kane:
        print(json.dumps(measure_kane(args.kane, args.trigsimp)))
        return
    timeout = args.trigsimp_timeout if args.trigsimp_timeout is not None else (60.0 if args.quick else 400.0)
    sizes = range(2, 5) if args.quick else range(2, 9)
    trigsimp_sizes = range(2, 5) if args.quick else range(2, 7)
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        robots = [(name, str(URDF.get(name, name)), False) for name in BUNDLED]
        for n in sizes:
            path = Path(folder) / f"pendulum{n}.yaml"
            path.write_text(pendulum_yaml(n))
            robots.append((f"pendulum{n}", str(path), n in trigsimp_sizes))
        for name, robot, trigsimp in robots:
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            row = _child("dynderive", robot, args, [])
            if row is None:
                continue
            row["robot"] = name
            if not args.no_kane:
                kane = _child("kane", robot, args, ["--trigsimp", str(timeout if trigsimp else 0.0)])
                row.update(kane or {})
            rows.append(row)
    items = goals(rows)
    report = "\n\n".join([derivation_table(rows), readable_table(rows), code_table(rows, args.batch), goals_table(items)])
    print(report)
    print(f"\n({'--quick, ' if args.quick else ''}{len(rows)} robots, {time.perf_counter() - started:.0f} s; "
          f"Python {sys.version.split()[0]}, repeats {args.repeats})")
    args.json.write_text(json.dumps({"rows": rows, "goals": items}, indent=2) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
