"""Joint drives and dissipation (``damping``, ``friction``, ``stiffness``, ``rest``,
``armature``) against references that do not use dynderive's algebra.

* closed forms: the two-mass chain rebuilt in absolute coordinates (its eigenvalues), the
  damped oscillator's decay rate, damped frequency and analytic solution (from simulations of
  the generated ``forward_dynamics``), a mass sliding to rest under Coulomb friction, and the
  smooth ``tanh`` Coulomb law;
* a spring about a rest position: ``N = k (q - rest)``, ``V = k (q - rest)**2 / 2``;
* Pinocchio (``crba``/``aba``/``rnea`` with ``model.armature``) on random 3-D trees whose
  joints carry every drive term, the dissipative and spring forces moved into ``tau``;
* the energy balance ``E(t) - E(0) = -integral of qd . F`` along a simulation of the damped
  cart-pole, with the dissipated power written here from the parameters;
* maximal coordinates against generalized ones (``H^T F_m = F_g``, the KKT accelerations);
* structural properties of a random planar tree with drives on every joint.

Every parameter is a full-precision float (round numbers hide bugs).
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
import sympy as sp
import yaml
from scipy.integrate import solve_ivp

from conftest import text_derivation

#: the drive keys, the parameter prefix used for them in ``with_drives`` and their range
DRIVE_RANGES = {
    "damping": ("b", 0.1, 1.0),
    "friction": ("fc", 0.1, 1.0),
    "stiffness": ("k", 0.5, 5.0),
    "rest": ("r", -1.0, 1.0),
    "armature": ("Ia", 0.05, 0.4),
}
TOL = {"rtol": 1e-9, "atol": 1e-9}


# --- deriving YAML texts (cached for the session) --------------------------------------


_derivation = text_derivation


@pytest.fixture(scope="session")
def derive_text(tmp_path_factory):
    """``derive_text(name, yaml_text)`` -> (derivation, generated module), cached per session."""
    directory = str(tmp_path_factory.mktemp("drives"))
    return lambda name, text: _derivation(name, text, directory)


def _f(value: float) -> str:
    return repr(float(value))


def slider_yaml(name: str, mass: float, **drives: float) -> str:
    """One point mass on a horizontal rail (gravity across it): coordinate ``x``, effort ``F``,
    drive terms as parameters ``b`` (damping), ``fc`` (friction), ``k`` (stiffness)."""
    symbol = {"damping": "b", "friction": "fc", "stiffness": "k"}
    params = "\n".join(f"  {symbol[key]}: {{value: {_f(value)}}}" for key, value in drives.items())
    keys = "\n".join(f"    {key}: {symbol[key]}" for key in drives)
    return f"""name: {name}
planar: true
parameters:
  m: {{value: {_f(mass)}}}
{params}
gravity: [0, -9.806650000000001]
links:
  - name: block
    mass: m
