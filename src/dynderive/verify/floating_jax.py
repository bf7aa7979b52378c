"""``check --backend jax`` of a floating-base robot: its JAX module (``solve --floating-base
--jax``) against its NumPy module, function by function, in float64, at random states on the
manifold (random unit quaternions), to 1e-12 relative to the result's largest entry."""

from __future__ import annotations

from typing import Any

import numpy as np

from .checks import Row
from .compiled import RTOL, _difference

#: The functions compared, with the arrays they take (``frame``: once per frame of FRAMES).
FUNCTIONS = (
    ("mass_matrix", "q"), ("coriolis_matrix", "q qd"), ("gravity_vector", "q"), ("inverse_dynamics", "q qd qdd"),
    ("forward_dynamics", "q qd u"), ("kinetic_energy", "q qd"), ("potential_energy", "q"), ("linearize", "q qd u"),
    ("regressor", "q qd qdd"), ("parameter_vector", ""), ("neutral_configuration", ""), ("integrate", "q qd"),
    ("configuration_rate", "q qd"), ("difference", "q q1"),
    ("frame_transform", "q frame"), ("frame_jacobian", "q frame"), ("frame_jacobian_dot_qd", "q qd frame"),
)
#: The functions that take no parameters.
_GEOMETRY = {"neutral_configuration", "integrate", "configuration_rate", "difference"}


def floating_jax_checks(derivation: Any, source: str, states: int = 12, seed: int = 0) -> list[Row]:
    """One row per function of the floating-base NumPy module (``source``) against the JAX
    module, for a batch of ``states`` states and for one state; ``jax_enable_x64`` is switched
    on for this process."""
    import jax

    from ..render.floating_jax import render_floating_jax
    from .checks import generated_module
    from .floating_checks import random_configurations

    jax.config.update("jax_enable_x64", True)
    robot = derivation.robot
    module = generated_module(source, robot.name)
    traced = generated_module(render_floating_jax(derivation), f"{robot.name}_jax")
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
            keywords = {} if name in _GEOMETRY else values
            worst = _difference(getattr(module, name)(*arrays, *extra, **keywords),
                                getattr(traced, name)(*arrays, *extra, **keywords))
            if arrays:   # one state
                worst = max(worst, _difference(getattr(module, name)(*(a[0] for a in arrays), *extra, **keywords),
                                               getattr(traced, name)(*(a[0] for a in arrays), *extra, **keywords)))
            rows.append(Row(f"JAX {name}{f' (frame {frame})' if frame else ''} == NumPy module",
                            "pass" if worst <= RTOL else "FAIL",
                            f"numeric, {states} states and one, relative (at most {RTOL:g})", worst))
    return rows
