"""Contact dynamics from C: solo12 on its four feet and talos_reduced on its two soles
(example-robot-data, free-flyer root), the generated ``<name>_constrained_forward_dynamics``
beside Pinocchio C++.

    python benchmarks/contacts.py [--robots solo12 talos_reduced] [--states 1000] [--repeats 7]
                                  [--rounds 3] [--build-dir DIR]

The contacts (``CONTACTS``): solo12's four feet as point contacts (3 rows each, world-aligned),
talos_reduced's two soles (``left_sole_link``, ``right_sole_link``) as surface contacts (6 rows
each, the sole's frame), as a humanoid standing on flat feet is usually held (Pinocchio's 6-D
contacts on the soles). Ours: a C loop over ``--states`` random states (random unit
quaternions, joints in [-1.5, 1.5], normal velocities and efforts), one call of
``constrained_forward_dynamics`` per state. The file compiled holds the header, the defaults,
``constrained_forward_dynamics`` and the generated functions it calls, cut from the generated
``<name>_dynamics.c`` byte for byte (``centroidal.functions_source``): talos_reduced's whole file
does not compile at -O2 within 600 s (``floating.py``). Pinocchio: a C++ loop over the same
states (its coordinate order) built on the ``pin`` wheel's libpinocchio as
``benchmarks/compiled.py`` builds it (its ``pinocchio_command``), each state
``computeJointJacobians``, ``forwardKinematics`` at zero acceleration, ``updateFramePlacements``,
each contact's rows of ``getFrameJacobian`` and its drift gamma (a point: the linear rows in
LOCAL_WORLD_ALIGNED and ``getFrameClassicalAcceleration``; a surface: all six rows in LOCAL and
``getFrameAcceleration``), then ``forwardDynamics(model, data, q, v, tau, J, gamma, 0)``: the
same computation from the same inputs (Pinocchio's tau the efforts less the URDF's joint damping
and friction, which ours computes: talos_reduced has them). Before timing each program writes
qdd and the forces at the first 20 states; the script stops unless they agree to 1e-9 relative.
Times are ns per state, the best of ``--repeats`` runs (``compiled.py``'s ``TIME`` loop) in each
of ``--rounds`` rounds, the two programs taking turns. Then the goal: ours at most 1/2 of
Pinocchio's time. No figure is typed in.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from centroidal import functions_source  # noqa: E402
from compiled import FLAGS, TIMING, _format, _gcc_version, pinocchio_command, run_program  # noqa: E402
from floating import ROBOTS, example_robot  # noqa: E402

import dynderive  # noqa: E402
from dynderive.input.urdf import identifier  # noqa: E402
from dynderive.render.targets.c.c import render_c  # noqa: E402
from dynderive.verify.checks import generated_module  # noqa: E402

#: each robot's contacts: (frame, kind) with kind 0 a point, 1 a surface
CONTACTS = {"solo12": [("FL_FOOT", 0), ("FR_FOOT", 0), ("HL_FOOT", 0), ("HR_FOOT", 0)],
            "talos_reduced": [("left_sole_link", 1), ("right_sole_link", 1)]}
CHECKED = 20      # states whose results both programs write and the script compares
AGREE = 1e-9      # relative agreement of qdd and the forces required before timing

OURS = TIMING + r"""
#include ROBOT_HEADER
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define F(x) CAT(ROBOT, x)
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]), nu = atol(argv[5]);
    const int repeats = atoi(argv[6]), n = atoi(argv[8]);
    int frames[8], kinds[8], nf = 0;
    for (int k = 0; k < n; ++k) {
        frames[k] = atoi(argv[9 + k]);
        kinds[k] = atoi(argv[9 + n + k]);
        nf += kinds[k] ? 6 : 3;
    }
    double *s = read_states(argv[1], N * (nq + nv + nu));
    const double *q = s, *qd = s + N * nq, *u = s + N * (nq + nv);
    double *qdd = (double *)malloc(sizeof(double) * nv), forces[48];
    FILE *out = fopen(argv[7], "wb");
    (void)argc;
    for (long i = 0; i < CHECKED && i < N; ++i) {
        if (F(constrained_forward_dynamics)(q + i * nq, qd + i * nv, u + i * nu, n, frames, kinds, NULL, NULL, NULL,
                                            qdd, forces) != 0) return 3;
        fwrite(qdd, sizeof(double), (size_t)nv, out);
        fwrite(forces, sizeof(double), (size_t)nf, out);
    }
    fclose(out);
    TIME("CFD", (void)F(constrained_forward_dynamics)(q + i * nq, qd + i * nv, u + i * nu, n, frames, kinds, NULL,
                                                      NULL, NULL, qdd, forces), qdd[0] + forces[2]);
    return 0;
}
"""

PINOCCHIO = r"""
#include <pinocchio/parsers/urdf.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/contact-dynamics.hpp>
#include <vector>
""" + TIMING + r"""
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]);
    const int repeats = atoi(argv[6]), n = atoi(argv[9]);
    pinocchio::Model model;
    pinocchio::urdf::buildModel(argv[8], pinocchio::JointModelFreeFlyer(), model);
    pinocchio::Data data(model);
    (void)argc;
    if (model.nq != nq || model.nv != nv) { fprintf(stderr, "nq %d, nv %d\n", model.nq, model.nv); return 2; }
    pinocchio::FrameIndex frames[8];
    int kinds[8], rows = 0;
    for (int k = 0; k < n; ++k) {
        frames[k] = model.getFrameId(argv[10 + k]);
        kinds[k] = atoi(argv[10 + n + k]);
        rows += kinds[k] ? 6 : 3;
    }
    double *s = read_states(argv[1], N * (nq + 2 * nv));
    std::vector<Eigen::VectorXd> q(N), v(N), tau(N);
    for (long i = 0; i < N; ++i) {
        q[i] = Eigen::Map<Eigen::VectorXd>(s + i * nq, nq);
        v[i] = Eigen::Map<Eigen::VectorXd>(s + N * nq + i * nv, nv);
        tau[i] = Eigen::Map<Eigen::VectorXd>(s + N * (nq + nv) + i * nv, nv);
    }
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(nv);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(rows, nv), J6 = Eigen::MatrixXd::Zero(6, nv);
    Eigen::VectorXd gamma(rows);
