"""The MATLAB/Octave target's numeric package (``solve --matlab``, ``render/targets/matlab/matlab.py``): every
function of every bundled robot agrees with the NumPy module at random states (loop robots at
assembled states, non-default parameters and friction smoothing included) to 1e-10 relative,
run in GNU Octave (one process per robot); ``ode45`` on the double pendulum conserves energy;
the documentation's ``ode45`` example runs; the files hold MATLAB syntax only; hostile free text stays
inside its comments; a name MATLAB cannot take is refused at its place in the robot file.

Floating-base robots too: every function, run in GNU Octave, agrees with the NumPy floating module
(which agrees with Pinocchio's free flyer) to 1e-10 relative at random unit quaternions, for a
random floating tree with full-precision numbers, random trees with spherical joints and a free
box with a non-default parameter; ``solve --matlab`` and ``build --matlab`` write the package.

The centre of mass and centroidal momentum functions (3-D robots) agree with the NumPy module to
1e-12 relative on the Panda and the floating tests/floating_elbow.urdf, with link parameters made
symbolic, and run in Octave without a warning.

The contact functions (3-D robots without loops) agree with the NumPy module to 1e-12 relative,
warning-free, on test_contacts' random floating tree (a surface and a point contact) and random
fixed-base tree, with contacts by name, number and struct array, Baumgarte gains and anchors; each
refusal is an error with its identifier; every bundled 3-D robot holds its first frame.

Needs GNU Octave: skipped locally without it, required in CI (CI=true).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.render.targets.matlab.matlab import render_matlab
from dynderive.verify.checks import random_configurations

from conftest import derivation_of, import_code, module_of

OCTAVE = shutil.which("octave-cli") or shutil.which("octave")
if OCTAVE is None and os.environ.get("CI"):
    raise RuntimeError("CI must run the MATLAB/Octave target tests, but GNU Octave (octave) was not found")
needs_octave = pytest.mark.skipif(OCTAVE is None, reason="GNU Octave is not installed")

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = sorted(p.stem for p in (ROOT / "robots").glob("*.yaml")) + ["panda", "ur5"]
#: An over-constrained loop beside the bundled bennett (4 rows of rank 3).
EXTRA = [str(ROOT / "tests" / "loops" / "double_parallelogram.yaml")]
LOOP_ROBOTS = {"four_bar", "slider_crank", "bennett", "spatial_four_bar", *EXTRA}
TOLERANCE = 1e-10
#: The centre of mass and centroidal momentum (3-D robots): each function's MATLAB arguments.
CENTROIDAL = {"total_mass": "", "center_of_mass": "q", "center_of_mass_velocity": "q, qd",
              "center_of_mass_jacobian": "q", "center_of_mass_acceleration_bias": "q, qd",
              "centroidal_momentum_matrix": "q", "centroidal_momentum": "q, qd", "centroidal_momentum_bias": "q, qd",
              "centroidal_inertia": "q"}


def _write(derivation, directory: Path) -> dict[str, str]:
    files = render_matlab(derivation)
    for path, text in files.items():
        (directory / path).parent.mkdir(parents=True, exist_ok=True)
        (directory / path).write_text(text)
    return files


def _octave(directory: Path, script: str, warnings: bool = True) -> str:
    """Octave's output of ``script`` run in ``directory``; no error (``warnings`` False: no
    warning either)."""
    (directory / "run_checks.m").write_text(script)
    result = subprocess.run([OCTAVE, "--no-gui", "--quiet", "--no-window-system", "--eval", "run_checks"],
                            cwd=directory, capture_output=True, text=True, timeout=300)
    assert "error:" not in result.stdout, result.stdout
    assert result.returncode == 0 and "error: " not in result.stderr.replace(
        "error: ignoring const execution_exception& while preparing to exit", ""), result.stderr
    if not warnings:
        assert "warning" not in (result.stdout + result.stderr).lower(), result.stdout + result.stderr
    return result.stdout


def _vector(values) -> str:
    return "[" + "; ".join(format(float(v), ".17g") for v in np.ravel(values)) + "]"


def _states(module, robot: str, rng, count: int):
    n, nu = len(module.COORDINATES), len(module.EFFORTS)
    if robot not in LOOP_ROBOTS:
        return [(rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, nu))
                for _ in range(count)]
    base = np.array(module.ASSEMBLED_CONFIGURATION)
    states = []
    while len(states) < count:
        try:
            q = module.assemble(base + rng.normal(scale=0.15, size=n))
        except ValueError:
            continue
        qd = module.reduced_basis(q) @ rng.normal(size=len(module.INDEPENDENT_COORDINATES))
        states.append((q, qd, rng.normal(size=n), rng.normal(size=nu)))
    return states


class _Calls:
    """Octave lines that print each result as ``label rows cols v1 v2 ...`` (row-major, %.17g),
    and the NumPy module's value of each label."""

    def __init__(self, package: str, tolerance: float = TOLERANCE):
        self.package, self.lines, self.expected, self.tolerance = package, [], {}, tolerance
        self.tolerances: dict[str, float] = {}   # a label's own, where not the calls'

    def add(self, label: str, call: str, expected, outputs: int = 1, tolerance: float | None = None) -> None:
        if tolerance is not None:
            self.tolerances.update({label + suffix: tolerance for suffix in ("", "A", "B")})
        if outputs == 1:
            self.lines.append(f"x = {self.package}.{call};")
            self.lines.append(f"fprintf('{label} %d %d', size(x, 1), size(x, 2)); fprintf(' %.17g', x.'); fprintf('\\n');")
            self.expected[label] = np.atleast_2d(np.asarray(expected, dtype=float))
            return
        self.lines.append(f"[x, y] = {self.package}.{call};")
        for suffix, name, value in (("A", "x", expected[0]), ("B", "y", expected[1])):
            self.lines.append(f"fprintf('{label}{suffix} %d %d', size({name}, 1), size({name}, 2)); "
                              f"fprintf(' %.17g', {name}.'); fprintf('\\n');")
            self.expected[label + suffix] = np.atleast_2d(np.asarray(value, dtype=float))

    def check(self, output: str) -> None:
        seen = set()
        for line in output.splitlines():
            parts = line.split()
            if not parts or parts[0] not in self.expected:
                continue
            label, rows, columns = parts[0], int(parts[1]), int(parts[2])
            got = np.array([float(v) for v in parts[3:]]).reshape(rows, columns)
            want = self.expected[label]
            if want.shape != got.shape:   # a vector: MATLAB's column, NumPy's 1-D
                want = want.reshape(got.shape)
            scale = max(1.0, float(np.max(np.abs(want)))) if want.size else 1.0
            error = float(np.max(np.abs(got - want))) if want.size else 0.0
            tolerance = self.tolerances.get(label, self.tolerance)
            assert error <= tolerance * scale, f"{label}: {error:.3g} off (scale {scale:.3g})\n{got}\n{want}"
            seen.add(label)
        assert seen == set(self.expected), f"missing from Octave's output: {sorted(set(self.expected) - seen)}"


