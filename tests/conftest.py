"""Shared test helpers: load robots, derive them once, import generated modules."""

from __future__ import annotations

import importlib.util
import itertools
import os
import sys
import zlib
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import dynderive

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"
REFERENCE = ROOT.parent / "shared" / "reference" / "hw6_lagrangian_dynamics.md"
BUNDLED = sorted(p.stem for p in ROBOTS.glob("*.yaml"))

_counter = itertools.count()


@pytest.fixture(autouse=True)
def _no_progress_lines(request, monkeypatch):
    """A command shows its stages on stderr once it has run a second, so on a loaded machine
    an error message would come after progress lines: tests of messages see only what they
    test, whatever the machine's speed (the tests marked ``progress`` test the lines)."""
    if request.node.get_closest_marker("progress") is None:
        from dynderive.commands import progress

        monkeypatch.setattr(progress, "SHOW_AFTER", float("inf"))
        monkeypatch.setattr(progress, "WATCH_AFTER", float("inf"))


#: The test files that take longest, slowest first (``--durations=0`` on one worker). With
#: ``--dist loadfile`` each file runs whole on one worker, and the workers take the files in the
#: order collected (``--no-loadscope-reorder``): the longest start first and the short ones fill
#: in around them, so no worker is left running a long file after the others have finished.
SLOWEST_FIRST = (
    "test_jax_target.py", "test_targets_agree.py", "test_matlab_script.py", "test_fuzz.py", "test_contacts.py",
    "test_centroidal_c.py", "test_centroidal.py", "test_contacts_c.py", "test_matlab_numeric.py",
    "test_c_extension.py", "test_scale.py", "test_build.py", "test_generated_programs.py", "test_mjcf_mujoco.py",
    # long files late in the alphabet (TeX, torch.compile, chromium): started early, they cannot
    # be the last file one worker runs while the other has finished
    "test_html.py", "test_sheets_compile.py", "test_torch_target.py",
)


def pytest_collection_modifyitems(config, items):
    """The slowest files' tests first (``SLOWEST_FIRST``), the others in their order."""
    rank = {name: index for index, name in enumerate(SLOWEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def _xla_test_flags() -> str:
    """XLA compiles the JAX tests' programs with LLVM's cheap passes: the UR5's traced batch of
    ``linearize`` compiles in 10 s instead of 35 s and runs in milliseconds either way. Where
    jaxlib has them (0.6 on), CPU fusions are emitted by the older elemental emitters, which
    compile the held batches' loops in half the time (the free box's 31 traced functions: 28 s
    of CPU instead of 60 s). The tests compare values, never speed (benchmarks/ measure that,
    with XLA's defaults). XLA stops at a flag it does not know, hence the version check."""
    import importlib.metadata

    flags = "--xla_backend_optimization_level=0 --xla_llvm_disable_expensive_passes=true"
    try:
        version = tuple(int(part) for part in importlib.metadata.version("jaxlib").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return flags
    return flags + " --xla_cpu_use_fusion_emitters=false" if version >= (0, 6) else flags


# Set before any test imports jax, and inherited by the commands the tests run; flags already
# given are kept.
os.environ["XLA_FLAGS"] = " ".join(filter(None, (_xla_test_flags(), os.environ.get("XLA_FLAGS", ""))))


def on_loops(module, qs, qds, spread: float = 0.3):
    """For a module with closed loops: the states assembled near the first configuration
    ``assemble`` finds from q = 0 (independent coordinates moved by ``spread * qs``) and the
    velocities projected onto the motions the loops allow; other modules: unchanged."""
    import numpy as np

    from dynderive.verify.checks import allowed_velocity

    if not hasattr(module, "LOOPS"):
        return qs, qds
    base = np.array(module.ASSEMBLED_CONFIGURATION)
    independent = [module.COORDINATES.index(c) for c in module.INDEPENDENT_COORDINATES]
    states, rates = [], []
    for q, qd in zip(qs, qds):
        guess = base.copy()
        guess[independent] += spread * q[independent]
        assembled = module.assemble(guess)
        states.append(assembled)
        rates.append(allowed_velocity(module, assembled, qd, {}))
    return np.array(states), np.array(rates)


@cache
def stable_seed(robot: str) -> int:
    """A random seed named by a robot's file name, not its path: the states a test draws must not
    depend on where the repository is checked out."""
    return zlib.crc32(Path(str(robot)).name.encode())


def acceleration_scale(module, q, qd, u) -> float:
    """The size of the unconstrained accelerations ``M^-1 (Y - C qd - N)`` at a state: a loop's
    constrained accelerations are those minus the constraint forces' share, and where the two
    nearly cancel the result is far smaller than the rounding of the terms, so generated code is
    compared with the NumPy module relative to this (or the result's own size, if larger)."""
    mass = np.asarray(module.mass_matrix(q), dtype=float)
    rhs = (np.asarray(module.generalized_forces(q, u), dtype=float)
           - np.einsum("...ij,...j->...i", module.coriolis_matrix(q, qd), qd) - module.gravity_vector(q))
    rhs = np.broadcast_to(rhs, mass.shape[:-1])
    return float(np.max(np.abs(np.linalg.solve(mass, rhs[..., None])), initial=0.0))


@cache
def derivation_of(robot: str):
    """Derivation of a bundled robot (cached across tests)."""
    return dynderive.derive(dynderive.load_robot(robot))


def import_code(source: str, directory: Path, name: str | None = None):
    """Import generated module source from ``directory`` under a fresh module name."""
    name = name or f"generated_{next(_counter)}"
    path = directory / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


@cache
def text_derivation(name: str, yaml_text: str, directory: str):
    """(Derivation, generated module) of a robot file's text, derived once per session."""
    folder = Path(directory) / name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.yaml"
    path.write_text(yaml_text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), folder, f"{name}_dynamics")
    return derivation, module


@cache
def module_of(robot: str, directory: str):
    return import_code(dynderive.render_code(derivation_of(robot)), Path(directory), f"{robot}_dynamics")


@pytest.fixture(scope="session")
def code_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("generated")


@pytest.fixture(scope="session")
def generated(code_dir):
    """``generated("rp_arm")`` -> the imported generated module of a bundled robot."""
    return lambda robot: module_of(robot, str(code_dir))


@cache
def random_tree_derivation(seed: int, n_joints: int, directory: str):
    """(Derivation, generated module) of ``random_planar_tree(Random(seed), n_joints)``.

    Cached, so test files that check the same random trees derive each one once.
    """
    import random

    from random_robots import random_planar_tree

    tree = random_planar_tree(random.Random(seed), n_joints)
    folder = Path(directory) / f"random_tree_{seed}_{n_joints}"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "random_tree.yaml"
    path.write_text(tree.yaml_text)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), folder, f"random_tree_{seed}_{n_joints}_dynamics")
    return derivation, module


