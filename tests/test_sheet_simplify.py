"""Issue 32, "simplification where it is cheap": textbook forms of chains' mass matrices, the
loops' reduced quantities named M_r, C_r, N_r and written over the constraint determinant as
one sine of an angle sum, and large entries broken over lines instead of dropped."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive

ROBOTS = Path(__file__).resolve().parents[1] / "robots"

POINT_MASS_DOUBLE_PENDULUM = """\
name: point_mass_double_pendulum
planar: true
parameters:
  m1: {value: 1.3}
  m2: {value: 0.7}
  l1: {value: 1.1}
  l2: {value: 0.9}
  g: {value: 9.81}
gravity: [0, -g]
links:
  - {name: bob1, mass: m1, com: [l1, 0], inertia: 0}
  - {name: bob2, mass: m2, com: [l2, 0], inertia: 0}
joints:
  - {name: q1, type: revolute, parent: world, child: bob1, effort: tau1}
  - {name: q2, type: revolute, parent: bob1, child: bob2, origin: [l1, 0, 0], effort: tau2}
"""


def _trig_squares(expr: sympy.Expr) -> bool:
    return any(p.exp.is_Integer and p.exp > 1 and p.base.has(sympy.sin, sympy.cos) for p in expr.atoms(sympy.Pow))


def test_point_mass_double_pendulum_mass_matrix_in_textbook_form(tmp_path):
    path = tmp_path / "pm.yaml"
    path.write_text(POINT_MASS_DOUBLE_PENDULUM)
    derivation = dynderive.derive(dynderive.load_robot(path))
    M = derivation.quantities["M_g"]
    m1, m2, l1, l2, q2 = sympy.symbols("m1 m2 l1 l2 q2")
    names = {s.name: s for s in M.free_symbols}
    textbook = (m1 + m2) * l1**2 + 2 * m2 * l1 * l2 * sympy.cos(q2) + m2 * l2**2
    textbook = textbook.xreplace({s: names[s.name] for s in textbook.free_symbols})
    assert not _trig_squares(M[0, 0]), M[0, 0]
    assert sympy.expand(M[0, 0] - textbook) == 0
    # the same matrix as before, numerically: the rewriting changes the form, not the value
    values = {s: v for s, v in zip(sorted(M.free_symbols, key=str), np.linspace(0.3, 1.7, len(M.free_symbols)))}
    built = sympy.Matrix([[names["l1"]**2 * names["m1"] + names["m2"] * (names["l1"] * sympy.cos(names["q2"])
                                                                          + names["l2"])**2
                           + names["l1"]**2 * names["m2"] * sympy.sin(names["q2"])**2]])
    assert float(M[0, 0].xreplace(values)) == pytest.approx(float(built[0].xreplace(values)), rel=1e-14)


def _reduced(robot: str):
    derivation = dynderive.derive(dynderive.load_robot(ROBOTS / f"{robot}.yaml"))
    return derivation, derivation.quantities


def test_four_bar_reduced_form_over_one_sine_of_an_angle_sum():
    derivation, q = _reduced("four_bar")
    q1, q2, q3 = derivation.symbols.q
    determinant = sympy.sin(q1 + q2 - q3)
    for key in ("R_g", "M_r", "C_r", "N_r"):
        entries = [e for e in q[key] if e.has(q1)]
        assert entries, key
        for entry in entries:
            denominator = sympy.fraction(entry)[1]
            # the denominator is a power of sin(q1 + q2 - q3) times parameters, never the
            # expanded -sin(q3) cos(q1 + q2) + sin(q1 + q2) cos(q3)
            assert denominator.has(determinant), (key, entry)
            assert not (denominator.has(sympy.cos(q3)) or denominator.has(sympy.cos(q1 + q2))), (key, entry)
    assert sympy.count_ops(q["M_r"][0]) < 40
    assert sympy.count_ops(q["C_r"][0]) < 200
    assert q["Y_r"][0] == derivation.symbols.efforts["tau1"]


def test_four_bar_sheet_names_reduced_quantities_and_typesets_all():
    derivation, _ = _reduced("four_bar")
    tex = dynderive.render_latex(derivation)
    reduced = tex[tex.index(r"\subsection{Reduced form}"):]
    assert "M_r = " in reduced or "M_r &= " in reduced
    assert "C_r = " in reduced or "C_r &= " in reduced
    assert "M_{1}" not in reduced and "C_{1}" not in reduced
    assert r"\sin{\left(q_{1} + q_{2} - q_{3} \right)}" in reduced
    assert "too large to typeset" not in tex


def test_large_entries_are_broken_over_lines_not_dropped():
    derivation, q = _reduced("spatial_four_bar")
    assert sum(1 for _ in sympy.preorder_traversal(q["C_r"][0])) > 6000   # over the old limit
    tex = dynderive.render_latex(derivation)
    assert "too large to typeset" not in tex
    block = tex[tex.index("C_r &= "):]
    block = block[:block.index(r"\end{align*}")]
    assert block.count(r"\\") > 20   # many display lines
