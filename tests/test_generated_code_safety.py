"""Safety and correctness of the generated module (issue 13, items 1-3).

* Free text (title, units, descriptions, the file's own name, a URDF's ``<robot name>``)
  never changes the program: a corpus of hostile strings goes into every free-text field,
  the module is imported in a child process, nothing runs, and the text reads back exactly
  from the module's docstring.
* Full-precision numbers (what CAD exporters write) give working code.
* Every function and constant the expression whitelist accepts works in every generated
  function, planar and 3-D, and agrees with the symbolic quantity.
* No robot symbol can collide with a name the generated module uses (checked on the
  modules' own syntax trees, so the reserved list cannot fall behind the template).
"""

from __future__ import annotations

import ast
import builtins
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.input.names import MODULE_NAMES
from dynderive.model.expressions import FUNCTIONS
from dynderive.render.encode import docstring, escape_tex, terminal_text

from conftest import import_code

MARKER = "dynderive_pwned"

#: Strings that break naive encoders: quotes that end a docstring, backslashes that start an
#: escape, NUL, line breaks (also Unicode ones), terminal escapes, LaTeX commands and
#: specials, bidi controls, non-Latin text.
HOSTILE = [
    f'x"""; __import__("pathlib").Path(r"{{tmp}}/{MARKER}").touch(); """',
    f"x'''; __import__('pathlib').Path('{{tmp}}/{MARKER}').touch(); '''",
    "C:\\Users\\new\\x41\\N{DIGIT ONE}",
    "nul\x00byte and \x07 bell",
    "line\nbreak\r\nand\u2028separator\u0085next",
    "\x1b[31mred\x1b[0m and \u202etxet desrever",
    "\\input{/etc/passwd} \\def\\x{1} \\write18{touch x}",
    "%$&#_{}~^<>|\"'`",
    '"',
    "\\",
    "ends with a quote\"",
    "héllo wörld, Ωμέγα, 機械",
    "#!/bin/sh\n# -*- coding: latin-1 -*-",
    "{{ 7 * 7 }} {% raw %} \\VAR{x} \\BLOCK{for}",
]


def _robot_yaml(title: str, unit: str, description: str, name: str = "hostile") -> str:
    dump = json.dumps   # a JSON string is a YAML double-quoted scalar
    return textwrap.dedent(f"""\
        name: {name}
        title: {dump(title)}
        planar: true
        parameters:
          m: {{value: 1.25, unit: {dump(unit)}, description: {dump(description)}}}
          l: {{value: 0.75, unit: m}}
        gravity: [0, -9.81]
        links:
          - {{name: link1, mass: m, com: [l/2, 0], inertia: m*l**2/12}}
          - {{name: link2, mass: m, com: [l/2, 0], inertia: m*l**2/12}}
        joints:
          - {{name: q1, type: revolute, parent: world, child: link1, effort: tau1}}
          - {{name: q2, type: prismatic, parent: link1, child: link2, origin: [l, 0], effort: f2}}
        """)


