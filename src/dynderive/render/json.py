"""Old import path of ``render.sheets.json`` (removed once every importer uses the new one)."""

import sys

from .sheets import json

sys.modules[__name__] = json
