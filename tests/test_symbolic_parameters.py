"""``--symbolic``: a URDF's inertial values as named parameters (DESIGN.md section 9).

The Panda with its hand (robots/panda.urdf plus example-robot-data's ``panda_hand``, welded to
``panda_link8`` turned by -pi/4): the hand and link 7 made parameters give the plain module's
numbers at the defaults, and another hand mass gives Pinocchio's gravity for a URDF with that
mass (Pinocchio merges the hand into joint 7's body as dynderive does). Another hand mass and
COM, given to every target as its parameters (the C parameters struct, the MATLAB struct in GNU
Octave, the JAX module's keywords, CasADi's ``p``), give the NumPy module's mass matrix, gravity
and inverse dynamics with those values to 1e-12 relative; each target is skipped without its
tool locally and required in CI, as in its own tests. Link names of 70 characters, or ending in
'_', give parameter names that MATLAB (63 characters) and C (no '__') take, run in Octave.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands.cli import app
from dynderive.errors import InputError
from dynderive.verify.checks import generated_module
from test_matlab_numeric import _Calls, _octave, _vector, needs_octave

from conftest import import_code

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
HAND = """  <joint name="panda_hand_joint" type="fixed">
    <parent link="panda_link8"/>
    <child link="panda_hand"/>
    <origin rpy="0 0 -0.7853981633974483" xyz="0 0 0"/>
  </joint>
  <link name="panda_hand">
    <inertial>
      <origin rpy="0 0 0" xyz="-0.01 0 0.03"/>
      <mass value="MASS"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0025" iyz="0" izz="0.0017"/>
    </inertial>
  </link>
