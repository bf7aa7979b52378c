"""The sheets' drawings (issue 32, "Drawings in TikZ"): planar robots as links with thickness
through their centres of mass, joints, frames, coordinates; 3-D robots as a kinematic diagram.

Checked without TeX: each centre of mass lies on its link's drawn body; the joints sit where
an independent forward kinematics (written here from the robot file) puts them at the drawn
configuration; a 3-D diagram's joint origins are the projections of the engine's kinematics;
arcs, travel arrows and frames lie where their coordinates say; labels clear the links; text
from the robot file is escaped; the output is deterministic. With TeX (skipped locally
without it, required in CI): sheets with drawings compile, bundled and random robots, a
12-link planar chain and a random 3-D chain among them.
"""

from __future__ import annotations

import math
import os
import random
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy

import dynderive
from dynderive.errors import LatexError
from dynderive.render.sheets.drawing import BAR_MM, OUTLINE_MM, convex_hull, label_size
from dynderive.render.sheets.figure import FRAME_MM, _configuration, planar_figure, sheet_figure
from dynderive.render.sheets.figure_3d import spatial_figure, view
from dynderive.render.sheets.latex_format import Formatter
from dynderive.render.sheets.pdf import tikz_available

from conftest import derivation_of
from random_robots import random_planar_tree
from random_robots3d import random_spatial_tree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from models import planar_chain_yaml, spatial_chain_yaml  # noqa: E402

PLANAR = ["double_pendulum", "planar_3r", "rp_arm", "cart_pole", "cart_pole_damped", "mass_spring_damper",
          "four_bar", "slider_crank"]
SPATIAL = ["elbow_arm", "ur5", "panda", "spatial_four_bar", "bennett"]


def _figure(derivation):
    return sheet_figure(derivation, Formatter.of(derivation))


def _derive_text(tmp_path: Path, text: str):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    return dynderive.derive(dynderive.load_robot(path))


def _xy(pair) -> tuple[float, float]:
    return float(pair[0]), float(pair[1])


def _direction(a, b) -> float:
    return math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))


def _values(derivation) -> dict:
    table = derivation.symbols
    return {table.parameters[p.name]: sympy.Float(p.value if p.value is not None else 1.0)
            for p in derivation.robot.parameters}


def _planar_kinematics(derivation, q) -> dict[str, tuple[float, float, float]]:
    """Each link's frame (x, y, angle) at ``q``, composed here from the robot file's joints."""
    robot, table, values = derivation.robot, derivation.symbols, _values(derivation)

    def num(entry) -> float:
        return float(sympy.sympify(table.expr(entry)).xreplace(values))

    index = {name: i for i, name in enumerate(robot.coordinates)}
    frames = {"world": (0.0, 0.0, 0.0)}
    todo = list(robot.joints)
    while todo:
        joint = next(j for j in todo if j.parent in frames)
        todo.remove(joint)
        x, y, angle = frames[joint.parent]
        ox, oy, otheta = ([num(e) for e in joint.origin] + [0.0, 0.0, 0.0])[:3]
        jx, jy, ja = x + math.cos(angle) * ox - math.sin(angle) * oy, y + math.sin(angle) * ox + math.cos(angle) * oy, angle + otheta
        value = q[index[joint.name]] if joint.moves else 0.0
        if joint.type == "revolute":
            frames[joint.child] = (jx, jy, ja + value)
        elif joint.type == "prismatic":
            ax, ay = (num(e) for e in joint.axis[:2])
            norm = math.hypot(ax, ay)
            frames[joint.child] = (jx + value * (math.cos(ja) * ax - math.sin(ja) * ay) / norm,
                                   jy + value * (math.sin(ja) * ax + math.cos(ja) * ay) / norm, ja)
        else:
            frames[joint.child] = (jx, jy, ja)
    return frames


