"""Old import path of the quasi-velocity sheet (now ``render_latex`` for every robot), kept for
imports outside the sheets until they use ``render.sheets``."""

from .sheets.latex import render_latex
from .sheets.latex_format import coordinate_names  # noqa: F401
from .sheets.quasi_velocity import dissipative_forces  # noqa: F401


def render_floating_latex(derivation, template_dir=None, digits=None):  # noqa: ANN001, ANN201
    return render_latex(derivation, template_dir, digits=digits)