</robot>"""
SYMBOLIC = ("panda_link7.*", "panda_hand.*")
runner = CliRunner()
#: The hand's parameters changed in every target's test: another payload, further out.
CHANGED = {"m_panda_hand": 2.5, "c_panda_hand_z": 0.07}
#: Agreement with the NumPy module, relative to the result's largest entry (at least 1).
RTOL = 1e-12


def panda_with_hand(folder: Path, mass: float = 0.73) -> Path:
    path = folder / f"panda_hand_{mass:g}.urdf"
    text = (ROBOTS / "panda.urdf").read_text().replace("</robot>", HAND.replace("MASS", repr(mass)))
    path.write_text(text)
    return path


def module(path: Path, symbolic=None):
    """(derivation, NumPy module) of a URDF."""
    derivation = dynderive.derive(dynderive.load_robot(path, symbolic=symbolic))
    return derivation, generated_module(dynderive.render_code(derivation), derivation.robot.name)


@pytest.fixture(scope="module")
def modules(tmp_path_factory):
    path = panda_with_hand(tmp_path_factory.mktemp("panda"))
    return path, module(path), module(path, SYMBOLIC)


def test_parameters_have_the_files_values_as_defaults(modules):
    _, _, (derivation, symbolic) = modules
    values = {p.name: p.value for p in derivation.robot.parameters}
    assert values["m_panda_hand"] == 0.73 and values["m_panda_link7"] == 0.735522
    assert [values[f"c_panda_hand_{a}"] for a in "xyz"] == [-0.01, 0.0, 0.03]
    assert [values[f"I_panda_link7_{k}"] for k in ("xx", "xy", "xz", "yy", "yz", "zz")] == [
        0.012516, -0.000428, -0.001196, 0.010027, -0.000741, 0.004815]
    assert len(values) == 1 + 2 * 10   # g, then 10 per link
    assert symbolic.PARAMETERS["I_panda_hand_yy"] == 0.0025


def test_equal_to_the_plain_module_at_the_defaults(modules):
    _, (_, plain), (_, symbolic) = modules
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, (3, 7))
        for name, args in (("mass_matrix", (q,)), ("gravity_vector", (q,)),
                           ("inverse_dynamics", (q, qd, qdd))):
            np.testing.assert_allclose(getattr(symbolic, name)(*args), getattr(plain, name)(*args),
                                       rtol=0, atol=1e-12)


def test_a_heavier_hand_as_pinocchio(modules, tmp_path):
    if os.environ.get("CI"):
        import pinocchio as pin
    else:
        pin = pytest.importorskip("pinocchio")
    _, _, (_, symbolic) = modules
    heavier = pin.buildModelFromUrdf(str(panda_with_hand(tmp_path, 2.5)))
    data = heavier.createData()
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-2, 2, 7)
        expected = pin.computeGeneralizedGravity(heavier, data, q)
        np.testing.assert_allclose(symbolic.gravity_vector(q, m_panda_hand=2.5), expected, rtol=0, atol=1e-9)
        assert not np.allclose(symbolic.gravity_vector(q), expected, atol=1e-6)


def test_every_massive_link_mass(modules):
    path = modules[0]
    robot = dynderive.load_robot(path, symbolic="*.mass")
    names = [p.name for p in robot.parameters if p.name != "g"]
    # panda_link8 is massless, panda_link0 welded to the world
    assert names == [f"m_panda_link{k}" for k in range(1, 8)] + ["m_panda_hand"]


@pytest.mark.parametrize("option, message", [
    ("x.mass", "--symbolic:1:1: no link matches 'x.mass' (links: panda_link1, "),
    ("panda_link7.mass,panda_link7.masss", "--symbolic:1:30: unknown field 'masss' in 'panda_link7.masss' "
                                           "(fields: mass, com, inertia) (did you mean 'mass'?)"),
    ("panda_link0.com", "--symbolic:1:1: no link matches 'panda_link0.com' (link 'panda_link0' is welded to "
                        "the world"),
    ("mass", "--symbolic:1:1: expected LINK.FIELD"),
])
def test_bad_patterns(option, message):
    result = runner.invoke(app, ["solve", str(ROBOTS / "panda.urdf"), "--symbolic", option])
    assert result.exit_code == 2
    assert result.output.startswith(message) and result.output.count("\n") == 1, result.output


def test_refused_on_a_yaml_robot():
    result = runner.invoke(app, ["check", "rp_arm", "--symbolic", "*.mass"])
    assert result.exit_code == 2
    assert result.output.startswith("--symbolic:1:1: --symbolic makes a URDF's inertial values parameters; "
                                    "a YAML robot file names")
    with pytest.raises(InputError):
        dynderive.load_robot("rp_arm", symbolic=("*.mass",))


def test_c_struct_and_casadi_p(modules, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(modules[0]), "--c", "--casadi", "--symbolic",
                                 ",".join(SYMBOLIC), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    header = (out / "panda_dynamics.h").read_text()
    assert "double m_panda_hand;" in header and "double I_panda_link7_xy;" in header
    casadi_text = (out / "panda_dynamics_casadi.py").read_text()
    assert '"m_panda_hand"' in casadi_text and '"c_panda_hand_z"' in casadi_text


def test_param_through_the_command_line(modules):
    result = runner.invoke(app, ["linearize", str(modules[0]), "--symbolic", "panda_hand.mass",
                                 "--param", "m_panda_hand=1.5", "--json", "-q"])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["linearize", str(modules[0]), "--symbolic", "panda_hand.mass",
                                 "--param", "m_panda_hand=-1", "-q"])
    assert result.exit_code == 2 and "--param:1:" in result.output, result.output


def test_names_are_made_unique():
    from dynderive.input.urdf_symbolic import free_name

    taken = {"m_a", "g"}
    assert free_name("m_a", taken) == "m_a_2" and free_name("m_a", taken) == "m_a_3"
    assert free_name("m_b", taken) == "m_b"


def test_a_floating_joint_and_param():
    urdf = str(Path(__file__).parent / "floating_elbow.urdf")
    result = runner.invoke(app, ["check", urdf, "--symbolic", "*.*", "--param", "m_lower=2", "-q"])
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def changed(modules):
    """States, the parameters with CHANGED, and the NumPy module's mass matrix, gravity vector
    and inverse dynamics at them (which differ from those at the defaults)."""
    _, _, (derivation, symbolic) = modules
    rng = np.random.default_rng(11)
    states = [tuple(rng.uniform(-2, 2, (3, 7))) for _ in range(3)]
    expected = []
    for q, qd, qdd in states:
        results = {"mass_matrix": symbolic.mass_matrix(q, **CHANGED),
                   "gravity_vector": symbolic.gravity_vector(q, **CHANGED),
                   "inverse_dynamics": symbolic.inverse_dynamics(q, qd, qdd, **CHANGED)}
        assert not np.allclose(results["gravity_vector"], symbolic.gravity_vector(q), atol=1e-3)
        assert not np.allclose(results["mass_matrix"], symbolic.mass_matrix(q), atol=1e-4)
        expected.append(results)
    return derivation, symbolic, symbolic.PARAMETERS | CHANGED, states, expected


def _close(got, want, what: str) -> None:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    error = float(np.max(np.abs(got - want)))
    assert error <= RTOL * max(1.0, float(np.max(np.abs(want)))), f"{what}: {error:.3g} off"


def test_c_parameter_struct_changes_the_hand(changed, tmp_path):
    """The C functions, compiled (strict C99, and C++) and called with a parameters struct whose
    hand mass and COM are changed, give the NumPy module's numbers with those values."""
    from test_c_target import Library  # skips without a C compiler, required in CI

    derivation, symbolic, values, states, expected = changed
    library = Library(derivation, tmp_path)
    p = [*(values[name] for name in symbolic.PARAMETERS), 0.0]   # the struct: parameters, friction_smoothing
    for (q, qd, qdd), want in zip(states, expected):
        _close(library.call("mass_matrix", [q], 49, p)[1].reshape(7, 7), want["mass_matrix"], "mass_matrix")
        _close(library.call("gravity_vector", [q], 7, p)[1], want["gravity_vector"], "gravity_vector")
        _close(library.call("inverse_dynamics", [q, qd, qdd], 7, p)[1], want["inverse_dynamics"], "inverse_dynamics")