joints:
  - name: x
    type: prismatic
    parent: world
    child: block
    axis: [1, 0]
    effort: F
{keys}
"""


def with_drives(yaml_text: str, rng: random.Random, pattern, *, as_parameters: bool) -> tuple[str, dict]:
    """The YAML text with drive terms added to the moving joints.

    ``pattern(i)`` gives the keys of the i-th moving joint. Values are drawn from ``rng`` (full
    precision) and written as numbers or, with ``as_parameters``, as parameters ``b1``, ``fc1``,
    ... Returns the text and ``{key: array over the coordinates}`` (zeros where absent; ``rest``
    zero without a rest position).
    """
    doc = yaml.safe_load(yaml_text)
    moving = [j for j in doc["joints"] if j["type"] != "fixed"]
    values = {key: np.zeros(len(moving)) for key in DRIVE_RANGES}
    if as_parameters and not doc.get("parameters"):
        doc["parameters"] = {}
    for i, joint in enumerate(moving):
        for key in pattern(i):
            prefix, low, high = DRIVE_RANGES[key]
            value = rng.uniform(low, high)
            values[key][i] = value
            if as_parameters:
                doc["parameters"][f"{prefix}{i + 1}"] = {"value": value}
                joint[key] = f"{prefix}{i + 1}"
            else:
                joint[key] = value
    return yaml.safe_dump(doc, sort_keys=False), values


def central_jacobian(f, x: np.ndarray, h: float) -> np.ndarray:
    columns = []
    for k in range(len(x)):
        e = np.zeros_like(x)
        e[k] = h
        columns.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(columns, axis=-1)


def match_eigenvalues(got: np.ndarray, expected: np.ndarray, rtol: float) -> None:
    """Every expected eigenvalue has a distinct computed one within ``rtol`` (relative)."""
    got = list(got)
    for value in expected:
        k = int(np.argmin([abs(g - value) for g in got]))
        assert abs(got[k] - value) <= rtol * abs(value), (value, got)
        got.pop(k)


# --- 1. mass-spring-damper closed forms ------------------------------------------------


def chain_parameters(seed: int) -> dict[str, float]:
    rng = random.Random(seed)
    return {
        "m1": rng.uniform(0.5, 2.0), "m2": rng.uniform(0.3, 1.5),
        "k1": rng.uniform(10.0, 60.0), "k2": rng.uniform(10.0, 60.0),
        "b1": rng.uniform(0.2, 2.0), "b2": rng.uniform(0.1, 1.5),
        "d": rng.uniform(0.2, 0.8), "g": rng.uniform(9.7, 9.9),
    }


@pytest.mark.parametrize("seed", [3, 17])
def test_two_mass_chain_matches_absolute_coordinates(generated, seed):
    """The chain in absolute coordinates X = T s (X1 = s1, X2 = s1 + s2): M = T^T diag(m) T,
    N = T^T K T s, F = T^T B T sd with wall-m1 and m1-m2 springs and dampers; the state
    matrix of the generated ``forward_dynamics`` (linearized by central differences) has the
    eigenvalues of the absolute-coordinate system."""
    module = generated("mass_spring_damper")
    p = chain_parameters(seed)
    m1, m2, k1, k2, b1, b2 = (p[k] for k in ("m1", "m2", "k1", "k2", "b1", "b2"))
    T = np.array([[1.0, 0.0], [1.0, 1.0]])
    M_abs = np.diag([m1, m2])
    K_abs = np.array([[k1 + k2, -k2], [-k2, k2]])
    B_abs = np.array([[b1 + b2, -b2], [-b2, b2]])

    rng = np.random.default_rng(seed)
    qs, qds = rng.uniform(-0.3, 0.3, (4, 2)), rng.uniform(-1.0, 1.0, (4, 2))
    for q, qd in zip(qs, qds):
        np.testing.assert_allclose(module.mass_matrix(q, **p), T.T @ M_abs @ T, **TOL)
        np.testing.assert_allclose(module.gravity_vector(q, **p), T.T @ K_abs @ T @ q, **TOL)
        np.testing.assert_allclose(module.friction_forces(qd, **p), T.T @ B_abs @ T @ qd, **TOL)
        X, Xd = T @ q, T @ qd
        assert module.kinetic_energy(q, qd, **p) == pytest.approx(Xd @ M_abs @ Xd / 2, rel=1e-12)
        dV = module.potential_energy(q, **p) - module.potential_energy(0 * q, **p)
        assert dV == pytest.approx(X @ K_abs @ X / 2, rel=1e-12)
    # batches: the same forces state by state
    np.testing.assert_allclose(module.friction_forces(qds, **p), qds @ (T.T @ B_abs @ T).T, **TOL)

    # rest is an equilibrium; the push F1 accelerates mass1 only: Xdd = (F1/m1, 0)
    zero = np.zeros(2)
    np.testing.assert_allclose(module.forward_dynamics(zero, zero, np.zeros(1), **p), zero, atol=1e-12)
    push = 1.7320508075688772
    np.testing.assert_allclose(module.forward_dynamics(zero, zero, np.array([push]), **p),
                               np.linalg.solve(T, [push / m1, 0.0]), **TOL)

    # linearization of the generated forward dynamics at rest
    state = np.zeros(4)

    def rhs(x):
        return module.forward_dynamics(x[:2], x[2:], np.zeros(1), **p)

    J = central_jacobian(rhs, state, 1e-3)
    A_gen = np.block([[np.zeros((2, 2)), np.eye(2)], [J]])
    Minv = np.linalg.inv(M_abs)
    A_abs = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K_abs, -Minv @ B_abs]])
    expected = np.linalg.eigvals(A_abs)
    assert np.all(expected.real < 0) and np.any(expected.imag != 0)  # damped oscillations
    match_eigenvalues(np.linalg.eigvals(A_gen), expected, rtol=1e-8)


OSCILLATOR = {"mass": 1.3718263544913871, "stiffness": 23.961807120745935, "damping": 0.41726387120195357}


def test_damped_oscillator_decay_rate_frequency_and_solution(derive_text):
    """m x'' + b x' + k x = 0 simulated with the generated ``forward_dynamics``: successive
    maxima are 2 pi / wd apart with wd = sqrt(k/m - (b/2m)**2) and shrink by exp(-b/(2m) Td),
    and x(t) = exp(-s t) (x0 cos wd t + (v0 + s x0)/wd sin wd t) pointwise."""
    m, k, b = OSCILLATOR["mass"], OSCILLATOR["stiffness"], OSCILLATOR["damping"]
    d, module = derive_text("drives_oscillator", slider_yaml("oscillator", m, stiffness=k, damping=b))
    x_, xd_ = d.symbols.q[0], d.symbols.qd[0]
    P = d.symbols.parameters
    assert sp.simplify(d["F_g"][0] - P["b"] * xd_) == 0
    assert sp.simplify(d["N_g"][0] - P["k"] * x_) == 0
    assert sp.simplify(d["D_g"] - P["b"] * xd_**2 / 2) == 0

    sigma = b / (2 * m)
    wd = math.sqrt(k / m - sigma**2)
    x0, v0 = 0.38274913671820834, -0.5162798320185735

    def rhs(t, y):
        return [y[1], module.forward_dynamics(y[:1], y[1:])[0]]

    def peak(t, y):
        return y[1]
    peak.direction = -1  # the velocity falls through zero: a maximum of x

    t_end = 12.0
    sol = solve_ivp(rhs, (0.0, t_end), [x0, v0], method="DOP853", rtol=1e-11, atol=1e-13,
                    dense_output=True, events=peak)
    times, xs = sol.t_events[0], sol.y_events[0][:, 0]
    assert len(times) >= 6
    periods = np.diff(times)
    np.testing.assert_allclose(periods, 2 * np.pi / wd, rtol=1e-6)
    np.testing.assert_allclose(np.log(xs[:-1] / xs[1:]) / periods, sigma, rtol=1e-6)

    t = np.linspace(0.0, t_end, 601)
    exact = np.exp(-sigma * t) * (x0 * np.cos(wd * t) + (v0 + sigma * x0) / wd * np.sin(wd * t))
    np.testing.assert_allclose(sol.sol(t)[0], exact, rtol=0, atol=1e-8 * abs(x0))


# --- 2. Coulomb friction ---------------------------------------------------------------


def test_coulomb_slide_to_rest_closed_form(derive_text):
    """A block sliding with friction only decelerates at fc/m: x = x0 + v0 t - fc t**2/(2m),
    v = v0 - fc t / m until it stops at m v0 / fc (integrated up to 0.9 of that)."""
    m, fc = 0.8462097813356149, 0.6379150217330473
    d, module = derive_text("drives_coulomb", slider_yaml("coulomb_block", m, friction=fc))
    xd_ = d.symbols.qd[0]
    assert sp.simplify(d["F_g"][0] - d.symbols.parameters["fc"] * sp.sign(xd_)) == 0
    assert d["D_g"] == 0  # no damper: the Rayleigh function is empty

    x0, v0 = -0.2718281828459045, 1.4142135623730951
    t_stop = m * v0 / fc

    def rhs(t, y):
        return [y[1], module.forward_dynamics(y[:1], y[1:], friction_smoothing=0.0)[0]]

    t = np.linspace(0.0, 0.9 * t_stop, 201)
    sol = solve_ivp(rhs, (0.0, t[-1]), [x0, v0], method="DOP853", rtol=1e-11, atol=1e-13, t_eval=t)
    assert sol.success
    np.testing.assert_allclose(sol.y[0], x0 + v0 * t - fc * t**2 / (2 * m), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(sol.y[1], v0 - fc * t / m, rtol=1e-9, atol=1e-12)
    # either direction, at any position: a = -fc sign(v) / m; at rest no force
    for v in (-2.3, -1e-7, 1e-7, 0.9):
        assert module.forward_dynamics(np.array([0.31]), np.array([v]))[0] == pytest.approx(-fc * np.sign(v) / m,
                                                                                           rel=1e-12)
    assert module.friction_forces(np.array([0.0]))[0] == 0.0


def test_smooth_coulomb_law(derive_text, generated):
    """friction_smoothing = eps: fc tanh(qd/eps) instead of fc sign(qd), in friction_forces,
    forward_dynamics and inverse_dynamics; it tends to fc sign(qd) as eps -> 0."""
    m, fc = 0.8462097813356149, 0.6379150217330473
    _, module = derive_text("drives_coulomb", slider_yaml("coulomb_block", m, friction=fc))
    qd = np.linspace(-0.7, 0.7, 141)[:, None]
    q = np.full_like(qd, 0.123)
    for eps in (1e-1, 1e-2, 1e-3):
        smooth = module.friction_forces(qd, friction_smoothing=eps)
        np.testing.assert_allclose(smooth, fc * np.tanh(qd / eps), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(module.forward_dynamics(q, qd, friction_smoothing=eps),
                                   -fc * np.tanh(qd / eps) / m, rtol=1e-12, atol=1e-15)
        qdd = np.full_like(qd, -0.4419417382415922)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd, friction_smoothing=eps),
                                   m * qdd + fc * np.tanh(qd / eps), rtol=1e-12, atol=1e-15)
    # the limit: at |qd| >= 0.05, eps = 1e-3 is the sign law to the last bit; the error at a
    # small rate shrinks with eps
    exact = module.friction_forces(qd)
    np.testing.assert_allclose(exact, fc * np.sign(qd), rtol=0, atol=0)
    away = np.abs(qd) >= 0.05
    np.testing.assert_allclose(module.friction_forces(qd, friction_smoothing=1e-3)[away], exact[away],
                               rtol=1e-15, atol=0)
    errors = [abs(module.friction_forces(np.array([0.01]), friction_smoothing=eps)[0] - fc)
              for eps in (1e-1, 1e-2, 1e-3, 1e-4)]
    assert all(a > b for a, b in zip(errors, errors[1:])) and errors[-1] < 1e-12 * fc

    # with a damper too (the bundled damped cart-pole): b qd + fc tanh(qd / eps)
    cart = generated("cart_pole_damped")
    p = cart_pole_parameters(5)
    rates = np.random.default_rng(5).uniform(-1.0, 1.0, (7, 2))
    for eps in (0.0, 0.05, 1e-3):
        direction = np.sign(rates[:, 0]) if eps == 0 else np.tanh(rates[:, 0] / eps)
        expected = np.stack([p["bc"] * rates[:, 0] + p["fc"] * direction, p["bp"] * rates[:, 1]], axis=-1)
        np.testing.assert_allclose(cart.friction_forces(rates, friction_smoothing=eps, **p), expected, **TOL)
    with pytest.raises(ValueError):
        cart.friction_forces(rates, friction_smoothing=-1e-3, **p)


# --- 3. spring rest position -----------------------------------------------------------


def test_spring_about_rest_position(derive_text):
    """No gravity; a spring without ``rest`` (about 0) on a slider, and a torsion spring about
    r0 on a revolute joint carried by it: N = (k2 s, k1 (th - r0)),
    V = k2 s**2/2 + k1 (th - r0)**2/2; (0, r0) at rest is an equilibrium."""
    J, k1, r0, k2, ms = 0.7316262803473185, 3.1862017431269534, 0.6182193750137762, 7.049306013412541, 0.5127453918743016
    text = f"""name: springs