def _import_and_read(module_dir: Path, module: str) -> dict:
    """Import the module in a child process; return its docstring and a mass matrix."""
    script = textwrap.dedent(f"""\
        import json, sys
        sys.path.insert(0, {str(module_dir)!r})
        import {module} as m
        print(json.dumps({{"doc": m.__doc__, "M": m.mass_matrix([0.3, 0.2]).tolist()}}))
        """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("index", range(len(HOSTILE)))
def test_hostile_text_in_every_field_runs_nothing_and_reads_back(index, tmp_path):
    text = HOSTILE[index].replace("{tmp}", str(tmp_path))
    source = tmp_path / "robot.yaml"
    source.write_text(_robot_yaml(text, "u " + text, "d " + text), encoding="utf-8")
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "dynderive", "solve", str(source), "--code", "--latex",
                           "--json", "--tests", "--out", str(out), "-q"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = _import_and_read(out, "hostile_dynamics")
    assert not (tmp_path / MARKER).exists()
    assert f"Equations of motion of {text} (robot ``hostile``)" in result["doc"]
    assert f"m [u {text}]: d {text}" in result["doc"]
    M = np.array(result["M"])
    assert M[1, 1] == 1.25 and np.allclose(M, M.T) and np.linalg.eigvalsh(M)[0] > 0
    tex = (out / "hostile.tex").read_text(encoding="utf-8")
    assert escape_tex(text) in tex
    for line in tex.splitlines():   # nothing of the text opens a command or a comment
        assert "\\input{/etc" not in line and "\\write18" not in line and "\\def\\x" not in line
    ast.parse((out / "test_hostile_dynamics.py").read_text(encoding="utf-8"))


def test_hostile_file_name_and_urdf_robot_name(tmp_path, monkeypatch):
    """The file's own name reaches the module's docstring; a URDF's <robot name> is its title
    (the marker's path is relative, so that the name stays within the 100 characters a robot
    name may have)."""
    monkeypatch.chdir(tmp_path)
    odd = tmp_path / 'a"""b\\c.yaml'
    odd.write_text(_robot_yaml("plain title", "kg", "mass"), encoding="utf-8")
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(textwrap.dedent(f"""\
        <robot name='x&quot;&quot;&quot;; __import__(&quot;pathlib&quot;).Path(r&quot;{MARKER}&quot;).touch(); &quot;&quot;&quot;'>
          <link name="base"/>
          <link name="l1"><inertial><mass value="1.5"/><origin xyz="0.1 0 0"/>
            <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
          <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
            <limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
        </robot>
        """), encoding="utf-8")
    for path in (odd, urdf):
        robot = dynderive.load_robot(path)
        code = dynderive.render_code(dynderive.derive(robot))
        module = import_code(code, tmp_path, f"m_{abs(hash(str(path)))}")
        assert robot.title in module.__doc__
        assert path.name in module.__doc__
        assert not (tmp_path / MARKER).exists()


def test_encoders_round_trip_every_character():
    text = "".join(chr(c) for c in range(0, 0x3000, 7)) + "\ud800\udfff\U0001f600"
    assert ast.literal_eval('"""' + docstring(text) + '"""') == text
    assert "\x1b" not in terminal_text("\x1b[2J") and "\\x1b" in terminal_text("\x1b[2J")
    tex = escape_tex(text)
    assert not any(c in tex for c in "\x00\n\r\x1b")


# -- numbers and functions ------------------------------------------------------------------

def _planar(body: str) -> str:
    return "name: fn\ntitle: functions\nplanar: true\n" + textwrap.dedent(body)


FULL_PRECISION_PLANAR = _planar("""\
    parameters:
      m: 1.3720931276412398
    gravity: [0.13049578309417325, -9.80913274610385]
    links:
      - {name: link1, mass: m, com: [0.41273640129374611, 0.01923847123847561], inertia: 0.09128374612837461}
      - {name: link2, mass: 0.73829101928374017, com: [0.2038471928374651, -0.0384756102938475], inertia: 0.011}
    joints:
      - {name: q1, type: revolute, parent: world, child: link1, origin: [0.1, 0.2, 0.30000000000000004], effort: t1}
      - {name: q2, type: prismatic, parent: link1, child: link2, origin: [0.7, 0.1, 0.3],
         axis: [0.33046510807172985, 0.9438182747114153], effort: f2}
    """)


def _spatial(expression: str) -> str:
    return textwrap.dedent(f"""\
        name: fn3
        title: functions in 3-D
        parameters:
          m: 1.3720931276412398
          a: 0.6180339887498949
        gravity: [0, 0, -9.81]
        links:
          - {{name: link1, mass: "{expression}", com: [0.1, 0.02, 0.3],
             inertia: [0.05, 0.06, 0.07, 0.001, 0.002, 0.003]}}
          - {{name: link2, mass: 1.1, com: [0.2, 0.01, 0.05], inertia: [0.02, 0.03, 0.04, 0, 0, 0]}}
        joints:
          - {{name: q1, type: revolute, parent: world, child: link1, axis: [0.2672612419124244, 0.5345224838248488, 0.8017837257372732], effort: t1}}
          - {{name: q2, type: revolute, parent: link1, child: link2, origin: {{xyz: [0.3, 0, 0.1], rpy: [0.1, 0.2, 0.3]}}, effort: t2}}
        """)


#: One robot-file expression per whitelisted function and constant, positive at the defaults.
EXPRESSIONS = {
    "sin": "1 + sin(a)", "cos": "1 + cos(a)", "tan": "1 + tan(a)", "asin": "1 + asin(a)",
    "acos": "1 + acos(a)", "atan": "1 + atan(m)", "atan2": "1 + atan2(a, m)", "sinh": "1 + sinh(a)",
    "cosh": "cosh(m)", "tanh": "1 + tanh(m)", "sqrt": "sqrt(m)", "exp": "exp(a)", "log": "1 + log(m)",
    "abs": "abs(a - m)", "pi": "pi*a", "E": "E*a",
}


def test_every_whitelisted_function_has_a_case():
    assert set(FUNCTIONS) | {"pi", "E"} == set(EXPRESSIONS)


def _check_module(derivation, module, parameters):
    """Every generated function runs, on one state and on a batch, and matches the symbolic
    quantities (constants folded to doubles for the reference)."""
    table = derivation.symbols
    n = len(table.q)
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.uniform(-1, 1, (3, n))
    u = rng.uniform(-1, 1, len(table.efforts))
    values = table.defaults(derivation.robot) | {table.parameters[k]: v for k, v in parameters.items()}
    state = dict(zip(table.q, q)) | dict(zip(table.qd, qd)) | dict(zip(table.qdd, qdd)) \
        | dict(zip(table.efforts.values(), u)) | values

    references = {}

    def reference(name):   # evaluated by SymPy at 30 digits: independent of the code printer (once per name)
        if name not in references:
            value = sympy.N(derivation[name].xreplace(state), 30)
            references[name] = np.array(value.tolist() if isinstance(value, sympy.MatrixBase) else float(value),
                                        dtype=float)
        return references[name]

    M = module.mass_matrix(q, **parameters)
    np.testing.assert_allclose(M, reference("M_g"), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(module.gravity_vector(q, **parameters), reference("N_g").reshape(-1), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(module.coriolis_matrix(q, qd, **parameters), reference("C_g"), rtol=1e-11, atol=1e-12)
    tau = module.inverse_dynamics(q, qd, qdd, **parameters)
    expected = reference("M_g") @ qdd + reference("C_g") @ qd + reference("N_g").reshape(-1)
    np.testing.assert_allclose(tau, expected, rtol=1e-11, atol=1e-12)
    acc = module.forward_dynamics(q, qd, u, **parameters)
    np.testing.assert_allclose(M @ acc, reference("Y_g").reshape(-1) - expected + M @ qdd, rtol=1e-10, atol=1e-11)
    assert np.isfinite(module.kinetic_energy(q, qd, **parameters))
    np.testing.assert_allclose(module.potential_energy(q, **parameters), float(reference("V_g")), rtol=1e-11, atol=1e-12)
    batch = module.forward_dynamics(np.tile(q, (5, 1)), np.tile(qd, (5, 1)), np.tile(u, (5, 1)), **parameters)
    np.testing.assert_allclose(batch, np.tile(acc, (5, 1)), rtol=1e-12, atol=1e-12)
    if "M_m" in derivation:
        qm = module.to_maximal(q, **parameters)
        qmd = module.to_maximal_jacobian(q, **parameters) @ qd
        assert np.all(np.isfinite(module.maximal_forward_dynamics(qm, qmd, u, **parameters)))
        np.testing.assert_allclose(module.constraints(qm, **parameters), 0, atol=1e-12)


def test_full_precision_numbers_give_working_code(tmp_path):
    path = tmp_path / "fn.yaml"
    path.write_text(FULL_PRECISION_PLANAR)
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), tmp_path, "full_precision")
    _check_module(derivation, module, {})


@pytest.mark.parametrize("function", sorted(EXPRESSIONS))
def test_whitelisted_function_works_in_planar_code(function, tmp_path):
    path = tmp_path / "fn.yaml"
    expression = EXPRESSIONS[function]
    path.write_text(_planar(f"""\
        parameters:
          m: 1.3720931276412398
          a: 0.6180339887498949
        gravity: [0, -9.81]
        links:
          - {{name: link1, mass: "{expression}", com: ["0.3*{expression}", 0.05], inertia: "{expression}/10"}}
          - {{name: link2, mass: m, com: [0.2, 0], inertia: 0.01}}
        joints:
          - {{name: q1, type: revolute, parent: world, child: link1, effort: t1}}
          - {{name: q2, type: prismatic, parent: link1, child: link2, axis: [0.33046510807172985, 0.9438182747114153], effort: f2}}
        """))
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), tmp_path, f"planar_{function}")
    _check_module(derivation, module, {})
    _check_module(derivation, module, {"m": 1.1, "a": 0.3})