#define CONSTRAINED(i) do { \
        pinocchio::computeJointJacobians(model, data, q[i]); \
        pinocchio::forwardKinematics(model, data, q[i], v[i], zero); \
        pinocchio::updateFramePlacements(model, data); \
        for (int k = 0, r = 0; k < n; ++k) { \
            J6.setZero(); \
            if (kinds[k]) { \
                pinocchio::getFrameJacobian(model, data, frames[k], pinocchio::LOCAL, J6); \
                J.middleRows(r, 6) = J6; \
                gamma.segment(r, 6) = pinocchio::getFrameAcceleration(model, data, frames[k], \
                                                                      pinocchio::LOCAL).toVector(); \
                r += 6; \
            } else { \
                pinocchio::getFrameJacobian(model, data, frames[k], pinocchio::LOCAL_WORLD_ALIGNED, J6); \
                J.middleRows(r, 3) = J6.topRows(3); \
                gamma.segment(r, 3) = pinocchio::getFrameClassicalAcceleration( \
                    model, data, frames[k], pinocchio::LOCAL_WORLD_ALIGNED).linear(); \
                r += 3; \
            } \
        } \
        pinocchio::forwardDynamics(model, data, q[i], v[i], tau[i], J, gamma, 0.0); \
    } while (0)
    FILE *out = fopen(argv[7], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        CONSTRAINED(i);
        fwrite(data.ddq.data(), sizeof(double), (size_t)nv, out);
        fwrite(data.lambda_c.data(), sizeof(double), (size_t)rows, out);
    }
    fclose(out);
    TIME("CFD", CONSTRAINED(i), data.ddq[0] + data.lambda_c[2]);
    return 0;
}
"""


def _maps(robot, model) -> tuple[np.ndarray, np.ndarray]:
    """(qp, vp): Pinocchio's q = ours[qp], v = ours[vp]."""
    where_q, where_v = robot.offsets()
    qp, vp = [], []
    for name, joint in zip(model.names[1:], model.joints[1:]):
        qp.extend(range(where_q[identifier(name)], where_q[identifier(name)] + joint.nq))
        vp.extend(range(where_v[identifier(name)], where_v[identifier(name)] + joint.nv))
    return np.array(qp), np.array(vp)


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def measure(key: str, work: Path, states: int, repeats: int, rounds: int, pin_binary: Path) -> dict:
    """ns per state of ours and Pinocchio's constrained forward dynamics of robot ``key``."""
    import pinocchio as pin

    urdf = example_robot(ROBOTS[key])
    if urdf is None:
        raise SystemExit("example-robot-data is not installed")
    robot = dynderive.load_robot(urdf, floating_base=True)
    derivation = dynderive.derive(robot)
    name = robot.name
    module = generated_module(dynderive.render_code(derivation), name)
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    qp, vp = _maps(robot, model)
    nq, nv, nu = module.NQ, module.NV, len(module.EFFORTS)
    rng = np.random.default_rng(12)
    q = module.integrate(module.neutral_configuration(), rng.uniform(-1.5, 1.5, (states, nv)))
    qd, u = rng.normal(size=(states, nv)), rng.normal(size=(states, nu))
    tau = np.zeros((states, nv))
    tau[:, list(robot.effort_columns())] = u
    where_v = robot.offsets()[1]
    for joint in (j for j in robot.joints if j.owns and not j.multi):   # URDF <dynamics> (talos): ours has F in it
        k = where_v[joint.name]
        tau[:, k] -= float(joint.damping or 0) * qd[:, k] + float(joint.friction or 0) * np.sign(qd[:, k])
    header, source = render_c(derivation)
    cut = functions_source(source, name, ["constrained_forward_dynamics"])
    (work / f"{name}_dynamics.h").write_text(header)
    (work / f"{name}_contacts.c").write_text(cut)
    (work / "contacts_bench.c").write_text(OURS)
    start = time.perf_counter()
    objects = work / f"{name}_contacts.o"
    subprocess.run(["gcc", "-std=c99", *FLAGS, "-c", str(work / f"{name}_contacts.c"), "-o", str(objects)], check=True)
    compile_ours = time.perf_counter() - start
    ours = work / f"{name}_contacts_ours"
    subprocess.run(["gcc", "-std=c99", *FLAGS, f"-DROBOT={name}_", f'-DROBOT_HEADER="{name}_dynamics.h"',
                    f"-DCHECKED={CHECKED}", f"-I{work}", str(work / "contacts_bench.c"), str(objects),
                    "-o", str(ours), "-lm"], check=True)
    np.concatenate([q.ravel(), qd.ravel(), u.ravel()]).tofile(work / f"{name}_ours.bin")
    np.concatenate([q[:, qp].ravel(), qd[:, vp].ravel(), tau[:, vp].ravel()]).tofile(work / f"{name}_pin.bin")
    contacts = CONTACTS[key]
    frames = [str(module.FRAMES.index(f)) for f, _ in contacts]
    kinds = [str(k) for _, k in contacts]
    rows = sum(6 if k else 3 for _, k in contacts)
    common = [str(states), str(nq), str(nv), str(nu), str(repeats)]
    runs = [("ours", [str(ours), str(work / f"{name}_ours.bin"), *common, str(work / f"{name}_ours.check"),
                      str(len(contacts)), *frames, *kinds]),
            ("pin", [str(pin_binary), str(work / f"{name}_pin.bin"), *common, str(work / f"{name}_pin.check"),
                     str(urdf), str(len(contacts)), *(f for f, _ in contacts), *kinds])]
    best: dict[str, float] = {}
    for round_ in range(max(1, rounds)):
        for label, call in runs:
            best[label] = min(best.get(label, float("inf")), run_program(call, f"{key} {label}")["CFD"])
        if round_ == 0:
            mine = np.fromfile(work / f"{name}_ours.check").reshape(-1, nv + rows)
            theirs = np.fromfile(work / f"{name}_pin.check").reshape(-1, nv + rows)
            worst = max(max(relative(a[:nv][vp], b[:nv]), relative(a[nv:], b[nv:])) for a, b in zip(mine, theirs))
            if len(mine) < min(CHECKED, states) or worst > AGREE:
                raise SystemExit(f"{key}: ours and Pinocchio disagree: {worst:.1e}")
    held = (f"its {len(contacts)} feet (point contacts)" if all(k == 0 for _, k in contacts) else
            f"its {len(contacts)} soles (surface contacts)")
    return {"name": name, "held": held, "ours": best["ours"], "pin": best["pin"], "worst": worst,
            "compile": compile_ours, "kb": len(cut) / 1e3, "whole_mb": len(source) / 1e6}


