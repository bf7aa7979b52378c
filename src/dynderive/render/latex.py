"""Old import path of ``render.sheets.latex`` (removed once every importer uses the new one)."""

import sys

from .sheets import latex

sys.modules[__name__] = latex
