"""Centroidal functions in C beside Pinocchio C++: the CoM Jacobian and the centroidal momentum
matrix A_G of floating-base robots (solo12, talos_reduced from example-robot-data, a free-flyer
root as ``--floating-base``).

    python benchmarks/centroidal.py [--robots solo12 talos_reduced] [--states 1000] [--repeats 7]
                                    [--rounds 3] [--build-dir DIR] [--full-compile SECONDS]

Ours: ``<name>_center_of_mass_jacobian`` and ``<name>_centroidal_momentum_matrix`` of the C
target (``render_c``). The file compiled holds the header, the defaults and the nine centroidal
functions cut from the generated ``<name>_dynamics.c`` byte for byte (the script checks that
each is a part of it): talos_reduced's whole file (7 MB) does not compile at -O2 within 600 s
(``floating.py``); ``--full-compile SECONDS`` also times the whole file at -O2 with that limit.
Pinocchio: a C++ program on the ``pin`` wheel's libpinocchio (``compiled.py``'s build, twice:
against libpinocchio_default and header-only at the same flags), the model from
``pinocchio::urdf::buildModel`` of the same URDF with a ``JointModelFreeFlyer`` root, the same
states in its coordinate order; ``jacobianCenterOfMass(model, data, q, false)`` (no subtree
centres of mass: its fastest form), ``ccrba(model, data, q, v)`` (A_G and h_G = A_G v) and
``computeCentroidalMap(model, data, q)`` (A_G alone). Both programs loop over ``--states``
random states (random unit quaternions, joints in [-1, 1]) and sum an entry of each result, as
``compiled.py``'s; each writes its results at the first 20 states first, and the script stops
unless they agree to 1e-9 relative. Times are ns per state, the best of ``--repeats`` runs in
each of ``--rounds`` rounds, the programs taking turns. Then the goals: ours at most 1/2 of the
faster Pinocchio build's time, per function and robot. No figure is typed in.

Needs gcc, g++, Pinocchio's wheel with Eigen's and urdfdom's headers (the ``bench`` extra) and
example-robot-data.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from compiled import CHECKED, FLAGS, TIMING, _format, _gcc_version, pinocchio_command, relative, run_program  # noqa: E402
from floating import ROBOTS, example_robot  # noqa: E402

import dynderive  # noqa: E402
from dynderive.render import api  # noqa: E402
from dynderive.render.targets.c.c import render_c  # noqa: E402

AGREE = 1e-9
#: (key, what, our function, Pinocchio's call)
KINDS = [("Jcom", "CoM Jacobian", "center_of_mass_jacobian", "jacobianCenterOfMass"),
         ("Ag", "centroidal momentum matrix", "centroidal_momentum_matrix", "ccrba")]

OURS = TIMING + r"""
#include ROBOT_HEADER
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define F(x) CAT(ROBOT, x)
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]);
    const int repeats = atoi(argv[5]);
    (void)argc;
    double *q = read_states(argv[1], N * nq);
    double *J = (double *)malloc(sizeof(double) * 3 * nv), *A = (double *)malloc(sizeof(double) * 6 * nv);
    FILE *out = fopen(argv[6], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        F(center_of_mass_jacobian)(q + i * nq, NULL, J);
        F(centroidal_momentum_matrix)(q + i * nq, NULL, A);
        fwrite(J, sizeof(double), (size_t)(3 * nv), out);
        fwrite(A, sizeof(double), (size_t)(6 * nv), out);
    }
    fclose(out);
    TIME("Jcom", F(center_of_mass_jacobian)(q + i * nq, NULL, J), J[3 * nv - 1]);
    TIME("Ag", F(centroidal_momentum_matrix)(q + i * nq, NULL, A), A[6 * nv - 1]);
    return 0;
}
"""

PINOCCHIO = r"""
#include <pinocchio/parsers/urdf.hpp>
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/centroidal.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <vector>
""" + TIMING + r"""
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]);
    const int repeats = atoi(argv[5]);
    (void)argc;
    pinocchio::Model model;
    pinocchio::urdf::buildModel(argv[7], pinocchio::JointModelFreeFlyer(), model);
    pinocchio::Data data(model);
    if (model.nq != nq || model.nv != nv) { fprintf(stderr, "nq %d, nv %d: not %ld, %ld\n", model.nq, model.nv, nq, nv); return 2; }
    double *s = read_states(argv[1], N * (nq + nv));
    std::vector<Eigen::VectorXd> q(N), v(N);
    for (long i = 0; i < N; ++i) {
        q[i] = Eigen::Map<Eigen::VectorXd>(s + i * nq, nq);
        v[i] = Eigen::Map<Eigen::VectorXd>(s + N * nq + i * nv, nv);
    }
    FILE *out = fopen(argv[6], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        Eigen::MatrixXd J = pinocchio::jacobianCenterOfMass(model, data, q[i], false).transpose();   /* row-major */
        fwrite(J.data(), sizeof(double), (size_t)(3 * nv), out);
        Eigen::MatrixXd A = pinocchio::ccrba(model, data, q[i], v[i]).transpose();
        fwrite(A.data(), sizeof(double), (size_t)(6 * nv), out);
    }
    fclose(out);
    TIME("Jcom", pinocchio::jacobianCenterOfMass(model, data, q[i], false), data.Jcom(2, nv - 1));
    TIME("Ag", pinocchio::ccrba(model, data, q[i], v[i]), data.Ag(5, nv - 1));
    TIME("map", pinocchio::computeCentroidalMap(model, data, q[i]), data.Ag(5, nv - 1));
    return 0;
}
"""


def functions_source(source: str, name: str, functions: list[str]) -> str:
    """The generated source's preamble (includes, the defaults) and ``functions`` with every
    generated function they call, each cut byte for byte in the file's order (every other
    function and the CasADi section left out)."""
    blocks = re.split(r"\n\n(?=/\* )", source)
    bodies = {}
    for block in blocks[1:]:
        found = re.match(rf"[^\n]*\n[a-z][\w ]* \*?{name}_(\w+)\(", block)
        if found:
            bodies[found.group(1)] = block[:block.index("\n}") + 2]
    wanted, todo = set(), list(functions)
    while todo:   # the functions asked for and those they call
        function = todo.pop()
        if function in wanted:
            continue
        if function not in bodies or f"{name}_default_parameters = {{" not in blocks[0]:
            raise RuntimeError(f"{name}: cannot find {function} in the generated source")
        wanted.add(function)
        todo.extend(f for f in re.findall(rf"\b{name}_(\w+)\(", bodies[function]) if f in bodies)
    kept = [body for function, body in bodies.items() if function in wanted]
    assert all(part in source for part in kept)
    return "\n\n".join([blocks[0], *kept]) + "\n"


def centroidal_source(source: str, name: str) -> str:
    """The generated source's preamble and its centroidal functions, cut byte for byte."""
    return functions_source(source, name, list(api.group("centroidal")))