_SHARED: list[Path] = []


@pytest.fixture(scope="session", autouse=True)
def _shared_folder(tmp_path_factory):
    """The folder this run's workers share (``shared_text``): the parent of a worker's base
    temporary folder under xdist (one per run, removed with it), else the base folder."""
    base = tmp_path_factory.getbasetemp()
    folder = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "shared"
    folder.mkdir(exist_ok=True)
    _SHARED[:] = [folder]


def shared_text(key: str, make) -> str:
    """``make()``, a text made once per test run: the first worker to ask makes it under a lock
    while the others wait, then all read the file. Several test files check the same large
    robot's generated module (talos_reduced: a minute to derive) against different references."""
    if not _SHARED:
        return make()
    try:
        import fcntl
    except ImportError:   # no POSIX locks: each worker makes its own
        return make()
    path = _SHARED[0] / f"{key}.txt"
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not path.exists():
                partial = path.with_suffix(f".{os.getpid()}.part")
                partial.write_text(make())
                partial.replace(path)
            return path.read_text()
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


@cache
def floating_module_source(relative: str) -> str:
    """The NumPy module of an example-robot-data URDF with ``--floating-base``, derived once per
    test run (``shared_text``)."""
    path = example_robot(relative)
    return shared_text(f"floating-{path.stem}-{zlib.crc32(relative.encode())}", lambda: dynderive.render_code(
        dynderive.derive(dynderive.load_robot(path, floating_base=True))))


def example_robot(relative: str) -> Path:
    """The path of a file of example-robot-data ending in ``relative`` (a test skips without it)."""
    import importlib.metadata

    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    paths = [Path(str(dist.locate_file(f))) for f in dist.files or () if str(f).endswith(relative)]
    if not paths:
        pytest.skip(f"{relative} is not in example-robot-data")
    return paths[0]


def compiled_model(path):
    """MuJoCo's model of an MJCF file through MjSpec, its compiler warnings silenced (the reader
    notes them): ``MjModel.from_xml_path`` would write MUJOCO_LOG.TXT into the working directory."""
    import warnings

    import mujoco

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return mujoco.MjSpec.from_file(str(path)).compile()
