"""The identification regressor: the generated ``regressor`` against Pinocchio's
``computeJointTorqueRegressor`` called from Python, and the time to build the program.

    python benchmarks/regressor.py [--repeats 5]      # about 30 s; prints a table

Each robot runs in a fresh subprocess. "build s" is ``regressor_program`` alone (SymPy);
"module s" is rendering the whole generated module. One state: Python floats through
``math`` (the generated body), median of ``--repeats`` runs of 200 calls; batch: 1000 states
in one call, per state. Pinocchio: its own URDF parser's model, one call and a Python loop
over the same 1000 states. The last column is the largest ``|Y pi - Y_pin pi_pin|`` (the
two regressors lay out their columns differently: Pinocchio merges links welded by fixed
joints into the joint's inertia, dynderive's URDF reader merges them into the link).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

ROBOTS = ["ur5", "panda"]

CHILD = r"""
import json, statistics, sys, time
import numpy as np
import pinocchio as pin
import dynderive
from dynderive.mechanics.regressor import regressor_program
from dynderive.model.symbols import SymbolTable
from dynderive.render.targets.numpy.code import program_function
from dynderive.verify.checks import generated_module

path, repeats = sys.argv[1], int(sys.argv[2])
robot = dynderive.load_robot(path)
start = time.perf_counter()
program = regressor_program(robot, SymbolTable.for_robot(robot))
build = time.perf_counter() - start
printed = program_function("r", "", [], program)
start = time.perf_counter()
module = generated_module(dynderive.render_code(dynderive.derive(robot)), robot.name)
render = time.perf_counter() - start
model = pin.buildModelFromUrdf(path)
data = model.createData()
perm = [list(module.COORDINATES).index(name) for name in model.names[1:]]
rng = np.random.default_rng(0)
n = len(module.COORDINATES)
q, qd, qdd = rng.uniform(-np.pi, np.pi, (1000, n)), rng.normal(size=(1000, n)), rng.normal(size=(1000, n))


def median(run, calls):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        times.append((time.perf_counter() - t) / calls)
    return statistics.median(times) * 1e6


def ours_one():
    for k in range(200):
        module.regressor(q[k], qd[k], qdd[k])


def pin_one():
    for k in range(200):
        pin.computeJointTorqueRegressor(model, data, q[k, perm], qd[k, perm], qdd[k, perm])


def pin_loop():
    for k in range(1000):
        pin.computeJointTorqueRegressor(model, data, q[k, perm], qd[k, perm], qdd[k, perm])


module.regressor(q, qd, qdd)
one, batch = median(ours_one, 200), median(lambda: module.regressor(q, qd, qdd), 1000)
pin_single, pin_batch = median(pin_one, 200), median(pin_loop, 1000)
pi = module.parameter_vector()
pi_pin = np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, model.njoints)])
Y = module.regressor(q[:50], qd[:50], qdd[:50])
diff = max(float(np.max(np.abs((Y[k] @ pi)[perm]
                               - pin.computeJointTorqueRegressor(model, data, q[k, perm], qd[k, perm], qdd[k, perm]) @ pi_pin)))
           for k in range(50))
print(json.dumps({"dof": n, "columns": len(pi), "build": build, "render": render, "lines": len(printed.lines),
                  "ops": printed.operations, "one": one, "batch": batch, "pin_one": pin_single,
                  "pin_loop": pin_batch, "diff": diff}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    header = (f"{'robot':<7} {'dof':>3} {'cols':>4} {'build s':>7} {'module s':>8} {'lines':>5} {'ops':>5} "
              f"{'ours 1x us':>10} {'ours batch us/state':>19} {'pin 1x us':>9} {'pin loop us/state':>17} "
              f"{'loop/batch':>10} {'diff Y pi':>9}")
    print(header)
    print("-" * len(header))
    for name in ROBOTS:
        done = subprocess.run([sys.executable, "-c", CHILD, f"robots/{name}.urdf", str(args.repeats)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            print(f"{name:<7} failed: {done.stderr[-800:]}")
            continue
        r = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{name:<7} {r['dof']:>3} {r['columns']:>4} {r['build']:>7.2f} {r['render']:>8.2f} {r['lines']:>5} "
              f"{r['ops']:>5} {r['one']:>10.1f} {r['batch']:>19.2f} {r['pin_one']:>9.1f} {r['pin_loop']:>17.2f} "
              f"{r['pin_loop'] / r['batch']:>9.1f}x {r['diff']:>9.1e}")
    print(f"\n(Python {sys.version.split()[0]}, repeats {args.repeats}, {time.strftime('%Y-%m-%d')})")


if __name__ == "__main__":
    main()