@needs_octave
@pytest.mark.parametrize("robot", ROBOTS + EXTRA, ids=lambda r: Path(r).stem)
def test_every_function_agrees_with_numpy(robot, tmp_path, code_dir):
    if "/" in robot:
        derivation = dynderive.derive(dynderive.load_robot(robot))
        module = import_code(dynderive.render_code(derivation), Path(code_dir), f"{derivation.robot.name}_m_dynamics")
    else:
        derivation, module = derivation_of(robot), module_of(robot, str(code_dir))
    name = derivation.robot.name
    files = _write(derivation, tmp_path)
    rng = np.random.default_rng(29)
    loops = robot in LOOP_ROBOTS
    calls = _Calls(name)
    calls.lines.append(f"p0 = {name}.parameters();")
    changed = {k: v * rng.uniform(0.8, 1.2) for k, v in module.PARAMETERS.items()}
    frames = list(getattr(module, "FRAMES", ()))
    for index, (q, qd, qdd, u) in enumerate(_states(module, robot, rng, 3)):
        kwargs = dict(changed) if index == 1 else {}
        smoothing = {"friction_smoothing": 0.05} if index == 2 and derivation.robot.dissipative else {}
        fields = "".join(f"p.{k} = {format(v, '.17g')}; " for k, v in kwargs.items())
        fields += "".join(f"p.{k} = {v}; " for k, v in smoothing.items())
        gains = {"alpha": 0.7, "beta": 1.3} if loops and index == 2 else {}
        fields += "".join(f"p.{k} = {v}; " for k, v in gains.items())
        calls.lines.append(f"p = p0; {fields}q = {_vector(q)}; qd = {_vector(qd)}; qdd = {_vector(qdd)}; "
                           f"u = {_vector(u)};")
        both = kwargs | smoothing
        tag = f"s{index}_"
        calls.add(tag + "M", "mass_matrix(q, p)", module.mass_matrix(q, **kwargs))
        calls.add(tag + "C", "coriolis_matrix(q, qd, p)", module.coriolis_matrix(q, qd, **kwargs))
        calls.add(tag + "N", "gravity_vector(q, p)", module.gravity_vector(q, **kwargs))
        calls.add(tag + "tau", "inverse_dynamics(q, qd, qdd, p)", module.inverse_dynamics(q, qd, qdd, **both))
        calls.add(tag + "Y", "generalized_forces(q, u, p)", module.generalized_forces(q, u, **kwargs))
        calls.add(tag + "qdd", "forward_dynamics(q, qd, u, p)", module.forward_dynamics(q, qd, u, **both, **gains))
        calls.add(tag + "T", "kinetic_energy(q, qd, p)", module.kinetic_energy(q, qd, **kwargs))
        calls.add(tag + "V", "potential_energy(q, p)", module.potential_energy(q, **kwargs))
        calls.add(tag + "F", "friction_forces(qd, p)", module.friction_forces(qd, **both))
        calls.add(tag + "lin", "linearize(q, qd, u, p)", module.linearize(q, qd, u, **both), outputs=2)
        calls.add(tag + "reg", "regressor(q, qd, qdd, p)", module.regressor(q, qd, qdd, **both))
        calls.add(tag + "pi", "parameter_vector(p)", module.parameter_vector(**kwargs))
        for number, frame in enumerate(frames, start=1):
            which = f"'{frame}'" if number % 2 else str(number)   # by name and by number
            calls.add(f"{tag}T{number}", f"frame_transform(q, {which}, p)", module.frame_transform(q, frame, **kwargs))
            calls.add(f"{tag}J{number}", f"frame_jacobian(q, {which}, p)", module.frame_jacobian(q, frame, **kwargs))
            calls.add(f"{tag}a{number}", f"frame_jacobian_dot_qd(q, qd, {which}, p)",
                      module.frame_jacobian_dot_qd(q, qd, frame, **kwargs))
        if hasattr(module, "total_mass"):   # 3-D robots: the centre of mass and centroidal momentum
            for function, arguments in CENTROIDAL.items():
                given = [a for a in arguments.split(", ") if a]
                values = {"q": q, "qd": qd}
                calls.add(tag + function, f"{function}({', '.join([*given, 'p'])})",
                          getattr(module, function)(*(values[a] for a in given), **kwargs))
        if hasattr(module, "impulse_dynamics"):   # contacts: the declared ones (none), the first frame as a point
            calls.add(tag + "cfd", "constrained_forward_dynamics(q, qd, u, [], [], [], p)",
                      module.constrained_forward_dynamics(q, qd, u, **both), outputs=2)
            if frames:
                calls.add(tag + "cfd1", "constrained_forward_dynamics(q, qd, u, 1, [0 2], {}, p)",
                          module.constrained_forward_dynamics(q, qd, u, [0], (0, 2.0), **both), outputs=2)
                calls.add(tag + "imp1", f"impulse_dynamics(q, qd, '{frames[0]}', 0.5, p)",
                          module.impulse_dynamics(q, qd, [frames[0]], 0.5, **kwargs), outputs=2)
        if loops:
            calls.add(tag + "lc", "loop_constraints(q, p)", module.loop_constraints(q, **kwargs))
            calls.add(tag + "lj", "loop_jacobian(q, p)", module.loop_jacobian(q, **kwargs))
            calls.add(tag + "ljd", "loop_jacobian_dot(q, qd, p)", module.loop_jacobian_dot(q, qd, **kwargs))
            calls.add(tag + "lf", "loop_forces(q, qd, u, p)", module.loop_forces(q, qd, u, **both))
            calls.add(tag + "rb", "reduced_basis(q, p)", module.reduced_basis(q, **kwargs))
            calls.add(tag + "rfd", "reduced_forward_dynamics(q, qd, u, p)",
                      module.reduced_forward_dynamics(q, qd, u, **both))
            guess = q + rng.uniform(-0.02, 0.02, q.shape)   # the dependent coordinates move back, the others stay
            calls.add(tag + "asm", f"assemble({_vector(guess)}, p)", module.assemble(guess, **kwargs), tolerance=1e-9)
    calls.add("default_M", f"mass_matrix({_vector(np.zeros(len(module.COORDINATES)))})",
              module.mass_matrix(np.zeros(len(module.COORDINATES))))
    calls.check(_octave(tmp_path, "\n".join(calls.lines) + "\n"))
    assert f"+{name}/parameters.m" in files


