"""Where a small robot's run goes: CPU seconds of each phase of ``solve
--latex --code --json`` in a fresh process, beside two anchors that produce less.

    python benchmarks/phases.py                          # the three slowest: bennett, panda, chain4
    python benchmarks/phases.py four_bar robots/ur5.urdf --repeats 3

Phases, in order, each in the same process (the command line's SymPy cache, as ``solve``):

- ``derive``: every quantity of DESIGN.md section 4 and the checks (``Derivation.checks``);
- ``sheet``: ``render_latex`` (the sheet's own step-by-step forms, then their LaTeX);
- ``code``: ``render_code`` (the straight-line programs, then the NumPy module's text);
- ``JSON``: ``render_json`` (every quantity's ``sympy`` and LaTeX strings; the printers'
  memory of the sheet's sub-expressions is shared, as in ``solve``).

Anchors, each in a fresh process of its own:

- ``SymPy print``: SymPy's own ``sstr`` and ``latex`` of every quantity the JSON holds (fresh
  printers, no memory shared), after the derivation: what printing the JSON's strings costs
  with SymPy's printers alone;
- ``Kane``: ``KanesMethod.kanes_equations`` of the same model, unsimplified, exact numbers
  (``anchors.kane_equations``): a bare symbolic derivation with no readable form, no check
  and no output (fixed-base robots without loops only).

``chain4`` is the CAD-number 4-joint planar chain of ``cad_numbers.py``. Each figure is the
fastest of ``--repeats`` processes (CPU seconds; this 2-core machine's figures move by
10-40 % from run to run).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import planar_chain_yaml  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PHASES = ("derive", "sheet", "code", "JSON")


def _command_line_cache() -> None:
    from dynderive.__main__ import use_command_line_sympy_cache

    use_command_line_sympy_cache()


def measure_phases(robot: str) -> dict:
    """In a child: CPU seconds of each phase of ``solve --latex --code --json``."""
    _command_line_cache()
    import dynderive
    from dynderive.render.sheets.json import render_json

    out, clock = {}, time.process_time()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.process_time()
        out[name] = now - clock
        clock = now

    derivation = dynderive.derive(dynderive.load_robot(robot))
    assert derivation.checks is not None   # every quantity, and the checks
    lap("derive")
    dynderive.render_latex(derivation)
    lap("sheet")
    dynderive.render_code(derivation)
    lap("code")
    render_json(derivation)
    lap("JSON")
    return out


def measure_sympy_print(robot: str) -> dict:
    """In a child: SymPy's ``sstr`` and ``latex`` of every quantity, after the derivation."""
    _command_line_cache()
    import sympy

    import dynderive

    derivation = dynderive.derive(dynderive.load_robot(robot))
    assert derivation.checks is not None   # every quantity, and the checks
    values = [derivation.quantities[name] for name in derivation.quantities]
    start = time.process_time()
    for value in values:
        sympy.sstr(value)
        sympy.latex(value)
    return {"SymPy print": time.process_time() - start}


def measure_kane(robot: str) -> dict:
    """In a child: KanesMethod's unsimplified equations of the same model."""
    _command_line_cache()
    import anchors

    import dynderive

    model = dynderive.load_robot(robot)
    if model.loops or model.floating:
        return {}
    result = anchors.kane_equations(model)
    return {"Kane": result["setup_s"] + result["kane_s"]}


def _child(flag: str, robot: str) -> dict:
    result = subprocess.run([sys.executable, __file__, flag, robot], capture_output=True, text=True)
    if result.returncode != 0:
        print(f"{robot} ({flag}) failed:\n{result.stderr[-2000:]}", file=sys.stderr)
        return {}
    return json.loads(result.stdout.strip().splitlines()[-1])


def _robot_path(name: str, folder: Path) -> str:
    if name == "chain4":
        path = folder / "chain4.yaml"
        path.write_text(planar_chain_yaml(4))
        return str(path)
    if Path(name).exists():
        return name
    for suffix in (".yaml", ".urdf"):
        bundled = ROOT / "robots" / f"{name}{suffix}"
        if bundled.exists():
            return str(bundled)
    raise SystemExit(f"phases.py: no robot {name!r}")


def table(rows: list[dict]) -> str:
    columns = ["robot", *PHASES, "total", "SymPy print", "Kane"]
    cells = [columns]
    for row in rows:
        total = sum(row[p] for p in PHASES) if all(p in row for p in PHASES) else None
        values = {**row, "total": total}
        cells.append([row["robot"], *("-" if values.get(c) is None else f"{values[c]:.2f}" for c in columns[1:])])
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in cells]
    return "\n".join([lines[0], "-" * len(lines[0]), *lines[1:]])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*", default=["bennett", "panda", "chain4"])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--phases", help=argparse.SUPPRESS)
    parser.add_argument("--sympy-print", help=argparse.SUPPRESS)
    parser.add_argument("--kane", help=argparse.SUPPRESS)
    args = parser.parse_args()
    for flag, function in (("phases", measure_phases), ("sympy_print", measure_sympy_print), ("kane", measure_kane)):
        if getattr(args, flag):
            print(json.dumps(function(getattr(args, flag))))
            return
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in args.robots:
            path = _robot_path(name, Path(folder))
            row: dict = {"robot": Path(name).stem}
            for flag in ("--phases", "--sympy-print", "--kane"):
                for _ in range(args.repeats):
                    for key, value in _child(flag, path).items():
                        row[key] = min(row.get(key, value), value)
            print(f"measured {row['robot']}", file=sys.stderr, flush=True)
            rows.append(row)
    print(table(rows))
    print(f"\n(CPU seconds, the fastest of {args.repeats} processes; Python {sys.version.split()[0]})")


if __name__ == "__main__":
    main()
