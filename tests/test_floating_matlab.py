"""The MATLAB/Octave package of floating-base robots (``render/targets/matlab/matlab.py``):
every function, run in GNU Octave, agrees with the NumPy floating module (which agrees with
Pinocchio's free flyer) to 1e-10 relative at random unit quaternions, for a random floating
tree with full-precision numbers and a free box with a non-default parameter; ``solve
--matlab`` and ``build --matlab`` write the package.

Needs GNU Octave: skipped locally without it, required in CI (CI=true)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.matlab.matlab import render_matlab
from dynderive.verify.checks import random_configurations
from test_free_flyer import BOX, _floating_tree, _module
from test_matlab_numeric import _Calls, _octave, _vector, needs_octave
from test_spherical import _tree as _spherical_tree


def _agree(derivation, directory: Path, seed: int, values: dict | None = None) -> None:
    for path, text in render_matlab(derivation).items():
        (directory / path).parent.mkdir(parents=True, exist_ok=True)
        (directory / path).write_text(text)
    module, name = _module(derivation.robot, directory), derivation.robot.name
    values = values or {}
    calls = _Calls(name)
    calls.lines.append(f"p = {name}.parameters();")
    calls.lines += [f"p.{key} = {format(value, '.17g')};" for key, value in values.items()]
    calls.add("neutral", "neutral_configuration()", module.neutral_configuration())
    calls.add("pi", "parameter_vector(p)", module.parameter_vector(**values))
    rng = np.random.default_rng(seed)
    nv, nu = module.NV, len(module.EFFORTS)
    for k in range(2):
        q, q1 = random_configurations(derivation.robot, rng, 2)
        qd, qdd, u = rng.normal(size=nv), rng.normal(size=nv), rng.normal(size=nu)
        Q, Q1, QD, QDD, U = (_vector(a) for a in (q, q1, qd, qdd, u))
        calls.add(f"M{k}", f"mass_matrix({Q}, p)", module.mass_matrix(q, **values))
        calls.add(f"C{k}", f"coriolis_matrix({Q}, {QD}, p)", module.coriolis_matrix(q, qd, **values))
        calls.add(f"N{k}", f"gravity_vector({Q}, p)", module.gravity_vector(q, **values))
        calls.add(f"tau{k}", f"inverse_dynamics({Q}, {QD}, {QDD}, p)", module.inverse_dynamics(q, qd, qdd, **values))
        calls.add(f"qdd{k}", f"forward_dynamics({Q}, {QD}, {U}, p)", module.forward_dynamics(q, qd, u, **values))
        calls.add(f"T{k}", f"kinetic_energy({Q}, {QD}, p)", module.kinetic_energy(q, qd, **values))
        calls.add(f"V{k}", f"potential_energy({Q}, p)", module.potential_energy(q, **values))
        calls.add(f"Y{k}", f"regressor({Q}, {QD}, {QDD}, p)", module.regressor(q, qd, qdd, **values))
        calls.add(f"lin{k}", f"linearize({Q}, {QD}, {U}, p)", module.linearize(q, qd, u, **values), outputs=2)
        calls.add(f"int{k}", f"integrate({Q}, {QD}, 0.3)", module.integrate(q, qd, 0.3))
        calls.add(f"dif{k}", f"difference({Q}, {Q1})", module.difference(q, q1))
        calls.add(f"rate{k}", f"configuration_rate({Q}, {QD})", module.configuration_rate(q, qd))
        for index, frame in enumerate(module.FRAMES):
            calls.add(f"F{k}_{index}", f"frame_transform({Q}, {index + 1}, p)", module.frame_transform(q, frame, **values))
            calls.add(f"J{k}_{index}", f"frame_jacobian({Q}, {index + 1}, p)", module.frame_jacobian(q, frame, **values))
            calls.add(f"a{k}_{index}", f"frame_jacobian_dot_qd({Q}, {QD}, {index + 1}, p)",
                      module.frame_jacobian_dot_qd(q, qd, frame, **values))
    calls.check(_octave(directory, "\n".join(calls.lines) + "\n"))


@needs_octave
def test_random_floating_tree_agrees_with_the_numpy_module(tmp_path):
    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(2))
    _agree(dynderive.derive(dynderive.load_robot(path)), tmp_path, seed=2)


@needs_octave
@pytest.mark.parametrize("floating", [False, True])
def test_random_trees_with_spherical_joints_agree_with_the_numpy_module(floating, tmp_path):
    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_spherical_tree(7, floating))
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert any(j.type == "spherical" for j in derivation.robot.joints)
    _agree(derivation, tmp_path, seed=7)


@needs_octave
def test_box_with_a_parameter_agrees_with_the_numpy_module(tmp_path):
    (tmp_path / "free_box.yaml").write_text(BOX.replace("name: box", "name: free_box"))   # Octave has a box()
    _agree(dynderive.derive(dynderive.load_robot(tmp_path / "free_box.yaml")), tmp_path, seed=4,
           values={"m": 2.5, "g": 9.7})


def test_solve_and_build_write_the_package(tmp_path):
    (tmp_path / "box.yaml").write_text(BOX)
    runner = CliRunner()
    result = runner.invoke(app, ["solve", str(tmp_path / "box.yaml"), "--matlab", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    integrate = (tmp_path / "out" / "+box" / "integrate.m").read_text()
    assert integrate.startswith("function out = integrate(q, v, dt)") and "function y = if_else(" in integrate
    result = runner.invoke(app, ["build", str(tmp_path / "box.yaml"), "--matlab", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "b" / "+box" / "integrate.m").read_text() == integrate
