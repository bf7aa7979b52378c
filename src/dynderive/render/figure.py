"""Old import path of ``render.sheets.figure`` (removed once every importer uses the new one)."""

import sys

from .sheets import figure

sys.modules[__name__] = figure
