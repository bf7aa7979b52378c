"""``dynderive import``: a URDF file converted into the equivalent YAML robot file."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import InputError
from .options import problem


def import_urdf(urdf: str, output: Path, floating_base: bool, echo: Callable[[str], None]) -> None:
    """Read ``urdf`` (a file or a bundled robot's name), check it as any robot file, and write
    ``output``; ``floating_base`` joins the world to the root link by a floating joint."""
    from ..input.loader import read_text, resolve_robot_path
    from ..input.schema import validate
    from ..input.urdf import read_urdf, to_yaml
    from .output import check_output_paths, write_all

    path = resolve_robot_path(urdf)
    check_output_paths({"--output": output}, (path,))
    if path.suffix.lower() in (".yaml", ".yml"):
        raise InputError(problem(str(path), "is already a YAML robot file (import converts URDF files)"))
    document = read_urdf(read_text(path), str(path), floating_base)
    for note in document.notes:
        echo(note)
    validate(document)  # the same checks as any robot file, before anything is written
    if document.impossible_inertias:   # a robot file's inertias must be physical: it would not load
        raise InputError([document.problem(path + ("inertia",), f"{document.labels[path]} inertia: not imported: it "
                                           "misses the triangle inequality (see the note), which a YAML robot file "
                                           "may not; correct it in the URDF, or use the URDF itself")
                          for path in sorted(document.impossible_inertias)])
    write_all({output: to_yaml(document.data, path.name).encode()})
    echo(f"wrote {output}")
