"""Old import path of ``render.sheets.floating_latex`` (removed once every importer uses the new one)."""

import sys

from .sheets import floating_latex

sys.modules[__name__] = floating_latex