class Robot:
    """One floating-base robot: its C, Pinocchio's coordinate order, random states."""

    def __init__(self, key: str, states: int):
        import pinocchio as pin

        from dynderive.input.urdf import identifier
        from dynderive.mechanics.tree import offsets

        self.key, self.urdf = key, example_robot(ROBOTS[key])
        if self.urdf is None:
            raise RuntimeError(f"{key}: example-robot-data's {ROBOTS[key]} is not installed")
        robot = dynderive.load_robot(self.urdf, floating_base=True)
        start = time.perf_counter()
        self.header, self.source = render_c(dynderive.derive(robot))
        self.render_s = time.perf_counter() - start
        self.name = robot.name
        model = pin.buildModelFromUrdf(str(self.urdf), pin.JointModelFreeFlyer())
        where = offsets(robot)
        self.qp, self.vp = [], []   # where Pinocchio's q and v entries are in ours
        for joint_name, joint in zip(model.names[1:], model.joints[1:]):
            ours = identifier(joint_name)
            self.qp.extend(range(where.q[ours], where.q[ours] + joint.nq))
            self.vp.extend(range(where.v[ours], where.v[ours] + joint.nv))
        self.nq, self.nv = model.nq, model.nv
        rng = np.random.default_rng(17)
        self.q = rng.uniform(-1, 1, (states, self.nq))
        for q_at in (where.q[j.name] for j in robot.joints if j.type == "floating"):
            quaternion = rng.normal(size=(states, 4))
            self.q[:, q_at + 3:q_at + 7] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
        self.v = rng.normal(size=(states, self.nv))
        self.states = states


