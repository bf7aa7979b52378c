"""Old import path of ``render.sheets.linebreak`` (removed once every importer uses the new one)."""

import sys

from .sheets import linebreak

sys.modules[__name__] = linebreak