@needs_octave
@pytest.mark.parametrize(("robot", "symbolic"), [("panda", "panda_link7.*"),
                                                 (str(ROOT / "tests" / "floating_elbow.urdf"), "*.mass")],
                         ids=["panda", "floating_elbow"])
def test_centroidal_functions_agree_with_numpy(robot, symbolic, tmp_path):
    """Every centroidal function, run warning-free in Octave, equals the NumPy module's to 1e-12
    relative at random full-precision states (unit quaternions on the floating base): with p
    omitted, the defaults' struct and other values of the link parameters ``symbolic`` makes."""
    derivation = dynderive.derive(dynderive.load_robot(robot, symbolic=symbolic))
    name = derivation.robot.name
    module = import_code(dynderive.render_code(derivation), tmp_path, f"{name}_centroidal_dynamics")
    files = _write(derivation, tmp_path)
    assert {f"+{name}/{f}.m" for f in CENTROIDAL} <= set(files)
    rng = np.random.default_rng(43)
    changed = {k: v * rng.uniform(0.8, 1.2) for k, v in module.PARAMETERS.items()}
    assert len(changed) > 1   # the link's parameters besides g
    calls = _Calls(name, tolerance=1e-12)
    calls.lines.append(f"p0 = {name}.parameters();")
    calls.add("mass_omitted", "total_mass()", module.total_mass())
    states = random_configurations(derivation.robot, rng, 3)
    for index, q in enumerate(states):
        qd = rng.normal(size=len(derivation.symbols.qd))
        kwargs = changed if index == 2 else {}
        fields = "".join(f"p.{k} = {format(v, '.17g')}; " for k, v in kwargs.items())
        calls.lines.append(f"p = p0; {fields}q = {_vector(q)}; qd = {_vector(qd)};")
        for function, arguments in CENTROIDAL.items():
            given = [a for a in arguments.split(", ") if a]
            call = f"{function}({', '.join([*given, '[]' if index == 0 else 'p'])})"
            values = {"q": q, "qd": qd}
            calls.add(f"s{index}_{function}", call, getattr(module, function)(*(values[a] for a in given), **kwargs))
    calls.lines.append(f"help {name}.centroidal_momentum_matrix")
    output = _octave(tmp_path, "\n".join(calls.lines) + "\n", warnings=False)
    calls.check(output)
    nv = len(derivation.symbols.qd)
    assert f"Centroidal momentum matrix A_G(q): linear, then angular momentum about the centre of mass, world axes, " \
           f"6 x {nv}." in output