@pytest.mark.parametrize("function", ["exp", "log", "abs", "atan", "cosh", "sqrt", "E", "atan2", "asin"])
def test_whitelisted_function_works_in_spatial_code(function, tmp_path):
    path = tmp_path / "fn3.yaml"
    path.write_text(_spatial(EXPRESSIONS[function]))
    derivation = dynderive.derive(dynderive.load_robot(path))
    module = import_code(dynderive.render_code(derivation), tmp_path, f"spatial_{function}")
    _check_module(derivation, module, {})
    _check_module(derivation, module, {"m": 1.1, "a": 0.3})


# -- names ----------------------------------------------------------------------------------

@pytest.mark.parametrize("robot", ["rp_arm", "elbow_arm", "cart_pole"])
def test_every_name_the_module_uses_is_reserved(robot):
    """Parse the generated module: in every function that takes the robot's parameters (as
    keyword arguments, where they would shadow a name), each name bound or read is a robot
    symbol, a private ``_name``, or reserved by the validator."""
    derivation = dynderive.derive(dynderive.load_robot(robot))
    tree = ast.parse(dynderive.render_code(derivation))
    robot_symbols = {str(s) for s in derivation.symbols.all_symbols()}
    parameters = set(derivation.symbols.parameters)
    used = set()
    for function in ast.walk(tree):
        if not (isinstance(function, ast.FunctionDef) and {a.arg for a in function.args.kwonlyargs} & parameters):
            continue
        for node in ast.walk(function):
            if isinstance(node, ast.Name):
                used.add(node.id)
            elif isinstance(node, ast.arg):
                used.add(node.arg)
    assert used, "no function takes the parameters"
    unreserved = {n for n in used - robot_symbols if not n.startswith("_")
                  and n not in MODULE_NAMES and n not in FUNCTIONS}
    assert not unreserved, f"names the module uses that a robot file could take: {sorted(unreserved)}"
    assert {"float", "alpha", "beta", "np", "math"} <= MODULE_NAMES
    assert set(dir(builtins)) - {n for n in dir(builtins) if n.startswith("_")} <= MODULE_NAMES
