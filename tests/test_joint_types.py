"""Joint types own their configuration space (``mechanics/joint_types/``, DESIGN.md section
10): each type's nq, nv and names agree with the robot model, and its configuration maps,
target-neutral program lines, hold the Lie-group properties at random full-precision states
(``difference(q, integrate(q, v, 1)) == v``, ``integrate(q, 0) == q``, the rate the time
derivative of ``integrate`` at 0, the derivatives' tangent seed the rate's derivative by
``v``) and equal Pinocchio's ``neutral``, ``integrate`` and ``difference`` on a one-joint
model. A robot's maps, joint by joint, equal its generated NumPy module's."""

from __future__ import annotations

import importlib.util
import random
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.mechanics.joint_types import JOINT_TYPES, configuration_programs, joint_type
from dynderive.mechanics.joint_types.quaternion import quaternion_matrix
from dynderive.mechanics.program import Program
from dynderive.model.robot import Joint
from dynderive.render.targets.numpy.code import render_code

pin = pytest.importorskip("pinocchio")

TESTS = Path(__file__).parent
#: Every registered type that moves: the contract below holds for each, a new type included.
MOVING = [name for name, kind in JOINT_TYPES.items() if kind.moves]
#: A generic unit axis (full precision) and the types' own keys at full-precision values.
AXIS = tuple(x / np.linalg.norm([0.3611, -0.4823, 0.7977]) for x in (0.3611, -0.4823, 0.7977))
_SECOND = np.cross(AXIS, (0.2718, 0.5771, -0.1414))
KEY_VALUES = {"pitch": 0.0731946218472513, "axis2": tuple(_SECOND / np.linalg.norm(_SECOND))}


def _sympy_geometry(kind) -> dict[str, object]:
    """The types' own keys as SymPy floats (a key of n entries a tuple)."""
    return {key: tuple(sympy.Float(x, 17) for x in value) if isinstance(value, tuple) else sympy.Float(value, 17)
            for key, value in _geometry(kind).items()}


def _geometry(kind) -> dict[str, float]:
    return {key.name: KEY_VALUES[key.name] for key in kind.spec.keys}


class Compiled:
    """A program's lines compiled once (``lambdify`` with ``math``, line by line), run at many
    points: ``run({symbol: value})`` gives the outputs as an array."""

    def __init__(self, program: Program):
        self.lines = []
        for name, expr in program.lines:
            symbols = sorted(expr.free_symbols, key=lambda s: s.name)
            self.lines.append((name, symbols, sympy.lambdify(symbols, expr, "math")))
        self.outputs = [(sorted(sympy.sympify(e).free_symbols, key=lambda s: s.name), e) for e in program.outputs]
        self.compiled = [(symbols, sympy.lambdify(symbols, e, "math")) for symbols, e in self.outputs]

    def run(self, values: dict[sympy.Symbol, float]) -> np.ndarray:
        env = dict(values)
        for name, symbols, function in self.lines:
            env[name] = function(*(env[s] for s in symbols))
        return np.array([float(f(*(env[s] for s in symbols))) for symbols, f in self.compiled])


def _symbols(prefix: str, n: int) -> list[sympy.Symbol]:
    return [sympy.Symbol(f"{prefix}{i}") for i in range(n)]