_CONTACT_TREES: dict[str, tuple] = {}


def _contact_tree(name: str, directory: Path):
    """(derivation, NumPy module) of test_contacts' random tree ``floating_10`` (a floating base:
    a surface contact ``sole`` and a point contact ``toe`` on the base) or ``fixed_6`` (a fixed
    base of 5 joints, both on its deepest link), full-precision numbers, derived once."""
    from test_contacts import _tree

    if name not in _CONTACT_TREES:
        path = directory / f"{name}.yaml"
        path.write_text(_tree(int(name.split("_")[1]), name.startswith("floating")))
        derivation = dynderive.derive(dynderive.load_robot(path))
        module = import_code(dynderive.render_code(derivation), directory, f"{name}_matlab_contacts_dynamics")
        _CONTACT_TREES[name] = derivation, module
    return _CONTACT_TREES[name]


def _matrix(values) -> str:
    return "[" + "; ".join(", ".join(format(float(v), ".17g") for v in row) for row in np.atleast_2d(values)) + "]"


@needs_octave
@pytest.mark.parametrize("robot", ["floating_10", "fixed_6"])
def test_contact_functions_agree_with_numpy(robot, tmp_path, code_dir):
    """constrained_forward_dynamics and impulse_dynamics, run warning-free in Octave, equal the
    NumPy module's to 1e-12 relative at random full-precision states: the declared contacts
    (contacts omitted and []; the floating tree's surface ``sole`` and point ``toe``), frames by
    number, by name and as a struct array (contacts() edited) with kinds, no contact ({}),
    Baumgarte gains with anchors (a 4 x 4 pose, a 3 x 1 position) and without (kd only), restitution
    0 and 0.5, non-default parameters. The fixed tree (5 joints) holds its point contact ``toe``."""
    derivation, module = _contact_tree(robot, Path(code_dir))
    name = derivation.robot.name
    files = _write(derivation, tmp_path)
    assert {f"+{name}/{f}.m" for f in ("constrained_forward_dynamics", "impulse_dynamics", "contacts")} <= set(files)
    floating = robot.startswith("floating")
    rng = np.random.default_rng(47)
    changed = {k: v * rng.uniform(0.8, 1.2) for k, v in module.PARAMETERS.items()}
    calls = _Calls(name, tolerance=1e-12)
    calls.lines.append(f"p0 = {name}.parameters(); c = {name}.contacts(); c(1).kind = 'point';")
    calls.lines.append("fprintf('declared'); for k = 1:numel(c), fprintf(' %s', c(k).frame); end; fprintf('\\n');")
    sole, toe = module.FRAMES.index("sole") + 1, module.FRAMES.index("toe") + 1
    for index in range(3):
        nv = len(derivation.symbols.qd)
        q = module.integrate(module.neutral_configuration(), rng.uniform(-1.5, 1.5, nv)) if floating else \
            rng.uniform(-1.5, 1.5, nv)
        qd, u = rng.normal(size=nv), rng.normal(size=len(module.EFFORTS))
        kwargs = changed if index == 2 else {}
        fields = "".join(f"p.{k} = {format(v, '.17g')}; " for k, v in kwargs.items())
        pose = module.frame_transform(q, "sole", **kwargs)
        turn = np.array([[np.cos(0.02), -np.sin(0.02), 0], [np.sin(0.02), np.cos(0.02), 0], [0, 0, 1]])
        anchor_sole = pose.copy()
        anchor_sole[:3, :3] = pose[:3, :3] @ turn
        anchor_sole[:3, 3] += rng.normal(scale=0.01, size=3)
        anchor_toe = module.frame_transform(q, "toe", **kwargs)[:3, 3] + rng.normal(scale=0.01, size=3)
        calls.lines.append(f"p = p0; {fields}q = {_vector(q)}; qd = {_vector(qd)}; u = {_vector(u)}; "
                           f"A_sole = {_matrix(anchor_sole)}; A_toe = {_vector(anchor_toe)};")
        given = "[]" if index == 0 else "p"
        tag = f"s{index}_"
        cfd, imp = module.constrained_forward_dynamics, module.impulse_dynamics
        if floating:
            calls.add(tag + "declared", f"constrained_forward_dynamics(q, qd, u, [], [], [], {given})",
                      cfd(q, qd, u, **kwargs), outputs=2)
            calls.add(tag + "gains", f"constrained_forward_dynamics(q, qd, u, {{'sole', {toe}}}, [25 10], "
                      f"{{A_sole, A_toe}}, {given})",
                      cfd(q, qd, u, ["sole", "toe"], (25.0, 10.0), anchors=[anchor_sole, anchor_toe], **kwargs),
                      outputs=2)
            calls.add(tag + "kd", f"constrained_forward_dynamics(q, qd, [], [{toe} {sole}], [0 4], {{}}, {given})",
                      cfd(q, qd, None, ["toe", "sole"], (0, 4.0), **kwargs), outputs=2)
            calls.add(tag + "struct", "constrained_forward_dynamics(q, qd, u, struct('frame', {'toe', 'sole'}, "
                      f"'kind', {{'surface', 'point'}}), [], [], {given})",
                      cfd(q, qd, u, [("toe", "surface"), ("sole", "point")], **kwargs), outputs=2)
            calls.add(tag + "edited", f"constrained_forward_dynamics(q, qd, u, c, [9 6], {{A_sole(1:3, 4), A_toe}}, "
                      f"{given})", cfd(q, qd, u, [("sole", "point"), "toe"], (9.0, 6.0),
                                       anchors=[anchor_sole[:3, 3], anchor_toe], **kwargs), outputs=2)
            calls.add(tag + "none", f"constrained_forward_dynamics(q, qd, u, {{}}, [], [], {given})",
                      cfd(q, qd, u, (), **kwargs), outputs=2)
            calls.add(tag + "impact", f"impulse_dynamics(q, qd, [], [], {given})", imp(q, qd, **kwargs), outputs=2)
            calls.add(tag + "bounce", f"impulse_dynamics(q, qd, {{{toe}, 'sole'}}, 0.5, {given})",
                      imp(q, qd, ["toe", "sole"], 0.5, **kwargs), outputs=2)
            if index == 0:   # every argument after q and qd omitted
                calls.add("omitted", "constrained_forward_dynamics(q, qd)", cfd(q, qd), outputs=2)
                calls.add("omitted_impact", "impulse_dynamics(q, qd)", imp(q, qd), outputs=2)
        else:
            calls.add(tag + "toe", f"constrained_forward_dynamics(q, qd, u, 'toe', [], [], {given})",
                      cfd(q, qd, u, "toe", **kwargs), outputs=2)
            calls.add(tag + "gains", f"constrained_forward_dynamics(q, qd, u, {toe}, [16 8], {{A_toe}}, {given})",
                      cfd(q, qd, u, ["toe"], (16.0, 8.0), anchors=[anchor_toe], **kwargs), outputs=2)
            calls.add(tag + "sole_point", f"constrained_forward_dynamics(q, qd, u, struct('frame', 'sole', 'kind', "
                      f"'point'), [0 3], [], {given})", cfd(q, qd, u, [("sole", "point")], (0, 3.0), **kwargs),
                      outputs=2)
            calls.add(tag + "impact", f"impulse_dynamics(q, qd, {{'toe'}}, 0.5, {given})",
                      imp(q, qd, ["toe"], 0.5, **kwargs), outputs=2)
    calls.lines.append(f"help {name}.constrained_forward_dynamics")
    output = _octave(tmp_path, "\n".join(calls.lines) + "\n", warnings=False)
    calls.check(output)
    assert "declared sole toe" in output
    assert "CONSTRAINED_FORWARD_DYNAMICS  (qdd, forces) with the contacts held" in output


