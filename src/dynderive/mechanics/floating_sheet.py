"""Old import path of ``mechanics.quasi_velocity`` (removed once every importer uses the new one)."""

from .quasi_velocity import is_step_by_step as is_small_floating  # noqa: F401
