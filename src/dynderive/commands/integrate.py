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

import math
import warnings
from collections import deque
from collections.abc import Callable

import numpy as np

from ..errors import InputError, Problem
from ..model.naming import did_you_mean

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
#: A run *runs away* (an effort growing without bound, ``exp(1000*t)``: the robot spins ever
#: faster and the integrator's steps shrink with it, so the run would go on for hours with
#: every number finite) when both hold: the state is ``RUNAWAY_GROWTH`` times larger than at
#: the start (or than 1, if it started smaller), and at the pace of its last ``PACE_STEPS``
#: steps the rest of the run would take more than ``RUNAWAY_STEPS`` steps. Counted in steps,
#: not seconds, so the run stops at the same step on any machine. An unforced double pendulum
#: for 1000 s takes about 1e6 steps in all at rtol = 1e-9, with its state below 20; a stiff
#: arm's steps are small, but its state stays where it started.
RUNAWAY_GROWTH = 1e4
RUNAWAY_STEPS = 1e6
PACE_STEPS = 100
#: A state beyond this (in any unit) is overflowing: its products leave a double's range.
OVERFLOW = 1e150

#: culprit(time, state, body) -> the positioned problem for a motion that stopped being
#: computable (``body`` says how): the option to blame, an effort for instance.
Culprit = Callable[[float, np.ndarray, str], Problem]


def at_duration(time: float, state: np.ndarray, body: str) -> Problem:
    """The default culprit: no effort or force to blame, so the run's length."""
    return Problem("--duration", 1, 1, body)


def singular_problem(body: str) -> Problem:
    """A configuration where the dynamics cannot be solved, blamed on the start (``--q0``)."""
    return Problem("--q0", 1, 1, body)


class _Stop(Exception):
    """Raised by the right-hand side at a state that cannot be computed with (caught by ``run``)."""

    def __init__(self, time: float, state: np.ndarray, body: str, singular: bool = False):
        super().__init__(body)
        self.time, self.state, self.body, self.singular = time, state, body, singular


def method_name(text: str) -> str:
    """``--method`` as SciPy spells it (any case), or an InputError listing the choices."""
    for name in METHODS:
        if text.lower() == name.lower():
            return name
    raise InputError(Problem("--method", 1, 1, f"expected one of {', '.join(METHODS)}, got {text!r}"
                             + did_you_mean(text, METHODS)))


class Integrator:
    """Integrates ``rhs`` over ``[0, duration]``, possibly interval by interval (closed loops
    are projected onto their constraints at every frame); counts steps over the whole run."""

    def __init__(self, rhs: Callable[[float, np.ndarray], np.ndarray], method: str, rtol: float, atol: float,
                 duration: float, note: Callable[[str], None], hint: str = "", culprit: Culprit = at_duration):
        from scipy import integrate

        self.method, self.rtol, self.atol, self.culprit = method, rtol, atol, culprit
        self.evaluations = self.steps = self.stalled = 0   # over the whole run, interval by interval

        def counted(time: float, y: np.ndarray) -> np.ndarray:
            self.evaluations += 1
            if not np.all(np.isfinite(y)):
                raise _Stop(time, y, "the motion stopped being finite (the state left the range of a double)")
            if float(np.max(np.abs(y), initial=0.0)) > OVERFLOW:
                raise _Stop(time, y, f"the motion overflows (the state passed {OVERFLOW:.0e}, beyond which a "
                                     "double cannot hold its products)")
            try:
                return rhs(time, y)
            except np.linalg.LinAlgError:
                raise _Stop(time, y, "the configuration reached is singular (the mass matrix or the constraint "
                                     "Jacobian cannot be inverted there)", singular=True) from None
            except (ArithmeticError, ValueError) as exc:   # math.sin(1e300) in the generated module...
                raise _Stop(time, y, f"the dynamics cannot be evaluated at the state reached "
                                     f"({str(exc) or type(exc).__name__})") from None
        self.rhs = counted
        self.start = 0.0                  # the largest entry of the state at the start of the run
        self.scale: float | None = None   # ... or 1 if that is more
        self.pace: deque[float] = deque(maxlen=PACE_STEPS + 1)   # the times of the last steps
        self.solver_class = getattr(integrate, method)
        self.duration, self.note, self.hint = duration, note, hint
        self.noted = False

    def run(self, start: float, end: float, y0: np.ndarray, times: np.ndarray) -> np.ndarray:
        """The state at ``times`` (within ``[start, end]``, ascending), shape (len(times), len(y0))."""
        out = np.empty((len(times), len(y0)))
        filled = 0
        while filled < len(times) and times[filled] <= start:
            out[filled] = y0
            filled += 1
        if self.scale is None:
            self.start = float(np.max(np.abs(y0), initial=0.0))
            self.scale = max(1.0, self.start)
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")   # SciPy's warnings become the messages below
            try:
                return self._run(start, end, y0, times, out, filled)
            except _Stop as stop:
                body = f"{stop.body}, at t = {stop.time:.6g} s; the run stops there"
                raise InputError(singular_problem(body) if stop.singular
                                 else self.culprit(stop.time, stop.state, body)) from None

    def _run(self, start: float, end: float, y0: np.ndarray, times: np.ndarray, out: np.ndarray,
             filled: int) -> np.ndarray:
        solver = self.solver_class(self.rhs, start, y0, end, rtol=self.rtol, atol=self.atol)
        while solver.status == "running":
            before = solver.t
            message = solver.step()
            if solver.status == "failed":
                raise InputError(Problem("--method", 1, 1, f"the integrator ({self.method}) failed at "
                                         f"t = {before:.6g} s: {message}{self._advice()}"))
            if not np.all(np.isfinite(solver.y)):
                raise InputError(self.culprit(solver.t, solver.y, f"the motion stopped being finite between "
                                              f"t = {before:.6g} s and {solver.t:.6g} s (the state left the "
                                              "range of a double); the run stops there"))
            self.steps += 1
            self._runaway(solver.t, solver.y)
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

    def _runaway(self, time: float, y: np.ndarray) -> None:
        """Stop a run whose state has grown RUNAWAY_GROWTH-fold while its steps shrank so much
        that the rest of it would take more than RUNAWAY_STEPS steps (constants above)."""
        self.pace.append(time)
        if len(self.pace) <= PACE_STEPS:
            return
        size = float(np.max(np.abs(y), initial=0.0))
        assert self.scale is not None
        if size <= RUNAWAY_GROWTH * self.scale:
            return
        step = (self.pace[-1] - self.pace[0]) / PACE_STEPS
        ahead = (self.duration - time) / step if step > 0 else math.inf
        if ahead > RUNAWAY_STEPS:
            raise InputError(self.culprit(time, y, f"the motion runs away: at t = {time:.3g} s its state has "
                                          f"grown from {self.start:.2g} to {size:.2g} and its last {PACE_STEPS} "
                                          f"steps took {step:.2g} s each, so the rest of the run would take "
                                          f"{ahead:.2g} more steps; the run stops there"))

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
