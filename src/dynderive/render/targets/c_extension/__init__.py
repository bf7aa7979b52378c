"""The C target compiled into a CPython extension (``--c-extension``): ``<name>_dynamics_c.*``,
the NumPy module's API (DESIGN.md section 9). Needs a C compiler; a compiler that fails leaves
its log beside the other outputs."""

from __future__ import annotations

import sysconfig

from ....derivation import Derivation
from ..target import MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS, Target
from .compile import extension_files, failure_files, require_compiler, toolchain


def offered(derivation: Derivation) -> set[str]:
    """The functions of the binding's table."""
    from .c_extension import bindings
    from .contacts import contact_names

    return {b.name for b in bindings(derivation)} | contact_names(derivation)


TARGET = Target(
    name="c-extension", flag="--c-extension", kind="c_extension", title="C extension", column=2,
    help="Write DIR/<name>_dynamics_c.*.so, the C code compiled into a Python extension with the NumPy module's API "
         "(needs a C compiler: CC, cc or gcc).",
    build_help="Write <name>_dynamics_c.*.so, the compiled extension (--check: compiled, not compared).",
    # the extension (this Python's suffix for extensions) and the log of a compiler that failed
    outputs=("{}_dynamics_c" + (sysconfig.get_config_var("EXT_SUFFIX") or ".so"), "{}_dynamics_c.log"),
    # the C target's files it compiles, its binding and the Python of its contact functions
    templates=("c/dynamics.h.j2", "c/dynamics.c.j2", "c_extension/extension.c.j2", "c_extension/extension_contacts.py.j2"),
    render=extension_files, offered=offered,
    progress="",   # build_extension says "compiling the C extension (...)" itself
    needs=require_compiler,
    failure=failure_files, fingerprint=toolchain,
    stale=("{}_dynamics_c.log",),
    not_built=(MAXIMAL_NOT_PRINTED, VECTOR_SPACE_MAPS),
)
