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

FRAME_KEYS = ("name", "link", "origin")


def read_frames(v: Any, top: dict[str, Any], tree: Any,
                origin: Callable[[Any, tuple[Any, ...]], tuple[Any, ...]], planar: bool = False,
                engine: EngineQuantities | None = None) -> list[Frame]:
    """The frames, every problem reported on the validator ``v`` (``tree``: the links read,
    ``schema._LinkNames``; a frame naming a link that is already reported as bad is not
    reported again; a frame whose quantities would be named as one of ``engine``'s,
    ``names.engine_quantities``, is refused)."""
    frames: list[Frame] = []
    for i, path, item, name, new in v.named_items(top, "frames", "frame", FRAME_KEYS, ("name", "link"), {}):
        if new:
            check_frame(v, name, path + ("name",), planar, engine or {})
        link = item.get("link")
        if "link" in item and link not in tree.names and not (tree.broken or link in tree.bad):
            hint = (" (a frame on the world is fixed: it needs no kinematics)" if link == "world"
                    else did_you_mean(str(link), tree.names))
            v.report(path + ("link",), f"unknown link {link!r}{hint}")
        frames.append(Frame(name or f"frame{i + 1}", str(link), origin(item.get("origin"), path + ("origin",))))
    return frames
