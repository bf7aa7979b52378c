"""Compiled code: the generated C beside Pinocchio C++, and the generated Python
(NumPy module, compiled extension) beside ``pin`` from Python, for the UR5 and the Panda.

    python benchmarks/compiled.py [--repeats 7] [--rounds 3] [--batch 100000] [--build-dir DIR]

From C: ``<name>_dynamics.c`` (``render_c``) and a small C loop over ``--states`` pre-generated
random states (full precision), against a C++ program built on the ``pin`` wheel's
libpinocchio (``pinocchio::urdf::buildModel`` of the same URDF, the same gravity, the same
states; ``crba``, ``rnea``, ``aba``, ``computeABADerivatives``). Both loops sum an entry of each
result so that no call is optimised away. Before timing, each program writes its results at
the first 20 states, and after the first round the script stops unless both sides agree (M,
tau, qdd and dqdd/dq to 1e-9 relative): the comparison is of the same computation. Times are per state, the best of
``--repeats`` runs of the loop (each at least 20 ms) in each of ``--rounds`` rounds, the
programs taking turns (on a shared machine the best run is the least disturbed one). The
Pinocchio program is built twice (1-5 minutes; ``--build-dir`` keeps it for the next run): against
libpinocchio_default.so (the algorithms as the wheel compiled them: ``extern template``
instantiations) and header-only (the algorithms compiled here with the table's flags).

From Python: one state (the best of ``--repeats`` runs of 200 calls) and a batch of
``--batch`` states (one call, the best of ``--repeats``; ``pin`` in a Python loop, having no batch
call). The compiled extension ``<name>_dynamics_c``
(``dynderive.render.targets.c_extension.compile.build_extension``) has its own rows (``extension_rows``),
skipped with a note while that module does not exist.

Needs gcc and g++, and the C++ headers of Eigen and urdfdom: ``pip install cmeel-eigen
cmeel-urdfdom-headers`` (the ``bench`` extra); without them the Pinocchio C++ columns say why
and the rest runs.
"""

from __future__ import annotations

import argparse
import importlib.machinery
import importlib.util
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

import dynderive  # noqa: E402
from dynderive.render.targets.c.c import render_c  # noqa: E402
from dynderive.verify.checks import generated_module  # noqa: E402

ROBOTS = ["ur5", "panda"]
CHECKED = 20      # states whose results both C programs write and the script compares
AGREE = 1e-9      # relative agreement required of M, tau, qdd and dqdd/dq before timing
FLAGS = ["-O3", "-DNDEBUG"]
KINDS = [("M", "mass matrix", "crba"), ("ID", "inverse dynamics", "rnea"),
         ("FD", "forward dynamics", "aba"), ("lin", "linearize", "computeABADerivatives")]

# A loop over the states, shared by both programs: TIME(kind, call, sink expression).
TIMING = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
static double now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}
static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}
static double *read_states(const char *path, long count) {
    double *data = (double *)malloc((size_t)count * sizeof(double));
    FILE *file = fopen(path, "rb");
    if (!data || !file || fread(data, sizeof(double), (size_t)count, file) != (size_t)count) {
        fprintf(stderr, "cannot read %ld numbers from %s\n", count, path);
        exit(2);
    }
    fclose(file);
    return data;
}
static volatile double sink;
/* the best of `repeats` runs of `passes` loops over the N states (each run >= 20 ms); ns per state */
#define TIME(kind, call, value) do { \
    double runs[64], total = 0.0; long passes = 1; \
    for (;;) { double t = now_ns(); \
        for (long pass = 0; pass < passes; ++pass) for (long i = 0; i < N; ++i) { call; total += (value); } \
        if (now_ns() - t > 2e7 || passes > 1000000) break; passes *= 2; } \
    for (int r = 0; r < repeats && r < 64; ++r) { double t = now_ns(); \
        for (long pass = 0; pass < passes; ++pass) for (long i = 0; i < N; ++i) { call; total += (value); } \
        runs[r] = (now_ns() - t) / (double)(passes * N); } \
    qsort(runs, (size_t)(repeats < 64 ? repeats : 64), sizeof(double), by_value); \
    sink = total; printf("%s %.3f\n", kind, runs[0]); } while (0)
