"""Contact dynamics in the C target and the C extension (DESIGN.md section 11):
``<name>_constrained_forward_dynamics`` and ``<name>_impulse_dynamics`` through ctypes, and the
extension's ``constrained_forward_dynamics`` and ``impulse_dynamics``, equal to the NumPy module's
to 1e-12 relative at random full-precision states: a random floating tree with a surface and a
point contact (the robot file's CONTACTS) and a random fixed-base tree;
with Baumgarte gains and anchors, impacts with restitution; the C functions' return codes
(redundant contacts, bad counts, frames and kinds, kp without anchors), the extension's errors and
check --backend c's rows for them.
The C compiles as strict C99 and as C++ with no diagnostic.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import shutil
import subprocess
import sysconfig
from pathlib import Path

import numpy as np
import pytest

import dynderive
from dynderive.render.targets.c.c import render_c
from dynderive.render.targets.c_extension.compile import build_extension
from dynderive.render.targets.numpy.code import render_code
from test_contacts import _example_robot, _random_state, _tree

from conftest import ROBOTS, import_code

CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++")
HEADERS = (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()
if CC is None or not HEADERS:
    if os.environ.get("CI"):
        raise RuntimeError("CI must run the C contact tests, but no C compiler or no Python.h was found")
    pytest.skip("no C compiler or no Python.h", allow_module_level=True)

STRICT = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wshadow"]
RTOL = 1e-12
P = ctypes.POINTER(ctypes.c_double)
INTS = ctypes.POINTER(ctypes.c_int)


def _close(actual, expected, what: str) -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    error = float(np.max(np.abs(actual - expected), initial=0.0))
    assert np.all(np.isfinite(actual)) and error <= RTOL * scale, f"{what}: error {error:.3g} at scale {scale:.3g}"


class Contacts:
    """A robot's NumPy module, its C (strict C99 and C++, no diagnostic) as a shared library, and
    its extension."""

    def __init__(self, derivation, folder: Path, optimization: str):
        folder.mkdir(parents=True, exist_ok=True)
        self.name = name = derivation.robot.name
        self.module = import_code(render_code(derivation), folder, f"{name}_contacts_c_dynamics")
        self.header, source = render_c(derivation)
        (folder / f"{name}_dynamics.h").write_text(self.header)
        path = folder / f"{name}_dynamics.c"
        path.write_text(source)
        shared = folder / f"{name}_contacts.so"
        for command in ([CC, *STRICT, optimization, "-shared", "-fPIC", str(path), "-o", str(shared), "-lm"],
                        *([[CXX, "-x", "c++", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-O0", "-c", str(path),
                            "-o", str(path.with_suffix(".cpp.o"))]] if CXX else [])):
            run = subprocess.run(command, capture_output=True, text=True)
            assert run.returncode == 0 and not run.stderr, f"{' '.join(command)}:\n{run.stderr}"
        self.lib = ctypes.CDLL(str(shared))
        filename, data = build_extension(derivation, c_files=(self.header, source), optimization="-O0")
        (folder / filename).write_bytes(data)
        spec = importlib.util.spec_from_file_location(f"{name}_dynamics_c", folder / filename)
        self.ext = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(self.ext)
        self.nv = len(derivation.symbols.qd)

    def numbers(self, held):
        frames = np.array([self.module.FRAMES.index(f) for f, _ in held], dtype=np.intc)
        kinds = np.array([kind == "surface" for _, kind in held], dtype=np.intc)
        return frames, kinds, sum(6 if k else 3 for k in kinds)

    def forward(self, q, qd, u, frames, kinds, baumgarte=None, anchors=None, rows=None):
        """(status, qdd, forces) of the C function (kinds None: NULL); outputs pre-filled with NaN."""
        rows = len(frames) * 6 if rows is None else rows
        qdd, forces = np.full(self.nv, np.nan), np.full(max(rows, 1), np.nan)
        status = getattr(self.lib, f"{self.name}_constrained_forward_dynamics")(
            _pointer(q), _pointer(qd), _pointer(u), ctypes.c_int(len(frames)), _ints(frames), _ints(kinds),
            _pointer(baumgarte), _pointer(anchors), None, qdd.ctypes.data_as(P), forces.ctypes.data_as(P))
        return status, qdd, forces[:rows]

    def impulse(self, q, qd, frames, kinds, restitution, rows):
        qd_plus, impulses = np.full(self.nv, np.nan), np.full(max(rows, 1), np.nan)
        status = getattr(self.lib, f"{self.name}_impulse_dynamics")(
            _pointer(q), _pointer(qd), ctypes.c_int(len(frames)), _ints(frames), _ints(kinds),
            ctypes.c_double(restitution), None, qd_plus.ctypes.data_as(P), impulses.ctypes.data_as(P))
        return status, qd_plus, impulses[:rows]


def _pointer(values):
    if values is None:
        return None
    array = np.ascontiguousarray(values, dtype=float)
    _KEEP.append(array)
    return array.ctypes.data_as(P)


def _ints(values):
    if values is None:
        return None
    array = np.ascontiguousarray(values, dtype=np.intc)
    _KEEP.append(array)
    return array.ctypes.data_as(INTS)


_KEEP: list[np.ndarray] = []   # the arrays behind the pointers of the current call
_BUILT: dict[str, Contacts] = {}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """``built(name)``: a random tree ("floating_10", "fixed_6") or solo12 (--floating-base), once."""

    def get(name: str) -> Contacts:
        if name not in _BUILT:
            folder = tmp_path_factory.mktemp(name)
            if name == "solo12":
                robot = dynderive.load_robot(_example_robot("solo_description/robots/solo12.urdf"), floating_base=True)
            else:
                path = folder / f"{name}.yaml"
                path.write_text(_tree(int(name.split("_")[1]), name.startswith("floating")))
                robot = dynderive.load_robot(path)
            # the fixed tree's C at -O1 (its flow analysis adds warnings); the floating tree's
            # megabyte of C at -O0: eight times faster to compile, the same contact solve
            _BUILT[name] = Contacts(dynderive.derive(robot), folder, "-O0" if name == "floating_10" else "-O1")
        return _BUILT[name]

    return get


def _anchors(module, q, held, rng):
    """Held poses and positions near the frames' current ones (a point's 3, a surface's 4 x 4)."""
    anchors = []
    for frame, kind in held:
        pose = module.frame_transform(q, frame)
        if kind == "point":
            anchors.append(pose[:3, 3] + rng.normal(scale=0.01, size=3))
        else:
            angle = rng.normal(scale=0.02)
            turn = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
            moved = pose.copy()
            moved[:3, :3] = pose[:3, :3] @ turn
            moved[:3, 3] += rng.normal(scale=0.01, size=3)
            anchors.append(moved)
    return anchors


