"""One row of the CPython binding's table (``c_extension.py``): a Python function of the
extension and the C function it calls for each state; the rows are ``c_extension.bindings``."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Binding:
    """One Python function of the extension and the C function of the same name it calls for
    each state.

    ``inputs``: the array arguments in order, each (name, size of its last axis); ``outputs``:
    the shape of each result for one state (several: a tuple is returned). ``returns``:
    "void", "status" (nonzero: the state could not be computed, its results are NaN) or
    "value" (the C function returns the one scalar result). ``optional``: the last input may
    be omitted or None (zeros, as ``u``). ``frame``: a frame name follows the arrays.
    ``wrenches``: the C function (without the robot's prefix) that takes the inputs, then the
    wrenches (NFRAMES x twist, row-major, zero for a frame without one), then the parameters
    and outputs; the Python function takes ``wrenches=None`` after the arrays. ``smoothing``:
    takes ``friction_smoothing``; ``refuses_negative``: a negative one is a ValueError (where
    the NumPy module's ``_direction`` raises). ``scalar``: one state gives a NumPy scalar, not
    a 0-d array (as the NumPy module's ``kinetic_energy`` of a program-built robot).
    ``members``: members of the C parameters struct after ``friction_smoothing`` (a loop
    robot's Baumgarte gains ``alpha``, ``beta``) that the function takes as keywords, before
    ``friction_smoothing`` (their default: the C target's). ``error``: the C function's nonzero
    return raises ``ValueError(error)`` (where the NumPy module raises it), for any state of a
    batch; it implies ``returns`` "status". ``parameters``: False where the C function takes no
    parameters struct and the Python function no parameter keywords (the configuration maps of a
    robot with quaternions). ``number``: the last input is a number per
    state (shape (...), as ``integrate``'s ``dt``), this C literal when omitted."""

    name: str
    inputs: tuple[tuple[str, int], ...]
    outputs: tuple[tuple[int, ...], ...]
    doc: str
    returns: str = "void"
    optional: bool = False
    frame: bool = False
    wrenches: str | None = None
    smoothing: bool = False
    refuses_negative: bool = False
    scalar: bool = False
    members: tuple[str, ...] = ()
    error: str | None = None
    parameters: bool = True
    number: str | None = None
