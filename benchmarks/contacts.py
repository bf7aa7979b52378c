"""Contact dynamics from C: solo12 (example-robot-data, free-flyer root) on its four feet, the
generated ``<name>_constrained_forward_dynamics`` beside Pinocchio C++.

    python benchmarks/contacts.py [--states 1000] [--repeats 7] [--rounds 3] [--build-dir DIR]

Ours: ``<name>_dynamics.c`` (``render_c``, gcc -O3 -DNDEBUG) and a C loop over ``--states``
random states (random unit quaternions, joints in [-1.5, 1.5], normal velocities and efforts),
one call of ``constrained_forward_dynamics`` with the four feet as point contacts per state.
Pinocchio: a C++ loop over the same states (its coordinate order) built on the ``pin`` wheel's
libpinocchio as ``benchmarks/compiled.py`` builds it (its ``pinocchio_command``), each state
``computeJointJacobians``, ``forwardKinematics`` at zero acceleration, ``updateFramePlacements``,
the feet's rows of ``getFrameJacobian`` (LOCAL_WORLD_ALIGNED) and ``getFrameClassicalAcceleration``
(gamma), then ``forwardDynamics(model, data, q, v, tau, J, gamma, 0)``: the same computation
from the same inputs. Before timing each program writes qdd and the forces at the first 20
states; the script stops unless they agree to 1e-9 relative. Times are ns per state, the best
of ``--repeats`` runs (``compiled.py``'s ``TIME`` loop) in each of ``--rounds`` rounds, the two
programs taking turns. Then the goal: ours at most 1/2 of Pinocchio's time. No figure is typed in.
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

from compiled import FLAGS, TIMING, _format, _gcc_version, pinocchio_command, run_program  # noqa: E402
from floating import example_robot  # noqa: E402

import dynderive  # noqa: E402
from dynderive.input.urdf import identifier  # noqa: E402
from dynderive.render.targets.c.c import render_c  # noqa: E402
from dynderive.verify.checks import generated_module  # noqa: E402

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
CHECKED = 20      # states whose results both programs write and the script compares
AGREE = 1e-9      # relative agreement of qdd and the forces required before timing

OURS = TIMING + r"""
#include ROBOT_HEADER
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define F(x) CAT(ROBOT, x)
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]), nu = atol(argv[5]);
    const int repeats = atoi(argv[6]);
    const int frames[4] = { atoi(argv[8]), atoi(argv[9]), atoi(argv[10]), atoi(argv[11]) }, kinds[4] = { 0, 0, 0, 0 };
    double *s = read_states(argv[1], N * (nq + nv + nu));
    const double *q = s, *qd = s + N * nq, *u = s + N * (nq + nv);
    double *qdd = (double *)malloc(sizeof(double) * nv), forces[12];
    FILE *out = fopen(argv[7], "wb");
    (void)argc;
    for (long i = 0; i < CHECKED && i < N; ++i) {
        if (F(constrained_forward_dynamics)(q + i * nq, qd + i * nv, u + i * nu, 4, frames, kinds, NULL, NULL, NULL,
                                            qdd, forces) != 0) return 3;
        fwrite(qdd, sizeof(double), (size_t)nv, out);
        fwrite(forces, sizeof(double), 12, out);
    }
    fclose(out);
    TIME("CFD", (void)F(constrained_forward_dynamics)(q + i * nq, qd + i * nv, u + i * nu, 4, frames, kinds, NULL,
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
static const char *FEET[4] = { "FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT" };
int main(int argc, char **argv) {
    const long N = atol(argv[2]), nq = atol(argv[3]), nv = atol(argv[4]);
    const int repeats = atoi(argv[6]);
    pinocchio::Model model;
    pinocchio::urdf::buildModel(argv[8], pinocchio::JointModelFreeFlyer(), model);
    pinocchio::Data data(model);
    (void)argc;
    if (model.nq != nq || model.nv != nv) { fprintf(stderr, "nq %d, nv %d\n", model.nq, model.nv); return 2; }
    pinocchio::FrameIndex feet[4];
    for (int k = 0; k < 4; ++k) feet[k] = model.getFrameId(FEET[k]);
    double *s = read_states(argv[1], N * (nq + 2 * nv));
    std::vector<Eigen::VectorXd> q(N), v(N), tau(N);
    for (long i = 0; i < N; ++i) {
        q[i] = Eigen::Map<Eigen::VectorXd>(s + i * nq, nq);
        v[i] = Eigen::Map<Eigen::VectorXd>(s + N * nq + i * nv, nv);
        tau[i] = Eigen::Map<Eigen::VectorXd>(s + N * (nq + nv) + i * nv, nv);
    }
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(nv);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(12, nv), J6 = Eigen::MatrixXd::Zero(6, nv);
    Eigen::VectorXd gamma(12);
#define CONSTRAINED(i) do { \
        pinocchio::computeJointJacobians(model, data, q[i]); \
        pinocchio::forwardKinematics(model, data, q[i], v[i], zero); \
        pinocchio::updateFramePlacements(model, data); \
        for (int k = 0; k < 4; ++k) { \
            J6.setZero(); \
            pinocchio::getFrameJacobian(model, data, feet[k], pinocchio::LOCAL_WORLD_ALIGNED, J6); \
            J.middleRows(3 * k, 3) = J6.topRows(3); \
            gamma.segment(3 * k, 3) = pinocchio::getFrameClassicalAcceleration( \
                model, data, feet[k], pinocchio::LOCAL_WORLD_ALIGNED).linear(); \
        } \
        pinocchio::forwardDynamics(model, data, q[i], v[i], tau[i], J, gamma, 0.0); \
    } while (0)
    FILE *out = fopen(argv[7], "wb");
    for (long i = 0; i < CHECKED && i < N; ++i) {
        CONSTRAINED(i);
        fwrite(data.ddq.data(), sizeof(double), (size_t)nv, out);
        fwrite(data.lambda_c.data(), sizeof(double), 12, out);
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


def main() -> None:
    import pinocchio as pin

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="runs of each loop (the best counts)")
    parser.add_argument("--rounds", type=int, default=3, help="times each program runs, in turn with the other")
    parser.add_argument("--states", type=int, default=1000, help="states in the loops")
    parser.add_argument("--build-dir", type=Path, help="keep the programs here; reuse the Pinocchio program "
                        "when its source and command are the same (it takes 1-5 minutes to build)")
    args = parser.parse_args()
    started = time.perf_counter()
    urdf = example_robot("solo_description/robots/solo12.urdf")
    if urdf is None:
        raise SystemExit("example-robot-data is not installed")
    robot = dynderive.load_robot(urdf, floating_base=True)
    derivation = dynderive.derive(robot)
    name = robot.name
    module = generated_module(dynderive.render_code(derivation), name)
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    qp, vp = _maps(robot, model)
    nq, nv, nu, count = module.NQ, module.NV, len(module.EFFORTS), args.states
    rng = np.random.default_rng(12)
    q = module.integrate(module.neutral_configuration(), rng.uniform(-1.5, 1.5, (count, nv)))
    qd, u = rng.normal(size=(count, nv)), rng.normal(size=(count, nu))
    tau = np.zeros((count, nv))
    tau[:, list(robot.effort_columns())] = u
    with tempfile.TemporaryDirectory(prefix="dynderive-contacts-") as directory:
        work = args.build_dir or Path(directory)
        work.mkdir(parents=True, exist_ok=True)
        header, source = render_c(derivation)
        (work / f"{name}_dynamics.h").write_text(header)
        (work / f"{name}_dynamics.c").write_text(source)
        (work / "contacts_bench.c").write_text(OURS)
        (work / "pin_contacts.cpp").write_text(PINOCCHIO)
        start = time.perf_counter()
        objects = work / f"{name}_dynamics.o"
        subprocess.run(["gcc", "-std=c99", *FLAGS, "-c", str(work / f"{name}_dynamics.c"), "-o", str(objects)], check=True)
        compile_ours = time.perf_counter() - start
        ours = work / "contacts_ours"
        subprocess.run(["gcc", "-std=c99", *FLAGS, f"-DROBOT={name}_", f'-DROBOT_HEADER="{name}_dynamics.h"',
                        f"-DCHECKED={CHECKED}", f"-I{work}", str(work / "contacts_bench.c"), str(objects),
                        "-o", str(ours), "-lm"], check=True)
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
        np.concatenate([q.ravel(), qd.ravel(), u.ravel()]).tofile(work / "ours.bin")
        np.concatenate([q[:, qp].ravel(), qd[:, vp].ravel(), tau[:, vp].ravel()]).tofile(work / "pin.bin")
        frames = [str(module.FRAMES.index(f)) for f in FEET]
        common = [str(count), str(nq), str(nv), str(nu), str(args.repeats)]
        runs = [("ours", [str(ours), str(work / "ours.bin"), *common, str(work / "ours.check"), *frames]),
                ("pin", [str(work / "pin_contacts"), str(work / "pin.bin"), *common, str(work / "pin.check"),
                         str(urdf)])]
        best: dict[str, float] = {}
        for round_ in range(max(1, args.rounds)):
            for label, call in runs:
                best[label] = min(best.get(label, float("inf")), run_program(call, label)["CFD"])
            if round_ == 0:
                mine = np.fromfile(work / "ours.check").reshape(-1, nv + 12)
                theirs = np.fromfile(work / "pin.check").reshape(-1, nv + 12)
                worst = max(max(relative(a[:nv][vp], b[:nv]), relative(a[nv:], b[nv:])) for a, b in zip(mine, theirs))
                if len(mine) < min(CHECKED, count) or worst > AGREE:
                    raise SystemExit(f"ours and Pinocchio disagree: {worst:.1e}")
    ratio = best["pin"] / best["ours"]
    print(f"solo12 on its four feet (point contacts): constrained forward dynamics from C, ns per state, the best of "
          f"{args.rounds} x {args.repeats} runs over {count} random states (gcc/g++ {' '.join(FLAGS)}; the check: "
          f"qdd and the forces at {CHECKED} states)\n")
    print(_format([["what", "ns"],
                   [f"ours C ({name}_constrained_forward_dynamics)", f"{best['ours']:.0f}"],
                   ["Pinocchio C++ (libpinocchio): J, gamma, forwardDynamics", f"{best['pin']:.0f}"],
                   ["  Pinocchio / ours", f"{ratio:.1f}x"],
                   ["  largest relative difference (qdd, forces)", f"{worst:.0e}"]]))
    print()
    print(_format([["goal", "measured", ""],
                   ["solo12 constrained forward dynamics from C <= 1/2 of Pinocchio C++",
                    f"{best['ours']:.0f} vs {best['pin']:.0f} ns: {ratio:.1f}x", "met" if ratio >= 2 else "NOT MET"]]))
    print(f"\n(gcc {_gcc_version()}, Pinocchio {pin.__version__}, {time.strftime('%Y-%m-%d')}; ours compiled in "
          f"{compile_ours:.0f} s, Pinocchio's program in {'-' if compile_pin is None else f'{compile_pin:.0f} s'}; "
          f"{time.perf_counter() - started:.0f} s in all)")


if __name__ == "__main__":
    main()