#: A floating and a fixed tree (solo12 on its four feet: the NumPy module against Pinocchio in
#: ``test_contacts.py``, its C compiled strictly in ``test_c_target.py``).
CASES = [("floating_10", [("sole", "surface"), ("toe", "point")]),
         ("fixed_6", [("toe", "point")])]


@pytest.mark.parametrize("name, held", CASES, ids=[c[0] for c in CASES])
def test_c_and_extension_equal_the_numpy_module(name, held, built):
    """At random states: the C functions (kinds given, and NULL for the declared kinds where the
    contacts are the robot file's) and the extension's, one state and a batch of 2 x 2, equal the
    NumPy module's to 1e-12: without Baumgarte, with (0, kd), with (kp, kd) and anchors; impacts
    with restitution 0 and 0.6."""
    c = built(name)
    module, ext = c.module, c.ext
    frames, kinds, rows = c.numbers(held)
    declared = [(f, module.CONTACT_KINDS[f]) for f in module.CONTACTS] == held
    rng = np.random.default_rng(7)
    for _ in range(3):
        q, qd, u = _random_state(module, rng)
        anchors = _anchors(module, q, held, rng)
        flat = np.concatenate([np.ravel(a) for a in anchors])
        for baumgarte, given in (((0.0, 0.0), None), ((0.0, 4.0), None), ((25.0, 10.0), anchors)):
            expected = module.constrained_forward_dynamics(q, qd, u, held, baumgarte, anchors=given)
            for kind_array in (kinds, None) if declared else (kinds,):
                status, qdd, forces = c.forward(q, qd, u, frames, kind_array, baumgarte,
                                                None if given is None else flat, rows)
                assert status == 0
                _close(qdd, expected[0], f"C qdd {baumgarte}")
                _close(forces, expected[1], f"C forces {baumgarte}")
            got = ext.constrained_forward_dynamics(q, qd, u, held, baumgarte, anchors=given)
            _close(got[0], expected[0], f"extension qdd {baumgarte}")
            _close(got[1], expected[1], f"extension forces {baumgarte}")
        for restitution in (0.0, 0.6):
            expected = module.impulse_dynamics(q, qd, held, restitution)
            status, qd_plus, impulses = c.impulse(q, qd, frames, kinds, restitution, rows)
            assert status == 0
            _close(qd_plus, expected[0], "C qd_plus")
            _close(impulses, expected[1], "C impulses")
            got = ext.impulse_dynamics(q, qd, held, restitution)
            _close(got[0], expected[0], "extension qd_plus")
            _close(got[1], expected[1], "extension impulses")
    # a batch, and contacts given by index
    q, qd, u = _random_state(module, rng, (2, 2))
    by_index = [(module.FRAMES.index(f), kind) for f, kind in held]
    for function, args in (("constrained_forward_dynamics", (q, qd, u[0], by_index, (0.0, 2.0))),
                           ("impulse_dynamics", (q, qd, by_index, 0.3))):
        expected, got = getattr(module, function)(*args), getattr(ext, function)(*args)
        for e, g, what in zip(expected, got, ("velocities", "forces")):
            _close(g, e, f"extension batch {function} {what}")
    # no contact: forward dynamics
    status, qdd, _ = c.forward(q[0, 0], qd[0, 0], u[0, 0], np.zeros(0, np.intc), None, None, None, 0)
    assert status == 0
    _close(qdd, module.forward_dynamics(q[0, 0], qd[0, 0], u[0, 0]), "C without contacts")
    assert ext.constrained_forward_dynamics(q, qd, u, ())[1].shape == (2, 2, 0)


