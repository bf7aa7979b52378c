"""The command line, through Typer's runner and as a real process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dynderive.commands.cli import app

runner = CliRunner()


def test_solve_writes_requested_files(tmp_path):
    result = runner.invoke(app, ["solve", "rp_arm", "--latex", "--code", "--json", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["rp_arm.json", "rp_arm.tex", "rp_arm_dynamics.py"]
    dump = json.loads((tmp_path / "out" / "rp_arm.json").read_text())
    assert dump["robot"] == "rp_arm"
    assert {"T_g", "V_g", "L_g", "Y_g", "EOM_g1", "M_g", "C_g", "N_g", "EOM_g2"} <= set(dump["quantities"])


def test_solve_without_flags_prints_equations(tmp_path):
    result = runner.invoke(app, ["solve", "rp_arm"])
    assert result.exit_code == 0
    assert "M(q) =" in result.stdout and "N(q) =" in result.stdout
    assert "[pass]" in result.stdout
    assert "cos(q₁)" in result.stdout


def test_bad_input_is_positioned_exit_2_no_output(tmp_path):
    robot = tmp_path / "bad.yaml"
    text = (Path(__file__).parents[1] / "robots" / "rp_arm.yaml").read_text()
    robot.write_text(text.replace("mass: m\n    com: [l/2, 0]\n    inertia: m*l**2/12\n  - name: link2",
                                  "mass: -1\n    com: [l/2, 0]\n    inertia: m*l**2/12\n  - name: link2"))
    result = runner.invoke(app, ["solve", str(robot), "--latex", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "mass: m" in t)
    assert result.stderr.strip() == f"{robot}:{line}:11: links[0].mass: must be positive (got -1)"
    assert not (tmp_path / "out").exists()
    assert "Traceback" not in result.output


def test_unknown_robot_name(tmp_path):
    result = runner.invoke(app, ["solve", "no_such_robot"])
    assert result.exit_code == 2
    assert "no_such_robot:1:1: no such file, and no bundled robot of that name" in result.stderr


def test_3d_robot_has_no_maximal_coordinates(tmp_path):
    robot = tmp_path / "arm3d.yaml"
    robot.write_text("name: arm\nplanar: false\ngravity: [0, 0, -9.81]\nlinks:\n  - {name: a, mass: 1}\n"
                     "joints:\n  - {name: q1, type: revolute, parent: world, child: a}\n"
                     "maximal:\n  constraints: [x1]\n")
    result = runner.invoke(app, ["solve", str(robot)])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"{robot}:9:16: maximal.constraints: maximal coordinates are "
                                     "planar-only for now")


def test_pdf_without_tex_engine_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))  # no latexmk on this PATH
    result = runner.invoke(app, ["solve", "rp_arm", "--pdf", "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "--pdf needs latexmk" in result.stderr
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_console_script_runs_from_any_directory(tmp_path):
    """Bundled robots and templates are found without the checkout as working directory."""
    env = dict(os.environ)
    result = subprocess.run([sys.executable, "-m", "dynderive", "solve", "cart_pole", "--code", "--out", "o"],
                            cwd=tmp_path, capture_output=True, text=True, env=env)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "o" / "cart_pole_dynamics.py").is_file()


@pytest.mark.parametrize("robot", ["rp_arm", "double_pendulum", "cart_pole"])
def test_same_input_same_bytes(tmp_path, robot):
    outputs = []
    for run in ("a", "b"):
        result = runner.invoke(app, ["solve", robot, "--latex", "--code", "--json", "--out", str(tmp_path / run)])
        assert result.exit_code == 0, result.output
        outputs.append({p.name: p.read_bytes() for p in sorted((tmp_path / run).iterdir())})
    assert outputs[0] == outputs[1]


def test_generated_module_imports_only_numpy(tmp_path):
    """NumPy is its only dependency; ``math`` (standard library) runs single states fast."""
    result = runner.invoke(app, ["solve", "rp_arm", "--code", "--out", str(tmp_path)])
    assert result.exit_code == 0
    source = (tmp_path / "rp_arm_dynamics.py").read_text()
    imports = [line for line in source.splitlines() if line.startswith(("import ", "from "))]
    assert imports == ["import math", "import numpy as np"]
    code = "import sys, rp_arm_dynamics; assert set(sys.modules) >= {'numpy'}; assert 'sympy' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], cwd=tmp_path, check=True)


def test_json_of_a_6_dof_arm_parses_back(tmp_path):
    """A 6-DOF arm's JSON: intermediate variables, then quantities over them; read back in
    order they give the derivation's values."""
    import random

    import sympy

    import dynderive

    derivation = dynderive.derive(dynderive.load_robot(Path(__file__).parents[1] / "robots" / "ur5.urdf"))
    assert derivation.intermediate_form
    document = json.loads(dynderive.render_json(derivation))
    names = derivation.symbols.locals()
    rng = random.Random(3)
    values = {s: sympy.Float(rng.uniform(-1, 1)) for s in derivation.symbols.all_symbols()}
    known = dict(values)
    for (name, entry), (symbol, definition) in zip(document["intermediates"].items(), derivation.intermediates):
        assert name == str(symbol)
        known[symbol] = sympy.sympify(entry["sympy"], locals=names).xreplace(known)
        expected = float(definition.xreplace(known))
        assert abs(float(known[symbol]) - expected) <= 1e-12 * max(1.0, abs(expected))
    assert len(known) > len(values) + 100
    for name in ("M_g", "C_g", "EOM_g2"):
        back = sympy.sympify(document["quantities"][name]["sympy"], locals=names)
        assert document["quantities"][name]["latex"] is not None   # names and short sums typeset
        original = derivation[name]
        for k in (0, len(original) - 1, len(original) // 2):
            expected = float(original[k].xreplace(known))
            assert abs(float(back[k].xreplace(known)) - expected) <= 1e-12 * max(1.0, abs(expected))


def test_plain_printing_of_large_entries_parses_back():
    """Entries too large to typeset are printed plainly (fast, no precedence rules); they
    still parse back to the same expression."""
    import sympy

    import dynderive
    from dynderive.render.sheets.json import _plain

    derivation = dynderive.derive(dynderive.load_robot("elbow_arm"))
    names = derivation.symbols.locals()
    for name in ("C_g", "EOM_g2", "T_g"):
        value = derivation[name]
        for entry in (value if isinstance(value, sympy.MatrixBase) else [value]):
            assert sympy.expand(sympy.sympify(_plain(entry), locals=names) - entry) == 0
