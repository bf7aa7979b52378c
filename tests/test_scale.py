"""Issue 17: lazy derivation, intermediate-variable form, structured code for large robots.

The intermediate-variable (IV) quantities come from the recursive programs; the expanded ones
from body Jacobians, Christoffel symbols of the expanded M and dV/dq. Lowering the size limit
derives the same small robot both ways, so each route checks the other, numerically, at
random states and full-precision parameters. Larger robots are checked against Pinocchio.
"""

from __future__ import annotations

import json
import random
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.mechanics import structured
from dynderive.render.sheets.json import render_json
from dynderive.verify.checks import generated_module

from random_robots3d import random_spatial_tree

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from models import planar_chain_yaml, spatial_chain_yaml  # noqa: E402


def _load(tmp_path: Path, text: str, name: str = "robot") -> dynderive.Robot:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return dynderive.load_robot(path)


def _values(derivation, rng: np.random.Generator) -> dict[sympy.Symbol, float]:
    table = derivation.symbols
    values = {s: float(v) for s, v in table.defaults(derivation.robot).items()}
    for group in (table.q, table.qd, table.qdd, list(table.efforts.values())):
        values.update({s: float(rng.uniform(-1.5, 1.5)) for s in group})
    return values


def _numeric(value, values: dict, intermediates: list) -> np.ndarray:
    """``value`` at ``values``, the intermediate variables evaluated in order first."""
    known = dict(values)
    for name, definition in intermediates:
        known[name] = sympy.Float(definition.xreplace(known))
    matrix = sympy.Matrix(value) if isinstance(value, sympy.MatrixBase) else sympy.Matrix([value])
    return np.array(matrix.xreplace(known).evalf(), dtype=float)


def _both_forms(robot, monkeypatch):
    """The robot derived expanded, and in intermediate-variable form (size limits at 0)."""
    expanded = dynderive.derive(robot)
    assert not expanded.intermediate_form
    with monkeypatch.context() as patch:
        patch.setattr(structured, "PLANAR_EXPLICIT_DOF", 0)
        patch.setattr(structured, "LAGRANGE_DOF_LIMIT", 0)
        iv = dynderive.derive(robot)
        assert iv.intermediate_form
        iv.keys()   # derive everything while the limits are lowered
    return expanded, iv


NAMES = ["T_g", "V_g", "L_g", "M_g", "C_g", "N_g", "EOM_g1", "EOM_g2"]


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_intermediate_form_equals_expanded(kind, tmp_path, monkeypatch):
    """Every IV quantity, read back from the JSON dump, equals the expanded derivation's."""
    if kind == "planar":
        robot = _load(tmp_path, planar_chain_yaml(4, seed=3))
    else:
        robot = _load(tmp_path, random_spatial_tree(random.Random(11), 3, fixed=True).yaml_text)
    expanded, iv = _both_forms(robot, monkeypatch)
    names = NAMES + [f"J_b{k}" for k in range(1, len(robot.links) + 1)]
    assert set(names) <= set(iv.keys())
    assert len(iv.intermediates) > 10
    document = json.loads(render_json(iv))
    scope = iv.symbols.locals()
    intermediates = [(sympy.Symbol(name), sympy.sympify(entry["sympy"], locals=scope))
                     for name, entry in document["intermediates"].items()]
    assert [name for name, _ in intermediates] == [name for name, _ in iv.intermediates]
    rng = np.random.default_rng(5)
    for _ in range(3):
        values = _values(expanded, rng)
        for name in names:
            ours = _numeric(sympy.sympify(document["quantities"][name]["sympy"], locals=scope), values, intermediates)
            reference = _numeric(expanded[name], values, [])
            assert ours.shape == reference.shape, name
            np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-10, err_msg=name)
        for step in ("dL_dqd", "ddt_dL_dqd", "dL_dq"):   # Lagrange's steps, over the names
            ours = _numeric(iv.generalized_steps["lagrange"][step], values, iv.intermediates)
            reference = _numeric(expanded.generalized_steps["lagrange"][step], values, [])
            np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-10, err_msg=step)


def test_lagrange_check_over_intermediates_can_fail(tmp_path, monkeypatch):
    """EOM_g1 == EOM_g2 of a large robot is evaluated with the intermediates: it passes as
    derived, and fails when the gravity terms are off by a little."""
    from dynderive.mechanics.consistency import _zero_over_intermediates

    _, iv = _both_forms(_load(tmp_path, planar_chain_yaml(3, seed=4)), monkeypatch)
    check = next(c for c in iv.checks if c.name == "EOM_g1 == EOM_g2")
    assert check.passed and check.method == "numeric"
    difference = sympy.Matrix(iv["EOM_g1"]) - iv["EOM_g2"]
    wrong = difference + sympy.Matrix([1e-6 * sympy.cos(iv.symbols.q[0])] + [0] * (len(iv.symbols.q) - 1))
    failed = _zero_over_intermediates(iv, "x", "", wrong, iv["EOM_g2"])
    assert not failed.passed and failed.residual > 1e-7


#: A title with Python, LaTeX and YAML specials: it must reach the outputs as inert text.
HOSTILE_TITLE = "Chain \"\"\"; __import__('os').system('x') #\n \\input{/etc/passwd} 100% & $_^~{}"