def test_return_codes_and_extension_errors(built):
    """The C functions return 2 for redundant contacts (the fixed tree's sole and toe: 9 rows on
    5 joints), 3 for a bad count, frame number (negative, NFRAMES, held twice) or kind, 4 for kp
    without anchors, and leave their outputs untouched; the extension raises the NumPy module's
    ValueErrors and refuses wrenches."""
    c = built("fixed_6")
    module, ext = c.module, c.ext
    q, qd, u = _random_state(module, np.random.default_rng(2))
    frames, kinds, rows = c.numbers([("sole", "surface"), ("toe", "point")])
    status, qdd, forces = c.forward(q, qd, u, frames, kinds)
    assert status == 2 and np.all(np.isnan(qdd)) and np.all(np.isnan(forces))
    assert c.impulse(q, qd, frames, kinds, 0.0, rows)[0] == 2
    assert c.forward(q, qd, u, frames, None)[0] == 2   # NULL: the declared kinds (surface, point)
    nframes = len(module.FRAMES)
    for bad_frames, bad_kinds in (([-1], [0]), ([nframes], [0]), ([1, 1], [0, 0]), ([1], [2]), ([1], [-1])):
        status, qdd, _ = c.forward(q, qd, u, np.array(bad_frames), np.array(bad_kinds))
        assert status == 3 and np.all(np.isnan(qdd)), (bad_frames, bad_kinds)
        assert c.impulse(q, qd, np.array(bad_frames), np.array(bad_kinds), 0.0, 6)[0] == 3
    assert c.forward(q, qd, u, np.zeros(nframes + 1, np.intc), None)[0] == 3   # more contacts than frames
    assert c.forward(q, qd, u, np.array([1]), None, (1.0, 0.0), None)[0] == 4
    assert c.forward(q, qd, u, np.array([1]), None, (0.0, 1.0), None, 3)[0] == 0   # kd alone needs no anchors
    macro = c.name.upper()
    for line in (f"#define {macro}_NCONTACTS 2", f"#define {macro}_CONTACT_FRAMES {{ 0, 1 }}",
                 f"#define {macro}_CONTACT_KINDS {{ 1, 0 }}", f"#define {macro}_CONTACT_REDUNDANT 2"):
        assert line in c.header
    with pytest.raises(ValueError, match="redundant"):
        ext.constrained_forward_dynamics(q, qd, u)
    with pytest.raises(ValueError, match="redundant"):
        ext.impulse_dynamics(q, qd)
    with pytest.raises(ValueError, match="unknown frame 'heel'"):
        ext.constrained_forward_dynamics(q, qd, u, ["heel"])
    with pytest.raises(ValueError, match="out of range"):
        ext.constrained_forward_dynamics(q, qd, u, [7])
    with pytest.raises(ValueError, match="held twice"):
        ext.constrained_forward_dynamics(q, qd, u, ["toe", 1])
    with pytest.raises(ValueError, match="kp needs anchors"):
        ext.constrained_forward_dynamics(q, qd, u, ["toe"], baumgarte=(1.0, 0.0))
    with pytest.raises(ValueError, match="takes none"):
        ext.constrained_forward_dynamics(q, qd, u, ["toe"], wrenches={"toe": np.ones(6)})
    with pytest.raises(TypeError, match="unexpected keyword argument 'mass'"):
        ext.impulse_dynamics(q, qd, ["toe"], mass=1.0)


