"""``check --backend c``: the compiled extension against the NumPy module, function by function.

The NumPy module is what every other check holds to the symbolic quantities, Pinocchio and
the reference closed forms, so the compiled code inherits that trust once each of its
functions gives the NumPy module's numbers at the same states: for a batch (the loop in C)
and for one state (the fast path), to 1e-12 relative to the result's largest entry (section
9 of the design). A robot with quaternions (a floating or spherical joint) is compared at
random states on its manifold (random unit quaternions), its configuration maps too; the
comparison is also ``check --backend jax``'s and ``casadi``'s, and ``tests/test_targets_agree.py``'s
for every target the registry can load.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..derivation import Derivation
from ..model.robot import Robot
from ..render import api
from .rows import Row, peak

#: Agreement required of the compiled functions, relative to the result's largest entry.
RTOL = 1e-12
#: ...except ``assemble``, an iteration that stops once |a_g| < 1e-12: two roots that close
#: (the NumPy module's batch takes further steps on states that have converged, until all have).
RTOLS = {"assemble": 1e-10}

#: The state each argument of the API is drawn from (``q_to``: a second configuration).
STATES = {"q": "q", "qd": "qd", "v": "qd", "qdd": "qdd", "u": "u", "q_guess": "q", "q_from": "q", "q_to": "q1",
          "qd_minus": "qd", "qm": "qm", "qmd": "qmd"}


def _arrays(function: api.Function) -> str:
    return " ".join(STATES[a] for a in function.arguments if a in STATES)


#: The functions compared (the API table's), with the arrays they take (``p``: keyword parameters
#: only); the contact functions hold the robot file's CONTACTS (none: forward dynamics); a planar
#: robot's maximal form (which only the Python modules print) where both modules have it, at
#: random maximal coordinates (``qm``, ``qmd``: compared as functions, off the constraints too).
FUNCTIONS = tuple((f.name, _arrays(f)) for f in api.API if f.group in ("dynamics", "centroidal", "loops", "configuration",
                                                                           "contacts", "maximal"))
#: The functions that take ``friction_smoothing``.
SMOOTHED = {"inverse_dynamics", "forward_dynamics", "friction_forces", "linearize", "inverse_dynamics_derivatives",
            "forward_dynamics_derivatives", "loop_forces", "reduced_forward_dynamics", "constrained_forward_dynamics"}
#: The functions that take no parameters (a robot with quaternions: its configuration maps).
GEOMETRY = set(api.group("configuration"))
FRAME_FUNCTIONS = tuple((f.name, _arrays(f)) for f in api.API if f.group == "frames")
#: The contact functions (the CasADi module builds a Function per set of contacts).
CONTACTS = set(api.group("contacts"))


def _difference(expected: Any, got: Any) -> float:
    """Largest difference relative to the largest entry (at least 1); tuples entry by entry."""
    if isinstance(expected, tuple):
        return max(_difference(e, g) for e, g in zip(expected, got, strict=True))
    expected, got = np.asarray(expected, dtype=float), np.asarray(got, dtype=float)
    if expected.shape != got.shape:
        return float("inf")
    return peak(expected - got) / max(1.0, peak(expected))


def _compared(module: Any, other: Any, values: dict[str, float], states: dict[str, np.ndarray],
              friction_smoothing: float, label: str) -> tuple[list[Row], list[str]]:
    """The rows of the functions of ``module`` that ``other`` has too, and those it lacks."""
    rows: list[Row] = []
    missing = []
    count = len(states["q"])
    friction = {"friction_smoothing": friction_smoothing}
    cases = [(name, args, ()) for name, args in FUNCTIONS]
    cases += [(name, args, (frame,)) for frame in getattr(module, "FRAMES", ()) for name, args in FRAME_FUNCTIONS]
    for name, args, extra in cases:
        if not hasattr(module, name) or (friction_smoothing and name not in SMOOTHED):   # the others take none
            continue
        if not hasattr(other, name):
            missing.append(name)
            continue
        arrays = [states[a] for a in args.split()]
        calls = [arrays, [a[0] for a in arrays]] if arrays else [arrays]   # a batch, and one state
        keywords = {} if name in GEOMETRY else dict(
            values, **(friction if name in SMOOTHED else {}))
        title = f"{label} {name}{_frame(extra, friction_smoothing)} == NumPy module"
        try:
            worst = max(_difference(*(getattr(m, name)(*given, *extra, **keywords) for m in (module, other)))
                        for given in calls)
        except (ValueError, TypeError, np.linalg.LinAlgError) as exc:
            rows.append(Row(title, "FAIL", f"raised {type(exc).__name__}: {exc}", float("nan")))
            continue
        tolerance = RTOLS.get(name, RTOL)
        rows.append(Row(title, "pass" if worst <= tolerance else "FAIL",
                        f"numeric, {count} states and one, relative (at most {tolerance:g})", worst))
    return rows, missing


def compiled_rows(module: Any, compiled: Any, values: dict[str, float], states: dict[str, np.ndarray],
                  friction_smoothing: float = 0.0, label: str = "compiled", target: str = "c-extension",
                  floating: bool = False) -> list[Row]:
    """One row per function of the NumPy ``module`` that ``compiled`` (the ``target`` of
    ``render/offered.py``) offers, at ``states`` (arrays ``q``, ``qd``, ``qdd``, ``u`` of one
    shape ``(count, size)``; ``q1``, a second configuration, for ``difference``), and
    ``missing_rows`` of the functions it does not offer (``floating``: a robot with quaternions)."""
    rows, missing = _compared(module, compiled, values, states, friction_smoothing, label)
    count = len(states["q"])
    frames = getattr(module, "FRAMES", ())
    if frames and hasattr(compiled, "inverse_dynamics"):
        rng = np.random.default_rng(1)
        size = module.frame_jacobian(states["q"][0], frames[0], **values).shape[0]
        wrenches = {frame: rng.uniform(-1.0, 1.0, (count, size)) for frame in frames}
        for name, arguments in (("inverse_dynamics", ("q", "qd", "qdd")), ("forward_dynamics", ("q", "qd", "u"))):
            arrays = [states[a] for a in arguments]
            worst = _difference(getattr(module, name)(*arrays, wrenches, **values),
                                getattr(compiled, name)(*arrays, wrenches, **values))
            rows.append(Row(f"{label} {name} with wrenches at every frame == NumPy module",
                            "pass" if worst <= RTOL else "FAIL", f"numeric, {count} states, relative", worst))
    missing += sorted(name for name, value in vars(module).items() if callable(value) and not name.startswith("_")
                      and not hasattr(compiled, name) and name not in missing and not isinstance(value, type))
    return rows + missing_rows(missing, target, label, floating, bool(frames), hasattr(module, "loop_constraints"))


def missing_rows(missing: list[str], target: str, label: str, floating: bool = False, frames: bool = True,
                 loops: bool = False) -> list[Row]:
    """The NumPy module's functions ``target`` lacks: one "skip" row per reason the table of
    what is not built (``render/offered.py``) gives, "not built" and the functions; a FAIL row
    for any it does not list."""
    from ..render.offered import not_built

    reasons: dict[str | None, list[str]] = {}
    for name in missing:
        reasons.setdefault(not_built(target, name, floating, frames, loops), []).append(name)
    rows = [Row(f"{label} not built: {names[0]}" + (f" and {len(names) - 1} more" if len(names) > 1 else ""), "skip",
                f"{reason}: {', '.join(names)}", float("nan"))
            for reason, names in reasons.items() if reason is not None]
    if None in reasons:
        rows.append(Row(f"{label} module offers every function", "FAIL",
                        "missing, and not listed as not built: " + ", ".join(reasons[None]), float("nan")))
    return rows


def _frame(extra: tuple, smoothing: float = 0.0) -> str:
    return (f" (frame {extra[0]})" if extra else "") + (f" (friction_smoothing {smoothing:g})" if smoothing else "")


def _states(robot: Robot, rng: np.random.Generator, states: int) -> dict[str, np.ndarray]:
    """Random states: ``q`` (and ``q1``) on the robot's manifold (unit quaternions), the rest uniform."""
    from .checks import random_configurations

    nv, nu = robot.velocity_count, len(robot.efforts)
    sample = {"q": random_configurations(robot, rng, states)}
    if robot.floating:
        sample["q1"] = random_configurations(robot, rng, states)
    sample |= {"qd": rng.uniform(-1.0, 1.0, (states, nv)), "qdd": rng.uniform(-1.0, 1.0, (states, nv)),
               "u": rng.uniform(-1.0, 1.0, (states, nu))}
    if "q1" not in sample:   # difference's q_to for every robot, drawn last: the states before it stay the same
        sample["q1"] = random_configurations(robot, rng, states)
    return sample


