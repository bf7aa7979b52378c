"""The CasADi target beside adam's CasADi functions, and CasADi's generated C beside the
project's C, for the Panda (``robots/panda.urdf``), measured in the same run.

    python benchmarks/casadi_vs_adam.py [--states 10000] [--calls 200] [--repeats 3] [--rounds 3] [--no-jit]

Needs ``casadi``, gcc and adam (``pip install adam-robotics liecasadi``: a benchmark requirement,
in no extra; ``adam.casadi`` imports ``liecasadi``, which adam-robotics 0.5.0 does not install).
``dynderive solve robots/panda.urdf --casadi --c --out TMP`` writes the module and the C;
adam's ``KinDynComputations(urdf, joints)`` is built with the module's ``COORDINATES`` as its
joint list (the same order) and the module's gravity. adam's ``aba_fun`` is a floating-base
ABA; a fixed base's dynamics are the joint block of its ``mass_matrix_fun`` and
``bias_force_fun`` at the identity base pose and zero base velocity: inverse dynamics
``M_jj qdd + h_j``, forward dynamics ``solve(M_jj, u - h_j)`` (``casadi.solve``, one SX
Function). Both sides are wrapped alike: a plain ``casadi.Function`` of ``(q, qd, u)`` (or
``(q, qd, qdd)``), the module's parameters and friction smoothing fixed to their defaults,
``cse`` on.

Rows: forward (FD) and inverse (ID) dynamics. Columns, in microseconds per state:

* per call: one ``Function`` call from Python on NumPy vectors, the best of ``--repeats`` runs of
  ``--calls`` calls (``call jit``: of the jitted Function);
* map: ``Function.map(states)`` on ``(n, states)`` NumPy matrices, one call, the best of
  ``--repeats``; ``map jit``: the same of the Function built with ``jit=True`` (gcc -O2);
  ``... DM``: the same on ``casadi.DM`` matrices made beforehand, as inside an optimizer (the
  conversions of NumPy matrices cost about 1 us a state, more than either side's arithmetic);
* external: the project's C through CasADi's external ABI (``<name>_dynamics.c`` compiled with
  ``-D<NAME>_CASADI_EXTERNAL -O2``, ``casadi.external``) per call and through ``map``, against
  adam's jitted Functions (adam's fastest) and beside our jitted SX;
  each of these measured in ``--rounds`` rounds, taking turns, the best of the rounds;
* C: ``Function.generate`` of each side's Function, compiled with gcc -O2 with the project's C
  (``panda_forward_dynamics``, ``panda_inverse_dynamics``) into one timing program (the loop of
  ``benchmarks/compiled.py``: the best of ``--repeats`` runs of at least 20 ms), all six over
  the same states, one after the other.

Before timing, the project's FD and ID must agree with adam's to 1e-8 (relative to the largest
entry) at the first 100 states, and the generated C programs' results with the Python ones.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
# this file's own name is casadi: its folder, first on the path when run, would shadow the package
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

import casadi as ca  # noqa: E402

_spec = importlib.util.spec_from_file_location("compiled", ROOT / "benchmarks" / "compiled.py")
_compiled = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_compiled)
TIMING = _compiled.TIMING

CHECKED = 100
AGREE = 1e-8
GOALS = {"call": 0.5, "map": 0.2, "map jit": 0.2, "map DM": 0.2, "map jit DM": 0.2, "C": 2.0}
#: The ways of calling each side, in the table's order.
HOWS = ("call", "call jit", "map", "map jit", "map DM", "map jit DM", "call external", "map external",
        "map external DM")

DRIVER = TIMING + r"""
#include "panda_dynamics.h"
#include "ours_fd.h"
#include "ours_id.h"
#include "adam_fd.h"
#include "adam_id.h"
#define CASADI_TIME(kind, fun, a, b, c, out) do { \
    casadi_int sz_arg, sz_res, sz_iw, sz_w; fun##_work(&sz_arg, &sz_res, &sz_iw, &sz_w); \
    casadi_int *iw = (casadi_int *)malloc(sizeof(casadi_int) * (sz_iw + 1)); \
    double *w = (double *)malloc(sizeof(double) * (sz_w + 1)); \
    const double *arg[8]; double *res[8]; res[0] = out; \
    TIME(kind, (arg[0] = a + i * n, arg[1] = b + i * n, arg[2] = c + i * n, \
                fun(arg, res, iw, w, 0)), out[0]); \
    arg[0] = a, arg[1] = b, arg[2] = c; \
    for (long i = 0; i < CHECKED; ++i) { arg[0] = a + i * n; arg[1] = b + i * n; arg[2] = c + i * n; \
        fun(arg, res, iw, w, 0); fwrite(out, sizeof(double), (size_t)n, check); } \
    free(iw); free(w); } while (0)
