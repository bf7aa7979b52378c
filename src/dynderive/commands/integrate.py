"""The integrator loop of ``simulate``: SciPy's solvers stepped one step at a time.

Stepping (rather than one ``solve_ivp`` call) lets the run be watched: the state must stay
finite (the run stops at the first step where it is not, saying when), the frames are
interpolated from each step's dense output (as ``solve_ivp``'s ``t_eval`` does), and a run
whose pace promises an unreasonable number of steps says so once, with what to try, instead
of integrating silently for minutes.

Default method: LSODA, which switches between a non-stiff (Adams) and a stiff (BDF) method
as the problem asks. Robots with strong damping or smoothed Coulomb friction are stiff: the
xarm7 of example-robot-data (``<dynamics damping="10" friction="1">``) integrated for 1 s from
0.5 rad took 0.6 s with LSODA, 0.8 s with BDF, 1.7 s with Radau, and more than 200 000
evaluations (40 s, still running) with RK45 or DOP853 (measured on this project's 2-core
machine, rtol = atol = 1e-9).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from ..errors import InputError, Problem

#: SciPy's ``solve_ivp`` methods that ``--method`` offers, the default first.
METHODS = ("LSODA", "Radau", "BDF", "RK45", "DOP853")
DEFAULT_METHOD = "LSODA"
EXPLICIT = ("RK45", "DOP853")
#: A run is said to struggle once it has evaluated the dynamics this many times and its pace
#: projects more than ``STRUGGLE_PROJECTED`` evaluations for the whole duration. Ordinary
#: runs stay far below (rtol = atol = 1e-9, 10 s of the 3R arm: 12 000 evaluations with LSODA,
#: 17 000 with DOP853); the xarm7 with DOP853 passes 20 000 in its first 0.5 % (about 4 s).
STRUGGLE_EVALUATIONS = 20_000
STRUGGLE_PROJECTED = 300_000
#: A run stops when this many steps in a row advance time by less than ``STALL`` of the
#: duration (LSODA can go on taking steps of size 0 at a singular force for ever).
STALL_STEPS = 100
STALL = 1e-12


def method_name(text: str) -> str:
    """``--method`` as SciPy spells it (any case), or an InputError listing the choices."""
    for name in METHODS:
        if text.lower() == name.lower():
            return name
    raise InputError(Problem("--method", 1, 1, f"expected one of {', '.join(METHODS)}, got {text!r}"))


class Integrator:
    """Integrates ``rhs`` over ``[0, duration]``, possibly interval by interval (closed loops
    are projected onto their constraints at every frame); counts steps over the whole run."""

    def __init__(self, rhs: Callable[[float, np.ndarray], np.ndarray], method: str, rtol: float, atol: float,
                 duration: float, note: Callable[[str], None], hint: str = ""):
        from scipy import integrate

        self.method, self.rtol, self.atol = method, rtol, atol
        self.evaluations = 0

        def counted(time: float, y: np.ndarray) -> np.ndarray:
            self.evaluations += 1
            return rhs(time, y)
        self.rhs = counted
        self.solver_class = getattr(integrate, method)
        self.duration, self.note, self.hint = duration, note, hint
        self.steps = 0
        self.stalled = 0
        self.noted = False

    def run(self, start: float, end: float, y0: np.ndarray, times: np.ndarray) -> np.ndarray:
        """The state at ``times`` (within ``[start, end]``, ascending), shape (len(times), len(y0))."""
        out = np.empty((len(times), len(y0)))
        filled = 0
        while filled < len(times) and times[filled] <= start:
            out[filled] = y0
            filled += 1
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")   # SciPy's warnings become the messages below
            solver = self.solver_class(self.rhs, start, y0, end, rtol=self.rtol, atol=self.atol)
            while solver.status == "running":
                before = solver.t
                message = solver.step()
                if solver.status == "failed":
                    raise InputError(Problem("--method", 1, 1, f"the integrator ({self.method}) failed at "
                                             f"t = {before:.6g} s: {message}{self._advice()}"))
                if not np.all(np.isfinite(solver.y)):
                    raise InputError(Problem("--duration", 1, 1, f"the motion stopped being finite between "
                                             f"t = {before:.6g} s and {solver.t:.6g} s (the state left the range "
                                             "of a double); the run stops there"))
                self.steps += 1
                self.stalled = self.stalled + 1 if solver.t - before <= STALL * self.duration else 0
                if self.stalled >= STALL_STEPS:
                    raise InputError(Problem("--method", 1, 1, f"the integrator ({self.method}) cannot advance "
                                             f"past t = {solver.t:.12g} s ({STALL_STEPS} steps in a row of "
                                             f"less than {STALL:g} of the run): an effort, a force or the "
                                             "motion may be singular there; the run stops there"))
                self._watch(solver.t, solver.step_size)
                if filled < len(times) and times[filled] <= solver.t:
                    dense = solver.dense_output()
                    while filled < len(times) and times[filled] <= solver.t:
                        out[filled] = dense(times[filled])
                        filled += 1
        out[filled:] = solver.y
        return out

    def _watch(self, time: float, step: float | None) -> None:
        if self.noted or self.evaluations < STRUGGLE_EVALUATIONS or time <= 0:
            return
        if self.evaluations * self.duration / time > STRUGGLE_PROJECTED:
            self.noted = True
            last = f", last step {step:.2g} s" if step else ""
            self.note(f"the integrator ({self.method}) struggles: {self.evaluations} evaluations of the dynamics "
                      f"in {self.steps} steps for {100 * time / self.duration:.2g} % of the run{last}"
                      f"{self._advice()}")

    def _advice(self) -> str:
        if self.method in EXPLICIT:
            return "; the robot may be stiff (strong damping, smoothed friction): try --method LSODA, Radau or BDF"
        return "; " + (self.hint or "the motion may be nearly discontinuous, or the tolerances too tight "
                                    "(--rtol, --atol)")


def checked(function: Callable[..., object], where: str, column: int, what: str) -> Callable[..., np.ndarray]:
    """``function(t, q, qd)`` (a lambdified option's expression) that raises a positioned
    InputError where its value is not finite (``1/t`` at t = 0, ``exp(1000*t)`` once it
    overflows), naming the time: the run stops there."""
    def evaluate(time: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        try:
            with np.errstate(all="ignore"):
                value = np.asarray(function(time, q, qd), dtype=float)
        except (ArithmeticError, ValueError, TypeError) as exc:   # 1/t at 0, math's domain errors
            shown, value = str(exc) or type(exc).__name__, None
        else:
            shown = ", ".join(f"{v:g}" for v in value.reshape(-1))
        if value is None or not np.all(np.isfinite(value)):
            raise InputError(Problem(where, 1, column, f"{what} is not finite at t = {time:.6g} s "
                                     f"({shown}); the run stops there"))
        return value
    return evaluate
