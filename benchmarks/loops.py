"""Closed-loop mechanisms: derivation time of the sheet, the module and the JSON,
and the constrained forward dynamics of the generated code, against the goals.

    python benchmarks/loops.py          # about 30 s; prints a table

Each robot is derived in a fresh subprocess (no warm caches), timed end to end.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

GOALS = {"four_bar": 10.0, "slider_crank": 10.0, "spatial_four_bar": 30.0,   # seconds
         "bennett": 30.0}                                                # over-constrained

CHILD = r"""
import json, sys, time
import numpy as np
import dynderive
from dynderive.verify.checks import generated_module
start = time.perf_counter()
d = dynderive.derive(dynderive.load_robot(sys.argv[1]))
latex, code, dump = dynderive.render_latex(d), dynderive.render_code(d), dynderive.render_json(d)
seconds = time.perf_counter() - start
module = generated_module(code, d.robot.name)
q = np.tile(np.array(module.ASSEMBLED_CONFIGURATION), (10_000, 1))
qd = np.zeros_like(q)
module.forward_dynamics(q[:10], qd[:10])
t = time.perf_counter(); module.forward_dynamics(q, qd); batch = (time.perf_counter() - t) / len(q)
t = time.perf_counter()
for _ in range(200):
    module.forward_dynamics(q[0], qd[0])
single = (time.perf_counter() - t) / 200
print(json.dumps({"dof": len(d.robot.coordinates), "constraints": d["a_g"].shape[0], "seconds": seconds,
                  "reduced": "M_r" in d, "batch_us": batch * 1e6, "single_us": single * 1e6}))
"""


def main() -> None:
    print(f"{'robot':<18} {'coords':>6} {'rows':>4} {'sheet+code+JSON s':>18} {'goal s':>7} {'':>7} "
          f"{'reduced':>7} {'FD us/state (batch)':>20} {'FD us (one call)':>17}")
    for robot, goal in GOALS.items():
        done = subprocess.run([sys.executable, "-c", CHILD, robot], capture_output=True, text=True)
        if done.returncode != 0:
            print(f"{robot:<18} failed: {done.stderr[-500:]}")
            continue
        r = json.loads(done.stdout.strip().splitlines()[-1])
        verdict = "met" if r["seconds"] <= goal else "NOT MET"
        print(f"{robot:<18} {r['dof']:>6} {r['constraints']:>4} {r['seconds']:>18.2f} {goal:>7.0f} {verdict:>7} "
              f"{'yes' if r['reduced'] else 'no':>7} {r['batch_us']:>20.2f} {r['single_us']:>17.1f}")
    print(f"\n(Python {sys.version.split()[0]}, {time.strftime('%Y-%m-%d')})")


if __name__ == "__main__":
    main()