@needs_octave
def test_matlab_struct_changes_the_hand(changed, tmp_path, monkeypatch):
    """The MATLAB package in GNU Octave, called with the struct of ``parameters()`` whose hand
    fields are changed, gives the NumPy module's numbers with those values."""
    import test_matlab_numeric
    from dynderive.render.targets.matlab.matlab import render_matlab

    monkeypatch.setattr(test_matlab_numeric, "TOLERANCE", RTOL)   # _Calls.check's tolerance
    derivation, _, _, states, expected = changed
    for path, text in render_matlab(derivation).items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    calls = _Calls("panda")
    fields = "".join(f"p.{name} = {value!r}; " for name, value in CHANGED.items())
    calls.lines.append(f"p = panda.parameters(); {fields}")
    for k, ((q, qd, qdd), want) in enumerate(zip(states, expected)):
        Q, QD, QDD = (_vector(x) for x in (q, qd, qdd))
        calls.add(f"M{k}", f"mass_matrix({Q}, p)", want["mass_matrix"])
        calls.add(f"N{k}", f"gravity_vector({Q}, p)", want["gravity_vector"])
        calls.add(f"tau{k}", f"inverse_dynamics({Q}, {QD}, {QDD}, p)", want["inverse_dynamics"])
    calls.check(_octave(tmp_path, "\n".join(calls.lines) + "\n"))


