"""Old import path of ``render.sheets.html_recursion`` (removed once every importer uses the new one)."""

import sys

from .sheets import html_recursion

sys.modules[__name__] = html_recursion
