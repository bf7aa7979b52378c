"""Old import path of ``render.sheets.figure_3d`` (removed once every importer uses the new one)."""

import sys

from .sheets import figure_3d

sys.modules[__name__] = figure_3d
