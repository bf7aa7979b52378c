"""Compatible names for imports not yet moved (tests of other areas): the NumPy target's one
renderer is ``code.py``, for every robot. To be deleted once nothing imports it."""

from .code import render_code as render_floating_code
from .code import render_code_tests as render_floating_code_tests

__all__ = ["render_floating_code", "render_floating_code_tests"]
