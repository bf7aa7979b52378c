"""Linearization and frames: the generated ``linearize`` against Pinocchio's
``computeABADerivatives`` called from Python, and ``frame_jacobian`` against
``computeFrameJacobian``, for the UR5 and the Panda.

    python benchmarks/linearize.py [--repeats 5]      # about 1 min; prints two tables

Each robot runs in a fresh subprocess. One state: median of ``--repeats`` runs of 200 calls
(Python floats through ``math`` in the generated bodies); batch: 1000 states in one call, per
state. Pinocchio: its own URDF parser's model, one call at a time (a Python loop). The
``linearize`` comparison includes what each returns: ours A and B (2n x 2n, 2n x n); Pinocchio
``ddq_dq``, ``ddq_dv`` and ``Minv``. The last columns are the largest differences of
``dqdd/dq`` and of the frame Jacobian.

The second table is the wall time of the command ``dynderive linearize ROBOT --at POINT -q``
(derivation, code generation, closed form and output, one run each) on the small robots a
student linearizes first, and whether the closed form was given or skipped for its size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

ROBOTS = [("ur5", "tool0"), ("panda", "panda_link8")]
#: (robot, --at) for the command's wall time
COMMANDS = [("robots/cart_pole.yaml", "theta=0"), ("robots/double_pendulum.yaml", "q=0,0"),
            ("robots/planar_3r.yaml", "u=equilibrium"), ("robots/planar_3r.yaml", "q=0.3,0.5,0.7"),
            ("tests/linearize/rrr_arm.yaml", "q=pi/2,0,0,u=equilibrium"),
            ("tests/linearize/cart_double_pendulum.yaml", "q=0,0,0"), ("robots/elbow_arm.yaml", "q=0.1,0.2,0.3")]

CHILD = r"""
import json, statistics, sys
import time
import numpy as np
import pinocchio as pin
import dynderive
from dynderive.verify.checks import generated_module

path, frame, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
robot = dynderive.load_robot(path)
module = generated_module(dynderive.render_code(dynderive.derive(robot)), robot.name)
model = pin.buildModelFromUrdf(path)
data = model.createData()
perm = [list(module.COORDINATES).index(name) for name in model.names[1:]]
n = len(perm)
rng = np.random.default_rng(0)
q, qd, u = rng.uniform(-np.pi, np.pi, (1000, n)), rng.normal(size=(1000, n)), rng.normal(size=(1000, n))
fid = model.getFrameId(frame)


def median(run, calls):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        times.append((time.perf_counter() - t) / calls)
    return statistics.median(times) * 1e6


def ours_one():
    for k in range(200):
        module.linearize(q[k], qd[k], u[k])


def pin_one():
    for k in range(200):
        pin.computeABADerivatives(model, data, q[k, perm], qd[k, perm], u[k, perm])


def jac_one():
    for k in range(200):
        module.frame_jacobian(q[k], frame)


def pin_jac():
    for k in range(200):
        pin.computeFrameJacobian(model, data, q[k, perm], fid, pin.LOCAL_WORLD_ALIGNED)


module.linearize(q[:2], qd[:2], u[:2])
result = {"dof": n, "one": median(ours_one, 200), "batch": median(lambda: module.linearize(q, qd, u), 1000),
          "pin_one": median(pin_one, 200), "jac_one": median(jac_one, 200),
          "jac_batch": median(lambda: module.frame_jacobian(q, frame), 1000), "pin_jac": median(pin_jac, 200)}
diff = jdiff = 0.0
for k in range(20):
    A, _ = module.linearize(q[k], qd[k], u[k])
    pin.computeABADerivatives(model, data, q[k, perm], qd[k, perm], u[k, perm])
    diff = max(diff, float(np.max(np.abs(A[n:, :n][np.ix_(perm, perm)] - data.ddq_dq))))
    J = pin.computeFrameJacobian(model, data, q[k, perm], fid, pin.LOCAL_WORLD_ALIGNED)
    jdiff = max(jdiff, float(np.max(np.abs(module.frame_jacobian(q[k], frame)[:, perm] - J))))
result["diff"], result["jdiff"] = diff, jdiff
print(json.dumps(result))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    header = (f"{'robot':<6} {'dof':>3} {'linearize 1x us':>15} {'batch us/state':>14} {'pin ABA-deriv 1x us':>19} "
              f"{'frame_jacobian 1x us':>20} {'batch us/state':>14} {'pin frame J 1x us':>17} "
              f"{'diff dqdd/dq':>12} {'diff J':>8}")
    print(header)
    print("-" * len(header))
    for name, frame in ROBOTS:
        done = subprocess.run([sys.executable, "-c", CHILD, f"robots/{name}.urdf", frame, str(args.repeats)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            print(f"{name:<6} failed: {done.stderr[-800:]}")
            continue
        r = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{name:<6} {r['dof']:>3} {r['one']:>15.1f} {r['batch']:>14.2f} {r['pin_one']:>19.1f} "
              f"{r['jac_one']:>20.1f} {r['jac_batch']:>14.2f} {r['pin_jac']:>17.1f} {r['diff']:>12.1e} {r['jdiff']:>8.1e}")
    print(f"\n{'dynderive linearize ROBOT --at POINT':<62} {'wall s':>7}  closed form")
    for path, point in COMMANDS:
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "dynderive", "linearize", path, "--at", point, "--json", "-q"],
                              capture_output=True, text=True)
        wall = time.perf_counter() - start
        method = json.loads(done.stdout)["method"] if done.returncode == 0 else f"failed: {done.stderr[-200:]}"
        print(f"{path.rsplit('/', 1)[-1] + ' --at ' + point:<62} {wall:>7.1f}  "
              f"{'given' if method == 'symbolic' else 'skipped' if method == 'numeric' else method}")
    print(f"\n(Python {sys.version.split()[0]}, repeats {args.repeats}, {time.strftime('%Y-%m-%d')})")


if __name__ == "__main__":
    main()