@needs_octave
def test_contact_errors_in_octave(tmp_path, code_dir):
    """Each refusal raises an error with its identifier: redundant contacts (the fixed tree's
    declared surface and point contacts: 9 rows on 5 joints), an unknown frame, a number out of
    range, an unknown kind, a frame held twice, kp without anchors, a wrong anchor; the same
    cases the NumPy module refuses."""
    derivation, module = _contact_tree("fixed_6", Path(code_dir))
    name = derivation.robot.name
    _write(derivation, tmp_path)
    rng, n = np.random.default_rng(1), len(module.COORDINATES)
    q, qd, u = rng.uniform(-1.5, 1.5, n), rng.normal(size=n), rng.normal(size=len(module.EFFORTS))
    cases = {
        "redundant": ("constrained_forward_dynamics(q, qd, u)", "redundant", "redundant"),
        "redundant_impact": ("impulse_dynamics(q, qd)", "redundant", "redundant"),
        "unknown": ("constrained_forward_dynamics(q, qd, u, {'heel'})", "contacts", "unknown frame 'heel'"),
        "range": ("constrained_forward_dynamics(q, qd, u, [7])", "contacts", "frame number 7 is out of range"),
        "kind": ("constrained_forward_dynamics(q, qd, u, struct('frame', 'toe', 'kind', 'line'))", "contacts",
                 "'point' or 'surface'"),
        "twice": ("constrained_forward_dynamics(q, qd, u, {'toe', 2})", "contacts", "held twice"),
        "pair": ("constrained_forward_dynamics(q, qd, u, {'toe'}, 1)", "baumgarte", "a pair"),
        "kp": ("constrained_forward_dynamics(q, qd, u, {'toe'}, [1 0])", "baumgarte", "kp needs anchors"),
        "anchor": ("constrained_forward_dynamics(q, qd, u, {'toe'}, [1 0], {eye(4)})", "anchors", "3 x 1"),
        "anchors": ("constrained_forward_dynamics(q, qd, u, {'toe'}, [1 0], {[0; 0; 0], [0; 0; 0]})", "anchors",
                    "one entry per contact"),
    }
    lines = [f"q = {_vector(q)}; qd = {_vector(qd)}; u = {_vector(u)};"]
    for label, (call, _, _) in cases.items():
        lines.append(f"try, {name}.{call}; fprintf('{label} no error\\n'); "
                     f"catch failure, fprintf('{label} %s | %s\\n', failure.identifier, failure.message); end")
    output = _octave(tmp_path, "\n".join(lines) + "\n")
    got = dict(line.split(" ", 1) for line in output.splitlines() if line.split(" ", 1)[0] in cases)
    assert set(got) == set(cases), output
    for label, (_, identifier, message) in cases.items():
        assert got[label].startswith(f"{name}:{identifier} | ") and message in got[label], (label, got[label])
    assert "sole (surface), toe (point)" in got["redundant"]
    for contacts in (["heel"], [("toe", "line")], ["toe", 1]):   # the NumPy module refuses them too
        with pytest.raises(ValueError):
            module.constrained_forward_dynamics(q, qd, u, contacts)