"""

OURS = TIMING + r"""
#include ROBOT_HEADER
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define F(x) CAT(ROBOT, x)
int main(int argc, char **argv) {
    const long N = atol(argv[2]), n = atol(argv[3]), nu = atol(argv[4]);
    const int repeats = atoi(argv[5]);
    double *s = read_states(argv[1], N * (3 * n + nu));
    const double *q = s, *qd = s + N * n, *qdd = s + 2 * N * n, *u = s + 3 * N * n;
    double *M = (double *)malloc(sizeof(double) * n * n), *tau = (double *)malloc(sizeof(double) * n);
    double *acc = (double *)malloc(sizeof(double) * n);
    double *A = (double *)malloc(sizeof(double) * 4 * n * n), *B = (double *)malloc(sizeof(double) * 2 * n * nu);
    FILE *out = fopen(argv[6], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        F(mass_matrix)(q + i * n, NULL, M);
        F(inverse_dynamics)(q + i * n, qd + i * n, qdd + i * n, NULL, tau);
        if (F(forward_dynamics)(q + i * n, qd + i * n, u + i * nu, NULL, acc) != 0) return 3;
        if (F(linearize)(q + i * n, qd + i * n, u + i * nu, NULL, A, B) != 0) return 3;
        fwrite(M, sizeof(double), (size_t)(n * n), out);
        fwrite(tau, sizeof(double), (size_t)n, out);
        fwrite(acc, sizeof(double), (size_t)n, out);
        for (long r = 0; r < n; ++r) fwrite(A + (n + r) * 2 * n, sizeof(double), (size_t)n, out);
    }
    fclose(out);
    TIME("M", F(mass_matrix)(q + i * n, NULL, M), M[n * n - 1]);
    TIME("ID", F(inverse_dynamics)(q + i * n, qd + i * n, qdd + i * n, NULL, tau), tau[0]);
    TIME("FD", (void)F(forward_dynamics)(q + i * n, qd + i * n, u + i * nu, NULL, acc), acc[0]);
    TIME("lin", (void)F(linearize)(q + i * n, qd + i * n, u + i * nu, NULL, A, B), A[4 * n * n - 1]);
    return 0;
}
"""

PINOCCHIO = r"""
#include <pinocchio/parsers/urdf.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <vector>
""" + TIMING + r"""
int main(int argc, char **argv) {
    const long N = atol(argv[2]), n = atol(argv[3]);
    const int repeats = atoi(argv[5]);
    pinocchio::Model model;
    pinocchio::urdf::buildModel(argv[7], model);
    pinocchio::Data data(model);
    if (model.nq != n || model.nv != n) { fprintf(stderr, "nq %d, nv %d: not %ld\n", model.nq, model.nv, n); return 2; }
    double *s = read_states(argv[1], N * 4 * n);
    std::vector<Eigen::VectorXd> q(N), qd(N), qdd(N), u(N);
    for (long i = 0; i < N; ++i) {
        q[i] = Eigen::Map<Eigen::VectorXd>(s + i * n, n);
        qd[i] = Eigen::Map<Eigen::VectorXd>(s + N * n + i * n, n);
        qdd[i] = Eigen::Map<Eigen::VectorXd>(s + 2 * N * n + i * n, n);
        u[i] = Eigen::Map<Eigen::VectorXd>(s + 3 * N * n + i * n, n);
    }
    FILE *out = fopen(argv[6], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        pinocchio::crba(model, data, q[i]);
        Eigen::MatrixXd M = data.M.triangularView<Eigen::Upper>();
        M.triangularView<Eigen::StrictlyLower>() = M.transpose();
        Eigen::MatrixXd Mt = M.transpose();   /* row-major, as ours */
        fwrite(Mt.data(), sizeof(double), (size_t)(n * n), out);
        Eigen::VectorXd tau = pinocchio::rnea(model, data, q[i], qd[i], qdd[i]);
        fwrite(tau.data(), sizeof(double), (size_t)n, out);
        Eigen::VectorXd acc = pinocchio::aba(model, data, q[i], qd[i], u[i]);
        fwrite(acc.data(), sizeof(double), (size_t)n, out);
        pinocchio::computeABADerivatives(model, data, q[i], qd[i], u[i]);
        Eigen::MatrixXd D = data.ddq_dq.transpose();
        fwrite(D.data(), sizeof(double), (size_t)(n * n), out);
    }
    fclose(out);
    TIME("M", pinocchio::crba(model, data, q[i]), data.M(0, n - 1));
    TIME("ID", pinocchio::rnea(model, data, q[i], qd[i], qdd[i]), data.tau[0]);
    TIME("FD", pinocchio::aba(model, data, q[i], qd[i], u[i]), data.ddq[0]);
    TIME("lin", pinocchio::computeABADerivatives(model, data, q[i], qd[i], u[i]), data.ddq_dq(n - 1, n - 1));
    return 0;
}
"""


def _prefix() -> Path:
    return Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"


def pinocchio_command(source: Path, binary: Path, library: bool) -> list[str] | str:
    """The g++ command building the Pinocchio program, or why it cannot be built."""
    prefix = _prefix()
    include = prefix / "include"
    missing = [what for what, path in (
        ("g++", shutil.which("g++")), ("the pin wheel's libpinocchio", (prefix / "lib" / "libpinocchio_default.so").exists()),
        ("Eigen's headers (pip install cmeel-eigen)", (include / "eigen3" / "Eigen" / "Core").exists()),
        ("urdfdom's headers (pip install cmeel-urdfdom-headers)", (include / "urdfdom_headers" / "urdf_model" / "model.h").exists()),
        ("Pinocchio's headers", (include / "pinocchio" / "algorithm" / "aba.hpp").exists())) if not path]
    if missing:
        return "not built: no " + ", no ".join(missing)
    defines = [*_wheel_defines(prefix), f"CHECKED={CHECKED}"]
    if library:
        defines.append("PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION")
    return ["g++", *FLAGS, "-std=c++17", "-w", *(f"-D{d}" for d in defines),
            *(f"-I{include / d}" for d in ("", "eigen3", "urdfdom_headers", "urdfdom", "pinocchio/deprecated")),
            str(source), "-o", str(binary), f"-L{prefix / 'lib'}", f"-Wl,-rpath,{prefix / 'lib'}",
            "-lpinocchio_parsers", "-lpinocchio_default", "-lurdfdom_model"]


def _wheel_defines(prefix: Path) -> list[str]:
    """The definitions the wheel's CMake targets ask of code built on its headers (urdfdom's
    header version, Boost.MPL's sizes), read from its ``pinocchioTargets.cmake``."""
    targets = prefix / "lib" / "cmake" / "pinocchio" / "pinocchioTargets.cmake"
    found = ["PINOCCHIO_WITH_URDFDOM"]
    text = targets.read_text() if targets.exists() else ""
    for line in text.splitlines():
        if "INTERFACE_COMPILE_DEFINITIONS" in line:
            for item in line.split('"')[1].split(";"):
                if item.startswith(("BOOST_", "PINOCCHIO_URDFDOM_HEADERS_")) and item not in found:
                    found.append(item)
    if len(found) == 1:   # no CMake file: the pin 3.x / 4.x wheels' values
        found += ["PINOCCHIO_URDFDOM_HEADERS_MAJOR_VERSION=3", "PINOCCHIO_URDFDOM_HEADERS_MINOR_VERSION=0",
                  "PINOCCHIO_URDFDOM_HEADERS_PATCH_VERSION=0", "BOOST_MPL_LIMIT_LIST_SIZE=30",
                  "BOOST_MPL_LIMIT_VECTOR_SIZE=30", "BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
                  "BOOST_FUSION_INVOKE_MAX_ARITY=12"]
    return found