def test_intermediate_form_sheet_names_every_variable(tmp_path, monkeypatch):
    text = planar_chain_yaml(3, seed=1)
    title = next(line for line in text.splitlines() if line.startswith("title:"))
    robot = _load(tmp_path, text.replace(title, "title: " + json.dumps(HOSTILE_TITLE)))
    assert robot.title == HOSTILE_TITLE
    _, iv = _both_forms(robot, monkeypatch)
    tex = dynderive.render_latex(iv)
    # the recursion line by line, named by meaning (issue 32), no numbered variables
    assert "Forward pass" in tex and "_w" not in tex and r"\mathsf{w}" not in tex
    assert tex.count(r"\omega_{") >= len(iv.symbols.q)
    assert "\\input{/etc/passwd}" not in tex and "100%" not in tex
    with monkeypatch.context() as patch:
        patch.setattr(structured, "PLANAR_EXPLICIT_DOF", 0)
        module = generated_module(dynderive.render_code(dynderive.derive(robot)), "hostile_chain")
    assert HOSTILE_TITLE in module.__doc__
    assert json.loads(render_json(iv))["intermediates"]


def test_structured_module_equals_expanded_module(tmp_path, monkeypatch):
    """A planar robot over the size limit gets M, C, N, T, V from programs; the functions
    agree with the module printed from the expanded quantities, maximal ones included."""
    robot = _load(tmp_path, planar_chain_yaml(4, seed=2))
    expanded = generated_module(dynderive.render_code(dynderive.derive(robot)), "expanded_chain")
    with monkeypatch.context() as patch:
        patch.setattr(structured, "PLANAR_EXPLICIT_DOF", 0)
        derivation = dynderive.derive(robot)
        source = dynderive.render_code(derivation)
    assert "def _potential_body" in source and "def _coriolis_body" in source
    programs = generated_module(source, "structured_chain")
    rng = np.random.default_rng(8)
    q, qd = rng.uniform(-2, 2, (2, 6, 4))
    u = rng.uniform(-2, 2, (6, 4))
    for name, args in [("mass_matrix", (q,)), ("coriolis_matrix", (q, qd)), ("gravity_vector", (q,)),
                       ("kinetic_energy", (q, qd)), ("potential_energy", (q,)), ("forward_dynamics", (q, qd, u)),
                       ("to_maximal", (q,)), ("to_maximal_jacobian", (q,))]:
        np.testing.assert_allclose(getattr(programs, name)(*args), getattr(expanded, name)(*args),
                                   rtol=1e-10, atol=1e-10, err_msg=name)


def test_code_only_derives_nothing_symbolic(tmp_path):
    """`--code` of a generic 7-DOF chain builds programs from the robot: no kinematics, no
    symbolic M, C, N, no checks (the stages are reported as they run)."""
    stages: list[str] = []
    derivation = dynderive.derive(_load(tmp_path, spatial_chain_yaml(7)), progress=stages.append)
    dynderive.render_code(derivation)
    assert stages and all(s.startswith("program:") for s in stages), stages
    assert derivation.checks_run == []


def test_maximal_model_without_generalized_equations(tmp_path):
    """Asking a large planar robot for h derives the maximal model only."""
    stages: list[str] = []
    derivation = dynderive.derive(_load(tmp_path, planar_chain_yaml(8)), progress=stages.append)
    assert derivation["h"].shape == (24, 1)
    assert not any("generalized" in s or "equations" in s for s in stages), stages


def test_keys_keep_the_derivation_order():
    """Whatever stage ran first, the quantities list in the order of the sheet."""
    d = dynderive.derive(dynderive.load_robot("rp_arm"))
    d["EOM_g3"], d["H"], d["M_g"]
    keys = d.keys()
    assert keys[:9] == ["T_g", "V_g", "L_g", "Y_g", "EOM_g1", "M_g", "C_g", "N_g", "EOM_g2"]
    assert keys.index("J_b2") < keys.index("q_m") < keys.index("EOM_m1") < keys.index("M_m") < keys.index("EOM_g3")


def test_large_spatial_chain_matches_pinocchio(tmp_path):
    """A generic 8-DOF chain in IV form (M, N, V from the sheet's quantities) and its module
    (C qd) against Pinocchio at full precision."""
    pin = pytest.importorskip("pinocchio")
    from dynderive.verify.pinocchio_model import pinocchio_model

    robot = _load(tmp_path, spatial_chain_yaml(8, seed=4))
    derivation = dynderive.derive(robot)
    assert derivation.intermediate_form
    model, perm = pinocchio_model(robot, {})
    data = model.createData()
    inverse = np.argsort(perm)
    module = generated_module(dynderive.render_code(derivation), "chain8")
    rng = np.random.default_rng(2)
    for _ in range(2):
        values = _values(derivation, rng)
        q = np.array([values[s] for s in derivation.symbols.q])
        qd = np.array([values[s] for s in derivation.symbols.qd])
        M = pin.crba(model, data, q[perm])
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(inverse, inverse)]
        gravity = pin.computeGeneralizedGravity(model, data, q[perm])[inverse]
        bias = pin.nonLinearEffects(model, data, q[perm], qd[perm])[inverse]
        potential = pin.computePotentialEnergy(model, data, q[perm])
        ours = {key: _numeric(derivation[key], values, derivation.intermediates) for key in ("M_g", "N_g", "V_g")}
        np.testing.assert_allclose(ours["M_g"], M, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(ours["N_g"].ravel(), gravity, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(module.coriolis_matrix(q, qd) @ qd, bias - gravity, rtol=1e-9, atol=1e-9)
        # potentials agree up to a constant: compare differences from the zero configuration
        zero = {**values, **{s: 0.0 for s in derivation.symbols.q}}
        ours_zero = _numeric(derivation["V_g"], zero, derivation.intermediates)[0, 0]
        pin_zero = pin.computePotentialEnergy(model, data, np.zeros(len(q)))
        assert abs((ours["V_g"][0, 0] - ours_zero) - (potential - pin_zero)) < 1e-9 * max(1.0, abs(potential))
        assert abs(module.potential_energy(q) - ours["V_g"][0, 0]) < 1e-9