def _double_pendulum_energy(tmp_path: Path) -> list[float]:
    _write(derivation_of("double_pendulum"), tmp_path)
    script = "\n".join([
        "p = double_pendulum.parameters();",
        "x0 = [0.9; -0.4; 0.3; -0.2];",
        "options = odeset('RelTol', 1e-8, 'AbsTol', 1e-10);",
        "[t, x] = ode45(@(t, x) [x(3:4); double_pendulum.forward_dynamics(x(1:2), x(3:4), [], p)], [0 5], x0, options);",
        "E = zeros(size(t));",
        "for k = 1:numel(t)",
        "    E(k) = double_pendulum.kinetic_energy(x(k, 1:2)', x(k, 3:4)', p) + double_pendulum.potential_energy(x(k, 1:2)', p);",
        "end",
        "fprintf('energy %.17g\\n', E);", ""])
    return [float(line.split()[1]) for line in _octave(tmp_path, script).splitlines() if line.startswith("energy")]


@needs_octave
def test_ode45_conserves_the_double_pendulums_energy(tmp_path):
    energies = _double_pendulum_energy(tmp_path)
    assert len(energies) > 20
    drift = max(abs(e - energies[0]) for e in energies) / abs(energies[0])
    assert drift < 1e-6, drift
    assert drift > 0   # the integrator's own error: the energies came from a real integration


def _readme_example() -> str:
    """The ``ode45`` example of the MATLAB/Octave reference page (docs/reference/matlab.md)."""
    text = (ROOT / "docs" / "reference" / "matlab.md").read_text()
    section = text[text.index("# MATLAB/Octave (`--matlab`)"):]
    return re.search(r"```matlab\n(.*?)```", section, re.S).group(1)


@needs_octave
def test_readme_ode45_example_runs(tmp_path):
    _write(derivation_of("rp_arm"), tmp_path)
    output = _octave(tmp_path, _readme_example() + "\nfprintf('final %.17g\\n', x(end, :));\n")
    final = [float(v) for line in output.splitlines() if line.startswith("final") for v in line.split()[1:]]
    (drift,) = [float(line.split()[-1]) for line in output.splitlines() if line.startswith("energy drift")]
    assert len(final) == 4 and np.all(np.isfinite(final))
    assert abs(final[0] - 0.5) > 1e-2   # the arm swung
    assert drift < 1e-5   # J: the energy is of order 10


#: Octave-only syntax, outside character-vector literals: comments by ``#``, ``!=``, ``!``,
#: ``++``, ``+=`` (and kin), ``end<keyword>``, ``printf``, double-quoted strings.
OCTAVE_ONLY = [re.compile(p) for p in (r"#", r"!=", r"!", r"\+\+", r"--", r"[-+*/^]=(?!=)", r"\bend(function|if|for|while|switch|_try_catch)\b",
                                       r"\bprintf\b", r"\"", r"\bunwind_protect\b", r"\*\*")]


