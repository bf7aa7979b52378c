"""``check --backend c`` of a floating-base robot: its compiled extension (``solve
--c-extension``, ``render/targets/c_extension/c_extension_floating.py``) against its NumPy module, function by
function, at random states on the manifold (random unit quaternions), for a batch (the loop in
C) and for one state (the fast path), to 1e-12 relative to the result's largest entry; the
comparison ``floating_rows`` is also ``check --backend jax``'s (``floating_jax.py``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .checks import Row
from .compiled import RTOL, _difference, missing_rows

#: The functions compared, with the arrays they take (``frame``: once per frame of FRAMES).
FUNCTIONS = (
    ("mass_matrix", "q"), ("coriolis_matrix", "q qd"), ("gravity_vector", "q"), ("friction_forces", "qd"),
    ("inverse_dynamics", "q qd qdd"),
    ("forward_dynamics", "q qd u"), ("kinetic_energy", "q qd"), ("potential_energy", "q"), ("linearize", "q qd u"),
    ("regressor", "q qd qdd"), ("parameter_vector", ""), ("neutral_configuration", ""), ("integrate", "q qd"),
    ("configuration_rate", "q qd"), ("difference", "q q1"),
    ("frame_transform", "q frame"), ("frame_jacobian", "q frame"), ("frame_jacobian_dot_qd", "q qd frame"),
)
#: The functions that take no parameters.
GEOMETRY = {"neutral_configuration", "integrate", "configuration_rate", "difference"}


def floating_rows(module: Any, other: Any, robot: Any, label: str, states: int = 12, seed: int = 0) -> list[Row]:
    """One row per function of the floating-base NumPy ``module`` against ``other`` (the JAX
    module, the compiled extension), for a batch of ``states`` states and for one state, with
    the parameters' defaults (1.0 where a parameter has none)."""
    from .floating_checks import random_configurations

    values = {p.name: (p.value if p.value is not None else 1.0) for p in robot.parameters}
    rng = np.random.default_rng(seed + 7)
    nv = robot.velocity_count
    sample = {"q": random_configurations(robot, rng, states), "q1": random_configurations(robot, rng, states),
              "qd": rng.uniform(-1.0, 1.0, (states, nv)), "qdd": rng.uniform(-1.0, 1.0, (states, nv)),
              "u": rng.uniform(-1.0, 1.0, (states, len(robot.efforts)))}
    rows = []
    for name, args in FUNCTIONS:
        for frame in (module.FRAMES if "frame" in args else [None]):
            arrays = [sample[a] for a in args.split() if a != "frame"]
            extra = [frame] if frame else []
            keywords = {} if name in GEOMETRY else values
            worst = _difference(getattr(module, name)(*arrays, *extra, **keywords),
                                getattr(other, name)(*arrays, *extra, **keywords))
            if arrays:   # one state
                worst = max(worst, _difference(getattr(module, name)(*(a[0] for a in arrays), *extra, **keywords),
                                               getattr(other, name)(*(a[0] for a in arrays), *extra, **keywords)))
            rows.append(Row(f"{label} {name}{f' (frame {frame})' if frame else ''} == NumPy module",
                            "pass" if worst <= RTOL else "FAIL",
                            f"numeric, {states} states and one, relative (at most {RTOL:g})", worst))
    return rows


def floating_c_checks(derivation: Any, source: str, compiled: Any, states: int = 12, seed: int = 0) -> list[Row]:
    """``floating_rows`` of the compiled extension ``compiled`` against the NumPy module
    ``source``, and ``missing_rows`` of the module's functions the extension lacks."""
    from .checks import generated_module

    robot = derivation.robot
    module = generated_module(source, robot.name)
    rows = floating_rows(module, compiled, robot, "compiled", states, seed)
    missing = sorted(name for name, value in vars(module).items() if callable(value) and not name.startswith("_")
                     and not isinstance(value, type) and not hasattr(compiled, name))
    return rows + missing_rows(missing, "c-extension", "compiled", floating=True, frames=bool(robot.frames))
