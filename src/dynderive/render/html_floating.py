"""Old import path of the quasi-velocity HTML page (now ``render_html`` for every robot), kept for
imports outside the sheets until they use ``render.sheets``."""

from .sheets.html import render_html
from .sheets.html_math import coordinate_math_names  # noqa: F401


def render_floating_html(derivation, template_dir=None, digits=None):  # noqa: ANN001, ANN201
    return render_html(derivation, template_dir, digits=digits)