def compiled_checks(derivation: Derivation, source: str, compiled: Any, states: int = 12, seed: int = 0,
                    label: str = "compiled", target: str = "c-extension",
                    values: dict[str, float] | None = None) -> list[Row]:
    """``compiled_rows`` at random states of ``derivation``'s robot (on the loops, for a robot
    with closed loops), with the parameters' defaults (1.0 where a parameter has none) or
    ``values`` where given."""
    from .checks import _loop_states, generated_module

    robot = derivation.robot
    module = generated_module(source, robot.name)
    values = {p.name: (p.value if p.value is not None else 1.0) for p in robot.parameters} | (values or {})
    sample = _states(robot, np.random.default_rng(seed + 7), states)
    if hasattr(module, "MAXIMAL_COORDINATES"):   # the maximal form's arguments
        rng, size = np.random.default_rng(seed + 11), len(module.MAXIMAL_COORDINATES)
        sample |= {"qm": rng.uniform(-1.5, 1.5, (states, size)), "qmd": rng.uniform(-1.0, 1.0, (states, size))}
    if robot.loops:
        sample["q"], sample["qd"], _ = _loop_states(derivation, module, values, sample["q"], sample["qd"])
        if not len(sample["q"]):
            return [Row("compiled module == NumPy module", "FAIL", "no random state could be assembled",
                        float("nan"))]
        sample = {k: v[: len(sample["q"])] for k, v in sample.items()}
    friction = 1e-3 if any(j.friction is not None for j in robot.joints if j.moves) else 0.0
    rows = compiled_rows(module, compiled, values, sample, label=label, target=target, floating=robot.floating)
    if friction:   # the smoothed sign too (what simulate integrates), for the functions that take it
        rows += [r for r in compiled_rows(module, compiled, values, sample, friction, label, target, robot.floating)
                 if "smoothing" in r.name]
    return rows


