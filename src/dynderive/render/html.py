"""Old import path of ``render.sheets.html`` (removed once every importer uses the new one)."""

import sys

from .sheets import html

sys.modules[__name__] = html