def measure(robot: Robot, work: Path, repeats: int, rounds: int, pin_binaries: dict, full_compile: float) -> dict:
    name, N = robot.name, robot.states
    (work / f"{name}_dynamics.h").write_text(robot.header)
    (work / f"{name}_centroidal.c").write_text(centroidal_source(robot.source, name))
    (work / f"{name}_bench.c").write_text(OURS)
    ours_states, pin_states = work / f"{name}_states.bin", work / f"{name}_pin_states.bin"
    robot.q.ravel().tofile(ours_states)
    np.concatenate([robot.q[:, robot.qp].ravel(), robot.v[:, robot.vp].ravel()]).tofile(pin_states)
    result: dict = {"render_s": robot.render_s, "nq": robot.nq, "nv": robot.nv,
                    "source_mb": len(robot.source) / 1e6}
    objects = work / f"{name}_centroidal.o"
    start = time.perf_counter()
    subprocess.run(["gcc", "-std=c99", *FLAGS, "-c", str(work / f"{name}_centroidal.c"), "-o", str(objects)],
                   check=True)
    result["compile_s"] = time.perf_counter() - start
    subprocess.run(["gcc", "-std=c99", *FLAGS, f"-DROBOT={name}_", f'-DROBOT_HEADER="{name}_dynamics.h"',
                    f"-DCHECKED={CHECKED}", f"-I{work}", str(work / f"{name}_bench.c"), str(objects),
                    "-o", str(work / f"{name}_ours"), "-lm"], check=True)
    if full_compile:
        (work / f"{name}_dynamics.c").write_text(robot.source)
        start = time.perf_counter()
        try:
            subprocess.run(["gcc", "-std=c99", "-O2", "-DNDEBUG", "-c", str(work / f"{name}_dynamics.c"), "-o",
                            str(work / f"{name}_dynamics.o")], check=True, timeout=full_compile)
            result["full_compile_s"] = time.perf_counter() - start
        except subprocess.TimeoutExpired:
            result["full_compile_s"] = f"> {full_compile:.0f}"
    common = [str(N), str(robot.nq), str(robot.nv), str(repeats)]
    runs = [("ours", [str(work / f"{name}_ours"), str(ours_states), *common, str(work / f"{name}_ours.check")])]
    runs += [(kind, [str(binary), str(pin_states), *common, str(work / f"{name}_{kind}.check"), str(robot.urdf)])
             for kind, binary in pin_binaries.items() if not isinstance(binary, str)]
    result |= {kind: binary for kind, binary in pin_binaries.items() if isinstance(binary, str)}
    for round_ in range(max(1, rounds)):
        for kind, command in runs:
            times = run_program(command, f"{name} {kind}")
            result[kind] = {k: min(v, result.get(kind, times)[k]) for k, v in times.items()}
        if round_ == 0:
            result |= _agreement(robot, work, [kind for kind, _ in runs[1:]])
    return result


def _agreement(robot: Robot, work: Path, kinds: list[str]) -> dict:
    """Largest relative differences of J_com and A_G between ours and each Pinocchio program
    at the first states; an error above ``AGREE``."""
    name, nv = robot.name, robot.nv
    ours = np.fromfile(work / f"{name}_ours.check").reshape(-1, 9 * nv)
    result = {}
    for kind in kinds:
        theirs = np.fromfile(work / f"{name}_{kind}.check").reshape(-1, 9 * nv)
        worst = {"Jcom": 0.0, "Ag": 0.0}
        for a, b in zip(ours, theirs):
            for key, (lo, rows) in (("Jcom", (0, 3)), ("Ag", (3 * nv, 6))):
                mine = a[lo:lo + rows * nv].reshape(rows, nv)[:, robot.vp]   # Pinocchio's column order
                worst[key] = max(worst[key], relative(mine, b[lo:lo + rows * nv].reshape(rows, nv)))
        result[f"{kind} diff"] = worst
        if len(theirs) < min(CHECKED, robot.states) or max(worst.values()) > AGREE:
            raise RuntimeError(f"{name}: the C code and Pinocchio ({kind}) disagree: {worst}")
    return result


def table(results: dict) -> str:
    rows = [["robot", "what", *(f"{key} ns" for key, *_ in KINDS), "computeCentroidalMap ns"]]
    for key, r in results.items():
        rows.append([key, "ours C " + " ".join(FLAGS), *(f"{r['ours'][k]:.0f}" for k, *_ in KINDS), ""])
        for kind, label in (("lib", "Pinocchio C++ (libpinocchio)"), ("headers", "Pinocchio C++ (headers -O3)")):
            if isinstance(r.get(kind), str):
                rows.append([key, label, r[kind], "", ""])
                continue
            rows.append([key, label, *(f"{r[kind][k]:.0f}" for k, *_ in KINDS), f"{r[kind]['map']:.0f}"])
            rows.append([key, "  ours / Pinocchio", *(f"{r['ours'][k] / r[kind][k]:.2f}x" for k, *_ in KINDS),
                         f"{r['ours']['Ag'] / r[kind]['map']:.2f}x"])
        diffs = [r[f"{kind} diff"] for kind in ("lib", "headers") if f"{kind} diff" in r]
        if diffs:
            rows.append([key, "  largest relative difference", *(f"{max(d[k] for d in diffs):.0e}" for k, *_ in KINDS),
                         ""])
    return _format(rows)