class CasadiModule:
    """The CasADi module (``--casadi``) behind the NumPy module's calling convention, for the
    comparison above (``check --backend casadi``): arrays of one state or a batch (one call of
    the ``casadi.Function`` per state, its inputs as column vectors), the parameters as
    keywords (gathered into the vector ``p`` in ``PARAMETER_NAMES``' order), ``friction_smoothing``
    as a keyword, a frame as the last positional argument (its Function from
    ``frame_transform(frame)``...), results in the API table's shapes (``render/api.py``), and
    the contact functions' Function of the robot file's contacts, ``inverse_dynamics``'
    ``wrenches`` added as ``J^T w`` with ``frame_jacobian(frame)``, as
    the CasADi reference says to. Only the module's own Functions are reached: a function it
    does not offer is an ``AttributeError`` (``hasattr`` false), as for the other modules."""

    RANKS = {f.name: tuple(len(shape) for shape in f.results) for f in api.API}

    def __init__(self, module: Any) -> None:
        self.module = module

    def __getattr__(self, name: str) -> Any:
        import casadi

        value = getattr(self.module, name)   # AttributeError: not offered
        if name.startswith("frame_") and name in self.RANKS and not isinstance(value, casadi.Function):
            return lambda *args, **keywords: self._call(value(args[-1]), name, args[:-1], keywords)
        if name in CONTACTS and not isinstance(value, casadi.Function):   # a Function per set: the file's contacts
            return lambda *args, **keywords: self._call(value(self.module.CONTACTS), name, args, keywords)
        if not isinstance(value, casadi.Function):
            return value
        if name == "inverse_dynamics":
            return self._inverse_dynamics
        if name == "forward_dynamics":
            return self._forward_dynamics
        return lambda *args, **keywords: self._call(value, name, args, keywords)

    def _inverse_dynamics(self, q: Any, qd: Any, qdd: Any, wrenches: Any = None,
                          **keywords: Any) -> np.ndarray:
        tau = self._call(self.module.inverse_dynamics, "inverse_dynamics", (q, qd, qdd), keywords)
        parameters = {k: v for k, v in keywords.items() if k != "friction_smoothing"}
        for frame, wrench in (wrenches or {}).items():
            jacobian = self._call(self.module.frame_jacobian(frame), "frame_jacobian", (q,), parameters)
            tau = tau - np.einsum("...ij,...i->...j", jacobian, np.asarray(wrench, dtype=float))
        return tau

    def _forward_dynamics(self, q: Any, qd: Any, u: Any = None, wrenches: Any = None,
                          **keywords: Any) -> np.ndarray:
        """The Function's accelerations, plus what the ``wrenches`` add: the solution of the
        (loop-constrained) mass matrix's system for ``J^T w`` (the accelerations are linear in
        the generalized forces, the Baumgarte terms in the loops' rows unchanged)."""
        if u is None:
            u = np.zeros(np.shape(q)[:-1] + (len(self.module.EFFORTS),))
        qdd = self._call(self.module.forward_dynamics, "forward_dynamics", (q, qd, u), keywords)
        if not wrenches:
            return qdd
        parameters = {k: v for k, v in keywords.items() if k not in ("friction_smoothing", "alpha", "beta")}
        force = sum(np.einsum("...ij,...i->...j", self._call(self.module.frame_jacobian(frame), "frame_jacobian",
                                                             (q,), parameters), np.asarray(wrench, dtype=float))
                    for frame, wrench in wrenches.items())
        matrix = np.asarray(self._call(self.module.mass_matrix, "mass_matrix", (q,), parameters))
        rows = np.zeros(matrix.shape[:-2] + (0, matrix.shape[-1]))
        if hasattr(self.module, "LOOPS"):
            rows = np.asarray(self._call(self.module.loop_jacobian, "loop_jacobian", (q,), parameters))
        size, count = matrix.shape[-1], rows.shape[-2]
        kkt = np.zeros(matrix.shape[:-2] + (size + count, size + count))
        kkt[..., :size, :size], kkt[..., :size, size:], kkt[..., size:, :size] = matrix, -np.swapaxes(rows, -1, -2), rows
        right = np.concatenate([np.broadcast_to(force, matrix.shape[:-1]), np.zeros(matrix.shape[:-2] + (count,))], -1)
        return qdd + np.linalg.solve(kkt, right[..., None])[..., :size, 0]

    def _call(self, function: Any, name: str, args: tuple, keywords: dict[str, Any]) -> Any:
        """``function`` at each state of ``args`` (the Function's array inputs in order)."""
        import casadi

        inputs = [n for n in function.name_in() if n not in ("p", "friction_smoothing", "alpha", "beta")]
        arrays = [np.asarray(a, dtype=float) for a in args]
        given: dict[str, Any] = {}
        if "p" in function.name_in():
            given["p"] = [float(keywords.get(n, v)) for n, v in
                          zip(self.module.PARAMETER_NAMES, self.module.default_parameters(), strict=True)]
        for key in ("friction_smoothing", "alpha", "beta"):
            if key in function.name_in() and key in keywords:
                given[key] = float(keywords[key])
        ranks = self.RANKS.get(name, (2,) * function.n_out())
        batch = bool(arrays) and arrays[0].ndim > 1

        def one(state: list[np.ndarray]) -> tuple[np.ndarray, ...]:
            arrays_in = {n: a.reshape(-1, 1) for n, a in zip(inputs[: len(state)], state, strict=True)}
            result = function.call({**given, **arrays_in})   # a dict, whatever the inputs
            values = [np.asarray(casadi.DM(result[n]), dtype=float) for n in function.name_out()]
            return tuple(v.reshape(()) if r == 0 else v.ravel() if r == 1 else v
                         for v, r in zip(values, ranks, strict=True))

        results = [one([a[i] for a in arrays]) for i in range(len(arrays[0]))] if batch else [one(arrays)]
        stacked = tuple(np.stack(r) for r in zip(*results, strict=True)) if batch else results[0]
        return stacked[0] if len(stacked) == 1 else stacked