def test_check_backend_c_compares_the_contact_functions(built):
    """``check --backend c``'s comparison (``verify.compiled.compiled_rows``) has a passing row for
    each contact function of the floating tree (its CONTACTS: a surface and a point)."""
    from dynderive.verify.compiled import compiled_rows

    c = built("floating_10")
    q, qd, u = _random_state(c.module, np.random.default_rng(4), (5,))
    states = {"q": q, "qd": qd, "qdd": np.zeros_like(qd), "u": u, "q1": q}
    rows = {row.name: row for row in compiled_rows(c.module, c.ext, {}, states, floating=True)}
    for name in ("constrained_forward_dynamics", "impulse_dynamics"):
        row = rows[f"compiled {name} == NumPy module"]
        assert row.status == "pass" and row.residual <= 1e-12, row


LEGS_WITHOUT_EFFORTS = """name: legs
planar: false
parameters: {m: 1.2345678901234, g: 9.80665}
gravity: [0.0123456789, -0.0234567891, -g]
links:
  - {name: torso, mass: 3.1234567891, com: [0.0123, 0.0234, -0.0345], inertia: [0.113, 0.127, 0.131, 0.0103, 0.0021, 0.0034]}
  - {name: l1, mass: m, com: [0.1031, 0.0117, 0.0009], inertia: [0.0103, 0.0112, 0.0125, 0.0011, 0.00013, 0.00021]}
  - {name: l2, mass: 0.8765432109, com: [0.0987, 0.0012, 0.0213], inertia: [0.0101, 0.0133, 0.0104, 0.00012, 0.00031, 0.00005]}
joints:
  - {name: base, type: floating, parent: world, child: torso}
  - {name: q1, type: revolute, parent: torso, child: l1, axis: [0.2123, 0.9712, 0.1091]}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [0.2012, 0.0034, -0.0051]}, axis: [0.0213, 0.9543, 0.2981]}
frames:
  - {name: foot, link: l2, origin: {xyz: [0.2031, 0.0102, -0.0043]}}
contacts:
  - {frame: foot, kind: surface}
"""


