"""Old import path of the quasi-velocity JSON dump (now ``render_json`` for every robot), kept for
imports outside the sheets until they use ``render.sheets``."""

from .sheets.json import render_json as render_floating_json  # noqa: F401
