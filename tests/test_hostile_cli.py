"""Careless and hostile command-line input (issue 27, items 1, 2, 9, 10): every case exits 2
with one positioned line per problem (``--option:1:COL: message``) and no traceback, or 0
with a correct result."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import dynderive
from dynderive.commands import integrate
from dynderive.commands.cli import app
from dynderive.commands.simulate import initial_configuration, parse_efforts, simulate
from dynderive.errors import InputError
from dynderive.render.targets.numpy.code import render_code
from dynderive.verify.checks import generated_module

pytest.importorskip("scipy")
runner = CliRunner()
ROBOTS = Path(__file__).resolve().parents[1] / "robots"


def refused(args: list[str], prefix: str) -> list[str]:
    """Run ``args``: exit 2, every stderr line positioned, the first starting with ``prefix``."""
    result = runner.invoke(app, args)
    assert result.exit_code == 2, (result.exit_code, result.output)
    lines = result.stderr.strip().splitlines()
    assert lines and lines[0].startswith(prefix), result.stderr
    assert all(re.match(r"^\S.*?:\d+:\d+: ", line) for line in lines), result.stderr
    assert "Traceback" not in result.output and "internal error" not in result.output
    return lines


def strict_json(text: str) -> object:
    def refuse(constant: str) -> None:
        raise AssertionError(f"bare {constant} in JSON")
    return json.loads(text, parse_constant=refuse)


# -- item 1: numbers and expressions on the command line -------------------------------------

@pytest.mark.parametrize("options, prefix", [
    (["--duration", "nan"], "--duration:1:1: expected a duration in seconds"),
    (["--duration", "inf"], "--duration:1:1: expected a duration in seconds"),
    (["--duration", "-1"], "--duration:1:1:"),
    (["--rtol", "nan"], "--rtol:1:1: expected a relative tolerance"),
    (["--rtol", "0", "--atol", "0"], "--rtol:1:1: expected a relative tolerance"),
    (["--atol", "inf"], "--atol:1:1: expected an absolute tolerance"),
    (["--baumgarte", "nan"], "--baumgarte:1:1:"),
    (["--friction-smoothing", "inf"], "--friction-smoothing:1:1:"),
    (["--frames", "1"], "--frames:1:1: expected at least 2 frames"),
    (["--method", "euler"], "--method:1:1: expected one of LSODA, Radau, BDF, RK45, DOP853"),
    (["--q0", "nan,0"], "--q0:1:1: 'nan' is not a finite number"),
    (["--q0", "0,inf"], "--q0:1:3: 'inf' is not a finite number"),
    (["--qd0", "1e200,0"], "--qd0:1:1: the accelerations at the initial velocities"),
])
def test_simulate_numbers(options, prefix):
    refused(["simulate", "rp_arm", "-q", *options], prefix)


@pytest.mark.parametrize("states", ["0", "-5"])
def test_check_needs_a_state(states):
    refused(["check", "rp_arm", "-q", "--states", states], "--states:1:1: expected a number of random states >= 1")


@pytest.mark.parametrize("states", ["1", "3", "7"])
def test_identify_needs_a_state_per_parameter(states):
    """rp_arm has 8 regressor parameters: fewer states are refused before any derivation."""
    refused(["identify", "rp_arm", "-q", "--states", states], "--states:1:1: expected at least 8 states for rp_arm")


def test_identify_at_the_fewest_states_finds_the_base_parameters():
    result = runner.invoke(app, ["identify", "rp_arm", "-q", "--states", "8", "--json"])
    assert result.exit_code == 0, result.output
    document = strict_json(result.stdout)
    assert document["rank"] == 6 and document["states"] == 8


@pytest.mark.parametrize("option, prefix, time", [
    ("tau1=log(t)", "--effort tau1=log(t):1:6: effort tau1 is not finite at t = 0 s", 0.0),
    ("tau1=1/t", "--effort tau1=1/t:1:6: effort tau1 is not finite at t = 0 s", 0.0),
    # the RP arm's slider flies off: its state passes 1e150 (where products overflow) at 0.69 s,
    # before the effort itself overflows (at log(max double) / 1000 = 0.7098 s)
    ("tau1=exp(1000*t)", "--effort tau1=exp(1000*t):1:6: effort tau1 reaches ", 0.6915),
    ("F2=sqrt(t-0.25)", "--effort F2=sqrt(t-0.25):1:4: effort F2 is not finite at t = 0 s", 0.0),
])
def test_efforts_not_finite_on_the_run_stop_it(option, prefix, time):
    line = refused(["simulate", "rp_arm", "-q", "--duration", "1", "--effort", option], prefix)[0]
    stopped = float(re.search(r"at t = (\S+) s", line).group(1))
    assert stopped == pytest.approx(time, abs=0.01)
    assert "the run stops there" in line


def test_forces_not_finite_on_the_run_stop_it():
    refused(["simulate", "planar_3r", "-q", "--duration", "1", "--force", "tool=0,1/t,0"],
            "--force tool=0,1/t,0:1:8: the force at tool is not finite at t = 0 s")


def test_a_singular_effort_between_samples_stops_the_integrator():
    """1/(t - 0.5) is finite at every time the integrator samples, unbounded at 0.5: the run
    stops there (LSODA would otherwise take steps of size 0 for ever)."""
    line = refused(["simulate", "rp_arm", "-q", "--duration", "1", "--effort", "tau1=1/(t-0.5)"], "--")[0]
    assert re.search(r"t = 0\.49\d* s|t = 0\.5 s", line), line


def test_at_keeps_commas_inside_calls():
    result = runner.invoke(app, ["linearize", "rp_arm", "-q", "--json", "--at", "q=atan2(1,1),0.2"])
    assert result.exit_code == 0, result.output
    assert strict_json(result.stdout)["state"]["q"] == [pytest.approx(math.pi / 4), 0.2]


# -- item 2: --param gets the checks of file values -----------------------------------------

@pytest.mark.parametrize("command", ["simulate", "check", "linearize", "identify"])
def test_negative_mass_from_the_command_line(command):
    lines = refused([command, "rp_arm", "-q", "--param", "m=-1"], "--param:1:3: m=-1: links[0].mass: must be positive")
    assert lines[0].endswith("rp_arm.yaml:14:11)")
    assert any("links[1].inertia: must not be negative" in line for line in lines)


def test_only_the_option_at_fault_is_named():
    lines = refused(["simulate", "rp_arm", "-q", "--param", "l=2", "--param", "m=-1"], "--param:1:3: m=-1:")
    assert not any("l=2" in line for line in lines)


def test_3d_inertia_from_the_command_line():
    refused(["check", "elbow_arm", "-q", "--param", "I1=-1"], "--param:1:4: I1=-1: links[0].inertia:")


@pytest.fixture
def sqrt_mass(tmp_path):
    text = (ROBOTS / "rp_arm.yaml").read_text().replace("    mass: m\n", "    mass: sqrt(m)\n", 1)
    path = tmp_path / "sqrt_arm.yaml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("command", [["simulate"], ["linearize"], ["identify", "--json"], ["check"]])
def test_derived_value_not_real_from_the_command_line(sqrt_mass, command):
    lines = refused([*command, sqrt_mass, "-q", "--param", "m=-1"], "--param:1:3: m=-1: links[0].mass: 'sqrt(m)' is "
                    "not a real number at the parameter values m = -1")
    assert lines[0].endswith("sqrt_arm.yaml:14:11)")


def test_a_parameter_without_default_is_checked_at_the_value_taken(tmp_path):
    text = (ROBOTS / "rp_arm.yaml").read_text()
    text = text.replace("  m: {value: 1.0,", "  m: {value: null,").replace("    mass: m\n", "    mass: m - 2\n", 1)
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    lines = refused(["check", str(path), "-q"], f"{path}:14:11: links[0].mass: must be positive (got -1)")
    assert "with m = 1, the value check takes for a parameter without a default" in lines[0]
    result = runner.invoke(app, ["linearize", str(path), "-q", "--param", "m=3"])
    assert result.exit_code == 0, result.output


def test_json_never_holds_nan():
    result = runner.invoke(app, ["identify", "rp_arm", "-q", "--json", "--param", "l=2"])
    assert result.exit_code == 0, result.output
    strict_json(result.stdout)
    result = runner.invoke(app, ["check", "rp_arm", "-q", "--json", "--states", "3"])
    assert result.exit_code in (0, 1), result.output
    rows = strict_json(result.stdout)["checks"]
    assert all(row["residual"] is None or math.isfinite(row["residual"]) for row in rows)


# -- item 9: simulate --method ----------------------------------------------------------------

def test_methods_agree_and_lsoda_is_the_default(tmp_path):
    finals = {}
    for method in ("default", *integrate.METHODS):
        csv = tmp_path / f"{method}.csv"
        extra = [] if method == "default" else ["--method", method.lower()]
        result = runner.invoke(app, ["simulate", "rp_arm", "-q", "--duration", "1", "--frames", "11",
                                     "--csv", str(csv), *extra])
        assert result.exit_code == 0, result.output
        finals[method] = np.array([float(v) for v in csv.read_text().splitlines()[-1].split(",")])
    for method in integrate.METHODS:
        np.testing.assert_allclose(finals[method], finals["DOP853"], atol=1e-5)
    np.testing.assert_array_equal(finals["default"], finals["LSODA"])


class _Noted(Exception):
    pass


def test_an_explicit_method_on_a_stiff_robot_says_so():
    """A damper of 1e5 N s/m between the masses makes the chain stiff: RK45 crawls, and says
    so (with what to try) long before the end; LSODA finishes without a note."""
    from dynderive.commands.options import with_parameters

    model = with_parameters(dynderive.load_robot("mass_spring_damper"), "mass_spring_damper", ["b2=1e5"], True)
    derivation = dynderive.derive(model)
    source = render_code(derivation)
    efforts = parse_efforts(derivation, [], False)

    def run(method, note):
        return simulate(derivation, source, 1.0, initial_configuration(derivation.robot, None), np.zeros(2), efforts, False,
                        1e-9, 1e-9, 10.0, 11, lambda s: None, 0.0, method=method, note=note)

    def stop(text):
        raise _Noted(text)

    with pytest.raises(_Noted, match=r"the integrator \(RK45\) struggles: .* try --method LSODA, Radau or BDF"):
        run("RK45", stop)
    trajectory = run("LSODA", stop)
    assert np.all(np.isfinite(trajectory.position)) and trajectory.dissipated[-1] > 0


# -- item 10: help text -------------------------------------------------------------------------

def _help(*command: str) -> str:
    result = runner.invoke(app, [*command, "--help"])
    assert result.exit_code == 0, result.output
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", result.stdout).split())


@pytest.mark.parametrize("command", ["solve", "check", "simulate", "linearize", "identify", "build", "import"])
def test_flags_show_no_value(command):
    text = _help(command)
    assert "--help" in text and "<bool>" not in text


def test_help_says_what_it_means():
    assert "<bool>" not in _help()
    assert "Robot file (YAML or URDF)" in _help("solve")
    identify = _help("identify")
    assert "[default: 0]" not in identify and "4 per parameter, at least 100" in identify
    assert "u=equilibrium" in _help("linearize") and "LSODA" in _help("simulate")
    result = runner.invoke(app, ["solve", "rp_arm", "--latex", "true"])
    assert result.exit_code == 2


def test_readme_no_longer_says_planar_only():
    pages = [ROBOTS.parent / "README.md", *sorted((ROBOTS.parent / "docs").rglob("*.md"))]
    assert len(pages) > 20   # the README and the documentation site
    for page in pages:
        assert "only planar robots are derived in this version" not in page.read_text(), page


def test_linearize_at_equilibrium():
    """rp_arm at q = (0.5, 0.2): u=equilibrium gives the efforts with qdd = 0 (the closed form
    agrees with the numbers), and no note; at u = 0 a note says the point is not one."""
    result = runner.invoke(app, ["linearize", "rp_arm", "--json", "--at", "q=0.5,0.2,u=equilibrium"])
    assert result.exit_code == 0, result.output
    assert "not an equilibrium" not in result.stderr
    document = strict_json(result.stdout)
    module = generated_module(render_code(dynderive.derive(dynderive.load_robot("rp_arm"))), "rp_arm")
    u = np.array(document["state"]["u"])
    np.testing.assert_allclose(module.forward_dynamics(np.array([0.5, 0.2]), np.zeros(2), u), 0, atol=1e-12)
    assert document["agreement"] < 1e-9
    result = runner.invoke(app, ["linearize", "rp_arm", "--at", "q=0.5,0.2"])
    assert result.exit_code == 0 and "note: the operating point is not an equilibrium" in result.stderr
    assert "u=equilibrium" in result.stderr


def test_linearize_equilibrium_where_the_actuation_cannot_hold():
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=0.3,u=equilibrium"])
    assert result.exit_code == 0, result.output
    assert "note: u=equilibrium: the efforts cannot hold this state" in result.stderr
    result = runner.invoke(app, ["linearize", "cart_pole", "--at", "theta=pi,u=equilibrium"])
    assert result.exit_code == 0 and "note:" not in result.stderr
    refused(["linearize", "cart_pole", "--at", "u=equilibrium,F=1"], "--at:1:1: u=equilibrium chooses every effort")


def test_linearize_equilibrium_on_closed_loops():
    result = runner.invoke(app, ["linearize", "four_bar", "--json", "--at", "q1=0.5,u=equilibrium"])
    assert result.exit_code == 0, result.output
    assert "not an equilibrium" not in result.stderr and "cannot hold" not in result.stderr
    state = strict_json(result.stdout)["state"]
    module = generated_module(render_code(dynderive.derive(dynderive.load_robot("four_bar"))), "four_bar")
    qdd = module.forward_dynamics(np.array(state["q"]), np.zeros(3), np.array(state["u"]))
    np.testing.assert_allclose(qdd, 0, atol=1e-9)


def _hostile_run(tmp_path, *args: str) -> subprocess.CompletedProcess[str]:
    """``dynderive simulate ARGS --csv`` in a subprocess: refused (exit 2, one positioned
    line, no traceback) with nothing written. The runs stop by counting steps, not seconds;
    the timeout only stops a run that would go on for hours (these take about 2 s on an idle
    machine, SymPy's import and the derivation included, and more than 10 s on a loaded one)."""
    csv = tmp_path / "run.csv"
    result = subprocess.run([sys.executable, "-m", "dynderive", "simulate", *args, "-q", "--csv", str(csv)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.splitlines()) == 1 and "Traceback" not in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []
    return result


@pytest.mark.parametrize("robot, effort", [
    ("double_pendulum", "tau1"), ("cart_pole", "F"), ("slider_crank", "tau1"), ("elbow_arm", "tau1"),
])
def test_an_effort_growing_without_bound_stops_the_run(tmp_path, robot, effort):
    """exp(1000*t) spins the robot ever faster: every number stays finite, the integrator's
    steps shrink (these ran for minutes); the run stops once its state has grown 1e4-fold and
    the rest would take more than 1e6 steps, blaming the effort."""
    option = f"{effort}=exp(1000*t)"
    line = _hostile_run(tmp_path, robot, "--duration", "1", "--effort", option).stderr
    assert line.startswith(f"--effort {option}:1:{len(effort) + 2}: effort {effort} reaches "), line
    assert "the motion runs away: at t = " in line and line.rstrip().endswith("; the run stops there")
    assert 0.005 < float(re.search(r"at t = (\S+) s", line).group(1)) < 0.05


@pytest.mark.parametrize("args", [["--coordinates", "maximal"], []])
def test_an_effort_overflowing_the_state_stops_the_run(tmp_path, args):
    """A state past 1e150 (its products overflow; the generated module's math.sin of it used to
    end in 'math domain error'): stopped at the effort."""
    line = _hostile_run(tmp_path, "rp_arm", *args, "--duration", "1", "--effort", "tau1=exp(1000*t)").stderr
    assert line.startswith("--effort tau1=exp(1000*t):1:6: effort tau1 reaches "), line
    assert "the motion overflows (the state passed 1e+150" in line or "the motion runs away" in line, line


@pytest.mark.parametrize("robot, q0, names, size", [
    ("four_bar", "0,0,0", "q1 = 0, q2 = 0, q3 = 0", "8 x 9"),
    ("slider_crank", "1.5707963267948966,0,0", "q1 = 1.5708, q2 = 0, s = 0", "8 x 9"),
])
def test_a_singular_maximal_start_is_refused(tmp_path, robot, q0, names, size):
    """Every link on one line: the constraint Jacobian's rows are dependent, so the KKT system
    is singular (numpy's solve raised LinAlgError where LAPACK found the pivot exactly 0)."""
    line = _hostile_run(tmp_path, robot, "--coordinates", "maximal", "--q0", q0, "--duration", "1").stderr
    assert line == (f"--q0:1:1: the configuration {names} is singular: the maximal coordinates' constraint "
                    f"Jacobian A(qm) ({size}) has rank 7, not 8 (its rows are dependent there), so the constrained "
                    "accelerations cannot be solved for; choose another --q0\n")


def test_the_runaway_stop_counts_steps():
    """The same run stops at the same step whatever the machine's speed: the integrator's
    own count, not a clock."""
    d = dynderive.derive(dynderive.load_robot("double_pendulum"))
    efforts = parse_efforts(d, ["tau1=exp(1000*t)"], False)
    stops = []
    for _ in range(2):
        with pytest.raises(InputError) as caught:
            simulate(d, render_code(d), 1.0, initial_configuration(d.robot, None), np.zeros(2), efforts, False, 1e-9, 1e-9, 10.0, 11,
                     lambda s: None)
        stops.append(str(caught.value))
    assert stops[0] == stops[1] and "the motion runs away" in stops[0]
