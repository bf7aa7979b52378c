"""MJCF input: time to derive ``--code`` for Gymnasium's humanoid and ant beside the same robot
written as a URDF.

    python benchmarks/mjcf.py [--models humanoid ant] [--rounds 3]

Per model, ``dynderive solve <file> --code`` as a user runs it, in a fresh process, CPU seconds
(user + system, the steadier figure on a shared machine), wall seconds and peak memory, the
best of ``--rounds`` runs taken in turns with the anchor:

- the MJCF file shipped in Gymnasium's wheel (``gymnasium/envs/mujoco/assets``), compiled by
  MuJoCo and mapped by the reader;
- the anchor: the same robot as a URDF, written by this script from the reader's own robot
  data (one URDF link per robot-file link, the free joint a ``floating`` joint, the inertias
  and origins as the reader found them, its frames as massless links welded on), so both derive
  the same tree with the same numbers and frames.
  The script checks that first: both modules' mass matrices at a random state agree to 1e-9
  (the MJCF's armatures taken off: a URDF has no armature, nor springs);
- the same robot as the YAML file ``dynderive import`` writes of the MJCF (drive terms
  included): its time less the MJCF's is what reading MJCF costs (importing and running MuJoCo's
  compiler), the URDF's less the YAML's what the drive terms cost.

Then the goal: the MJCF file takes at most the time of the URDF of the same robot (CPU
seconds), and what reading MJCF costs (the MJCF's time less the YAML's). No figure is typed in.

Needs the ``mjcf`` extra (mujoco) and gymnasium (its models).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from dynderive.input.sources import read_source  # noqa: E402


def gymnasium_model(name: str) -> Path:
    import gymnasium

    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{name}.xml"


def _angle(value) -> float:
    """An ``rpy`` entry of the reader's data: a number, or a quarter turn it wrote as text
    (``pi/2``, ``-pi``, ``3*pi/2``)."""
    if not isinstance(value, str):
        return float(value)
    text = value.replace(" ", "")
    half = text.endswith("/2")
    count = text.removesuffix("/2").removesuffix("pi").removesuffix("*")
    turns = {"": 1, "-": -1}[count] if count in ("", "-") else int(count)
    return turns * math.pi * (0.5 if half else 1.0)


def _rpy(values) -> str:
    return " ".join(repr(_angle(v)) for v in values)


def urdf_of(data: dict) -> str:
    """The reader's robot data as a URDF: a link per robot-file link, a joint per joint."""
    lines = [f"<robot name={quoteattr(data['name'] + '_urdf')}>", '  <link name="world"/>']
    for link in data["links"]:
        ixx, iyy, izz, ixy, ixz, iyz = (float(v) for v in link["inertia"])
        lines.append(f"  <link name={quoteattr(link['name'])}>")
        if float(link["mass"]) > 0:
            com = " ".join(repr(float(v)) for v in link["com"])
            lines += [f'    <inertial><origin xyz="{com}"/><mass value="{float(link["mass"])!r}"/>',
                      f'      <inertia ixx="{ixx!r}" iyy="{iyy!r}" izz="{izz!r}" ixy="{ixy!r}" ixz="{ixz!r}" '
                      f'iyz="{iyz!r}"/></inertial>']
        lines.append("  </link>")
    types = {"revolute": "continuous", "prismatic": "prismatic", "floating": "floating"}
    for joint in data["joints"]:
        xyz = " ".join(repr(float(v)) for v in joint["origin"]["xyz"])
        lines.append(f"  <joint name={quoteattr(joint['name'])} type=\"{types[joint['type']]}\">")
        lines.append(f"    <parent link={quoteattr(joint['parent'])}/><child link={quoteattr(joint['child'])}/>")
        lines.append(f'    <origin xyz="{xyz}" rpy="{_rpy(joint["origin"]["rpy"])}"/>')
        if "axis" in joint:
            lines.append(f'    <axis xyz="{" ".join(repr(float(v)) for v in joint["axis"])}"/>')
        if joint["type"] == "prismatic":
            lines.append('    <limit lower="-10" upper="10" effort="1" velocity="1"/>')
        if joint.get("damping") or joint.get("friction"):
            lines.append(f'    <dynamics damping="{float(joint.get("damping", 0))!r}" '
                         f'friction="{float(joint.get("friction", 0))!r}"/>')
        lines.append("  </joint>")
    for frame in data.get("frames", []):   # a frame: a massless link welded to its link (the URDF reader's frames)
        xyz = " ".join(repr(float(v)) for v in frame["origin"]["xyz"])
        lines.append(f"  <link name={quoteattr(frame['name'])}/>")
        lines.append(f"  <joint name={quoteattr(frame['name'] + '_weld')} type=\"fixed\">")
        lines.append(f"    <parent link={quoteattr(frame['link'])}/><child link={quoteattr(frame['name'])}/>")
        lines.append(f'    <origin xyz="{xyz}" rpy="{_rpy(frame["origin"]["rpy"])}"/>')
        lines.append("  </joint>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def solve_code(path: Path, out: Path) -> dict:
    """``solve <path> --code`` in a fresh process: its own CPU seconds, wall seconds, peak MB."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])))
    command = [sys.executable, "-m", "dynderive", "solve", str(path), "--code", "--out", str(out), "-q"]
    start = time.perf_counter()
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{path.name}: solve --code failed\n{process.stderr.read().decode()[-2000:]}")
    return {"cpu": usage.ru_utime + usage.ru_stime, "wall": wall, "mb": usage.ru_maxrss / 1024}


def _module(folder: Path):
    path = next(folder.glob("*_dynamics.py"))
    spec = importlib.util.spec_from_file_location(f"bench_{folder.name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def same_robot(mjcf_out: Path, urdf_out: Path, data: dict) -> float:
    """Largest relative difference of the two modules' mass matrices at a random state, the
    MJCF's armatures taken off its diagonal (a URDF has none)."""
    a, b = _module(mjcf_out), _module(urdf_out)
    rng = np.random.default_rng(7)
    q = rng.uniform(-1, 1, a.NQ)
    if a.NQ != a.NV:   # the free joint's quaternion (x, y, z, w after the position)
        q[3:7] /= np.linalg.norm(q[3:7])
    sizes = {"floating": 6, "spherical": 3}
    armature = [float(j.get("armature", 0)) for j in data["joints"] for _ in range(sizes.get(j["type"], 1))]
    M_a, M_b = a.mass_matrix(q) - np.diag(armature), b.mass_matrix(q)
    return float(np.max(np.abs(M_a - M_b)) / np.max(np.abs(M_b)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="+", default=["humanoid", "ant"])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rows, started = [], time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.models:
            mjcf = gymnasium_model(name)
            data = read_source(mjcf).data
            urdf = Path(tmp) / f"{name}.urdf"
            urdf.write_text(urdf_of(data))
            yaml_file = Path(tmp) / f"{name}.yaml"
            subprocess.run([sys.executable, "-m", "dynderive", "import", str(mjcf), "-o", str(yaml_file)], check=True,
                           stderr=subprocess.DEVNULL, env=dict(os.environ, PYTHONPATH=str(ROOT / "src")))
            best: dict[str, dict] = {}
            for round_ in range(args.rounds):
                for kind, path in (("MJCF", mjcf), ("YAML", yaml_file), ("URDF", urdf)):
                    out = Path(tmp) / f"{name}_{kind}_{round_}"
                    result = solve_code(path, out)
                    if kind not in best or result["cpu"] < best[kind]["cpu"]:
                        best[kind] = result | {"out": out}
            difference = same_robot(best["MJCF"]["out"], best["URDF"]["out"], data)
            if difference > 1e-9:
                raise SystemExit(f"{name}: the MJCF and URDF modules differ ({difference:.1e}): not the same robot")
            nq, nv = _module(best["MJCF"]["out"]).NQ, _module(best["MJCF"]["out"]).NV
            rows.append((name, nq, nv, best, difference))
    print(f"MJCF against the same robot as URDF: solve --code, best of {args.rounds} fresh processes\n")
    header = f"{'model':<10} {'nq':>3} {'nv':>3} {'input':<5} {'CPU s':>6} {'wall s':>7} {'peak MB':>8}  M differs by"
    print(header)
    print("-" * len(header))
    for name, nq, nv, best, difference in rows:
        for kind in ("MJCF", "YAML", "URDF"):
            r = best[kind]
            tail = f"  {difference:.0e}" if kind == "MJCF" else ""
            print(f"{name:<10} {nq:>3} {nv:>3} {kind:<5} {r['cpu']:>6.1f} {r['wall']:>7.1f} {r['mb']:>8.0f}{tail}")
    print("\ngoal                                          measured                     reading MJCF (MJCF - YAML)")
    for name, _, _, best, _ in rows:
        mj, ur, ya = best["MJCF"]["cpu"], best["URDF"]["cpu"], best["YAML"]["cpu"]
        verdict = "met" if mj <= ur else "NOT MET"
        print(f"{name + ': MJCF --code CPU <= the URDF':<45} {mj:.1f} vs {ur:.1f} s ({mj / ur:.2f}x) {verdict:<8} "
              f"{mj - ya:+.1f} s")
    import platform

    import mujoco
    print(f"\n(Python {platform.python_version()}, MuJoCo {mujoco.__version__}, {time.strftime('%Y-%m-%d')}, "
          f"{time.perf_counter() - started:.0f} s in all)")


if __name__ == "__main__":
    main()
