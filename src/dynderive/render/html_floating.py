"""Old import path of ``render.sheets.html_floating`` (removed once every importer uses the new one)."""

import sys

from .sheets import html_floating

sys.modules[__name__] = html_floating
