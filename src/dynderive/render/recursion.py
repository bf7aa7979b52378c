"""Old import path of ``render.sheets.recursion`` (removed once every importer uses the new one)."""

import sys

from .sheets import recursion

sys.modules[__name__] = recursion
