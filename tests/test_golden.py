"""Golden sheets: the committed examples/ are the expected outputs.

For a few small bundled robots the LaTeX sheet (``dynderive.render_latex``) and the generated
module (``dynderive.render_code``) are regenerated in memory and compared byte for byte with
``examples/<name>.tex`` and ``examples/<name>_dynamics.py``, which ``dynderive build`` wrote
(it writes exactly these strings, UTF-8 encoded). A change of an engine or a template that
alters an output fails here, with the first differing lines, until the examples are
regenerated with the command below and the change to them is reviewed and committed.
(``tests/test_build.py::test_committed_examples_are_current`` checks every bundled robot,
PDFs included, with ``build --check``; this test is the quick one, without TeX.)
"""

from __future__ import annotations

import difflib
from functools import cache
from pathlib import Path

import pytest

import dynderive

ROOT = Path(__file__).resolve().parents[1]
UPDATE = "dynderive build robots --out examples --latex --code --pdf --c"
#: Small robots, about 60 s together: revolute + prismatic, two and three revolute joints,
#: a cart-pole with damping and friction (drives).
ROBOTS = ["rp_arm", "double_pendulum", "planar_3r", "cart_pole_damped"]


@cache
def _derivation(name: str):
    return dynderive.derive(dynderive.load_robot(ROOT / "robots" / f"{name}.yaml"))


def _compare(rendered: str, golden: Path) -> None:
    assert golden.is_file(), f"{golden.relative_to(ROOT)} is missing; write it with: {UPDATE}"
    expected = golden.read_bytes()
    if rendered.encode() == expected:
        return
    diff = difflib.unified_diff(expected.decode(errors="replace").splitlines(), rendered.splitlines(),
                                f"{golden.relative_to(ROOT)} (committed)", "regenerated", lineterm="", n=1)
    shown = "\n".join(line[:200] for line in list(diff)[:40])
    pytest.fail(f"{golden.relative_to(ROOT)} differs from the regenerated output:\n{shown}\n"
                f"If the change is intended, regenerate the examples with: {UPDATE} "
                "(from the repository root) and commit them.", pytrace=False)


@pytest.mark.parametrize("name", ROBOTS)
def test_sheet_matches_the_committed_example(name):
    _compare(dynderive.render_latex(_derivation(name)), ROOT / "examples" / f"{name}.tex")


@pytest.mark.parametrize("name", ROBOTS)
def test_generated_module_matches_the_committed_example(name):
    _compare(dynderive.render_code(_derivation(name)), ROOT / "examples" / f"{name}_dynamics.py")


@pytest.mark.parametrize("name", ROBOTS)
def test_c_target_matches_the_committed_example(name):
    from dynderive.render.targets.c.c import render_c

    header, source = render_c(_derivation(name))
    _compare(header, ROOT / "examples" / f"{name}_dynamics.h")
    _compare(source, ROOT / "examples" / f"{name}_dynamics.c")


def test_a_module_does_not_depend_on_the_other_outputs_of_its_run(tmp_path):
    """``solve ur5 --c --code`` alone writes the bytes ``build`` wrote beside the sheet: the
    3-D robots' M, C, N program grows with what a run asks for first (the sheet's Jacobians),
    and the module must not show it (same input, same bytes)."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "dynderive", "solve", "ur5", "--c", "--code", "--out",
                          str(tmp_path), "-q"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    for name in ("ur5_dynamics.c", "ur5_dynamics.py"):
        assert (tmp_path / name).read_bytes() == (ROOT / "examples" / name).read_bytes(), name