planar: true
parameters:
  J: {{value: {_f(J)}}}
  k1: {{value: {_f(k1)}}}
  r0: {{value: {_f(r0)}}}
  k2: {{value: {_f(k2)}}}
  ms: {{value: {_f(ms)}}}
gravity: [0, 0]
links:
  - name: slider
    mass: ms
  - name: disk
    mass: 2.0943951023931953
    com: [0.1414213562373095, 0.0]
    inertia: J
joints:
  - name: s
    type: prismatic
    parent: world
    child: slider
    axis: [1, 0]
    stiffness: k2
  - name: th
    type: revolute
    parent: slider
    child: disk
    origin: [0.3090169943749474, -0.2]
    stiffness: k1
    rest: r0
"""
    d, module = derive_text("drives_springs", text)
    s, th = d.symbols.q
    P = d.symbols.parameters
    assert sp.simplify(d["N_g"] - sp.Matrix([P["k2"] * s, P["k1"] * (th - P["r0"])])) == sp.zeros(2, 1)
    assert sp.simplify(d["V_g"] - P["k1"] * (th - P["r0"]) ** 2 / 2 - P["k2"] * s**2 / 2) == 0
    assert all(c.passed for c in d.checks), [c.summary() for c in d.checks if not c.passed]
    with pytest.raises(KeyError):
        d["F_g"]  # no damping or friction: no dissipative forces

    rng = np.random.default_rng(11)
    qs = rng.uniform(-2.0, 2.0, (6, 2))
    expected = np.stack([k2 * qs[:, 0], k1 * (qs[:, 1] - r0)], axis=-1)
    np.testing.assert_allclose(module.gravity_vector(qs), expected, **TOL)
    np.testing.assert_allclose(module.potential_energy(qs),
                               k2 * qs[:, 0] ** 2 / 2 + k1 * (qs[:, 1] - r0) ** 2 / 2, **TOL)
    # another rest position and stiffness through the keywords
    r_other, k_other = -0.4342944819032518, 1.4426950408889634
    np.testing.assert_allclose(module.gravity_vector(qs, r0=r_other, k1=k_other)[:, 1],
                               k_other * (qs[:, 1] - r_other), **TOL)
    np.testing.assert_allclose(module.forward_dynamics(np.array([0.0, r0]), np.zeros(2)), 0.0, atol=1e-12)
    np.testing.assert_allclose(module.friction_forces(rng.uniform(-1, 1, (3, 2))), 0.0, atol=0)
    # the disk turned off its rest position: M qdd = (0, -k1 dth), the mass matrix coupled
    q = np.array([0.0, r0 + 0.01])
    M = module.mass_matrix(q)
    assert abs(M[0, 1]) > 1e-3
    np.testing.assert_allclose(module.forward_dynamics(q, np.zeros(2)), np.linalg.solve(M, [0.0, -k1 * 0.01]),
                               rtol=1e-9, atol=1e-12)


# --- 4. armature and drives against Pinocchio ------------------------------------------

#: (seed, moving joints) of ``random_spatial_tree``: chosen to derive quickly
PIN_CASES = [(7, 3), (1, 3), (16, 5)]


def _pin_pattern(i: int) -> tuple[str, ...]:
    """Every joint: armature and damping; then by turns friction, a spring about a rest
    position, a spring about 0 with friction."""
    return ("armature", "damping") + [("friction",), ("stiffness", "rest"), ("stiffness", "friction")][i % 3]


@pytest.mark.pinocchio
@pytest.mark.parametrize(("seed", "n_joints"), PIN_CASES, ids=[f"seed{s}-{n}dof" for s, n in PIN_CASES])
def test_drives_match_pinocchio(seed, n_joints, derive_text):
    """Generated M (with armature) == crba with ``model.armature``; forward dynamics ==
    aba(q, v, tau - b v - fc sign(v) - k (q - rest)); inverse == rnea + those forces;
    T == Pinocchio's kinetic energy + sum Ia qd**2/2, V == Pinocchio's + springs."""
    pytest.importorskip("pinocchio")
    from test_pinocchio_spatial import PinRobot  # the hand-built, URDF-checked Pinocchio model

    from random_robots3d import random_spatial_tree

    tree = random_spatial_tree(random.Random(seed), n_joints)
    text, values = with_drives(tree.yaml_text, random.Random(900 + seed), _pin_pattern, as_parameters=False)
    _, module = derive_text(f"drives_tree3d_{seed}_{n_joints}", text)
    b, fc, k, rest, armature = (values[key] for key in ("damping", "friction", "stiffness", "rest", "armature"))
    assert np.all(armature > 0) and np.count_nonzero(rest) >= 1 and np.count_nonzero(fc) >= 1

    plain, robot = PinRobot.of(tree), PinRobot.of(tree)
    robot.model.armature = armature[robot.perm]  # Pinocchio's joint order
    robot.data = robot.model.createData()
    # Pinocchio 4 counts the armature itself: crba adds it to M's diagonal (and aba and rnea
    # use that M). Its computeKineticEnergy does not count it for JointModelRevoluteUnaligned
    # (Pinocchio 4.1.0), so the kinetic energy below is the armature-free model's plus Ia v**2/2.
    q = np.full(tree.n_dof, 0.7071067811865476)
    np.testing.assert_allclose(robot.mass(q), plain.mass(q) + np.diag(armature), rtol=1e-13, atol=1e-13)

    rng = np.random.default_rng(2000 + seed)
    n = tree.n_dof
    qs, qds, us = rng.uniform(-1.5, 1.5, (5, n)), rng.uniform(-1.5, 1.5, (5, n)), rng.uniform(-5.0, 5.0, (5, n))
    for q, qd, u in zip(qs, qds, us):
        drive = b * qd + fc * np.sign(qd) + k * (q - rest)
        np.testing.assert_allclose(module.mass_matrix(q), robot.mass(q), **TOL)
        np.testing.assert_allclose(module.friction_forces(qd), b * qd + fc * np.sign(qd), **TOL)
        np.testing.assert_allclose(module.gravity_vector(q), robot.gravity(q) + k * (q - rest), **TOL)
        np.testing.assert_allclose(module.forward_dynamics(q, qd, u), robot.aba(q, qd, u - drive), **TOL)
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, u), robot.rnea(q, qd, u) + drive, **TOL)
        np.testing.assert_allclose(module.kinetic_energy(q, qd), plain.kinetic(q, qd) + armature @ qd**2 / 2, **TOL)
        np.testing.assert_allclose(module.kinetic_energy(q, qd), qd @ robot.mass(q) @ qd / 2, **TOL)
        np.testing.assert_allclose(module.potential_energy(q),
                                   plain.potential(q) + k @ (q - rest) ** 2 / 2, **TOL)
    # batched, with the smooth Coulomb law
    eps = 0.3183098861837907
    drive = b * qds + fc * np.tanh(qds / eps) + k * (qs - rest)
    expected = np.stack([robot.aba(q, qd, u - f) for q, qd, u, f in zip(qs, qds, us, drive)])
    np.testing.assert_allclose(module.forward_dynamics(qs, qds, us, friction_smoothing=eps), expected, **TOL)


# --- 5. energy balance with dissipation ------------------------------------------------


def cart_pole_parameters(seed: int) -> dict[str, float]:
    rng = random.Random(seed)
    return {
        "mc": rng.uniform(0.8, 1.6), "mp": rng.uniform(0.1, 0.4), "lp": rng.uniform(0.6, 1.2),
        "bc": rng.uniform(0.2, 0.6), "fc": rng.uniform(0.1, 0.3), "bp": rng.uniform(0.005, 0.03),
        "Jm": rng.uniform(0.03, 0.1), "g": rng.uniform(9.7, 9.9),
    }


def test_energy_balance_of_damped_cart_pole(generated):
    """Along a simulation (u = 0), E(t) - E(0) = -W(t), W the work of the dissipative forces
    integrated with the state, its power bc xd**2 + fc |xd| + bp thetad**2 written here from
    the parameters; E falls all the time. The cart keeps moving, so sign(xd) never flips."""
    module = generated("cart_pole_damped")
    p = cart_pole_parameters(7)

    def energy(q, qd):
        return module.kinetic_energy(q, qd, **p) + module.potential_energy(q, **p)

    def rhs(t, y):
        q, qd = y[:2], y[2:4]
        power = p["bc"] * qd[0] ** 2 + p["fc"] * abs(qd[0]) + p["bp"] * qd[1] ** 2
        return [*qd, *module.forward_dynamics(q, qd, friction_smoothing=0.0, **p), power]

    y0 = [0.1732050807568877, 2.718281828459045, 2.449489742783178, -1.1180339887498949, 0.0]
    t = np.linspace(0.0, 2.5, 501)
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-11, atol=1e-12, t_eval=t)
    assert sol.success
    q, qd, work = sol.y[:2].T, sol.y[2:4].T, sol.y[4]
    assert qd[:, 0].min() > 0.05
    E = energy(q, qd)
    assert work[-1] > 0.1 * abs(E[0])  # a real loss, not rounding
    np.testing.assert_allclose(E - E[0], -work, rtol=0, atol=1e-6 * work[-1])
    assert np.all(np.diff(E) < 0)
    # the power the generated friction_forces gives is the same
    np.testing.assert_allclose(np.einsum("ti,ti->t", qd, module.friction_forces(qd, **p)),
                               p["bc"] * qd[:, 0] ** 2 + p["fc"] * np.abs(qd[:, 0]) + p["bp"] * qd[:, 1] ** 2, **TOL)


# --- 6. maximal coordinates == generalized ---------------------------------------------


def _maximal_case(robot: str):
    if robot == "mass_spring_damper":
        return chain_parameters(23)
    return cart_pole_parameters(23)


@pytest.mark.parametrize("robot", ["mass_spring_damper", "cart_pole_damped"])
def test_maximal_matches_generalized(generated, robot):
    """qm = h(q), qmd = H qd: H^T F_m = F_g, H^T M_m H = M_g (armature included), equal
    energies, and the KKT accelerations are H qdd + Hdot qd with qdd from forward_dynamics."""
    module = generated(robot)
    p = _maximal_case(robot)
    rng = np.random.default_rng(31)
    n = len(module.COORDINATES)
    qs, qds = rng.uniform(-1.5, 1.5, (5, n)), rng.uniform(-1.5, 1.5, (5, n))
    us = rng.uniform(-3.0, 3.0, (5, len(module.EFFORTS)))
    h = 1e-6
    for q, qd, u in zip(qs, qds, us):
        qm = module.to_maximal(q, **p)
        H = module.to_maximal_jacobian(q, **p)
        qmd = H @ qd
        Hdot_qd = (module.to_maximal_jacobian(q + h * qd, **p) - module.to_maximal_jacobian(q - h * qd, **p)) @ qd / (2 * h)
        np.testing.assert_allclose(H.T @ module.maximal_friction_forces(qm, qmd, **p),
                                   module.friction_forces(qd, **p), rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(H.T @ module.maximal_mass_matrix(qm, **p) @ H, module.mass_matrix(q, **p),
                                   rtol=1e-10, atol=1e-10)
        assert module.maximal_kinetic_energy(qm, qmd, **p) == pytest.approx(module.kinetic_energy(q, qd, **p),
                                                                            rel=1e-10)
        assert module.maximal_potential_energy(qm, **p) == pytest.approx(module.potential_energy(q, **p),
                                                                         rel=1e-10, abs=1e-10)
        qdd = module.forward_dynamics(q, qd, u, **p)
        np.testing.assert_allclose(module.maximal_forward_dynamics(qm, qmd, u, **p), H @ qdd + Hdot_qd,
                                   rtol=1e-8, atol=1e-8)


# --- 7. properties of a random planar tree with drives ---------------------------------

#: ``random_planar_tree(Random(7), 3)``: a weld to the world, then revolute, prismatic, revolute
PLANAR_SEED, PLANAR_JOINTS = 7, 3
ALL_DRIVES = ("damping", "friction", "stiffness", "rest", "armature")


@pytest.fixture(scope="module")
def planar_case(derive_text):
    from random_robots import random_planar_tree

    tree = random_planar_tree(random.Random(PLANAR_SEED), PLANAR_JOINTS)
    text, values = with_drives(tree.yaml_text, random.Random(4000 + PLANAR_SEED), lambda i: ALL_DRIVES,
                               as_parameters=True)
    d, module = derive_text(f"drives_planar_{PLANAR_SEED}_{PLANAR_JOINTS}", text)
    return tree, d, module, values


def test_planar_tree_with_drives_symbolic(planar_case):
    """The checks pass; F_g = b qd + fc sign(qd), D_g = sum b qd**2 / 2, joint by joint."""
    tree, d, _, _ = planar_case
    assert tree.has_fixed
    assert d.checks and all(c.passed for c in d.checks), [c.summary() for c in d.checks if not c.passed]
    P, qd = d.symbols.parameters, d.symbols.qd
    expected_F = sp.Matrix([P[f"b{i + 1}"] * v + P[f"fc{i + 1}"] * sp.sign(v) for i, v in enumerate(qd)])
    assert sp.simplify(d["F_g"] - expected_F) == sp.zeros(len(qd), 1)
    assert sp.simplify(d["D_g"] - sum(P[f"b{i + 1}"] * v**2 for i, v in enumerate(qd)) / 2) == 0


def test_planar_tree_with_drives_numeric(planar_case):
    """M symmetric positive definite, the armature on its diagonal (M(Ia) - M(Ia = 0));
    springs in N (N(k) - N(k = 0) = k (q - rest)); Mdot - 2C skew (central differences);
    inverse_dynamics = M qdd + C qd + N + F; inverse(forward) = Y with and without smoothing;
    dE/dt = qd . (Y - F)."""
    tree, _, module, values = planar_case
    n = tree.n_dof
    b, fc, k, rest, armature = (values[key] for key in ("damping", "friction", "stiffness", "rest", "armature"))
    no_armature = {f"Ia{i + 1}": 0.0 for i in range(n)}
    no_springs = {f"k{i + 1}": 0.0 for i in range(n)}
    rng = np.random.default_rng(77)
    qs, qds, us = rng.uniform(-1.5, 1.5, (5, n)), rng.uniform(-2.0, 2.0, (5, n)), rng.uniform(-3.0, 3.0, (5, n))

    M = module.mass_matrix(qs)
    np.testing.assert_allclose(M, np.swapaxes(M, -1, -2), rtol=0, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(M - module.mass_matrix(qs, **no_armature), np.broadcast_to(np.diag(armature), M.shape),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(module.gravity_vector(qs) - module.gravity_vector(qs, **no_springs), k * (qs - rest),
                               rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(module.friction_forces(qds), b * qds + fc * np.sign(qds), **TOL)
    np.testing.assert_allclose(module.kinetic_energy(qs, qds) - module.kinetic_energy(qs, qds, **no_armature),
                               (armature * qds**2).sum(-1) / 2, rtol=1e-10, atol=1e-10)

    h = 1e-5
    for q, qd, u in zip(qs, qds, us):
        mdot = (module.mass_matrix(q + h * qd) - module.mass_matrix(q - h * qd)) / (2 * h)
        S = mdot - 2 * module.coriolis_matrix(q, qd)
        np.testing.assert_allclose(S + S.T, 0.0, rtol=0, atol=1e-7)
        qdd = module.forward_dynamics(q, qd, u)
        decomposed = (module.mass_matrix(q) @ qdd + module.coriolis_matrix(q, qd) @ qd + module.gravity_vector(q)
                      + module.friction_forces(qd))
        np.testing.assert_allclose(module.inverse_dynamics(q, qd, qdd), decomposed, rtol=1e-10, atol=1e-10)

        Y = module.generalized_forces(q, u)

        def energy(t, q=q, qd=qd, qdd=qdd):
            qt, qdt = q + qd * t + qdd * t**2 / 2, qd + qdd * t
            return module.kinetic_energy(qt, qdt) + module.potential_energy(qt)

        rate = (energy(h) - energy(-h)) / (2 * h)
        assert rate == pytest.approx(qd @ (Y - module.friction_forces(qd)), rel=1e-6, abs=1e-7)

    for eps in (0.0, 0.2718281828459045, 1e-3):
        qdd = module.forward_dynamics(qs, qds, us, friction_smoothing=eps)
        np.testing.assert_allclose(module.inverse_dynamics(qs, qds, qdd, friction_smoothing=eps),
                                   module.generalized_forces(qs, us), rtol=1e-10, atol=1e-10)
    # the smoothing matters: a different answer at a rate comparable to eps
    slow = qds * 1e-2
    assert not np.allclose(module.forward_dynamics(qs, slow, us, friction_smoothing=0.1),
                           module.forward_dynamics(qs, slow, us), rtol=1e-6, atol=1e-6)
