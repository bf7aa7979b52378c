"""The JAX target under ``jax.vmap``: ``jax.jit(jax.vmap(forward_dynamics))`` (one state per
call, batched by JAX, as inside a user's own jitted code) beside the module's own batch call
``jax.jit(forward_dynamics)`` and the NumPy module's batch call, in the same run.

    python benchmarks/jax_vmap.py [--robot panda] [--states 10000 100000] [--repeats 3]

Each row is one batch size: the best of ``--repeats`` calls, in nanoseconds per state, and the
ratio of the vmapped function's time to the NumPy module's (below 1: faster). float64
(``jax_enable_x64``); before timing, both JAX results at the first 100 states must agree with
the NumPy module's to 1e-12 relative.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import dynderive  # noqa: E402
from dynderive.render.targets.jax.jax import render_jax  # noqa: E402
from dynderive.verify.checks import generated_module  # noqa: E402

CHECKED = 100


def relative(actual, expected) -> float:
    return float(np.max(np.abs(np.asarray(actual) - expected)) / max(float(np.max(np.abs(expected))), 1.0))


def best(call, repeats: int, *arguments) -> float:
    """The fastest of ``repeats`` calls ``call(*arguments)`` (JAX's waited for), in seconds."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(call(*arguments))
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--states", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    derivation = dynderive.derive(dynderive.load_robot(args.robot))
    name = derivation.robot.name
    numpy_module = generated_module(dynderive.render_code(derivation), name)
    jax_module = generated_module(render_jax(derivation), f"{name}_jax")
    print(f"JAX {jax.__version__} ({jax.default_backend()}); robot {name}, {len(numpy_module.COORDINATES)} "
          "coordinates; forward_dynamics, ns per state")
    print(f"{'states':>8}  {'NumPy':>8}  {'jit(batch)':>10}  {'jit(vmap)':>10}  {'vmap/NumPy':>10}  {'batch/NumPy':>11}")
    rng = np.random.default_rng(0)
    n, nu = len(numpy_module.COORDINATES), len(numpy_module.EFFORTS)
    for size in args.states:
        q, qd, u = rng.uniform(-1.5, 1.5, (size, n)), rng.normal(size=(size, n)), rng.normal(size=(size, nu))
        expected = numpy_module.forward_dynamics(q[:CHECKED], qd[:CHECKED], u[:CHECKED])
        arrays = [jax.device_put(a) for a in (q, qd, u)]
        batch = jax.jit(jax_module.forward_dynamics).lower(*arrays).compile()
        mapped = jax.jit(jax.vmap(jax_module.forward_dynamics)).lower(*arrays).compile()
        for label, function in (("jit(batch)", batch), ("jit(vmap)", mapped)):
            worst = relative(np.asarray(function(*arrays))[:CHECKED], expected)
            if worst > 1e-12:
                raise SystemExit(f"{label} differs from the NumPy module: {worst:.3g}")
        times = {"numpy": best(numpy_module.forward_dynamics, args.repeats, q, qd, u),
                 "batch": best(batch, args.repeats, *arrays), "vmap": best(mapped, args.repeats, *arrays)}
        ns = {k: v * 1e9 / size for k, v in times.items()}
        print(f"{size:>8}  {ns['numpy']:>8.0f}  {ns['batch']:>10.0f}  {ns['vmap']:>10.0f}  "
              f"{times['vmap'] / times['numpy']:>10.2f}  {times['batch'] / times['numpy']:>11.2f}", flush=True)


if __name__ == "__main__":
    main()