def run_program(command: list[str], label: str) -> dict[str, float]:
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{label} failed ({done.returncode}): {done.stderr[-600:]}")
    return {kind: float(value) for kind, value in (line.split() for line in done.stdout.split("\n") if line.strip())}


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


class Robot:
    """One robot: its derivation, NumPy module, Pinocchio model and random states (ours and
    Pinocchio's coordinate order)."""

    def __init__(self, name: str, states: int, batch: int):
        import pinocchio as pin

        self.urdf = ROOT / "robots" / f"{name}.urdf"
        self.derivation = dynderive.derive(dynderive.load_robot(str(self.urdf)))
        self.name = self.derivation.robot.name
        self.module = generated_module(dynderive.render_code(self.derivation), self.name)
        self.model = pin.buildModelFromUrdf(str(self.urdf))
        self.data = self.model.createData()
        self.perm = [list(self.module.COORDINATES).index(j) for j in self.model.names[1:]]
        self.n, self.nu = len(self.derivation.symbols.q), len(self.derivation.symbols.efforts)
        rng = np.random.default_rng(28)
        count = max(states, batch)
        self.q = rng.uniform(-np.pi, np.pi, (count, self.n))
        self.qd, self.qdd = rng.normal(size=(count, self.n)), rng.normal(size=(count, self.n))
        self.u = rng.normal(size=(count, self.nu))
        self.states = states


