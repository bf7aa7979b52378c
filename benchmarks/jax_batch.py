"""The JAX target: forward dynamics of the Panda for 10^3 ... 10^6 states, jit-compiled,
beside the NumPy module and the compiled C extension.

    python benchmarks/jax_batch.py [--max 1000000] [--repeats 3] [--no-extension]

Each row is one batch size: the best of ``--repeats`` calls of each backend on the same random
full-precision states (q uniform in [-1.5, 1.5], qd and u normal), in milliseconds per call and
nanoseconds per state. JAX runs ``jax.jit(forward_dynamics)`` compiled for that batch shape
beforehand (``lower(...).compile()``, its seconds in their own column: compile time is
measured here, never in a test), in float64 (``jax_enable_x64``) and in float32. Before timing,
the float64 results at the first 100 states must agree with the NumPy module's to 1e-12
relative, the float32 ones to 1e-3. The C extension (``--c-extension``'s module, built with the
machine's C compiler) is skipped with a note when there is no compiler. The script prints the
device JAX runs on: it runs unchanged on a GPU (``pip install "jax[cuda12]"``).
"""

from __future__ import annotations

import argparse
import importlib.machinery
import importlib.util
import shutil
import sys
import tempfile
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

ROBOT = "panda"
CHECKED = 100


def relative(actual: np.ndarray, expected: np.ndarray) -> float:
    return float(np.max(np.abs(actual - expected)) / max(float(np.max(np.abs(expected))), 1.0))


def best(call, repeats: int) -> float:
    """The fastest of ``repeats`` calls, in seconds."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return min(times)


def extension(derivation, work: Path):
    """The compiled extension's module, or why there is none."""
    if not (shutil.which("gcc") or shutil.which("cc")):
        return "no C compiler"
    from dynderive.render.targets.c_extension.compile import build_extension

    filename, content = build_extension(derivation)
    path = work / filename
    path.write_bytes(content)
    name = f"{derivation.robot.name}_dynamics_c"
    spec = importlib.util.spec_from_file_location(name, path, loader=importlib.machinery.ExtensionFileLoader(name, str(path)))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--max", type=int, default=10**6, help="largest batch (default 10^6)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-extension", action="store_true", help="skip the compiled C extension")
    args = parser.parse_args()
    derivation = dynderive.derive(dynderive.load_robot(ROBOT))
    numpy_module = generated_module(dynderive.render_code(derivation), ROBOT)
    jax_module = generated_module(render_jax(derivation), f"{ROBOT}_jax")
    with tempfile.TemporaryDirectory() as folder:
        compiled = "skipped (--no-extension)" if args.no_extension else extension(derivation, Path(folder))
    print(f"JAX {jax.__version__}, device: {jax.devices()[0].device_kind} ({jax.default_backend()}); "
          f"robot {ROBOT}, {len(numpy_module.COORDINATES)} coordinates")
    if isinstance(compiled, str):
        print(f"C extension: {compiled}")
    header = (f"{'states':>9}  {'NumPy ms':>10}  {'C ext ms':>10}  {'JAX64 ms':>10}  {'JAX32 ms':>10}  "
              f"{'NumPy ns/st':>11}  {'C ns/st':>8}  {'JAX64 ns/st':>11}  {'JAX32 ns/st':>11}  {'compile s':>9}")
    print(header)
    rng = np.random.default_rng(0)
    size = 1000
    while size <= args.max:
        times, compile_seconds = measure(size, rng, numpy_module, jax_module, compiled, args.repeats)

        def cell(key: str, scale: float, width: int, times: dict = times) -> str:
            return f"{times[key] * scale:>{width}.3f}" if key in times else f"{'-':>{width}}"

        print(f"{size:>9}  {cell('numpy', 1e3, 10)}  {cell('c', 1e3, 10)}  {cell('jax64', 1e3, 10)}  "
              f"{cell('jax32', 1e3, 10)}  {cell('numpy', 1e9 / size, 11)}  {cell('c', 1e9 / size, 8)}  "
              f"{cell('jax64', 1e9 / size, 11)}  {cell('jax32', 1e9 / size, 11)}  {compile_seconds:>9.1f}", flush=True)
        size *= 10


def measure(size: int, rng: np.random.Generator, numpy_module, jax_module, compiled, repeats: int) -> tuple[dict, float]:
    """Seconds per call of each backend on ``size`` random states (after checking that they
    agree), and the seconds jax.jit took to compile the float64 function for that shape."""
    n, nu = len(numpy_module.COORDINATES), len(numpy_module.EFFORTS)
    q, qd, u = rng.uniform(-1.5, 1.5, (size, n)), rng.normal(size=(size, n)), rng.normal(size=(size, nu))
    expected = numpy_module.forward_dynamics(q[:CHECKED], qd[:CHECKED], u[:CHECKED])
    start = time.perf_counter()
    double = jax.jit(jax_module.forward_dynamics).lower(q, qd, u).compile()
    compile_seconds = time.perf_counter() - start
    single_args = [jax.device_put(a.astype(np.float32)) for a in (q, qd, u)]
    single = jax.jit(jax_module.forward_dynamics).lower(*single_args).compile()
    double_args = [jax.device_put(a) for a in (q, qd, u)]
    ours = np.asarray(double(*double_args))[:CHECKED]
    if relative(ours, expected) > 1e-12:
        raise SystemExit(f"JAX float64 differs from the NumPy module: {relative(ours, expected):.3g}")
    if relative(np.asarray(single(*single_args))[:CHECKED], expected) > 1e-3:
        raise SystemExit("JAX float32 is not close to the NumPy module")
    times = {"numpy": best(lambda: numpy_module.forward_dynamics(q, qd, u), repeats)}
    if not isinstance(compiled, str):
        if relative(compiled.forward_dynamics(q[:CHECKED], qd[:CHECKED], u[:CHECKED]), expected) > 1e-12:
            raise SystemExit("the C extension differs from the NumPy module")
        times["c"] = best(lambda: compiled.forward_dynamics(q, qd, u), repeats)
    times["jax64"] = best(lambda: double(*double_args).block_until_ready(), repeats)
    times["jax32"] = best(lambda: single(*single_args).block_until_ready(), repeats)
    return times, compile_seconds


if __name__ == "__main__":
    main()
