"""Old import path of ``render.sheets.html_math`` (removed once every importer uses the new one)."""

import sys

from .sheets import html_math

sys.modules[__name__] = html_math
