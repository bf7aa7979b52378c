"""The PyTorch target beside adam's PyTorch backend, for the Panda (``robots/panda.urdf``), a batch
of states on the CPU in float64, measured in the same run.

    python benchmarks/torch_adam.py [--states 10000] [--repeats 5] [--threads N] [--compile]

Needs ``torch`` (the ``torch`` extra) and adam (``pip install adam-robotics``: a benchmark
requirement, in no extra). ``dynderive solve robots/panda.urdf --torch`` writes the module;
adam's ``KinDynComputationsBatch(urdf, joints, dtype=torch.float64, device=cpu)`` is built with
the module's ``COORDINATES`` as its joint list (the same order) and the module's gravity.
adam's ``aba`` is a floating-base ABA; a fixed base's dynamics are the joint block of its batched
``mass_matrix`` and ``bias_force`` at the identity base pose and zero base velocity: forward
dynamics ``torch.linalg.solve(M_jj, u - h_j)``, as ``benchmarks/casadi_vs_adam.py`` does with
adam's CasADi functions.

Rows: forward dynamics (FD) and the mass matrix (M), each side called once on the whole batch
(tensors made beforehand), the best of ``--repeats`` calls after one warm-up call; with
``--compile`` also ``torch.compile`` of our two functions (compile time printed, not timed).
Before timing, both must agree to 1e-8 (relative to the largest entry) at the first 100 states.
The goal: ours at most 0.3x adam's time per state.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

CHECKED = 100
AGREE = 1e-8
GOAL = 0.3


def relative(actual: torch.Tensor, expected: torch.Tensor) -> float:
    return float((actual - expected).abs().max() / max(1.0, float(expected.abs().max())))


def best(call, repeats: int) -> float:
    """Seconds of the fastest of ``repeats`` calls, after one warm-up call."""
    call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return min(times)


def our_module(urdf: Path):
    import dynderive
    from dynderive.render.targets.torch.harness import module_from_source
    from dynderive.render.targets.torch.printer import render_torch

    derivation = dynderive.derive(dynderive.load_robot(str(urdf)))
    return module_from_source(render_torch(derivation), "panda_dynamics_torch")


def adam_functions(module, urdf: Path):
    from adam.pytorch import KinDynComputationsBatch

    gravity = torch.tensor([0.0, 0.0, -float(module.PARAMETERS.get("g", 9.81)), 0.0, 0.0, 0.0], dtype=torch.float64)
    kd = KinDynComputationsBatch(str(urdf), list(module.COORDINATES), device=torch.device("cpu"),
                                 dtype=torch.float64, gravity=gravity)

    def mass_matrix(base, q):
        return kd.mass_matrix(base, q)[:, 6:, 6:]

    def forward_dynamics(base, q, qd, u):
        zero = torch.zeros(q.shape[0], 6, dtype=q.dtype)
        bias = kd.bias_force(base, q, zero, qd)[:, 6:]
        return torch.linalg.solve(mass_matrix(base, q), (u - bias)[..., None])[..., 0]

    return mass_matrix, forward_dynamics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=0, help="torch.set_num_threads (0: torch's default)")
    parser.add_argument("--compile", action="store_true", help="also time torch.compile of our functions")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    urdf = ROOT / "robots" / "panda.urdf"
    start = time.perf_counter()
    module = our_module(urdf)
    print(f"derived and rendered the Panda's PyTorch module in {time.perf_counter() - start:.1f} s")
    adam_mass, adam_forward = adam_functions(module, urdf)

    rng = np.random.default_rng(0)
    n, states = len(module.COORDINATES), args.states
    q = torch.from_numpy(rng.uniform(-1.0, 1.0, (states, n)))
    qd = torch.from_numpy(rng.uniform(-1.0, 1.0, (states, n)))
    u = torch.from_numpy(rng.uniform(-1.0, 1.0, (states, len(module.EFFORTS))))
    base = torch.eye(4, dtype=torch.float64).expand(states, 4, 4).contiguous()

    checked = slice(0, CHECKED)
    for name, ours, theirs in (
            ("FD", module.forward_dynamics(q[checked], qd[checked], u[checked]),
             adam_forward(base[checked], q[checked], qd[checked], u[checked])),
            ("M", module.mass_matrix(q[checked]), adam_mass(base[checked], q[checked]))):
        error = relative(ours, theirs)
        if not error <= AGREE:
            raise SystemExit(f"{name}: ours and adam's differ by {error:.3g} (relative), over {AGREE:g}")

    rows = {
        "FD": {"ours": lambda: module.forward_dynamics(q, qd, u), "adam": lambda: adam_forward(base, q, qd, u)},
        "M": {"ours": lambda: module.mass_matrix(q), "adam": lambda: adam_mass(base, q)},
    }
    if args.compile:
        for name, function, call in (("FD", module.forward_dynamics, lambda f: f(q, qd, u)),
                                     ("M", module.mass_matrix, lambda f: f(q))):
            compiled = torch.compile(function)
            start = time.perf_counter()
            call(compiled)
            print(f"torch.compile of {name}: {time.perf_counter() - start:.1f} s (first call)")
            rows[name]["ours compiled"] = lambda compiled=compiled, call=call: call(compiled)

    print(f"\nPanda, {states} states, CPU float64, torch {torch.__version__}, {torch.get_num_threads()} threads; "
          f"best of {args.repeats} calls, ns per state")
    columns = ["ours", "ours compiled", "adam"] if args.compile else ["ours", "adam"]
    print("| function | " + " | ".join(columns) + " | ours / adam |" + (" compiled / adam |" if args.compile else ""))
    print("|---" * (len(columns) + 2 + args.compile) + "|")
    met = True
    for name, calls in rows.items():
        ns = {how: best(call, args.repeats) / states * 1e9 for how, call in calls.items()}
        ratio = ns["ours"] / ns["adam"]
        met &= min(ratio, ns.get("ours compiled", ns["ours"]) / ns["adam"]) <= GOAL
        cells = " | ".join(f"{ns[c]:.0f}" for c in columns)
        extra = f" {ns['ours compiled'] / ns['adam']:.3f} |" if args.compile else ""
        print(f"| {name} | {cells} | {ratio:.3f} |{extra}")
    print(f"\ngoal (ours <= {GOAL}x adam per state): {'met' if met else 'NOT met'}")


if __name__ == "__main__":
    main()
