"""The API table (``render/api.py``) is the generated API: every public function of a generated
NumPy module is a row of it, takes the row's arguments in its order and returns the row's
shapes; the C extension's functions and ``check --backend``'s list are read from it."""

from __future__ import annotations

import inspect
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render import api
from dynderive.render.targets.c_extension.c_extension import bindings
from dynderive.verify import compiled

from conftest import ROOT, derivation_of, import_code

#: A planar robot (with its maximal form), one with drives, a closed loop, a 3-D robot with
#: frames, and a floating base.
SAMPLES = ("rp_arm", "cart_pole_damped", "four_bar", "elbow_arm", "tests/floating_elbow.urdf")


@cache
def _generated(robot: str, directory: str):
    derivation = dynderive.derive(dynderive.load_robot(ROOT / robot)) if "/" in robot else derivation_of(robot)
    name = robot.replace("/", "_").replace(".", "_")
    return derivation, import_code(dynderive.render_code(derivation), Path(directory), f"api_{name}")


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    directory = tmp_path_factory.mktemp("api")
    return lambda robot: _generated(robot, str(directory))


def _public(module) -> set[str]:
    return {name for name, value in vars(module).items()
            if inspect.isfunction(value) and value.__module__ == module.__name__ and not name.startswith("_")}


@pytest.mark.parametrize("robot", SAMPLES)
def test_every_public_function_is_a_row_with_its_arguments(robot, sample):
    derivation, module = sample(robot)
    public = _public(module)
    assert not public - set(api.BY_NAME), f"not in the API table: {sorted(public - set(api.BY_NAME))}"
    for name in public:
        positional = [p.name for p in inspect.signature(getattr(module, name)).parameters.values()
                      if p.kind is p.POSITIONAL_OR_KEYWORD]
        assert positional[:len(api.BY_NAME[name].arguments)] == list(api.BY_NAME[name].arguments), name


@pytest.mark.parametrize("robot", SAMPLES)
def test_results_have_the_rows_shapes(robot, sample):
    derivation, module = sample(robot)
    size = api.sizes(derivation)
    rng = np.random.default_rng(7)
    values = {"frame": module.FRAMES[0] if module.FRAMES else None, "dt": 0.25}
    for argument, letter in api.ARGUMENT_SIZES.items():
        if letter is not None:
            values[argument] = rng.uniform(-0.5, 0.5, size[letter])
    if hasattr(module, "neutral_configuration"):
        for argument in ("q", "q_from", "q_to"):
            values[argument] = module.integrate(module.neutral_configuration(), rng.uniform(-0.5, 0.5, size["NV"]))
    if hasattr(module, "ASSEMBLED_CONFIGURATION"):
        values["q_guess"] = np.array(module.ASSEMBLED_CONFIGURATION)
    checked = 0
    for name in sorted(_public(module)):
        row = api.BY_NAME[name]
        if "frame" in row.arguments and values["frame"] is None:
            continue
        result = getattr(module, name)(*(values[a] for a in row.arguments))
        results = result if isinstance(result, tuple) else (result,)
        assert tuple(np.shape(r) for r in results) == api.shapes(name, size), name
        checked += 1
    assert checked >= 12


@pytest.mark.parametrize("robot", SAMPLES)
def test_the_extension_and_the_backend_check_read_the_table(robot, sample):
    derivation, module = sample(robot)
    size = api.sizes(derivation)
    for binding in bindings(derivation):
        row = api.BY_NAME[binding.name]
        assert [name for name, _ in binding.inputs] == [a for a in row.arguments if a != "frame"]
        assert binding.outputs == api.shapes(binding.name, size)
        assert binding.doc.startswith(row.summary)
    compared = {name for name, _ in compiled.FUNCTIONS + compiled.FRAME_FUNCTIONS}
    # the maximal form and the contact dynamics: Python modules only
    assert _public(module) - compared <= set(api.group("maximal")) | set(api.group("contacts"))


def test_descriptions_state_shapes_in_each_idiom():
    size = {"NV": 3, "NP": 12, "2NV": 6, "NU": 2, "NQ": 3}
    assert api.python_doc("mass_matrix", size) == "Mass matrix M_g(q) (Pinocchio's ``crba``), shape (..., 3, 3)."
    assert api.python_doc("parameter_vector", size, batch=False).endswith("shape (12,).")
    assert api.python_doc("kinetic_energy", size).endswith("shape (...).")
    assert api.described("linearize", size, "{n} entries", ", row-major").endswith(
        "u, 6 x 6 and 6 x 2, row-major")
    assert api.described("gravity_vector", size, "{n} x 1") == "Gravity vector N_g(q), the gradient of V_g, 3 x 1"
