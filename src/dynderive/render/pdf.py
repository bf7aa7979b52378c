"""Old import path of ``render.sheets.pdf`` (removed once every importer uses the new one)."""

import sys

from .sheets import pdf

sys.modules[__name__] = pdf