def _code_part(line: str) -> str:
    """The part of a line before its ``%`` comment, with character-vector literals removed."""
    code = re.sub(r"'(?:[^'\n]|'')*'", "''", line) if "'" in line and "=" in line else line
    return code.split("%", 1)[0]


@pytest.mark.parametrize("robot", ["rp_arm", "four_bar", "cart_pole_damped", "bennett", "planar_3r", "elbow_arm"])
def test_files_hold_matlab_syntax_only(robot):
    files = render_matlab(derivation_of(robot))
    for path, text in files.items():
        assert text.isascii(), path
        for number, line in enumerate(text.splitlines(), start=1):
            stripped = line.strip()
            assert stripped not in ("%{", "%}"), (path, number)
            if stripped.startswith("%"):
                continue
            code = _code_part(line)
            for pattern in OCTAVE_ONLY:
                if pattern.pattern == r"[-+*/^]=(?!=)":
                    bad = re.search(r"(?<![=<>~])[-+*/^]=(?!=)", code)
                else:
                    bad = pattern.search(code)
                assert not bad, f"{path}:{number}: {line!r} ({pattern.pattern})"
        assert text.rstrip().endswith("end"), path
        assert re.match(r"function ", text), path


HOSTILE = "Arm %}\n%{\nerror('x') # \u00e9\u202e\r\n}"


def _robot_file(tmp_path: Path, title: str = "A two-link arm", gravity: str = "g") -> Path:
    """rp_arm.yaml with another title (also the description of ``m``) and name of ``g``."""
    source = (ROOT / "robots" / "rp_arm.yaml").read_text()
    text = source.replace("title: Two-link RP arm (revolute + prismatic)", "title: " + json.dumps(title))
    text = text.replace("description: mass of each link", "description: " + json.dumps(title))
    text = text.replace("  g: {value", f"  {gravity}: {{value").replace("[0, -g]", f"[0, -{gravity}]")
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    return path


def test_hostile_title_stays_in_its_comments(tmp_path):
    robot = dynderive.load_robot(str(_robot_file(tmp_path, HOSTILE)))
    assert robot.title == HOSTILE
    files = render_matlab(dynderive.derive(robot))
    for path, text in files.items():
        assert text.isascii()
        lines = text.splitlines()
        assert not any(line.strip().startswith(("%{", "%}")) for line in lines), path
        (title_line,) = [line for line in lines if "equations of motion of" in line]
        assert title_line.startswith("%   Package rp_arm: ")
        assert "\\x0a" in title_line and "\\u202e" in title_line and "%\\}" in title_line
        code = "\n".join(line for line in lines if not line.lstrip().startswith("%"))
        assert "error('x')" not in code
    assert "%   m: Arm %\\}\\x0a%\\{" in files["+rp_arm/parameters.m"]


@needs_octave
def test_hostile_title_runs_and_reads_back_in_help(tmp_path):
    _write(dynderive.derive(dynderive.load_robot(str(_robot_file(tmp_path, HOSTILE)))), tmp_path)
    output = _octave(tmp_path, "M = rp_arm.mass_matrix([0.1; 0.2]);\nfprintf('ok %d\\n', numel(M));\n"
                     "help rp_arm.mass_matrix\n")
    assert "ok 4" in output and "MASS_MATRIX" in output and "Arm %\\}\\x0a%\\{" in output


@pytest.mark.parametrize("keyword", ["end", "function", "endif"])
def test_a_matlab_keyword_is_refused_at_its_place(tmp_path, keyword):
    path = _robot_file(tmp_path, gravity=keyword)
    line = next(n for n, t in enumerate(path.read_text().splitlines(), start=1) if t.startswith(f"  {keyword}:"))
    # -q: on a slow machine the progress lines ("[ 1.0 s] generating MATLAB") come first
    result = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), "--matlab", "-q", "--out",
                             str(tmp_path / "out")], capture_output=True, text=True)
    assert result.returncode == 2, result.stderr
    assert re.fullmatch(rf"\S*arm\.yaml:{line}:3: --matlab: parameter name '{keyword}' is a MATLAB or Octave "
                        r"keyword: it would be a field of the MATLAB parameters struct; rename it\n", result.stderr), \
        result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "out").exists()


