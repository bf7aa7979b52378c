"""Small robots written with CAD numbers: every output of each bundled
robot, a 4-joint planar chain and the four-bar, once with round numbers and once with
17-significant-digit numbers, against the goals.

    python benchmarks/cad_numbers.py                # about 3 minutes on 2 cores; prints a table
    python benchmarks/cad_numbers.py --repeats 3    # the fastest of 3 processes per variant
    python benchmarks/cad_numbers.py --only four_bar chain4
    python benchmarks/cad_numbers.py --baseline /tmp/old/src   # beside an earlier commit's src
                                                               # (git archive COMMIT src templates)

Variants of each robot, each derived in a fresh process (``scaling.py --outputs``: load,
derive, ``--latex --code --json`` rendered, no PDF; from loading the file to the last
string, CPU seconds and, in parentheses, wall seconds; the goals are judged on CPU time,
which equals the wall time on an idle machine and varies less on a shared one):

- ``shipped``: the bundled file as it is (YAML robots keep their parameters as symbols);
- ``round``: YAML robots with every parameter that has a value written into the expressions
  as that number (``m2*b**2/12`` -> ``(1.5)*(0.9)**2/12``); URDFs and the chain as they are;
- ``CAD``: the same file with each of those numbers (parameter values; the URDFs' masses,
  inertias and origin offsets; the chain's every number) moved by up to 1 % and written with
  17 significant digits, as CAD exporters write them. A parameter keeps one number wherever it
  occurs and a URDF inertia tensor is scaled as a whole, so each mechanism keeps its shape
  (the loops still close, inertias stay physical). Angles (``rpy``, ``pi/2``) and axes stay.

The chain is ``models.planar_chain_yaml(4)`` (the scaling benchmark's chain4, CAD numbers)
and the same chain with two significant digits. Goals: every variant <= 3 s, CAD <= 1.5x round.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import planar_chain_yaml  # noqa: E402
from scaling import _cell, _child  # noqa: E402  (fresh-process measurement of every output)

ROOT = Path(__file__).resolve().parent.parent
GOAL_S = 3.0
GOAL_RATIO = 1.5
VARIANTS = ("shipped", "round", "CAD")
#: YAML keys whose text is a name, not an expression.
NAME_KEYS = {"name", "title", "description", "unit", "type", "parent", "child", "link", "independent", "effort"}


def _cad(value: float, rng: random.Random) -> str:
    """``value`` moved by up to 1 %, with 17 significant digits."""
    return f"{value * (1 + rng.uniform(-0.01, 0.01)):.17g}"


def yaml_numbers(text: str, cad: bool, seed: int) -> str:
    """A YAML robot with its parameters' values written into the expressions (round numbers,
    or with ``cad`` 17-digit numbers near them; other decimal literals likewise)."""
    rng = random.Random(seed)
    data = yaml.safe_load(text)
    parameters = data.get("parameters") or {}
    values = {name: spec["value"] for name, spec in parameters.items() if spec.get("value") is not None}
    numbers = {name: _cad(float(v), rng) if cad else repr(float(v)) for name, v in values.items()}
    kept = {name: spec for name, spec in parameters.items() if name not in values}
    if kept:
        data["parameters"] = kept
    else:
        data.pop("parameters", None)
    pattern = re.compile(r"\b(" + "|".join(map(re.escape, numbers)) + r")\b") if numbers else None

    def walk(node, key=None):
        if key in NAME_KEYS:
            return node
        if isinstance(node, dict):
            return {k: walk(v, k) for k, v in node.items()}
        if isinstance(node, list):
            return [walk(v, key) for v in node]
        if isinstance(node, str) and pattern is not None:
            return pattern.sub(lambda m: f"({numbers[m.group(1)]})", node)
        if isinstance(node, float) and cad and node != int(node):
            return _cad(node, rng)
        return node

    return yaml.safe_dump(walk(data), sort_keys=False, width=1000)


def urdf_numbers(text: str, seed: int) -> str:
    """A URDF with its masses, inertias (each tensor scaled as a whole) and non-zero origin
    offsets moved by up to 1 % and written with 17 significant digits; angles and axes stay."""
    rng = random.Random(seed)
    root = ET.fromstring(text)
    for element in root.iter():
        if element.tag == "mass":
            element.set("value", _cad(float(element.get("value")), rng))
        elif element.tag == "inertia":
            factor = 1 + rng.uniform(-0.01, 0.01)
            for name, value in element.attrib.items():
                element.set(name, f"{float(value) * factor:.17g}")
        elif element.tag == "origin" and element.get("xyz"):
            element.set("xyz", " ".join(_cad(float(v), rng) if float(v) else v for v in element.get("xyz").split()))
    return ET.tostring(root, encoding="unicode")


def variants(name: str, path: Path) -> dict[str, tuple[str, str]]:
    """``{variant: (suffix, text)}`` of one bundled robot."""
    text = path.read_text()
    seed = sum(map(ord, name))
    if path.suffix == ".urdf":
        return {"round": (".urdf", text), "CAD": (".urdf", urdf_numbers(text, seed))}
    return {"shipped": (".yaml", text), "round": (".yaml", yaml_numbers(text, False, seed)),
            "CAD": (".yaml", yaml_numbers(text, True, seed))}


def robots() -> dict[str, dict[str, tuple[str, str]]]:
    out = {path.stem: variants(path.stem, path) for path in sorted((ROOT / "robots").iterdir())
           if path.suffix in (".yaml", ".urdf")}
    out["chain4"] = {"round": (".yaml", planar_chain_yaml(4, round_numbers=True)),
                     "CAD": (".yaml", planar_chain_yaml(4))}
    return out


def _measure(path: Path, repeats: int, timeout: float, source: Path | None = None) -> dict:
    """The fastest (CPU) of ``repeats`` fresh processes; with ``source``, of the dynderive
    under that ``src`` folder instead of the installed one."""
    saved = os.environ.get("PYTHONPATH")
    if source is not None:
        os.environ["PYTHONPATH"] = str(source)
    try:
        runs = [_child("--outputs", str(path), [], timeout) or {} for _ in range(repeats)]
    finally:
        if source is not None:
            os.environ.pop("PYTHONPATH") if saved is None else os.environ.update(PYTHONPATH=saved)
    return min(runs, key=lambda r: r.get("all_cpu_s", float("inf")))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", nargs="*", help="these robots only (file stems, or chain4)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per process")
    parser.add_argument("--keep", type=Path, help="also write the generated robot files into this folder")
    parser.add_argument("--repeats", type=int, default=1, help="processes per variant; the fastest counts")
    parser.add_argument("--baseline", type=Path, help="the src folder of another dynderive (an earlier commit): "
                        "each variant is measured with it too, alternately, and shown beside")
    args = parser.parse_args()
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, files in robots().items():
            if args.only and name not in args.only:
                continue
            row: dict = {"robot": name, "notes": []}
            for variant, (suffix, text) in files.items():
                path = Path(args.keep or folder) / f"{name}_{variant.lower()}{suffix}"
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
                print(f"measuring {name} ({variant}) ...", file=sys.stderr, flush=True)
                result = _measure(path, args.repeats, args.timeout)
                row[variant] = (result["all_cpu_s"], result["all_s"]) if "all_s" in result else None
                if args.baseline:
                    before = _measure(path, args.repeats, args.timeout, args.baseline.resolve())
                    row[f"{variant} before"] = before.get("all_cpu_s")
                if "timed_out" in result:
                    row["notes"].append(f"{variant} > {args.timeout:.0f} s")
                if result.get("checks_failed"):
                    row["notes"].append(f"{variant} checks failed: {', '.join(result['checks_failed'])}")
            rows.append(row)
    print(table(rows, bool(args.baseline)))
    missed = [r["robot"] for r in rows if verdicts(r) != ("met", "met")]
    print(f"\ngoals: {len(rows) - len(missed)} of {len(rows)} robots meet both"
          + (f" (not: {', '.join(missed)})" if missed else ""))
    print(f"({len(rows)} robots, {time.perf_counter() - started:.0f} s; Python {sys.version.split()[0]}, "
          f"{time.strftime('%Y-%m-%d')}; load average {os.getloadavg()[0]:.1f} at the end)")


def verdicts(row: dict) -> tuple[str, str]:
    """Whether every variant took at most GOAL_S and CAD at most GOAL_RATIO times round
    (CPU seconds: the steadier figure on a shared machine; equal to wall time when idle)."""
    times = [row[v] for v in VARIANTS if v in row]
    fast = "met" if None not in times and max(t[0] for t in times) <= GOAL_S else "NOT MET"
    ratio = _ratio(row)
    return fast, "-" if ratio is None else "met" if ratio <= GOAL_RATIO else "NOT MET"


def _ratio(row: dict) -> float | None:
    return row["CAD"][0] / row["round"][0] if row.get("CAD") and row.get("round") else None


def table(rows: list[dict], baseline: bool = False) -> str:
    """One line per robot: CPU seconds (wall seconds in parentheses) of each variant; with
    ``baseline``, the baseline's CPU seconds after a slash."""
    def cell(row: dict, variant: str) -> str:
        value = row.get(variant)
        text = "-" if value is None else f"{value[0]:.2f} ({value[1]:.1f})"
        before = row.get(f"{variant} before")
        return text + (f" / {before:.2f}" if baseline and before is not None else "")

    cells = [["robot", *(f"{v} s" + (" / before" if baseline else "") for v in VARIANTS), "CAD/round",
              f"<= {GOAL_S:g} s", f"<= {GOAL_RATIO:g}x", "notes"]]
    for row in rows:
        cells.append([row["robot"], *(cell(row, v) if v in row else "-" for v in VARIANTS),
                      _cell(_ratio(row), "{:.2f}x"), *verdicts(row), "; ".join(row["notes"])])
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]))]
    last = len(widths) - 1
    lines = ["  ".join(c.ljust(w) if i in (0, last) else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))).rstrip()
             for r in cells]
    return "\n".join([lines[0], "-" * len(lines[0]), *lines[1:]])


if __name__ == "__main__":
    main()
