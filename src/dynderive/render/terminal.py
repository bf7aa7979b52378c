"""Old import path of ``render.sheets.terminal`` (removed once every importer uses the new one)."""

import sys

from .sheets import terminal

sys.modules[__name__] = terminal