def c_side(robot: Robot, work: Path, repeats: int, rounds: int, pin_binaries: dict[str, Path | str]) -> dict:
    """Compile ours (-O3 and -O2); run ours and both Pinocchio programs in turn, ``rounds``
    times (the best time of each); check that both sides agree."""
    header, source = render_c(robot.derivation)
    name, n, nu, N = robot.name, robot.n, robot.nu, robot.states
    (work / f"{name}_dynamics.h").write_text(header)
    (work / f"{name}_dynamics.c").write_text(source)
    (work / f"{name}_bench.c").write_text(OURS)
    ours_states = work / f"{name}_states.bin"
    np.concatenate([a[:N].ravel() for a in (robot.q, robot.qd, robot.qdd, robot.u)]).tofile(ours_states)
    pin_states = work / f"{name}_pin_states.bin"
    if nu != n:   # a URDF's efforts are its joints' torques; the check below tells any other map
        raise RuntimeError(f"{name}: {nu} efforts for {n} coordinates; no like-for-like Pinocchio call")
    np.concatenate([a[:N][:, robot.perm].ravel() for a in (robot.q, robot.qd, robot.qdd, robot.u)]).tofile(pin_states)
    result: dict = {}
    for flags in (FLAGS, ["-O2", "-DNDEBUG"]):
        binary, objects = work / f"{name}_ours{flags[0]}", work / f"{name}_dynamics{flags[0]}.o"
        start = time.perf_counter()   # the generated file alone: the compile-time goal
        subprocess.run(["gcc", "-std=c99", *flags, "-c", str(work / f"{name}_dynamics.c"), "-o", str(objects)],
                       check=True)
        result[f"compile{flags[0]}"] = time.perf_counter() - start
        subprocess.run(["gcc", "-std=c99", *flags, f"-DROBOT={name}_", f'-DROBOT_HEADER="{name}_dynamics.h"',
                        f"-DCHECKED={CHECKED}", f"-I{work}", str(work / f"{name}_bench.c"), str(objects),
                        "-o", str(binary), "-lm"], check=True)
    runs = [(f"ours{flags}", [str(work / f"{name}_ours{flags}"), str(ours_states), str(N), str(n), str(nu),
                              str(repeats), str(work / f"{name}_ours{flags}.check")]) for flags in ("-O3", "-O2")]
    runs += [(kind, [str(binary), str(pin_states), str(N), str(n), str(nu), str(repeats),
                     str(work / f"{name}_{kind}.check"), str(robot.urdf)])
             for kind, binary in pin_binaries.items() if not isinstance(binary, str)]
    result |= {kind: binary for kind, binary in pin_binaries.items() if isinstance(binary, str)}
    for round_ in range(max(1, rounds)):
        for kind, command in runs:
            times = run_program(command, f"{name} {kind}")
            result[kind] = {k: min(v, result.get(kind, times)[k]) for k, v in times.items()}
        if round_ == 0:   # each program wrote its results before timing: compare them now
            result |= _agreement(robot, work, [kind for kind, _ in runs[2:]])
    return result


