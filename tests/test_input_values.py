"""Inputs that are not robot files, and expression values: refused fast, or accepted exactly.

Files that are not regular files (a FIFO blocks on open, a symlink to ``/dev/zero`` never
ends) are refused with exit code 2 before they are opened; the CLI runs in a subprocess with
a timeout, so a hang fails the test instead of blocking the suite. The corpus
(``tests/corpus``) holds the refused expressions; here valid ones must still parse.
"""

from __future__ import annotations

import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
import sympy

from dynderive.errors import InputError
from dynderive.input.loader import MAX_FILE_BYTES, read_text
from dynderive.model.expressions import ExpressionError, parse_expression

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
#: Seconds a refusal may take in a fresh interpreter (imports included).
TIMEOUT = 60


def run(*args: str) -> subprocess.CompletedProcess[str]:
    """``dynderive ARGS`` in a fresh interpreter, stopped after ``TIMEOUT`` seconds."""
    code = "import sys; from dynderive.commands.cli import app; sys.argv = ['dynderive', *sys.argv[1:]]; app()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          timeout=TIMEOUT, stdin=subprocess.DEVNULL)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "robot.yaml"
    os.mkfifo(fifo)
    result = run("solve", str(fifo), "--json", "--out", str(tmp_path / "out"))
    assert result.returncode == 2, result.stderr
    assert result.stderr.splitlines() == [f"{fifo}:1:1: not a regular file (a FIFO)"]
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_symlink_to_dev_zero_is_refused_without_reading_forever(tmp_path):
    link = tmp_path / "robot.yaml"
    link.symlink_to("/dev/zero")
    result = run("solve", str(link), "--json", "--out", str(tmp_path / "out"))
    assert result.returncode == 2, result.stderr
    assert result.stderr.splitlines() == [f"{link}:1:1: not a regular file (a character device)"]
    urdf = tmp_path / "robot.urdf"
    urdf.symlink_to("/dev/zero")
    result = run("import", str(urdf), "--output", str(tmp_path / "out.yaml"))
    assert result.returncode == 2, result.stderr
    assert "not a regular file (a character device)" in result.stderr
    assert "Traceback" not in result.stderr


def test_directory_is_refused(tmp_path):
    with pytest.raises(InputError, match="is a directory"):
        read_text(tmp_path)


def test_read_text_never_reads_more_than_the_limit(tmp_path, monkeypatch):
    """A file that grows after its ``stat`` (or lies about its size) is still cut off."""
    path = tmp_path / "big.yaml"
    path.write_bytes(b"#" * 100)
    monkeypatch.setattr("dynderive.input.loader.MAX_FILE_BYTES", 10)
    with pytest.raises(InputError, match="larger than 10 bytes"):
        read_text(path)
    assert MAX_FILE_BYTES > 10


def test_regular_file_and_symlink_to_it_are_read(tmp_path):
    path = tmp_path / "rp_arm.yaml"
    path.write_bytes((ROBOTS / "rp_arm.yaml").read_bytes())
    link = tmp_path / "link.yaml"
    link.symlink_to(path)
    assert read_text(link) == read_text(path) == (ROBOTS / "rp_arm.yaml").read_text(encoding="utf-8")


# -- expressions ------------------------------------------------------------------------

m, l, x = sympy.symbols("m l x")
SCOPE = {"m": m, "l": l, "x": x}


@pytest.mark.parametrize(("text", "expected"), [
    ("exp(l)", sympy.exp(l)),
    ("log(l)", sympy.log(l)),
    ("abs(x)", sympy.Abs(x)),
    ("atan(x)", sympy.atan(x)),
    ("cosh(x)", sympy.cosh(x)),
    ("sqrt(m)", sympy.sqrt(m)),
    ("E", sympy.E),
    ("pi/2", sympy.pi / 2),
    ("E**x", sympy.exp(x)),
    ("2**x", 2**x),
    ("m*l**2/12", m * l**2 / 12),
    ("acos(1/2)", sympy.pi / 3),
    ("log(E)", sympy.Integer(1)),
    ("sqrt(2)**2 - 2", sympy.Integer(0)),
    ("exp(700)", sympy.exp(700)),
    ("10**308", sympy.Integer(10) ** 308),
    ("1e-300", sympy.Rational(1, 10**300)),
    ("m**12", m**12),
    ("(m*l)**6", m**6 * l**6),
    ("sqrt(m)**24", None),  # refused: a written exponent above 12, even if the power is m**12
    ("atan2(l, m)", sympy.atan2(l, m)),
    ("-x", -x),
    ("--x", x),
])
def test_valid_expressions_still_parse(text, expected):
    if expected is None:
        with pytest.raises(ExpressionError):
            parse_expression(text, SCOPE)
        return
    assert parse_expression(text, SCOPE) == expected


def test_full_precision_floats_are_exact_decimals():
    value = parse_expression("0.33046510807172985", SCOPE)
    assert value == sympy.Rational("0.33046510807172985")
    assert Fraction(int(value.p), int(value.q)) == Fraction("0.33046510807172985")
    assert parse_expression(0.33046510807172985, SCOPE) == value  # a YAML float, by its repr
    assert parse_expression("0.1*m", SCOPE) == m / 10


def test_long_sums_and_products_are_built_without_recursion():
    """A chain of 499 additions is flat (one nesting level), so it parses instead of crashing."""
    assert parse_expression("1" + "+x" * 499, SCOPE) == 1 + 499 * x
    text = "+".join(f"{k}*m" for k in range(1, 150))
    assert parse_expression(text, SCOPE) == sum(range(1, 150)) * m
    assert parse_expression("*".join(["2"] * 400), SCOPE) == sympy.Integer(2) ** 400


@pytest.mark.parametrize(("text", "message"), [
    ("-" * 999 + "x", "nested too deeply"),
    ("+" * 999 + "x", "nested too deeply"),
    ("2**-" * 200 + "2", "nested too deeply"),
    ("(10**999)**999", "out of the range of a double"),
    ("(10**300)**999", "out of the range of a double"),
    ("exp(exp(exp(100)))", "out of the range of a double"),
    ("x*" + "10**300*" * 3 + "x", "out of the range of a double"),
    ("m" + "*m" * 12, "limited to exponent 12"),
    ("(m**12)**12", "limited to exponent 12"),
    ("(m**6)**3", "limited to exponent 12"),
    ("log(x - x)", "is infinite"),
    ("atan2(0, 0)", "is undefined"),
    ("asin(2)", "not a real number"),
    ("sqrt(-2)*x", "not a real number"),
])
def test_bad_expressions_are_refused_fast(text, message):
    import time

    start = time.perf_counter()
    with pytest.raises(ExpressionError, match=message):
        parse_expression(text, SCOPE)
    assert time.perf_counter() - start < 20   # a bound on runaway work, not a speed test (benchmarks time speed)


def test_offending_sub_expression_is_pointed_at():
    with pytest.raises(ExpressionError) as info:
        parse_expression("m*l + acos(2)*m", SCOPE)
    assert info.value.offset == len("m*l + ")
    with pytest.raises(ExpressionError) as info:
        parse_expression("m*(10**999)**2", SCOPE)
    assert info.value.offset == len("m*(")
