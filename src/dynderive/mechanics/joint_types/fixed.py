"""The fixed joint: no coordinate, no motion (RigidBodyDynamics.jl's ``Fixed``); its child is
welded to its parent. Its configuration space is a point: every map is empty."""

from __future__ import annotations

from collections.abc import Sequence

from .base import Column, JointType


class Fixed(JointType):
    name = "fixed"
    nq = nv = 0
    moves = False

    def columns(self, axis: Sequence[object]) -> list[Column]:
        return []