def _agreement(robot: Robot, work: Path, kinds: list[str]) -> dict:
    """The largest relative differences of M, tau, qdd and dqdd/dq between ours and each
    Pinocchio program at the first states; an error above ``AGREE``."""
    name, n = robot.name, robot.n
    ours = np.fromfile(work / f"{name}_ours-O3.check").reshape(-1, 2 * n * n + 2 * n)
    back = np.argsort(robot.perm)   # Pinocchio's order -> ours
    square = np.ix_(back, back)
    result = {}
    for kind in kinds:
        theirs = np.fromfile(work / f"{name}_{kind}.check").reshape(-1, 2 * n * n + 2 * n)
        diffs = []
        for a, b in zip(ours, theirs):
            pieces_a = np.split(a, [n * n, n * n + n, n * n + 2 * n])
            pieces_b = np.split(b, [n * n, n * n + n, n * n + 2 * n])
            pieces_b = [pieces_b[0].reshape(n, n)[square].ravel(), pieces_b[1][back], pieces_b[2][back],
                        pieces_b[3].reshape(n, n)[square].ravel()]
            diffs.append([relative(x, y) for x, y in zip(pieces_a, pieces_b)])
        worst = np.max(np.array(diffs), axis=0)
        result[f"{kind} diff"] = dict(zip(["M", "ID", "FD", "lin"], worst.tolist()))
        if len(diffs) < min(CHECKED, robot.states) or np.max(worst) > AGREE:
            raise RuntimeError(f"{name}: the C code and Pinocchio ({kind}) disagree: {result[f'{kind} diff']}")
    return result


def _best_us(run, calls: int, repeats: int) -> float:
    """The best of ``repeats`` runs, in us per call (on a shared machine, the least disturbed)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append((time.perf_counter() - start) / calls)
    return min(times) * 1e6


def module_rows(module, robot: Robot, repeats: int, batch: int, label: str) -> dict:
    """One state and a batch of ``batch`` states through a module with the NumPy module's API."""
    q, qd, qdd, u = robot.q, robot.qd, robot.qdd, robot.u
    # one state: called exactly as pin is below (the arguments indexed in the call, nothing else)
    calls = {"M": lambda k: module.mass_matrix(q[k]),
             "ID": lambda k: module.inverse_dynamics(q[k], qd[k], qdd[k]),
             "FD": lambda k: module.forward_dynamics(q[k], qd[k], u[k]),
             "lin": lambda k: module.linearize(q[k], qd[k], u[k])}
    batches = {"M": lambda k: module.mass_matrix(q[:k]),
               "ID": lambda k: module.inverse_dynamics(q[:k], qd[:k], qdd[:k]),
               "FD": lambda k: module.forward_dynamics(q[:k], qd[:k], u[:k]),
               "lin": lambda k: module.linearize(q[:k], qd[:k], u[:k])}
    row = {"label": label}
    for kind, call in calls.items():
        call(0)   # warm: first calls import and allocate
        batches[kind](2)
        row[kind] = _best_us(lambda call=call: [call(k) for k in range(200)], 200, repeats)
        row[f"{kind} batch"] = _best_us(lambda call=batches[kind]: call(batch), batch, repeats) * 1e3
    return row


def pin_rows(robot: Robot, repeats: int, batch: int) -> dict:
    import pinocchio as pin

    model, data, perm = robot.model, robot.data, robot.perm
    q, qd, qdd, u = (x[:, perm] for x in (robot.q, robot.qd, robot.qdd, robot.u))
    calls = {"M": lambda k: pin.crba(model, data, q[k]),
             "ID": lambda k: pin.rnea(model, data, q[k], qd[k], qdd[k]),
             "FD": lambda k: pin.aba(model, data, q[k], qd[k], u[k]),
             "lin": lambda k: pin.computeABADerivatives(model, data, q[k], qd[k], u[k])}
    row = {"label": "pin from Python"}
    for kind, call in calls.items():
        row[kind] = _best_us(lambda call=call: [call(k) for k in range(200)], 200, repeats)
        row[f"{kind} batch"] = _best_us(lambda call=call: [call(k) for k in range(batch)], batch,
                                        repeats) * 1e3
    return row


# --- The compiled extension <name>_dynamics_c (--c-extension) ---

def extension_rows(robot: Robot, work: Path, repeats: int, batch: int) -> dict | str:
    """The rows of the compiled extension, or why there are none: it is built by
    ``dynderive.render.targets.c_extension.compile.build_extension(derivation) -> (filename, bytes)`` and has the
    NumPy module's API (one state or a batch)."""
    try:
        from dynderive.render.targets.c_extension.compile import build_extension
    except ImportError:
        return "extension not built (dynderive.render.targets.c_extension.compile does not exist yet)"
    filename, content = build_extension(robot.derivation)
    path = work / filename
    path.write_bytes(content)
    module_name = f"{robot.name}_dynamics_c"
    spec = importlib.util.spec_from_file_location(module_name, path,
                                                  loader=importlib.machinery.ExtensionFileLoader(module_name, str(path)))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    for kind, ours, theirs in (("M", module.mass_matrix(robot.q[:3]), robot.module.mass_matrix(robot.q[:3])),
                               ("FD", module.forward_dynamics(robot.q[:3], robot.qd[:3], robot.u[:3]),
                                robot.module.forward_dynamics(robot.q[:3], robot.qd[:3], robot.u[:3]))):
        if relative(np.asarray(ours), np.asarray(theirs)) > 1e-12:
            raise RuntimeError(f"{robot.name}: the extension's {kind} differs from the NumPy module's")
    return module_rows(module, robot, repeats, batch, "extension from Python")