def test_extension_contacts_of_a_robot_without_efforts(tmp_path, monkeypatch):
    """A robot that declares no efforts (u of shape (..., 0)): the extension's contact functions
    flatten the empty efforts by the batch's count (a reshape to (-1, 0) cannot be inferred) and
    agree with the NumPy module, by check --backend c's rows (the extension built at -O0, as the
    others here: the values are compared, not the speed)."""
    import functools

    from typer.testing import CliRunner

    from dynderive.commands.cli import app
    from dynderive.render.targets.c_extension import compile as extension

    monkeypatch.setattr(extension, "build_extension", functools.partial(extension.build_extension, optimization="-O0"))

    path = tmp_path / "legs.yaml"
    path.write_text(LEGS_WITHOUT_EFFORTS)
    result = CliRunner().invoke(app, ["check", str(path), "--backend", "c", "-q"])
    rows = [line for line in result.output.splitlines() if "dynamics == NumPy module" in line]
    assert any(line.startswith("compiled constrained_forward_dynamics") for line in rows), result.output
    assert any(line.startswith("compiled impulse_dynamics") for line in rows), result.output
    assert not [line for line in rows if " FAIL " in line], rows
    assert result.exit_code == 0, result.output


#: An arm of three revolute joints on generic axes, full-precision numbers, hung from ``{parent}``
#: of a bundled loop robot, with a point frame at its end and a surface frame on its middle link.
ARM = """  - {{name: arm1, mass: 0.3123456789012345, com: [0.0712345678901234, 0.0112345678901234, -0.0098765432109876], inertia: [0.0011234567890123, 0.0021234567890123, 0.0019876543210987, 0.0001234567890123, -0.0000987654321098, 0.0000543210987654]}}
  - {{name: arm2, mass: 0.2712345678901234, com: [0.0612345678901234, -0.0087654321098765, 0.0123456789012345], inertia: [0.0009876543210987, 0.0017654321098765, 0.0015432109876543, -0.0000765432109876, 0.0000432109876543, 0.0001098765432109]}}
  - {{name: arm3, mass: 0.1912345678901234, com: [0.0412345678901234, 0.0067654321098765, 0.0054321098765432], inertia: [0.0004321098765432, 0.0007654321098765, 0.0006543210987654, 0.0000321098765432, -0.0000210987654321, 0.0000123456789012]}}
joints:
  - {{name: s1, type: revolute, parent: {parent}, child: arm1, origin: {{xyz: [0.0512345678901234, 0.0312345678901234, -0.0212345678901234], rpy: [0.3123456789012345, -0.2123456789012345, 0.1123456789012345]}}, axis: [0.2672612419124244, 0.5345224838248488, 0.8017837257372732], effort: tau_s1}}
  - {{name: s2, type: revolute, parent: arm1, child: arm2, origin: {{xyz: [0.1512345678901234, -0.0112345678901234, 0.0087654321098765], rpy: [-0.1712345678901234, 0.2412345678901234, 0.0512345678901234]}}, axis: [0.8017837257372732, -0.2672612419124244, 0.5345224838248488]}}
  - {{name: s3, type: revolute, parent: arm2, child: arm3, origin: {{xyz: [0.1312345678901234, 0.0212345678901234, -0.0112345678901234], rpy: [0.0912345678901234, -0.0612345678901234, 0.2212345678901234]}}, axis: [-0.5345224838248488, 0.8017837257372732, 0.2672612419124244]}}
"""
FRAMES = """frames:
  - {name: tip, link: arm3, origin: {xyz: [0.0912345678901234, -0.0112345678901234, 0.0087654321098765]}}
  - {name: pad, link: arm2, origin: {xyz: [0.0712345678901234, 0.0112345678901234, -0.0212345678901234], rpy: [0.2123456789012345, -0.1123456789012345, 0.3123456789012345]}}
"""


def _loop_with_arm(robot: str, parent: str) -> str:
    """A bundled loop robot with ``ARM`` on its link ``parent`` (its joints independent) and ``FRAMES``."""
    text = (ROBOTS / f"{robot}.yaml").read_text()
    links, rest = text.split("joints:\n", 1)
    rest = rest.replace("independent: [q1]", "independent: [q1, s1, s2, s3]")
    return links + ARM.format(parent=parent) + rest.rstrip("\n") + "\n" + FRAMES


def _tied_arm() -> str:
    from test_targets_agree import TIED_ARM

    return TIED_ARM