def test_jax_keywords_change_the_hand(changed, tmp_path):
    """The JAX module, given the changed hand values as its keyword parameters (traced by
    ``jit`` too), gives the NumPy module's numbers with those values."""
    jax = importorskip_in_ci("jax")
    jax.config.update("jax_enable_x64", True)
    from dynderive.render.targets.jax.jax import render_jax

    derivation, _, _, states, expected = changed
    jx = import_code(render_jax(derivation), tmp_path, "panda_symbolic_dynamics_jax")
    gravity = jax.jit(lambda q, m, z: jx.gravity_vector(q, m_panda_hand=m, c_panda_hand_z=z))
    for (q, qd, qdd), want in zip(states, expected):
        _close(jx.mass_matrix(q, **CHANGED), want["mass_matrix"], "mass_matrix")
        _close(jx.gravity_vector(q, **CHANGED), want["gravity_vector"], "gravity_vector")
        _close(jx.inverse_dynamics(q, qd, qdd, **CHANGED), want["inverse_dynamics"], "inverse_dynamics")
        _close(gravity(q, *CHANGED.values()), want["gravity_vector"], "jit gravity_vector")


def test_casadi_p_changes_the_hand(changed, tmp_path):
    """The CasADi Functions, given ``p`` (in ``PARAMETER_NAMES``' order) with the hand's entries
    changed, give the NumPy module's numbers with those values."""
    importorskip_in_ci("casadi")
    from dynderive.render.targets.casadi.casadi import render_casadi

    derivation, symbolic, values, states, expected = changed
    cs = import_code(render_casadi(derivation), tmp_path, "panda_symbolic_dynamics_casadi")
    assert set(cs.PARAMETER_NAMES) == set(symbolic.PARAMETERS)
    p = np.array([values[name] for name in cs.PARAMETER_NAMES])
    assert list(p) != list(cs.default_parameters())

    def call(name: str, *arrays):
        function = getattr(cs, name)
        extra = {"p": p, "friction_smoothing": 0.0}
        return np.array(function(*arrays, *(extra[n] for n in function.name_in()[len(arrays):])))

    for (q, qd, qdd), want in zip(states, expected):
        _close(call("mass_matrix", q), want["mass_matrix"], "mass_matrix")
        _close(call("gravity_vector", q).ravel(), want["gravity_vector"], "gravity_vector")
        _close(call("inverse_dynamics", q, qd, qdd).ravel(), want["inverse_dynamics"], "inverse_dynamics")


def importorskip_in_ci(name: str):
    """``name`` imported: skipped without it locally, required in CI (as the target's own tests)."""
    if os.environ.get("CI"):
        return __import__(name)
    return pytest.importorskip(name)


#: Two links whose names (70 characters) share their first 60, and a link whose name ends in '_'.
UPPER, FORE = "l" * 60 + "_upper_arm", "l" * 60 + "_fore_arm_"
LONG = """<?xml version="1.0"?>
<robot name="long_links">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="UPPER"/><axis xyz="0 1 0"/>
    <limit effort="10" velocity="1" lower="-3" upper="3"/>
  </joint>
  <link name="UPPER">
    <inertial><origin xyz="0.1 0 -0.2"/><mass value="1.5"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>
  </link>
  <joint name="j2" type="revolute">
    <parent link="UPPER"/><child link="FORE"/><origin xyz="0 0 -0.4"/><axis xyz="0 1 0"/>
    <limit effort="10" velocity="1" lower="-3" upper="3"/>
  </joint>
  <link name="FORE">
    <inertial><origin xyz="0 0.05 -0.15"/><mass value="0.8"/>
      <inertia ixx="0.004" ixy="0.0002" ixz="0" iyy="0.005" iyz="0" izz="0.002"/></inertial>
  </link>
  <joint name="j3" type="revolute">
    <parent link="FORE"/><child link="tool_"/><origin xyz="0 0 -0.3"/><axis xyz="1 0 0"/>
    <limit effort="10" velocity="1" lower="-3" upper="3"/>
  </joint>
  <link name="tool_">
    <inertial><origin xyz="0 0 -0.05"/><mass value="0.3"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.0005"/></inertial>
  </link>
</robot>
""".replace("UPPER", UPPER).replace("FORE", FORE)


@pytest.fixture(scope="module")
def long_links(tmp_path_factory):
    path = tmp_path_factory.mktemp("long") / "long_links.urdf"
    path.write_text(LONG)
    return path, module(path, "*.*")


