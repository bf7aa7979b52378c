"""The robot as plain typed data (``Robot``), the safe expression parser and the symbols.

No file is read and nothing is derived here: ``input`` builds a ``Robot`` from a file,
``mechanics`` derives from it.
"""

from .robot import Joint, Link, LoopJoint, Parameter, Robot

__all__ = ["Joint", "Link", "LoopJoint", "Parameter", "Robot"]