int main(int argc, char **argv) {
    const long N = atol(argv[2]), n = atol(argv[3]);
    const int repeats = atoi(argv[4]);
    double *s = read_states(argv[1], N * 4 * n);
    const double *q = s, *qd = s + N * n, *qdd = s + 2 * N * n, *u = s + 3 * N * n;
    double acc[64], tau[64];
    FILE *check = fopen(argv[5], "wb");
    TIME("C_FD", (void)panda_forward_dynamics(q + i * n, qd + i * n, u + i * n, NULL, acc), acc[0]);
    for (long i = 0; i < CHECKED; ++i) {
        (void)panda_forward_dynamics(q + i * n, qd + i * n, u + i * n, NULL, acc);
        fwrite(acc, sizeof(double), (size_t)n, check); }
    TIME("C_ID", panda_inverse_dynamics(q + i * n, qd + i * n, qdd + i * n, NULL, tau), tau[0]);
    for (long i = 0; i < CHECKED; ++i) {
        panda_inverse_dynamics(q + i * n, qd + i * n, qdd + i * n, NULL, tau);
        fwrite(tau, sizeof(double), (size_t)n, check); }
    CASADI_TIME("ours_FD", ours_fd, q, qd, u, acc);
    CASADI_TIME("ours_ID", ours_id, q, qd, qdd, tau);
    CASADI_TIME("adam_FD", adam_fd, q, qd, u, acc);
    CASADI_TIME("adam_ID", adam_id, q, qd, qdd, tau);
    fclose(check);
    return 0;
}
"""


def relative(actual, expected) -> float:
    expected = np.asarray(expected)
    return float(np.max(np.abs(np.asarray(actual) - expected)) / max(float(np.max(np.abs(expected))), 1.0))


def generate(urdf: Path, work: Path):
    """``dynderive solve URDF --casadi --c --out WORK``; the imported CasADi module."""
    command = [sys.executable, "-m", "dynderive", "solve", str(urdf), "--casadi", "--c", "--out", str(work)]
    environment = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    subprocess.run(command, check=True, capture_output=True, env=environment)
    path = next(work.glob("*_dynamics_casadi.py"))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def functions(module, urdf: Path, options: dict) -> dict[str, ca.Function]:
    """Plain Functions of (q, qd, u) / (q, qd, qdd) for both sides, built with ``options``."""
    try:
        from adam.casadi import KinDynComputations
    except ImportError as error:
        raise SystemExit(f"needs adam: pip install adam-robotics liecasadi ({error})") from None

    n = len(module.COORDINATES)
    p = module.default_parameters()
    q, qd, x = ca.SX.sym("q", n), ca.SX.sym("qd", n), ca.SX.sym("x", n)
    g = np.array([0.0, 0.0, -float(module.PARAMETERS["g"]), 0.0, 0.0, 0.0])   # the URDF's gravity: -z
    kd = KinDynComputations(str(urdf), list(module.COORDINATES), gravity=g, f_opts={"cse": True})
    H, vb = ca.SX.eye(4), ca.SX.zeros(6)
    M = kd.mass_matrix(H, q)[6:, 6:]
    h = kd.bias_force(H, q, vb, qd)[6:]
    return {
        "ours_fd": ca.Function("ours_fd", [q, qd, x], [module.forward_dynamics(q, qd, x, p, 0.0)], options),
        "ours_id": ca.Function("ours_id", [q, qd, x], [module.inverse_dynamics(q, qd, x, p, 0.0)], options),
        "adam_fd": ca.Function("adam_fd", [q, qd, x], [ca.solve(M, x - h)], options),
        "adam_id": ca.Function("adam_id", [q, qd, x], [ca.mtimes(M, x) + h], options),
    }


def values(f: ca.Function, q, qd, x) -> np.ndarray:
    """``f`` at the first CHECKED states, one row each."""
    return np.array([np.asarray(f(q[i], qd[i], x[i])).ravel() for i in range(CHECKED)])


def best(call, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return min(times)


def python_times(fs: dict, states: tuple, calls: int, repeats: int, label: str) -> dict[str, float]:
    """Microseconds per state: ``label`` "call" (one call per state) or "map"."""
    q, qd, qdd, u = states
    size = q.shape[0]
    out = {}
    mapped = {name: f.map(size) for name, f in fs.items()} if label != "call" else {}
    for name in fs:
        x = u if name.endswith("fd") else qdd
        if label == "call":
            rows = [(q[i], qd[i], x[i]) for i in range(calls)]
            out[name] = best(lambda f=fs[name], rows=rows: [f(*r) for r in rows], repeats) * 1e6 / calls
        else:
            args = (q.T.copy(), qd.T.copy(), x.T.copy())
            args = tuple(ca.DM(a) for a in args) if label == "map DM" else args
            out[name] = best(lambda m=mapped[name], args=args: m(*args), repeats) * 1e6 / size
    return out


def c_times(fs: dict, states: tuple, work: Path, repeats: int) -> dict[str, float]:
    """Generate each Function's C, build one program with the project's C, run it."""
    q, qd, qdd, u = states
    size, n = q.shape
    for name, f in fs.items():
        f.generate(f"{name}.c", {"with_header": True, "casadi_real": "double", "casadi_int": "long long int"})
        shutil.move(f"{name}.c", work / f"{name}.c")
        shutil.move(f"{name}.h", work / f"{name}.h")
    (work / "driver.c").write_text(DRIVER)
    binary = work / "driver"
    sources = [work / "driver.c", work / "panda_dynamics.c", *(work / f"{name}.c" for name in fs)]
    subprocess.run(["gcc", "-std=c99", "-O2", "-DNDEBUG", f"-DCHECKED={CHECKED}", f"-I{work}",
                    *map(str, sources), "-o", str(binary), "-lm"], check=True)
    data = work / "states.bin"
    np.concatenate([a.ravel() for a in (q, qd, qdd, u)]).tofile(data)
    check = work / "check.bin"
    done = subprocess.run([str(binary), str(data), str(size), str(n), str(repeats), str(check)],
                          capture_output=True, text=True, check=True)
    lines = (line.split() for line in done.stdout.splitlines() if line.strip())
    times = {kind: float(ns) / 1000 for kind, ns in lines}
    results = np.fromfile(check).reshape(6, CHECKED, n)
    return times, results


def externals(work: Path, fallback: dict) -> dict[str, ca.Function]:
    """The project's C FD and ID as ``casadi.external`` Functions, beside adam's ``fallback``
    ones (jitted when jit is on)."""
    library = work / "libpanda_external.so"
    subprocess.run(["gcc", "-std=c99", "-O2", "-shared", "-fPIC", "-DPANDA_CASADI_EXTERNAL",
                    str(work / "panda_dynamics.c"), "-o", str(library), "-lm"], check=True)
    return {"ours_fd": ca.external("panda_casadi_forward_dynamics", str(library)),
            "ours_id": ca.external("panda_casadi_inverse_dynamics", str(library)),
            "adam_fd": fallback["adam_fd"], "adam_id": fallback["adam_id"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=10_000)
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-jit", action="store_true")
    args = parser.parse_args()
    urdf = ROOT / "robots" / "panda.urdf"
    jit = not args.no_jit and shutil.which("gcc") is not None
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as directory:
        work = Path(directory)
        module = generate(urdf, work)
        n = len(module.COORDINATES)
        rng = np.random.default_rng(28)
        q = rng.uniform(-np.pi, np.pi, (args.states, n))
        qd, qdd, u = (rng.normal(size=(args.states, n)) for _ in range(3))
        states = (q, qd, qdd, u)
        plain = functions(module, urdf, {"cse": True})
        # the same computation on both sides, before any timing
        for kind, x in (("fd", u), ("id", qdd)):
            ours, adam = (values(plain[f"{side}_{kind}"], q, qd, x) for side in ("ours", "adam"))
            worst = relative(ours, adam)
            if worst > AGREE:
                raise SystemExit(f"{kind.upper()}: the project's CasADi and adam's differ by {worst:.3g}")
            print(f"{kind.upper()}: the project's CasADi and adam's agree at {CHECKED} states: {worst:.1e}")
        cwd = os.getcwd()
        os.chdir(work)   # CasADi's jit and generate write into the working directory
        try:
            options = {"cse": True, "jit": True, "compiler": "shell", "jit_options": {"flags": ["-O2"]}}
            compiled = functions(module, urdf, options) if jit else {}
            external = externals(work, compiled or plain)
            for kind, x in (("fd", u), ("id", qdd)):
                worst = relative(values(external[f"ours_{kind}"], q, qd, x), values(plain[f"ours_{kind}"], q, qd, x))
                if worst > AGREE:
                    raise SystemExit(f"{kind.upper()}: the external C and the CasADi module differ by {worst:.3g}")
            c, checked = c_times(plain, states, work, args.repeats)
            pairs = (("ours_fd", u), ("ours_id", qdd)) * 2 + (("adam_fd", u), ("adam_id", qdd))
            expected = [values(plain[f], q, qd, x) for f, x in pairs]
            labels = ("C FD", "C ID", "ours FD", "ours ID", "adam FD", "adam ID")
            for label, got, want in zip(labels, checked, expected):
                if relative(got, want) > AGREE:
                    raise SystemExit(f"generated C {label} differs from CasADi: {relative(got, want):.3g}")
            measured: dict[str, dict[str, float]] = {}
            for _ in range(args.rounds):   # the kinds take turns; the best of the rounds
                kinds = [("call", plain, "call"), ("map", plain, "map"), ("map DM", plain, "map DM")]
                kinds += [("call jit", compiled, "call"), ("map jit", compiled, "map"),
                          ("map jit DM", compiled, "map DM")] if jit else []
                kinds += [("call external", external, "call"), ("map external", external, "map"),
                          ("map external DM", external, "map DM")]
                for how, fs, label in kinds:
                    got = python_times(fs, states, args.calls, args.repeats, label)
                    old = measured.setdefault(how, got)
                    measured[how] = {name: min(old[name], got[name]) for name in got}
        finally:
            # the jitted libraries live in the directory: release them before it goes
            compiled = kinds = fs = external = None  # noqa: F841
            os.chdir(cwd)
    report(measured, c, args, jit, time.perf_counter() - started)


def report(measured: dict, c: dict, args, jit: bool, seconds: float) -> None:
    print(f"\nPanda, 7 joints; CasADi {ca.__version__}; {args.states} states; microseconds per state")
    header = f"{'':4} {'how':15} {'dynderive':>10} {'adam':>10} {'ratio':>7}"
    print(header + "\n" + "-" * len(header))
    goals = []
    for kind in ("FD", "ID"):
        for how in HOWS:
            if how not in measured:
                continue
            ours, adam = measured[how][f"ours_{kind.lower()}"], measured[how][f"adam_{kind.lower()}"]
            sx = measured.get(how.replace("external", "jit" if jit else "").replace("  ", " ").strip(), {})
            beside = f"   our SX{' jit' if jit else ''} {sx[f'ours_{kind.lower()}']:.3f}" if "external" in how else ""
            print(f"{kind:4} {how:15} {ours:>10.3f} {adam:>10.3f} {ours / adam:>7.2f}{beside}")
            if how in GOALS:
                goals.append((f"{kind} {how}: at most {GOALS[how]}x adam's time", ours / adam, GOALS[how]))
        ours, adam, own = c[f"ours_{kind}"], c[f"adam_{kind}"], c[f"C_{kind}"]
        print(f"{kind:4} {'C (-O2)':15} {ours:>10.3f} {adam:>10.3f} {ours / adam:>7.2f}   "
              f"project's C {own:.3f}, CasADi C / project's C {ours / own:.2f}")
        goals.append((f"{kind} CasADi-generated C within {GOALS['C']}x of the project's C",
                      ours / own, GOALS["C"]))
    print()
    for text, ratio, goal in goals:
        print(f"{text:60} {ratio:>6.2f}x  {'met' if ratio <= goal else 'NOT met'}")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    machine = platform.processor() or platform.machine()
    print(f"\n({seconds:.0f} s; Python {platform.python_version()}; {machine}, {os.cpu_count()} cores, "
          f"load average {load:.1f}; jit {'on (gcc -O2)' if jit else 'off'})")


if __name__ == "__main__":
    main()