def sizes(results: dict) -> str:
    rows = [["robot", "nq", "nv", "render_c s", "whole .c MB", "9 centroidal functions gcc -O3 s",
             "whole .c gcc -O2 s"]]
    for key, r in results.items():
        full = r.get("full_compile_s")
        rows.append([key, str(r["nq"]), str(r["nv"]), f"{r['render_s']:.0f}", f"{r['source_mb']:.1f}",
                     f"{r['compile_s']:.1f}", "not measured" if full is None else
                     full if isinstance(full, str) else f"{full:.0f}"])
    return _format(rows)


def goals(results: dict) -> list[list[str]]:
    items = []
    for key, r in results.items():
        builds = [r[k] for k in ("lib", "headers") if not isinstance(r.get(k), str)]
        for k, what, _, pin_name in KINDS:
            goal = f"{key} {what} from C <= 0.5x Pinocchio C++ ({pin_name})"
            if not builds:
                items.append([goal, r["lib"], "not measured"])
                continue
            fastest = min(b[k] for b in builds)
            ratio = r["ours"][k] / fastest
            items.append([goal, f"{r['ours'][k]:.0f} vs {fastest:.0f} ns: {ratio:.2f}x", "met" if ratio <= 0.5 else
                          "NOT MET"])
    return items


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    parser.add_argument("--repeats", type=int, default=7, help="runs of each loop (the best counts)")
    parser.add_argument("--rounds", type=int, default=3, help="times each program runs, in turn with the others")
    parser.add_argument("--states", type=int, default=1000, help="states in the C loops")
    parser.add_argument("--full-compile", type=float, default=0.0, metavar="SECONDS",
                        help="also compile the whole generated file at -O2, at most this long (0: not)")
    parser.add_argument("--build-dir", type=Path, help="keep the programs here; reuse its Pinocchio programs "
                        "when their source and command are the same")
    args = parser.parse_args()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="dynderive-centroidal-") as directory:
        work = args.build_dir or Path(directory)
        work.mkdir(parents=True, exist_ok=True)
        (work / "pin_centroidal.cpp").write_text(PINOCCHIO)
        pin_binaries: dict[str, Path | str] = {}
        pin_compile: dict[str, float] = {}
        for kind in ("lib", "headers"):
            binary = work / f"pin_centroidal_{kind}"
            command = pinocchio_command(work / "pin_centroidal.cpp", binary, kind == "lib")
            if isinstance(command, str):
                pin_binaries[kind] = command
                continue
            stamp = binary.with_suffix(".command")
            if stamp.exists() and stamp.read_text() == PINOCCHIO + repr(command) and binary.exists():
                pin_binaries[kind] = binary
                continue
            start = time.perf_counter()
            done = subprocess.run(command, capture_output=True, text=True)
            pin_compile[kind] = time.perf_counter() - start
            if done.returncode == 0:
                stamp.write_text(PINOCCHIO + repr(command))
            pin_binaries[kind] = binary if done.returncode == 0 else \
                "not built: g++ failed: " + " ".join(done.stderr.split())[-300:]
        results = {}
        for key in args.robots:
            print(f"measuring {key} ...", file=sys.stderr, flush=True)
            results[key] = measure(Robot(key, args.states), work, args.repeats, args.rounds, pin_binaries,
                                   args.full_compile)
    print(f"1. From C: ns per state, the best of {args.rounds} x {args.repeats} runs over {args.states} random states "
          f"(gcc/g++ {' '.join(FLAGS)}; the check: both sides' results at {CHECKED} states)\n")
    print(table(results))
    print("\n2. The generated C\n")
    print(sizes(results))
    print("\n3. Goals\n")
    print(_format([["goal", "measured", ""], *goals(results)]))
    import pinocchio as pin

    compiled = ", ".join(f"{k} {v:.0f} s" for k, v in pin_compile.items())
    print(f"\n(gcc {_gcc_version()}, Pinocchio {pin.__version__}, Python {sys.version.split()[0]}, "
          f"{time.strftime('%Y-%m-%d')}; Pinocchio C++ compiled in {compiled or '- (reused)'}; "
          f"{time.perf_counter() - started:.0f} s in all)")


if __name__ == "__main__":
    main()
