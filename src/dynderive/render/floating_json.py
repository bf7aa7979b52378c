"""Old import path of ``render.sheets.floating_json`` (removed once every importer uses the new one)."""

import sys

from .sheets import floating_json

sys.modules[__name__] = floating_json
