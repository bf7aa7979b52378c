"""The optional ``frames`` list of a robot file: named frames fixed on links.

Each has a ``name`` (an identifier, unique among the frames: it names the quantities
``p_<frame>``, ``J_<frame>`` and the generated functions' ``frame`` argument, so none of
those may be a quantity the engine derives), the ``link`` it
is fixed on and an ``origin`` in that link's frame, written as a joint's origin. Part of
validation: ``schema.validate`` calls ``read_frames`` and passes it its origin reader.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..model.naming import did_you_mean
from ..model.robot import Frame
from .names import EngineQuantities, check_frame
from .validator import kind

FRAME_KEYS = ("name", "link", "origin")


def read_frames(v: Any, top: dict[str, Any], link_names: dict[str, Any], links_broken: bool, bad_links: set[Any],
                origin: Callable[[Any, tuple[Any, ...]], tuple[Any, ...]], planar: bool = False,
                engine: EngineQuantities | None = None) -> list[Frame]:
    """The frames, every problem reported on the validator ``v`` (a frame naming a link that
    is already reported as bad is not reported again; a frame whose quantities would be named
    as one of ``engine``'s, ``names.engine_quantities``, is refused)."""
    if "frames" not in top:
        return []
    raw = top["frames"]
    if not isinstance(raw, list) or not raw:
        v.error(("frames",), f"frames: expected a non-empty list of frames, got {kind(raw, empty=True)}")
        return []
    frames: list[Frame] = []
    taken: dict[str, tuple[Any, ...]] = {}
    for i, item_raw in enumerate(raw):
        path = ("frames", i)
        item = v.mapping(item_raw, path, FRAME_KEYS, required=("name", "link"))
        if item is None:
            continue
        name = v.identifier(item.get("name"), path + ("name",), "frame name") if "name" in item else None
        if name is not None and name in taken:
            v.error(path + ("name",), f"{v.label(path + ('name',))}: duplicate frame name '{name}' "
                    f"(first at {v.at(taken[name])})")
        elif name is not None:
            taken[name] = path + ("name",)
            check_frame(v, name, path + ("name",), planar, engine or {})
        link = item.get("link")
        if "link" in item and link not in link_names and not (links_broken or link in bad_links):
            if link == "world":
                hint = " (a frame on the world is fixed: it needs no kinematics)"
            else:
                hint = did_you_mean(str(link), link_names)
            v.error(path + ("link",), f"{v.label(path + ('link',))}: unknown link {link!r}{hint}")
        frames.append(Frame(name or f"frame{i + 1}", str(link), origin(item.get("origin"), path + ("origin",))))
    return frames