class Maps:
    """A joint type's four maps compiled over symbols ``q``, ``v``, ``dt``, ``q0``, ``q1``."""

    def __init__(self, name: str):
        kind = self.kind = joint_type(name)
        self.q, self.v, self.q0, self.q1 = (_symbols(p, n) for p, n in
                                            (("q", kind.nq), ("v", kind.nv), ("a", kind.nq), ("b", kind.nq)))
        self.dt = sympy.Symbol("dt")
        built = {}
        for map_name, build in (("integrate", lambda let: kind.integrate(let, self.q, self.v, self.dt)),
                                ("difference", lambda let: kind.difference(let, self.q0, self.q1)),
                                ("rate", lambda let: kind.rate(let, self.q, self.v))):
            program = Program()
            program.outputs = build(program.let)
            built[map_name] = Compiled(program)
        self.built = built
        program = Program()
        seeds = kind.tangent_seed(self.q, program.let)
        program.outputs = [seed.get(s, 0) for seed in seeds for s in self.q]   # nv x nq, row by row
        self.seed = Compiled(program)

    def integrate(self, q, v, dt=1.0) -> np.ndarray:
        return self.built["integrate"].run({**dict(zip(self.q, q)), **dict(zip(self.v, v)), self.dt: dt})

    def difference(self, q0, q1) -> np.ndarray:
        return self.built["difference"].run({**dict(zip(self.q0, q0)), **dict(zip(self.q1, q1))})

    def rate(self, q, v) -> np.ndarray:
        return self.built["rate"].run({**dict(zip(self.q, q)), **dict(zip(self.v, v))})

    def tangent_seed(self, q) -> np.ndarray:
        return self.seed.run(dict(zip(self.q, q))).reshape(self.kind.nv, self.kind.nq)


@pytest.fixture(scope="module")
def maps() -> dict[str, Maps]:
    return {name: Maps(name) for name in MOVING}


def _random_configuration(name: str, rng: np.random.Generator) -> np.ndarray:
    """Full-precision entries; the quaternion unit (either hemisphere)."""
    kind = joint_type(name)
    q = rng.uniform(-2.0, 2.0, kind.nq)
    if kind.quaternion_start is not None:
        s = kind.quaternion_start
        quaternion = rng.normal(size=4)
        q[s:s + 4] = quaternion / np.linalg.norm(quaternion)
    return q


