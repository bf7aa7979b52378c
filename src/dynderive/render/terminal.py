"""Old import path of ``render.sheets.terminal``, kept for imports outside the sheets until they
use the new one; ``render_floating_terminal`` is ``render_terminal`` now."""

from .sheets.terminal import render_terminal


def render_floating_terminal(derivation, digits=None):  # noqa: ANN001, ANN201
    return render_terminal(derivation, digits)