# --- Tables ---

def _format(rows: list[list[str]]) -> str:
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    lines = ["  ".join(cell.rjust(w) if c else cell.ljust(w) for c, (cell, w) in enumerate(zip(row, widths)))
             for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def c_table(results: dict) -> str:
    rows = [["robot", "what", *(f"{k} ns" for k, _, _ in KINDS)]]
    for name, r in results.items():
        rows.append([name, "ours C -O3 -DNDEBUG", *(f"{r['ours-O3'][k]:.0f}" for k, _, _ in KINDS)])
        rows.append([name, "ours C -O2 -DNDEBUG", *(f"{r['ours-O2'][k]:.0f}" for k, _, _ in KINDS)])
        for kind, label in (("lib", "Pinocchio C++ (libpinocchio)"), ("headers", "Pinocchio C++ (headers -O3)")):
            if isinstance(r.get(kind), str):
                rows.append([name, label, r[kind], "", "", ""])
                continue
            rows.append([name, label, *(f"{r[kind][k]:.0f}" for k, _, _ in KINDS)])
            rows.append([name, "  Pinocchio / ours -O3", *(f"{r[kind][k] / r['ours-O3'][k]:.1f}x" for k, _, _ in KINDS)])
        diffs = [r[f"{kind} diff"] for kind in ("lib", "headers") if f"{kind} diff" in r]
        if diffs:
            rows.append([name, "  largest relative difference", *(f"{max(d[k] for d in diffs):.0e}" for k, _, _ in KINDS)])
    return _format(rows)


def python_table(results: dict, batch: int) -> str:
    rows = [["robot", "what", *(f"{k} 1x us" for k, _, _ in KINDS), *(f"{k} batch ns" for k, _, _ in KINDS)]]
    notes = []
    for name, entries in results.items():
        for entry in entries:
            if isinstance(entry, str):
                notes.append(f"{name}: {entry}")
                continue
            rows.append([name, entry["label"], *(f"{entry[k]:.2f}" for k, _, _ in KINDS),
                         *(f"{entry[f'{k} batch']:.0f}" for k, _, _ in KINDS)])
    return _format(rows) + "".join(f"\n{note}" for note in notes)


def goals(c_results: dict, py_results: dict) -> list[tuple[str, str, str]]:
    items = []
    panda = c_results.get("panda")
    for kind, what, pin_name in KINDS[:3]:
        goal = f"Panda {what} from C <= 1/2 of Pinocchio C++ ({pin_name})"
        if panda is None:
            continue
        builds = [panda[k] for k in ("lib", "headers") if not isinstance(panda.get(k), str)]
        if not builds:
            items.append((goal, panda["lib"], "not measured"))
            continue
        fastest = min(b[kind] for b in builds)
        ratio = fastest / panda["ours-O3"][kind]
        items.append((goal, f"{panda['ours-O3'][kind]:.0f} vs {fastest:.0f} ns: {ratio:.1f}x", "met" if ratio >= 2 else "NOT MET"))
    for name, entries in py_results.items():
        extension = next((e for e in entries if not isinstance(e, str) and e["label"].startswith("extension")), None)
        numpy_row = next(e for e in entries if not isinstance(e, str) and e["label"].startswith("NumPy"))
        pin_row = next(e for e in entries if not isinstance(e, str) and e["label"].startswith("pin"))
        for kind, what, pin_name in KINDS[:3]:
            goal = f"{name} {what}: one extension call <= pin.{pin_name} from Python"
            if extension is None:
                items.append((goal, "extension not built", "not measured"))
            else:
                items.append((goal, f"{extension[kind]:.2f} vs {pin_row[kind]:.2f} us",
                              "met" if extension[kind] <= pin_row[kind] else "NOT MET"))
        goal = f"{name}: extension batch >= 3x faster than the NumPy module (M, ID, FD, lin)"
        if extension is None:
            items.append((goal, "extension not built", "not measured"))
        else:
            ratios = [numpy_row[f"{k} batch"] / extension[f"{k} batch"] for k, _, _ in KINDS]
            items.append((goal, ", ".join(f"{r:.1f}x" for r in ratios), "met" if min(ratios) >= 3 else "NOT MET"))
    if panda is not None:
        seconds = panda["compile-O2"]
        items.append(("Panda's C (panda_dynamics.c) compiled with gcc -O2 < 30 s", f"{seconds:.1f} s", "met" if seconds < 30 else "NOT MET"))
    return items


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="runs of each loop (the best counts)")
    parser.add_argument("--rounds", type=int, default=3, help="times each C program runs, in turn with the others")
    parser.add_argument("--batch", type=int, default=100_000, help="states in one batch call from Python")
    parser.add_argument("--states", type=int, default=1000, help="states in the C loops")
    parser.add_argument("--build-dir", type=Path, help="keep the programs here; reuse its Pinocchio programs "
                        "when their source and command are the same (each takes 1-5 minutes to build)")
    args = parser.parse_args()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="dynderive-compiled-") as directory:
        work = args.build_dir or Path(directory)
        work.mkdir(parents=True, exist_ok=True)
        (work / "pin_bench.cpp").write_text(PINOCCHIO)
        pin_binaries: dict[str, Path | str] = {}
        pin_compile: dict[str, float] = {}
        for kind in ("lib", "headers"):
            command = pinocchio_command(work / "pin_bench.cpp", work / f"pin_{kind}", kind == "lib")
            if isinstance(command, str):
                pin_binaries[kind] = command
                continue
            stamp = work / f"pin_{kind}.command"
            if stamp.exists() and stamp.read_text() == PINOCCHIO + repr(command) and (work / f"pin_{kind}").exists():
                pin_binaries[kind] = work / f"pin_{kind}"
                continue
            start = time.perf_counter()
            done = subprocess.run(command, capture_output=True, text=True)
            pin_compile[kind] = time.perf_counter() - start
            if done.returncode == 0:
                stamp.write_text(PINOCCHIO + repr(command))
            pin_binaries[kind] = (work / f"pin_{kind}" if done.returncode == 0 else
                                  "not built: g++ failed: " + " ".join(done.stderr.split())[-300:])
        c_results, py_results = {}, {}
        for name in ROBOTS:
            robot = Robot(name, args.states, args.batch)
            c_results[robot.name] = c_side(robot, work, args.repeats, args.rounds, pin_binaries)
            py_results[robot.name] = [module_rows(robot.module, robot, args.repeats, args.batch,
                                                  "NumPy module"),
                                      pin_rows(robot, args.repeats, args.batch),
                                      extension_rows(robot, work, args.repeats, args.batch)]
    print(f"1. From C: ns per state, the best of {args.rounds} x {args.repeats} runs over {args.states} random states "
          f"(gcc/g++ {' '.join(FLAGS)} unless said; the check: both sides' results at {CHECKED} states)\n")
    print(c_table(c_results))
    print(f"\n2. From Python: one call in us (the best of {args.repeats} x 200 calls); a batch of "
          f"{args.batch} states in ns per state (pin: a Python loop)\n")
    print(python_table(py_results, args.batch))
    print("\n3. Goals\n")
    print(_format([["goal", "measured", ""], *[list(g) for g in goals(c_results, py_results)]]))
    compiled = ", ".join(f"{k} {v:.0f} s" for k, v in pin_compile.items())
    import pinocchio as pin

    print(f"\n(gcc {_gcc_version()}, Pinocchio {pin.__version__}, Python {sys.version.split()[0]}, "
          f"{time.strftime('%Y-%m-%d')}; "
          f"Pinocchio C++ compiled in {compiled or '- (reused)'}; {time.perf_counter() - started:.0f} s in all)")


def _gcc_version() -> str:
    done = subprocess.run(["gcc", "-dumpfullversion"], capture_output=True, text=True)
    return done.stdout.strip() or "?"


if __name__ == "__main__":
    main()
