"""Old import path of ``render.sheets.drawing`` (removed once every importer uses the new one)."""

import sys

from .sheets import drawing

sys.modules[__name__] = drawing
