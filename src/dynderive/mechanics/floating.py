"""Compatibility names for ``floating_sheet.py`` until it imports ``tree.py`` (remove at merge)."""

from .tree import Offsets, efforts, not_built, offsets, quaternion_matrix

__all__ = ["Offsets", "efforts", "not_built", "offsets", "quaternion_matrix"]