#: Loop robots holding contacts: the loops' rank known and equal to their rows (a spherical loop
#: joint), known and below them (Bennett's over-constrained loop: 5 rows of rank 2), found at each
#: state (a floating base tied by a spherical loop joint; quaternions in q).
LOOP_CASES = {
    "full_rank": (lambda: _loop_with_arm("spatial_four_bar", "crank"), [("tip", "point")]),
    "over_constrained": (lambda: _loop_with_arm("bennett", "link2"), [("tip", "point")]),
    "floating": (_tied_arm, [("wrist", "point")]),
}


def _on_loops(module, rng):
    """A state on the loops (assembled near a random configuration, qd in the motions they allow)."""
    nv = len(module.VELOCITIES) if hasattr(module, "VELOCITIES") else len(module.COORDINATES)
    if hasattr(module, "ASSEMBLED_CONFIGURATION"):   # near it (Newton from farther may not converge)
        q = module.assemble(np.array(module.ASSEMBLED_CONFIGURATION) + rng.uniform(-0.02, 0.02, nv))
    else:   # quaternions in q: Gauss-Newton on the tangent space
        q = module.assemble(module.integrate(module.neutral_configuration(), rng.uniform(-0.2, 0.2, nv)))
    _, sigma, vt = np.linalg.svd(module.loop_jacobian(q))
    null = vt[int(np.sum(sigma > 1e-9 * sigma[0])):]
    return q, null.T @ (null @ rng.normal(size=nv)), rng.normal(size=len(module.EFFORTS))


@pytest.mark.parametrize("case", LOOP_CASES)
def test_c_and_extension_hold_contacts_on_loops(case, tmp_path):
    """Contacts on robots with closed loops (the loops' rows and the contacts' in one solve): the C
    functions and the extension's equal the NumPy module's to 1e-12 at states on the loops, with
    the loops' Baumgarte gains (the struct's alpha and beta, the extension's keywords), the
    contacts' (kp with anchors, kd), impacts with restitution, and no contact (forward dynamics
    with the loops closed)."""
    made, held = LOOP_CASES[case]
    path = tmp_path / "robot.yaml"
    path.write_text(made())
    c = Contacts(dynderive.derive(dynderive.load_robot(path)), tmp_path, "-O1")
    module, ext = c.module, c.ext
    frames, kinds, rows = c.numbers(held)
    rng = np.random.default_rng(17)
    for _ in range(3):
        q, qd, u = _on_loops(module, rng)
        anchors = _anchors(module, q, held, rng)
        flat = np.concatenate([np.ravel(a) for a in anchors])
        for alpha, beta in ((0.0, 0.0), (1.7, 2.3)):
            for baumgarte, given in (((0.0, 0.0), None), ((25.0, 10.0), anchors)):
                expected = module.constrained_forward_dynamics(q, qd, u, held, baumgarte, anchors=given, alpha=alpha,
                                                               beta=beta)
                got = ext.constrained_forward_dynamics(q, qd, u, held, baumgarte, anchors=given, alpha=alpha,
                                                       beta=beta)
                _close(got[0], expected[0], f"extension qdd {alpha, beta, baumgarte}")
                _close(got[1], expected[1], f"extension forces {alpha, beta, baumgarte}")
                if (alpha, beta) == (0.0, 0.0):   # the C function with the default parameters (p NULL)
                    status, qdd, forces = c.forward(q, qd, u, frames, kinds, baumgarte, None if given is None else flat,
                                                    rows)
                    assert status == 0
                    _close(qdd, expected[0], f"C qdd {baumgarte}")
                    _close(forces, expected[1], f"C forces {baumgarte}")
        for restitution in (0.0, 0.6):
            expected = module.impulse_dynamics(q, qd, held, restitution)
            status, qd_plus, impulses = c.impulse(q, qd, frames, kinds, restitution, rows)
            assert status == 0
            _close(qd_plus, expected[0], "C qd_plus")
            _close(impulses, expected[1], "C impulses")
            got = ext.impulse_dynamics(q, qd, held, restitution)
            _close(got[0], expected[0], "extension qd_plus")
            _close(got[1], expected[1], "extension impulses")
        status, qdd, _ = c.forward(q, qd, u, np.zeros(0, np.intc), None, None, None, 0)
        assert status == 0
        _close(qdd, module.forward_dynamics(q, qd, u), "C without contacts: the loops' forward dynamics")
