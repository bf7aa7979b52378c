"""Draw the README's and the docs' pictures of robots: each bundled planar robot's drawing
(``cart_pole_damped`` is drawn as ``cart_pole``) and the UR5's kinematic diagram, as on their
sheets, to ``docs/images/drawing_<robot>.png``.

    python docs/make_images.py            # from the checkout, with dynderive importable

Each drawing is the sheet's TikZ picture (``templates/drawing.tex.j2``) on a page of its own
size, compiled with pdflatex and rasterised with ``pdftoppm -r 150``; the PDF is reproducible
(no dates, no random ID), so the pictures are the same bytes on every run with the same TeX.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import dynderive
from dynderive.render.environment import render
from dynderive.render.figure import sheet_figure
from dynderive.render.sheets.latex import Formatter

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
#: The robots drawn: every bundled planar robot, and one 3-D diagram.
ROBOTS = ["double_pendulum", "planar_3r", "rp_arm", "cart_pole", "mass_spring_damper", "four_bar",
          "slider_crank", "ur5"]

PAGE = r"""\documentclass{article}
\usepackage[paperwidth=%(width)smm, paperheight=%(height)smm, margin=0mm]{geometry}
\usepackage{amsmath,amssymb,tikz}
\usetikzlibrary{arrows.meta}
\pagestyle{empty}
\pdfinfoomitdate=1 \pdftrailerid{} \pdfsuppressptexinfo=-1
\begin{document}\noindent
%(picture)s
\end{document}
"""


def standalone(robot: str) -> str:
    """The LaTeX document of one robot's drawing, on a page of the drawing's size."""
    derivation = dynderive.derive(dynderive.load_robot(robot))
    figure = sheet_figure(derivation, Formatter.of(derivation))
    if figure is None:
        raise SystemExit(f"{robot}: no drawing")
    picture = render("latex", "drawing.tex.j2", {"figure": figure}, None)
    return PAGE % {"width": figure["width"], "height": figure["height"], "picture": picture}


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for robot in ROBOTS:
        with tempfile.TemporaryDirectory() as folder:
            work = Path(folder)
            (work / "drawing.tex").write_text(standalone(robot))
            subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "drawing.tex"],
                           cwd=work, check=True, capture_output=True)
            subprocess.run(["pdftoppm", "-png", "-r", "150", "-singlefile", "drawing.pdf", "drawing"],
                           cwd=work, check=True)
            shutil.copyfile(work / "drawing.png", OUT / f"drawing_{robot}.png")
        print(f"docs/images/drawing_{robot}.png", file=sys.stderr)


if __name__ == "__main__":
    main()
