"""Checks of a derivation and its generated code (``checks``), and the Pinocchio model built
from a ``Robot`` for independent comparisons (``pinocchio_model``; Pinocchio is optional)."""