def main() -> None:
    import pinocchio as pin

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(CONTACTS), choices=list(CONTACTS))
    parser.add_argument("--repeats", type=int, default=7, help="runs of each loop (the best counts)")
    parser.add_argument("--rounds", type=int, default=3, help="times each program runs, in turn with the other")
    parser.add_argument("--states", type=int, default=1000, help="states in the loops")
    parser.add_argument("--build-dir", type=Path, help="keep the programs here; reuse the Pinocchio program "
                        "when its source and command are the same (it takes 1-5 minutes to build)")
    args = parser.parse_args()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="dynderive-contacts-") as directory:
        work = args.build_dir or Path(directory)
        work.mkdir(parents=True, exist_ok=True)
        (work / "pin_contacts.cpp").write_text(PINOCCHIO)
        command = pinocchio_command(work / "pin_contacts.cpp", work / "pin_contacts", True)
        compile_pin = None
        if isinstance(command, str):
            raise SystemExit(f"Pinocchio C++: {command}")
        stamp = work / "pin_contacts.command"
        if not (stamp.exists() and stamp.read_text() == PINOCCHIO + repr(command) and (work / "pin_contacts").exists()):
            start = time.perf_counter()
            done = subprocess.run(command, capture_output=True, text=True)
            compile_pin = time.perf_counter() - start
            if done.returncode != 0:
                raise SystemExit("g++ failed: " + " ".join(done.stderr.split())[-600:])
            stamp.write_text(PINOCCHIO + repr(command))
        results = {}
        for key in args.robots:
            print(f"measuring {key} ...", file=sys.stderr, flush=True)
            results[key] = measure(key, work, args.states, args.repeats, args.rounds, work / "pin_contacts")
    print(f"Constrained forward dynamics from C, ns per state, the best of {args.rounds} x {args.repeats} runs over "
          f"{args.states} random states (gcc/g++ {' '.join(FLAGS)}; the check: qdd and the forces at {CHECKED} "
          f"states)\n")
    rows = [["robot", "held on", "what", "ns"]]
    for key, r in results.items():
        rows += [[key, r["held"], f"ours C ({r['name']}_constrained_forward_dynamics)", f"{r['ours']:.0f}"],
                 [key, "", "Pinocchio C++ (libpinocchio): J, gamma, forwardDynamics", f"{r['pin']:.0f}"],
                 [key, "", "  Pinocchio / ours", f"{r['pin'] / r['ours']:.1f}x"],
                 [key, "", "  largest relative difference (qdd, forces)", f"{r['worst']:.0e}"]]
    print(_format(rows))
    print()
    print(_format([["robot", "whole .c MB", "cut .c kB (the function and its callees)", "gcc -O3 s"]] +
                  [[key, f"{r['whole_mb']:.1f}", f"{r['kb']:.0f}", f"{r['compile']:.0f}"]
                   for key, r in results.items()]))
    print()
    print(_format([["goal", "measured", ""]] +
                  [[f"{key} constrained forward dynamics from C <= 1/2 of Pinocchio C++",
                    f"{r['ours']:.0f} vs {r['pin']:.0f} ns: {r['pin'] / r['ours']:.1f}x",
                    "met" if r["pin"] / r["ours"] >= 2 else "NOT MET"] for key, r in results.items()]))
    print(f"\n(gcc {_gcc_version()}, Pinocchio {pin.__version__}, {time.strftime('%Y-%m-%d')}; Pinocchio's program "
          f"compiled in {'- (reused)' if compile_pin is None else f'{compile_pin:.0f} s'}; "
          f"{time.perf_counter() - started:.0f} s in all)")


if __name__ == "__main__":
    main()
