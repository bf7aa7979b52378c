"""What runs on ``pip install dynderive`` without its extras: ``simulate --csv`` without
matplotlib (the ``plot`` extra), ``solve --jax`` without JAX (the ``jax`` extra; a note).

Each run is a subprocess in which the extra is made unimportable (``sys.modules[name] = None``,
so that ``import name`` raises ImportError as if it were not installed), then the command
line's entry point runs.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

pytest.importorskip("scipy")
runner = CliRunner()

#: ``dynderive ARGS`` with the module named by the first argument unimportable.
WITHOUT = """\
import sys
sys.modules[sys.argv[1]] = None
from dynderive.__main__ import run
sys.argv = ["dynderive", *sys.argv[2:]]
run()
"""


def without(module: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", WITHOUT, module, *args], capture_output=True, text=True,
                          timeout=300)


def test_simulate_csv_runs_without_matplotlib(tmp_path):
    csv = tmp_path / "s.csv"
    result = without("matplotlib", "simulate", "rp_arm", "-q", "--duration", "0.5", "--frames", "11",
                     "--csv", str(csv))
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("simulated 0.5 s of rp_arm in generalized coordinates")
    lines = csv.read_text().splitlines()
    assert lines[0].startswith("t,q1,q2,") and len(lines) == 12


@pytest.mark.parametrize("option, name", [("--plot", "s.png"), ("--animate", "s.gif")])
def test_drawing_without_matplotlib_is_refused_at_the_option(tmp_path, option, name):
    """Refused before any work, exit 2, one line saying what to install; the CSV asked for
    beside it is not written either."""
    result = without("matplotlib", "simulate", "rp_arm", "-q", "--duration", "0.5", option, str(tmp_path / name),
                     "--csv", str(tmp_path / "s.csv"))
    assert result.returncode == 2, result.stderr
    assert result.stderr == (f'{option}:1:1: needs matplotlib, which is not installed: pip install "dynderive[plot]" '
                             "(or leave out the option: --csv needs no matplotlib)\n")
    assert result.stdout == "" and list(tmp_path.iterdir()) == []


def test_solve_jax_without_jax_writes_the_module_and_says_so(tmp_path):
    result = without("jax", "solve", "rp_arm", "--jax", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    note = ('note: --jax: JAX is not installed here; the JAX module is written, and imports once JAX is installed: '
            'pip install "dynderive[jax]"')
    assert result.stderr.splitlines().count(note) == 1, result.stderr
    module = Path(tmp_path / "rp_arm_dynamics_jax.py")
    assert "import jax" in module.read_text()


def test_solve_jax_with_jax_installed_has_no_note(tmp_path):
    if importlib.util.find_spec("jax") is None:
        pytest.skip("JAX is not installed")
    result = runner.invoke(app, ["solve", "rp_arm", "--jax", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "JAX is not installed" not in result.stderr
    assert (tmp_path / "rp_arm_dynamics_jax.py").exists()