def _random_velocity(name: str, rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    """Angular parts below pi in norm (the logarithm's principal branch)."""
    return rng.uniform(-1.0, 1.0, joint_type(name).nv) * scale


STATES = 8


@pytest.mark.parametrize("name", list(JOINT_TYPES))
def test_sizes_and_names_agree_with_the_robot_model(name):
    kind = joint_type(name)
    joint = Joint("j", name, "world", "link", (0,) * 6, (1, 0, 0) if kind.spec.takes_axis else (),
                  geometry=tuple(_geometry(kind).items()))
    assert joint.sizes == (kind.nq, kind.nv) == (kind.spec.nq, kind.spec.nv)
    assert joint.moves == kind.moves and joint.kind is kind.spec
    assert len(kind.columns(kind.neutral(), (sympy.Integer(1), sympy.Integer(0), sympy.Integer(0)), _geometry(kind))) == kind.nv
    assert len(joint.kind.names("j")[0]) == kind.nq
    assert len(kind.neutral()) == kind.nq
    assert (kind.quaternion_start is not None) == joint.multi


def test_lookup_refuses_an_unknown_type():
    with pytest.raises(ValueError, match="unknown joint type 'ball'"):
        joint_type("ball")


@pytest.mark.parametrize("name", MOVING)
def test_neutral_integrate_zero_and_difference_inverts_integrate(maps, name):
    m, rng = maps[name], np.random.default_rng(7)
    neutral = np.array([float(x) for x in m.kind.neutral()])
    if m.kind.quaternion_start is not None:
        s = m.kind.quaternion_start
        assert np.linalg.norm(neutral[s:s + 4]) == 1.0 and neutral[s + 3] == 1.0
    for scale in (1.0, 1e-7):   # the closed forms and the series below SMALL
        for _ in range(STATES):
            q, v = _random_configuration(name, rng), _random_velocity(name, rng, scale)
            np.testing.assert_allclose(m.integrate(q, np.zeros(m.kind.nv)), q, rtol=0, atol=1e-15)
            np.testing.assert_allclose(m.difference(q, q), np.zeros(m.kind.nv), rtol=0, atol=1e-15)
            np.testing.assert_allclose(m.difference(q, m.integrate(q, v, 1.0)), v, rtol=0, atol=1e-12)
            dt = rng.uniform(0.1, 1.0)
            np.testing.assert_allclose(m.difference(q, m.integrate(q, v, dt)), v * dt, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", MOVING)
def test_rate_is_the_derivative_of_integrate_and_the_seed_its_derivative_by_v(maps, name):
    m, rng = maps[name], np.random.default_rng(11)
    h = 1e-6
    for _ in range(STATES):
        q, v = _random_configuration(name, rng), _random_velocity(name, rng)
        central = (m.integrate(q, v, h) - m.integrate(q, v, -h)) / (2 * h)
        np.testing.assert_allclose(m.rate(q, v), central, rtol=0, atol=1e-8)
        seed = m.tangent_seed(q)
        for k in range(m.kind.nv):   # the rate is linear in v: its derivative by v_k is rate(q, e_k)
            np.testing.assert_allclose(seed[k], m.rate(q, np.eye(m.kind.nv)[k]), rtol=0, atol=1e-15)


def _pinocchio_model(name: str):
    """A one-joint model: the type's own Pinocchio joint model at AXIS and KEY_VALUES."""
    model, kind = pin.Model(), joint_type(name)
    model.addJoint(0, kind.pinocchio(pin, np.array(AXIS), _geometry(kind)), pin.SE3.Identity(), "j")
    return model


@pytest.mark.parametrize("name", MOVING)
def test_maps_equal_pinocchio_on_a_one_joint_model(maps, name):
    m, rng, model = maps[name], np.random.default_rng(13), _pinocchio_model(name)
    assert (model.nq, model.nv) == (m.kind.nq, m.kind.nv)
    np.testing.assert_array_equal(pin.neutral(model), [float(x) for x in m.kind.neutral()])
    for scale in (1.0, None, 1e-7):   # None: turns by 3.5 to 6 (a floating joint's quaternion changes hemisphere)
        for _ in range(STATES):
            q0, v = _random_configuration(name, rng), _random_velocity(name, rng, scale or 1.0)
            dt = rng.uniform(0.1, 1.0)
            if scale is None and m.kind.quaternion_start is not None:
                v[-3:] *= rng.uniform(3.5, 6.0) / (dt * np.linalg.norm(v[-3:]))
            q1 = m.integrate(q0, v, dt)
            np.testing.assert_allclose(q1, pin.integrate(model, q0, v * dt), rtol=0, atol=1e-12)
            other = _random_configuration(name, rng)
            np.testing.assert_allclose(m.difference(q0, other), pin.difference(model, q0, other), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", MOVING)
def test_motion_equals_pinocchio_on_a_one_joint_model(name):
    """The type's child placement (rotation, displacement) and motion columns (its local
    Jacobian, linear then angular in Pinocchio) at AXIS and KEY_VALUES, at random states."""
    kind, rng = joint_type(name), np.random.default_rng(17)
    model = _pinocchio_model(name)
    data = model.createData()
    axis = tuple(sympy.Float(a, 17) for a in AXIS)
    geometry = _sympy_geometry(kind)
    for _ in range(STATES):
        q = _random_configuration(name, rng)
        entries = [sympy.Float(x, 17) for x in q]
        pin.forwardKinematics(model, data, q)
        R = np.array(kind.rotation(entries, axis, geometry), dtype=float)
        shift = kind.displacement(sympy.eye(3), entries, axis, geometry)
        p = np.zeros(3) if shift is None else np.array(shift, dtype=float).reshape(3)
        np.testing.assert_allclose(R, data.oMi[1].rotation, rtol=0, atol=1e-14)
        np.testing.assert_allclose(p, data.oMi[1].translation, rtol=0, atol=1e-14)
        pin.computeJointJacobians(model, data, q)
        J = np.asarray(pin.getJointJacobian(model, data, 1, pin.LOCAL)).reshape(6, -1)
        S = np.array([[*v, *w] for w, v in kind.columns(entries, axis, geometry)], dtype=float).T
        np.testing.assert_allclose(S, J, rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", MOVING)
def test_column_rates_give_pinocchio_s_bias_acceleration(name):
    """``c_J = sum_k rate_k v_k`` (the columns' rates in the child frame) equals Pinocchio's
    joint bias: a one-joint model's link acceleration at zero joint acceleration (zero for a
    type whose columns are constant)."""
    kind, rng = joint_type(name), np.random.default_rng(19)
    model = _pinocchio_model(name)
    data = model.createData()
    axis = tuple(sympy.Float(a, 17) for a in AXIS)
    geometry = _sympy_geometry(kind)
    for _ in range(STATES):
        q, v = _random_configuration(name, rng), _random_velocity(name, rng)
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        rates = kind.column_rates([sympy.Float(x, 17) for x in q], [sympy.Float(x, 17) for x in v], axis, geometry)
        bias = np.zeros(6)
        for (w, lin), rate in zip(rates or [], v):
            bias += np.array([*lin, *w], dtype=float) * rate
        np.testing.assert_allclose(bias, data.a[1].vector, rtol=0, atol=1e-14)


def test_revolute_and_prismatic_move_along_their_axis():
    axis = (sympy.Rational(3, 5), sympy.Integer(0), sympy.Rational(4, 5))
    q = sympy.Symbol("q")
    revolute, prismatic = joint_type("revolute"), joint_type("prismatic")
    assert revolute.rotation([q], axis) * sympy.Matrix(axis) == sympy.Matrix(axis)
    assert revolute.columns([q], axis) == [(axis, (0, 0, 0))] and prismatic.columns([q], axis) == [((0, 0, 0), axis)]
    assert prismatic.displacement(sympy.eye(3), [q], axis) == sympy.Matrix(axis) * q
    assert prismatic.rotation([q], axis) == sympy.eye(3) and revolute.displacement(sympy.eye(3), [q], axis) is None
    floating = joint_type("floating")
    symbols = sympy.symbols("x y z qx qy qz qw")
    assert floating.rotation(symbols) == quaternion_matrix(*symbols[3:])
    assert floating.displacement(sympy.eye(3), symbols) == sympy.Matrix(symbols[:3])
    assert joint_type("fixed").columns([], ()) == [] and joint_type("fixed").neutral() == []


def _module(robot, tmp_path: Path):
    path = tmp_path / f"{robot.name}_dynamics.py"
    path.write_text(render_code(dynderive.derive(robot)))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BALL_ARM = """\
name: ball_arm
planar: false
gravity: [0, 0, -9.81]
links:
- {name: base, mass: 2.1234567890123456, com: [0.1, 0.02, -0.03], inertia: [0.3, 0.2, 0.25, 0.01, 0.0, 0.02]}
- {name: arm, mass: 1.3, com: [0.2, 0.0, 0.01], inertia: [0.1, 0.12, 0.09, 0.0, 0.01, 0.0]}
- {name: hand, mass: 0.7, com: [0.05, 0.01, 0.0], inertia: [0.02, 0.03, 0.025, 0.0, 0.0, 0.001]}
- {name: slide, mass: 0.4, com: [0.0, 0.0, 0.1], inertia: [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]}
joints:
- {name: free, type: floating, parent: world, child: base, origin: {xyz: [0.1, -0.2, 0.3], rpy: [0.3, -0.2, 0.1]}}
- {name: ball, type: spherical, parent: base, child: arm, origin: {xyz: [0.2, 0.1, 0.0], rpy: [0.0, 0.4, 0.0]}}
- {name: wrist, type: revolute, parent: arm, child: hand, origin: {xyz: [0.4, 0.0, 0.0], rpy: [0, 0, 0]}, axis: [0, 0.6, 0.8]}
- {name: drawer, type: prismatic, parent: base, child: slide, origin: {xyz: [0, 0, 0.1], rpy: [0, 0, 0]}, axis: [1, 0, 0]}
"""


@pytest.mark.parametrize("source", ["floating_elbow.urdf", "ball_arm.yaml"])
def test_a_robots_maps_equal_its_generated_module(source, tmp_path):
    """``configuration_programs`` (the joints' maps, joint by joint) gives the generated NumPy
    module's ``neutral_configuration``, ``integrate``, ``difference`` and ``configuration_rate``
    (hand-written in its template today)."""
    path = TESTS / source
    if source == "ball_arm.yaml":
        path = tmp_path / source
        path.write_text(BALL_ARM)
    robot = dynderive.load_robot(path)
    module = _module(robot, tmp_path)
    table = dynderive.derive(robot).symbols
    programs = configuration_programs(robot, table)
    compiled = {name: Compiled(entry.program) for name, entry in programs.items()}
    arguments = {name: entry.arguments for name, entry in programs.items()}
    np.testing.assert_array_equal(compiled["neutral_configuration"].run({}), module.neutral_configuration())
    rng, starts = random.Random(5), robot.quaternion_starts
    for _ in range(4):
        q0, q1 = (np.array([rng.uniform(-1.5, 1.5) for _ in range(module.NQ)]) for _ in range(2))
        for q in (q0, q1):
            for s in starts:
                q[s:s + 4] /= np.linalg.norm(q[s:s + 4])
        v = np.array([rng.uniform(-1.0, 1.0) for _ in range(module.NV)])
        dt = rng.uniform(0.1, 1.0)

        def bind(name, **values):
            return {s: x for key, value in values.items() for s, x in zip(arguments[name][key], np.atleast_1d(value))}

        np.testing.assert_allclose(compiled["integrate"].run(bind("integrate", q=q0, v=v, dt=dt)),
                                   module.integrate(q0, v, dt), rtol=0, atol=1e-13)
        np.testing.assert_allclose(compiled["difference"].run(bind("difference", q_from=q0, q_to=q1)),
                                   module.difference(q0, q1), rtol=0, atol=1e-12)
        np.testing.assert_allclose(compiled["configuration_rate"].run(bind("configuration_rate", q=q0, v=v)),
                                   module.configuration_rate(q0, v), rtol=0, atol=1e-13)


#: Where a joint type's name is written as a string literal outside the joint specification
#: (model/joint_kinds.py) and the types' modules (mechanics/joint_types/), and why: the JSON's
#: ``floating`` key (DESIGN.md section 10) names the robot class, not a joint's type. The
#: readers ask the specification (``is_welded``, ``is_free``, ``WELDED``, ``PLANE_AS_JOINTS``).
NAMED_TYPES_LEFT = {
    "render/sheets/json.py": 1,
}


#: Type names that are robot-file keys as well (``planar: true``): counted only where a value
#: is compared with them (``jtype == "planar"``), not as the key. The URDF reader's three
#: (its planar joint split into three joints) were counted from the day "planar" became a type.
AMBIGUOUS = {"planar"}


def _named_types(source: str) -> int:
    """How many string constants of a module (docstrings aside) are a joint type's name."""
    import ast

    tree, names = ast.parse(source), set(JOINT_TYPES)
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    compared = {id(n) for node in ast.walk(tree)
                if isinstance(node, ast.Compare) and all(isinstance(op, (ast.Eq, ast.NotEq)) for op in node.ops)
                for part in (node.left, *node.comparators) for n in ast.walk(part)}
    return sum(1 for node in ast.walk(tree) if isinstance(node, ast.Constant) and node.value in names
               and id(node) not in docstrings and (node.value not in AMBIGUOUS or id(node) in compared))


def test_joint_type_names_are_written_only_where_the_types_are_defined():
    package = Path(dynderive.__file__).parent
    found = {}
    for path in sorted(package.rglob("*.py")):
        relative = path.relative_to(package).as_posix()
        if relative == "model/joint_kinds.py" or relative.startswith("mechanics/joint_types/"):
            continue
        count = _named_types(path.read_text(encoding="utf-8"))
        if count:
            found[relative] = count
    grown = {f: (n, NAMED_TYPES_LEFT.get(f, 0)) for f, n in found.items() if n > NAMED_TYPES_LEFT.get(f, 0)}
    assert not grown, f"joint type names written outside the joint specification (count, allowed): {grown}"
    fallen = {f: (found.get(f, 0), n) for f, n in NAMED_TYPES_LEFT.items() if found.get(f, 0) < n}
    assert not fallen, f"fewer type names than NAMED_TYPES_LEFT allows: lower it to the count found: {fallen}"
