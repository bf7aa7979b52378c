"""Cart-pole swing-up by direct collocation (Hermite-Simpson) with ``casadi.Opti`` and IPOPT.

The dynamics are the CasADi module that ``dynderive solve robots/cart_pole.yaml --casadi``
writes: its ``forward_dynamics`` is a ``casadi.Function``, so the optimizer sees exact
derivatives of the derived equations of motion. The pole hangs down at rest (theta = pi,
measured from the upward vertical) and must be upright at rest (theta = 0) after ``duration``
seconds, pushed by a cart force of at most ``force_limit`` newtons; the cost is the integral
of the force squared.

Run it: ``python docs/tutorials/cart_pole_swing_up.py`` (writes the module to a temporary
folder, solves, re-integrates the trajectory with the NumPy module and prints the result).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

ROBOT = Path(__file__).resolve().parents[2] / "robots" / "cart_pole.yaml"


def generate(robot: Path, directory: Path, flag: str = "--casadi"):
    """Run ``dynderive solve ROBOT FLAG --out DIRECTORY`` and import the module it writes
    (``--casadi``: ``<name>_dynamics_casadi.py``; ``--code``: the NumPy ``<name>_dynamics.py``)."""
    subprocess.run(
        [sys.executable, "-m", "dynderive", "solve", str(robot), flag, "--out", str(directory), "--quiet"],
        check=True,
    )
    suffix = "_casadi" if flag == "--casadi" else ""
    (path,) = Path(directory).glob(f"*_dynamics{suffix}.py")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module
    spec.loader.exec_module(module)
    return module


@dataclass
class SwingUp:
    """The solution: knot times ``t`` (N + 1), states ``x`` (N + 1 x 4: x, theta, xd, thetad),
    forces ``u`` at the knots (N + 1) and at the interval midpoints ``u_mid`` (N), and IPOPT's
    return status (``"Solve_Succeeded"`` when it converged)."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    u_mid: np.ndarray
    status: str

    def control(self, time: float) -> float:
        """The force at ``time``: the quadratic through the knot, midpoint and next knot values
        of its interval (Hermite-Simpson's control interpolation)."""
        n = len(self.t) - 1
        h = self.t[1] - self.t[0]
        k = min(int(time / h), n - 1)
        s = (time - self.t[k]) / h
        a, m, b = self.u[k], self.u_mid[k], self.u[k + 1]
        return float(a * (1 - s) * (1 - 2 * s) + 4 * m * s * (1 - s) + b * s * (2 * s - 1))


def swing_up(cart_pole, duration: float = 2.5, intervals: int = 50, force_limit: float = 10.0,
             track: float = 2.0, verbose: bool = False) -> SwingUp:
    """Solve the swing-up with ``cart_pole``, the imported CasADi module of ``cart_pole.yaml``."""
    # --8<-- [start:problem]
    # The state derivative as one Function of (state, force), mapped over the intervals.
    state, force = ca.SX.sym("x", 4), ca.SX.sym("u", 1)
    q, qd = state[:2], state[2:]
    qdd = cart_pole.forward_dynamics(q, qd, force)          # p left out: the robot file's values
    f = ca.Function("f", [state, force], [ca.vertcat(qd, qdd)]).map(intervals)
    f_knots = ca.Function("f", [state, force], [ca.vertcat(qd, qdd)]).map(intervals + 1)

    opti = ca.Opti()
    X = opti.variable(4, intervals + 1)      # states at the knots
    Xm = opti.variable(4, intervals)         # states at the midpoints
    U = opti.variable(1, intervals + 1)      # forces at the knots
    Um = opti.variable(1, intervals)         # forces at the midpoints
    h = duration / intervals

    F = f_knots(X, U)
    Fa, Fb = F[:, :-1], F[:, 1:]
    Fm = f(Xm, Um)
    Xa, Xb = X[:, :-1], X[:, 1:]
    # Hermite-Simpson (separated form): the midpoint interpolates, Simpson's rule integrates.
    opti.subject_to(Xm == (Xa + Xb) / 2 + h / 8 * (Fa - Fb))
    opti.subject_to(Xb == Xa + h / 6 * (Fa + 4 * Fm + Fb))

    opti.subject_to(X[:, 0] == [0, np.pi, 0, 0])             # hanging down at rest
    opti.subject_to(X[:, -1] == [0, 0, 0, 0])                # upright at rest
    opti.subject_to(opti.bounded(-force_limit, U, force_limit))
    opti.subject_to(opti.bounded(-force_limit, Um, force_limit))
    opti.subject_to(opti.bounded(-track, X[0, :], track))   # the rail's length

    # The integral of the force squared, by Simpson's rule (exact for the quadratic force).
    opti.minimize(h / 6 * (ca.sumsqr(U[:-1]) + 4 * ca.sumsqr(Um) + ca.sumsqr(U[1:])))
    # --8<-- [end:problem]

    # Initial guess: the pole turning from pi to 0 at a constant rate, the cart still.
    s = np.linspace(0, 1, intervals + 1)
    opti.set_initial(X[1, :], np.pi * (1 - s))
    opti.set_initial(X[3, :], -np.pi / duration)
    opti.set_initial(Xm[1, :], np.pi * (1 - (s[:-1] + s[1:]) / 2))
    opti.set_initial(Xm[3, :], -np.pi / duration)

    quiet = {} if verbose else {"print_level": 0, "sb": "yes"}
    opti.solver("ipopt", {"print_time": verbose}, {"tol": 1e-10, **quiet})
    solution = opti.solve()
    return SwingUp(
        t=np.linspace(0, duration, intervals + 1),
        x=np.asarray(solution.value(X)).T,
        u=np.asarray(solution.value(U)).ravel(),
        u_mid=np.asarray(solution.value(Um)).ravel(),
        status=opti.stats()["return_status"],
    )


# --8<-- [start:reintegrate]
def reintegrate(numpy_module, result: SwingUp) -> np.ndarray:
    """The state at the final time when the interpolated force drives the NumPy module's
    ``forward_dynamics`` from the initial state (``scipy.integrate.solve_ivp``, tight tolerances):
    near the trajectory's final state when the collocation defects are small."""
    from scipy.integrate import solve_ivp

    def rhs(time, x):
        qdd = numpy_module.forward_dynamics(x[:2], x[2:], np.array([result.control(time)]))
        return np.concatenate([x[2:], qdd])

    h = result.t[1] - result.t[0]
    solution = solve_ivp(rhs, (result.t[0], result.t[-1]), result.x[0], method="DOP853",
                         rtol=1e-10, atol=1e-10, max_step=h / 4)
    return solution.y[:, -1]
# --8<-- [end:reintegrate]


def main() -> None:
    with tempfile.TemporaryDirectory() as directory:
        cart_pole = generate(ROBOT, Path(directory) / "casadi", "--casadi")
        numpy_module = generate(ROBOT, Path(directory) / "numpy", "--code")
        result = swing_up(cart_pole, verbose=True)
        end = reintegrate(numpy_module, result)
    print(f"IPOPT: {result.status}")
    print(f"final state (x, theta, xd, thetad): {np.array2string(result.x[-1], precision=3)}")
    print(f"re-integrated with the NumPy module:  {np.array2string(end, precision=3)}")
    print(f"largest force: {np.max(np.abs(result.u)):.2f} N")


if __name__ == "__main__":
    main()