def test_every_name_the_files_use_is_refused_as_a_package_name():
    """The refusal list covers every function and local variable the generated code names (a
    package of that name would be shadowed inside the functions)."""
    from dynderive.render.targets.matlab.matlab_names import GENERATED_NAMES, MATLAB_KEYWORDS

    used, packages, functions = set(), set(), set()
    for robot in ["rp_arm", "bennett", "cart_pole_damped", "planar_3r", "slider_crank", "elbow_arm"]:
        files = render_matlab(derivation_of(robot))
        packages.add(robot)
        functions |= {path.split("/")[1][:-2] for path in files}
        for text in files.values():
            for line in text.splitlines():
                if line.lstrip().startswith("%"):
                    continue
                # character vectors (a quote after an operator, not a transpose) and comments: not names
                line = re.sub(r"(?<=[(\[{,=;\s])'(?:[^'\n]|'')*'", "''", line).split("%", 1)[0]
                used |= set(re.findall(r"(?<![.\w])([A-Za-z]\w*)", line))
    missing = used - GENERATED_NAMES - MATLAB_KEYWORDS - packages - functions
    assert not {m for m in missing if not re.fullmatch(r"t[0-9]+", m)}, missing


def test_a_robot_name_matlab_cannot_call_is_refused(tmp_path):
    source = (ROOT / "robots" / "rp_arm.yaml").read_text().replace("name: rp_arm", "name: p")
    path = tmp_path / "p.yaml"
    path.write_text(source)
    result = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(path), "--matlab", "--out",
                             str(tmp_path / "out")], capture_output=True, text=True)
    assert result.returncode == 2
    assert re.search(r"p\.yaml:4:7: --matlab: robot name 'p' is a function or a local variable", result.stderr), \
        result.stderr


def test_solve_and_build_write_the_package_folder(tmp_path):
    run = [sys.executable, "-m", "dynderive"]
    solved = subprocess.run([*run, "solve", "rp_arm", "--matlab", "--out", str(tmp_path / "solve"), "-q"],
                            capture_output=True, text=True)
    assert solved.returncode == 0, solved.stderr
    written = sorted(p.relative_to(tmp_path / "solve").as_posix() for p in (tmp_path / "solve").rglob("*.m"))
    assert written == sorted([*render_matlab(derivation_of("rp_arm")), "rp_arm_derivation.m"])
    build = [*run, "build", str(ROOT / "robots" / "rp_arm.yaml"), "--matlab", "--out", str(tmp_path / "b"), "-j", "1"]
    assert subprocess.run(build, capture_output=True, text=True).returncode == 0
    assert (tmp_path / "b" / "+rp_arm" / "forward_dynamics.m").read_text() == \
        (tmp_path / "solve" / "+rp_arm" / "forward_dynamics.m").read_text()
    assert subprocess.run([*build, "--check"], capture_output=True, text=True).returncode == 0
    (tmp_path / "b" / "+rp_arm" / "mass_matrix.m").write_text("% edited\n")
    checked = subprocess.run([*build, "--check"], capture_output=True, text=True)
    assert checked.returncode == 1 and "+rp_arm/mass_matrix.m: differs" in checked.stdout + checked.stderr


# -- floating base and spherical joints ------------------------------------------------------------
# test_free_flyer and test_spherical skip themselves without Pinocchio: the tests below import
# them, so that the rest of this file runs without it.

def _agree(derivation, directory: Path, seed: int, values: dict | None = None) -> None:
    from test_free_flyer import _module

    _write(derivation, directory)
    module, name = _module(derivation, directory), derivation.robot.name
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
    from test_free_flyer import _floating_tree

    path = tmp_path / "floating_tree.yaml"
    path.write_text(_floating_tree(2))
    _agree(dynderive.derive(dynderive.load_robot(path)), tmp_path, seed=2)


@needs_octave
@pytest.mark.parametrize("floating", [False, True])
def test_random_trees_with_spherical_joints_agree_with_the_numpy_module(floating, tmp_path):
    from test_spherical import _tree as _spherical_tree

    path = tmp_path / "spherical_tree.yaml"
    path.write_text(_spherical_tree(7, floating))
    derivation = dynderive.derive(dynderive.load_robot(path))
    assert any(j.type == "spherical" for j in derivation.robot.joints)
    _agree(derivation, tmp_path, seed=7)


@needs_octave
def test_box_with_a_parameter_agrees_with_the_numpy_module(tmp_path):
    from test_free_flyer import BOX

    (tmp_path / "free_box.yaml").write_text(BOX.replace("name: box", "name: free_box"))   # Octave has a box()
    _agree(dynderive.derive(dynderive.load_robot(tmp_path / "free_box.yaml")), tmp_path, seed=4,
           values={"m": 2.5, "g": 9.7})


def test_solve_and_build_write_the_package_of_a_floating_robot(tmp_path):
    from test_free_flyer import BOX

    (tmp_path / "box.yaml").write_text(BOX)
    runner = CliRunner()
    result = runner.invoke(app, ["solve", str(tmp_path / "box.yaml"), "--matlab", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    integrate = (tmp_path / "out" / "+box" / "integrate.m").read_text()
    assert integrate.startswith("function out = integrate(q, v, dt)") and "function y = if_else(" in integrate
    result = runner.invoke(app, ["build", str(tmp_path / "box.yaml"), "--matlab", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "b" / "+box" / "integrate.m").read_text() == integrate
