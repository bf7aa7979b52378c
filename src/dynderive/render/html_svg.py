"""Old import path of ``render.sheets.html_svg`` (removed once every importer uses the new one)."""

import sys

from .sheets import html_svg

sys.modules[__name__] = html_svg