def _distance_to_polygon(p, polygon) -> float:
    """0 inside a convex polygon (counter-clockwise), else the distance to its boundary."""
    if len(polygon) >= 3 and all((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= -1e-9
                                 for a, b in zip(polygon, polygon[1:] + polygon[:1])):
        return 0.0
    best = math.inf
    for a, b in zip(polygon, polygon[1:] + polygon[:1]):
        ab = (b[0] - a[0], b[1] - a[1])
        t = 0.0 if ab == (0.0, 0.0) else max(0.0, min(1.0, ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / (ab[0] ** 2 + ab[1] ** 2)))
        best = min(best, math.dist(p, (a[0] + t * ab[0], a[1] + t * ab[1])))
    return best


def _random_planar(tmp_path: Path, seed: int, n: int):
    return _derive_text(tmp_path, random_planar_tree(random.Random(seed), n).yaml_text)


# ---- planar: the links carry their centres of mass; the joints are where the kinematics says

@pytest.mark.parametrize("robot", PLANAR)
def test_each_centre_of_mass_lies_on_its_link_body(robot):
    """The COM symbol of every link is inside its drawn body (the outlined bar or plate: the
    hull's polygon thickened by the stroke), so it never floats beside its link."""
    derivation = derivation_of(robot)
    _check_coms_on_bodies(derivation, _figure(derivation))


def test_random_trees_carry_their_centres_of_mass(tmp_path):
    for seed, n in [(0, 3), (1, 4), (2, 5), (3, 3), (4, 5), (7, 2)]:
        derivation = _random_planar(tmp_path, seed, n)
        _check_coms_on_bodies(derivation, planar_figure(derivation, Formatter.of(derivation)))


def _check_coms_on_bodies(derivation, figure) -> None:
    reach = BAR_MM / 2 - OUTLINE_MM + 0.02   # the light fill's half width, and the text's rounding
    for link in derivation.robot.links:
        com = _xy(figure["anchors"][f"com:{link.name}"])
        (symbol,) = [i for i in figure["items"] if i["kind"] == "com" and i["tag"] == link.name]
        assert _xy(symbol["centre"]) == com
        bodies = [i for i in figure["items"] if i["style"] == "body" and i["tag"] == link.name]
        if not bodies:   # a body of one point: its joint, where the COM sits
            assert math.dist(com, _xy(figure["anchors"][f"joint:{derivation.robot.parent_joint(link.name).name}"])) < 0.02
            continue
        polygon = [_xy(p) for p in bodies[0]["points"]]
        assert _distance_to_polygon(com, polygon) <= reach, (link.name, com, polygon)
        edges = [i for i in figure["items"] if i["style"] == "edge" and i["tag"] == link.name]
        assert edges and edges[0]["points"] == bodies[0]["points"]   # outlined


@pytest.mark.parametrize("robot", PLANAR)
def test_joints_are_drawn_where_the_kinematics_puts_them(robot):
    """Every joint's point, relative to the world origin, is the drawing's scale times the
    position an independent forward kinematics gives at the drawn configuration (closed
    loops: the loop's two sides meet)."""
    derivation = derivation_of(robot)
    figure = _figure(derivation)
    _check_joints(derivation, figure)


def test_random_tree_joints_are_where_the_kinematics_puts_them(tmp_path):
    for seed, n in [(5, 3), (6, 5)]:
        derivation = _random_planar(tmp_path, seed, n)
        _check_joints(derivation, planar_figure(derivation, Formatter.of(derivation)))


def _check_joints(derivation, figure) -> None:
    frames = _planar_kinematics(derivation, figure["q"])
    origin, scale = _xy(figure["anchors"]["world"]), figure["scale"]
    for joint in derivation.robot.joints:
        x, y, _ = frames[joint.child]
        drawn = _xy(figure["anchors"][f"joint:{joint.name}"])
        assert drawn == pytest.approx((origin[0] + scale * x, origin[1] + scale * y), abs=0.02), joint.name
        if joint.type == "revolute":   # its symbol is there
            assert any(i["kind"] == "circle" and i["tag"] == joint.name and _xy(i["centre"]) == drawn
                       for i in figure["items"])


def test_planar_drawing_at_the_reference_configuration_and_its_caption():
    """The double pendulum at 30 degrees per joint: the first link rises at 30 degrees, the
    second at 60; the caption says what is drawn, not how to read it."""
    derivation = derivation_of("double_pendulum")
    figure = _figure(derivation)
    assert figure["configuration"] == r"q_{1} = 30^\circ, q_{2} = 30^\circ"
    assert figure["caption"] == r"The robot at $q_{1} = 30^\circ, q_{2} = 30^\circ$."
    a, b = _xy(figure["anchors"]["joint:q1"]), _xy(figure["anchors"]["joint:q2"])
    c = _xy(figure["anchors"]["com:link2"]) if "com:link2" in figure["anchors"] else None
    assert _direction(a, b) == pytest.approx(30.0, abs=0.5)
    if c is not None:
        assert _direction(b, c) == pytest.approx(60.0, abs=0.5)
    tex = dynderive.render_latex(derivation)
    assert r"\begin{tikzpicture}" in tex and r"\begin{picture}" not in tex and r"\usepackage{tikz}" in tex
    assert tex.count(r"\path[") == len([i for i in figure["items"] if i["kind"] != "label"])
    assert "The robot at $q_{1} = 30^\\circ, q_{2} = 30^\\circ$." in tex and "circles" not in tex


@pytest.mark.parametrize("name, zero, child", [
    ("double_pendulum", [0.0, 30.0], [30.0, 60.0]),
    ("planar_3r", [0.0, 30.0, 60.0], [30.0, 60.0, 90.0]),
    ("cart_pole", [90.0], [120.0]),   # theta from the cart's y-axis (its joint origin turns by pi/2)
])
def test_revolute_arcs_run_from_the_zero_direction_to_the_child_link(name, zero, child):
    """Each angle's arc starts on the joint frame's zero direction and ends on the child
    link's direction, 30 degrees further counter-clockwise, centred on its joint; the dashed
    reference line lies along the zero direction (not where the world's x axis already is)."""
    derivation = derivation_of(name)
    figure = _figure(derivation)
    arcs = [i for i in figure["items"] if i["kind"] == "arc"]
    assert [float(a["start"]) for a in arcs] == zero and [float(a["end"]) for a in arcs] == child
    for arc, start in zip(arcs, zero):
        centre, radius = _xy(arc["centre"]), float(arc["radius"])
        assert centre == _xy(figure["anchors"][f"joint:{arc['tag']}"])
        assert math.dist(_xy(arc["from"]), centre) == pytest.approx(radius, abs=0.02)
        assert _direction(centre, _xy(arc["from"])) == pytest.approx(start, abs=0.5)
        ray = (math.cos(math.radians(start)), math.sin(math.radians(start)))
        dashes = [i for i in figure["items"] if i["style"] == "dashed" and i["tag"] == arc["tag"]]
        for dash in dashes:
            for p in map(_xy, dash["points"]):
                along = (p[0] - centre[0]) * ray[0] + (p[1] - centre[1]) * ray[1]
                assert along >= -0.05 and math.dist(p, (centre[0] + along * ray[0], centre[1] + along * ray[1])) < 0.05
    if name != "cart_pole":   # the first joint's zero direction is the world's x axis: no dashes
        tags = {i["tag"] for i in figure["items"] if i["style"] == "dashed"}
        assert arcs[0]["tag"] not in tags and all(a["tag"] in tags for a in arcs[1:])


@pytest.mark.parametrize("name", ["rp_arm", "cart_pole", "slider_crank"])
def test_prismatic_arrows_lie_along_the_axis_over_the_travel(name):
    """A prismatic coordinate's arrow is parallel to the slide, beside it, as long as the
    travel (the scale times the coordinate), ending level with the block."""
    derivation = derivation_of(name)
    figure = _figure(derivation)
    joint = next(j for j in derivation.robot.joints if j.type == "prismatic")
    value = figure["q"][derivation.robot.coordinates.index(joint.name)]
    (arrow,) = [i for i in figure["items"] if i["kind"] == "path" and i["arrow"] and i["tag"] == joint.name]
    start, end = map(_xy, arrow["points"])
    assert math.dist(start, end) == pytest.approx(abs(value) * figure["scale"], abs=0.05)
    block = _xy(figure["anchors"][f"joint:{joint.name}"])
    axis = math.radians(_direction(start, end))
    offset = (block[0] - end[0]) * -math.sin(axis) + (block[1] - end[1]) * math.cos(axis)
    along = (block[0] - end[0]) * math.cos(axis) + (block[1] - end[1]) * math.sin(axis)
    assert abs(along) < 0.05 and abs(offset) >= 3.0
    ticks = [i for i in figure["items"] if i["style"] == "thin" and not i.get("arrow") and i["tag"] == joint.name]
    assert len(ticks) == 2


def test_named_frames_are_drawn_on_their_link():
    """The 3R arm's tool frame: two axes of FRAME_MM at the end of link 3 (straight up at 90
    degrees), x along the link, y to the left, labelled with its name; link 3's body reaches it."""
    derivation = derivation_of("planar_3r")
    figure = _figure(derivation)
    axes = [i for i in figure["items"] if i["tag"] == "tool" and i["kind"] == "path"]
    (origin, x_tip), (origin_y, y_tip) = ([_xy(p) for p in a["points"]] for a in axes)
    assert origin == origin_y and all(a["arrow"] for a in axes)
    assert _direction(origin, x_tip) == pytest.approx(90.0, abs=0.5)
    assert _direction(origin, y_tip) == pytest.approx(180.0, abs=0.5)
    assert math.dist(origin, x_tip) == pytest.approx(FRAME_MM, abs=0.05)
    body = next(i for i in figure["items"] if i["style"] == "body" and i["tag"] == "link3")
    assert _distance_to_polygon(origin, [_xy(p) for p in body["points"]]) < 0.02
    assert any(i["kind"] == "label" and i["text"] == r"\mathrm{tool}" for i in figure["items"])


def test_closed_loops_are_drawn_assembled():
    """The four-bar with q1 at 30 degrees and the others assembled on the default assembly's
    branch: the constraints hold, the loop joint is drawn once where both sides meet, and
    the world's pivots are hatched."""
    derivation = derivation_of("four_bar")
    figure = _figure(derivation)
    assert figure["configuration"].startswith(r"q_{1} = 30^\circ, ") and figure["caption"].endswith("its loops closed.")
    loops, table = derivation.loop_model, derivation.symbols
    values = {table.parameters[p.name]: p.value for p in derivation.robot.parameters}
    q = _configuration(derivation.robot, table, derivation.link_kinematics, values, loops)
    assert q == figure["q"]
    at = {s: sympy.Float(v) for s, v in (values | dict(zip(table.q, q))).items()}
    assert max(abs(float(r.xreplace(at))) for r in loops.constraints) < 1e-9
    assert abs(q[2] - loops.assembled[2]) < 1.0   # the assembled branch
    loop = _xy(figure["anchors"]["loop:c1"])
    frames = _planar_kinematics(derivation, q)
    for name in ("coupler", "rocker"):   # both bodies reach the loop joint
        body = next(i for i in figure["items"] if i["style"] == "body" and i["tag"] == name)
        assert _distance_to_polygon(loop, [_xy(p) for p in body["points"]]) < 0.02
    assert len([i for i in figure["items"] if i["tag"] == "loop"]) == 1
    assert len([i for i in figure["items"] if i["style"] == "ground" and i.get("closed")]) == 2   # two pedestals
    assert frames["rocker"][0] > 0


def test_labels_clear_the_links_and_the_drawing_is_deterministic():
    """No label box crosses a link's bar; the same robot gives the same drawing, with two
    decimals everywhere."""
    for name in ("rp_arm", "double_pendulum", "planar_3r", "cart_pole", "slider_crank", "ur5"):
        derivation = derivation_of(name)
        figure = _figure(derivation)
        assert figure == _figure(derivation)
        texts = [v for i in figure["items"] for key in ("points", "centre", "at") for p in
                 (i.get(key) if key == "points" else [i.get(key)]) or [] if p for v in p]
        assert texts and all(len(v.split(".")[1]) == 2 for v in texts)
        for label in (i for i in figure["items"] if i["kind"] == "label"):
            x, y = _xy(label["at"])
            w, h = label_size(label["text"])
            for body in (i for i in figure["items"] if i["style"] == "edge"):
                points = [_xy(p) for p in body["points"]]
                for a, b in zip(points, points[1:] + points[:1]):
                    for k in range(51):
                        p = (a[0] + k / 50 * (b[0] - a[0]), a[1] + k / 50 * (b[1] - a[1]))
                        assert not (abs(p[0] - x) < w and abs(p[1] - y) < h), (name, label["text"])


# ---- 3-D: a kinematic diagram of the joint axes at the reference configuration --------------

@pytest.mark.parametrize("robot", SPATIAL)
def test_3d_diagram_projects_the_engines_kinematics(robot):
    """Each joint origin and centre of mass in the diagram is the axonometric projection
    (times the scale) of the engine's own kinematics at the drawn configuration (zero, or
    the default assembly for loops); each moving joint has its symbol and its label."""
    derivation = derivation_of(robot)
    figure = _figure(derivation)
    assert figure is not None
    right, up, towards = view()
    assert np.allclose([right @ up, right @ towards, up @ towards], 0.0) and up[2] > 0
    table, values = derivation.symbols, _values(derivation)
    at = values | {s: sympy.Float(v) for s, v in zip(table.q, figure["q"])}
    origin, scale = _xy(figure["anchors"]["world"]), figure["scale"]

    def projected(p) -> tuple[float, float]:
        return origin[0] + scale * float(right @ p), origin[1] + scale * float(up @ p)

    robot_ = derivation.robot
    for link in derivation.link_kinematics:
        com = np.array([float(v) for v in link.com_world.xreplace(at)], dtype=float)
        R = np.array(link.rotation.xreplace(at).evalf(), dtype=float)
        local = np.array([float(sympy.sympify(table.expr(e)).xreplace(values)) for e in
                          next(lk for lk in robot_.links if lk.name == link.name).com])
        assert _xy(figure["anchors"][f"com:{link.name}"]) == pytest.approx(projected(com), abs=0.02)
        joint = robot_.parent_joint(link.name)
        if joint.type == "revolute":   # its origin is the link frame's
            assert _xy(figure["anchors"][f"joint:{joint.name}"]) == pytest.approx(projected(com - R @ local), abs=0.02)
    for joint in robot_.joints:
        if joint.moves:
            assert any(i["tag"] == joint.name and i["style"] == "shade" for i in figure["items"]), joint.name
            assert any(i["tag"] == joint.name and i["kind"] == "label" for i in figure["items"]), joint.name
    assert figure["caption"].startswith("The robot at its zero configuration" if not robot_.loops
                                        else "The robot at its default assembly")


def test_3d_diagram_of_a_random_chain_and_prismatic_joints(tmp_path):
    """A random 3-D chain (revolute and prismatic joints): every moving joint drawn (a
    cylinder's or a box's hull), the world's three axes labelled."""
    derivation = _derive_text(tmp_path, random_spatial_tree(random.Random(3), 5).yaml_text)
    figure = spatial_figure(derivation, Formatter.of(derivation))
    labels = {i["text"] for i in figure["items"] if i["kind"] == "label"}
    assert {"x_s", "y_s", "z_s"} <= labels
    for joint in derivation.robot.joints:
        if joint.moves:
            shades = [i for i in figure["items"] if i["tag"] == joint.name and i["style"] == "shade"]
            assert shades and len(shades[0]["points"]) >= 4 and shades[0]["closed"]
    assert planar_figure(derivation, Formatter.of(derivation)) is None


# ---- text from the robot file ------------------------------------------------------------------

HOSTILE_PLANAR = """
name: hostile
planar: true
gravity: [0, -9.81]
links:
  - {name: __l__a_, mass: 1, com: [0.5, 0], inertia: 0.1}
  - {name: _b__, mass: 1, com: [0.5, 0], inertia: 0.1}
joints:
  - {name: j__1__, type: revolute, parent: world, child: __l__a_, origin: [0, 0]}
  - {name: j__2_, type: prismatic, parent: __l__a_, child: _b__, origin: [1, 0], axis: [1, 0]}
frames:
  - {name: __tool__x_, link: _b__, origin: [1, 0]}
"""


def test_names_from_the_robot_file_are_escaped(tmp_path):
    """Frame names reach the drawing only through escape_tex (``_`` as ``\\_``): the labels
    hold no bare subscript of the file's text, the sheet holds the escaped name."""
    derivation = _derive_text(tmp_path, HOSTILE_PLANAR)
    figure = planar_figure(derivation, Formatter.of(derivation))
    labels = [i["text"] for i in figure["items"] if i["kind"] == "label"]
    assert r"\mathrm{\_\_tool\_\_x\_}" in labels
    tex = dynderive.render_latex(derivation)
    assert r"{$\mathrm{\_\_tool\_\_x\_}$};" in tex
    text = (ROOT / "robots" / "elbow_arm.yaml").read_text().replace("name: wrist", "name: __w_r__")
    spatial = _derive_text(tmp_path, text)
    labels = [i["text"] for i in spatial_figure(spatial, Formatter.of(spatial))["items"] if i["kind"] == "label"]
    assert r"\mathrm{\_\_w\_r\_\_}" in labels


# ---- the sheets compile with their drawings ---------------------------------------------------

@pytest.fixture
def tex():
    missing = [t for t in ("latexmk", "pdflatex") if shutil.which(t) is None]
    if not missing and not tikz_available():
        missing = ["TikZ (texlive-pictures)"]   # the sheets' drawings
    if missing:
        if os.environ.get("CI"):
            raise RuntimeError(f"CI must run the PDF tests, but these tools are missing: {missing}")
        pytest.skip(f"no TeX engine ({', '.join(missing)} missing)")


SHEETS = [("bundled", "four_bar"), ("bundled", "slider_crank"), ("bundled", "elbow_arm"),
          ("bundled", "spatial_four_bar"), ("hostile", ""), ("planar chain", "12"), ("3-D chain", "4")]


@pytest.mark.pdf
@pytest.mark.parametrize(("kind", "which"), SHEETS, ids=[f"{k.replace(' ', '-')}-{w}" for k, w in SHEETS])
def test_sheets_with_drawings_compile(tmp_path, tex, kind, which):
    from dynderive.render.sheets.pdf import compile_pdf_report

    if kind == "bundled":
        derivation = derivation_of(which)
    elif kind == "hostile":
        derivation = _derive_text(tmp_path, HOSTILE_PLANAR)
    elif kind == "planar chain":
        derivation = _derive_text(tmp_path, planar_chain_yaml(int(which), seed=0))
    else:
        derivation = _derive_text(tmp_path, spatial_chain_yaml(int(which), seed=1))
    sheet = dynderive.render_latex(derivation)
    assert r"\begin{tikzpicture}" in sheet
    try:
        pdf, pages, _ = compile_pdf_report(sheet, "sheet")
    except LatexError as exc:
        pytest.fail(f"{kind} {which}: {exc}", pytrace=False)
    assert pdf.startswith(b"%PDF") and pages >= 1


def test_convex_hull_of_a_link():
    """A bar's two ends; a plate's corners counter-clockwise, inner and repeated points dropped."""
    assert convex_hull([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 0.0)]) == [(0.0, 0.0), (2.0, 0.0)]
    assert convex_hull([(0.0, 0.0), (2.0, 0.0), (1.0, 0.5), (2.0, 2.0), (0.0, 2.0)]) == [
        (0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]
    assert convex_hull([(1.0, 1.0)]) == [(1.0, 1.0)]


def test_every_style_is_drawn_by_tikz_and_svg():
    """The styles the drawings use are defined in the TikZ picture and in the HTML's SVG."""
    from dynderive.render.sheets.drawing import HALF_WIDTH
    from dynderive.render.sheets.html_svg import STYLES

    template = (ROOT / "templates" / "drawing.tex.j2").read_text()
    assert all(f"  {style}/.style={{" in template for style in HALF_WIDTH)
    assert set(STYLES) == set(HALF_WIDTH)
    used = {i["style"] for name in ("rp_arm", "four_bar", "cart_pole", "ur5") for i in _figure(derivation_of(name))["items"]}
    assert used - {"label"} <= set(HALF_WIDTH) and {"edge", "body", "joint", "shade", "ground", "hatch"} <= used


def test_no_zero_length_item_in_large_and_3d_drawings(tmp_path):
    """A 12-link planar chain (its picture-mode drawing overflowed before) and random 3-D
    trees: no path with a repeated point, no arc without sweep, everything inside the drawing."""
    derivations = [_derive_text(tmp_path, planar_chain_yaml(12, seed=0))]
    derivations += [_derive_text(tmp_path, random_spatial_tree(random.Random(seed), n).yaml_text)
                    for seed, n in ((0, 2), (1, 4), (5, 6))]
    for derivation in derivations:
        figure = _figure(derivation)
        width, height = float(figure["width"]), float(figure["height"])
        for item in figure["items"]:
            if item["kind"] == "path":
                points = item["points"] + (item["points"][:1] if item["closed"] else [])
                assert len(item["points"]) >= 2 and all(a != b for a, b in zip(points, points[1:])), item
            if item["kind"] == "arc":
                assert abs(float(item["end"]) - float(item["start"])) >= 1.0 and float(item["radius"]) > 0
            for x, y in item.get("points", [item.get("centre") or item.get("at")]):
                assert 0.0 <= float(x) <= width and 0.0 <= float(y) <= height, item