def test_names_of_long_links_fit_matlab_and_c(long_links, tmp_path):
    """A parameter name has at most 63 characters (MATLAB's namelengthmax) and no '__' (C): the
    link part is cut to 58, ``_2`` where two links cut alike; ``--matlab --c`` writes the files."""
    path, (derivation, numpy_module) = long_links
    names = [p.name for p in derivation.robot.parameters]
    cut = "l" * 58
    assert names == ["g", f"m_{cut}", f"c_{cut}_x", f"c_{cut}_y", f"c_{cut}_z",
                     *(f"I_{cut}_{k}" for k in ("xx", "xy", "xz", "yy", "yz", "zz")),
                     f"m_{cut[:56]}_2", f"c_{cut[:56]}_2_x", f"c_{cut[:56]}_2_y", f"c_{cut[:56]}_2_z",
                     *(f"I_{cut[:56]}_2_{k}" for k in ("xx", "xy", "xz", "yy", "yz", "zz")),
                     "m_tool", "c_tool_x", "c_tool_y", "c_tool_z",
                     *(f"I_tool_{k}" for k in ("xx", "xy", "xz", "yy", "yz", "zz"))]
    assert max(map(len, names)) == 63
    descriptions = {p.name: p.description for p in derivation.robot.parameters}
    assert descriptions[f"m_{cut[:56]}_2"] == f"mass of link '{FORE}' (URDF)"
    assert numpy_module.PARAMETERS[f"I_{cut[:56]}_2_xy"] == 0.0002
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(path), "--matlab", "--c", "--symbolic", "*.*", "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    assert f"p.I_{cut}_xx = 0.01;" in (out / "+long_links" / "parameters.m").read_text()


@pytest.mark.parametrize("link, stem, again", [
    ("tool_", "tool", "tool_2"), ("a--b", "a_b", "a_b_2"), ("_x", "x", "x_2"), ("1st", "r_1st", "r_1st_2"),
    ("t\u00f6\u00f6l", "t_l", "t_l_2"), ("\u00e9", "link", "link_2"),
    ("a" * 57 + "_b", "a" * 57, "a" * 56 + "_2"), ("a" * 70, "a" * 58, "a" * 56 + "_2"),
])
def test_link_stems(link, stem, again):
    """A link's part of its parameter names, and that of a second link with the same part."""
    from dynderive.input.urdf import identifier
    from dynderive.input.urdf_symbolic import link_stem

    used = set()
    assert link_stem(link, identifier, used) == stem
    assert link_stem(link, identifier, used) == again


def test_a_suffix_keeps_a_name_within_63_characters():
    from dynderive.input.urdf_symbolic import free_name

    base = "I_" + "a" * 58 + "_xx"
    assert free_name(base, {base}) == "I_" + "a" * 58 + "_2"


@needs_octave
def test_long_link_names_in_octave(long_links, tmp_path):
    """The MATLAB package of the long-named links, in GNU Octave: the struct with a cut name's
    field changed gives the NumPy module's gravity and mass matrix with that value."""
    from dynderive.render.targets.matlab.matlab import render_matlab

    _, (derivation, numpy_module) = long_links
    for path, text in render_matlab(derivation).items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    values = {f"m_{'l' * 58}": 2.5, f"c_{'l' * 56}_2_z": -0.25, "I_tool_xx": 0.003}
    calls = _Calls("long_links")
    calls.lines.append("p = long_links.parameters(); " + "".join(f"p.{k} = {v!r}; " for k, v in values.items()))
    q = np.array([0.3, -0.7, 1.1])
    calls.add("N", f"gravity_vector({_vector(q)}, p)", numpy_module.gravity_vector(q, **values))
    calls.add("M", f"mass_matrix({_vector(q)}, p)", numpy_module.mass_matrix(q, **values))
    assert not np.allclose(numpy_module.gravity_vector(q, **values), numpy_module.gravity_vector(q))
    calls.check(_octave(tmp_path, "\n".join(calls.lines) + "\n"))
