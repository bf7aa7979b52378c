"""The derivation's stages: each part of it runs the first time one of its results is read
(``Stages``: by a quantity's name, or the stage itself for its typed result), and the quantities
it fills are a dict derived on access (``LazyMapping``); ``Derivation`` declares its stages,
``derive(robot, wants)`` runs those the requested outputs read before any renderer does."""

from __future__ import annotations

from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import dataclass
from typing import Any

from .model.naming import quantity_rank


@dataclass
class Stage:
    """A part of the derivation, run the first time one of its results is needed."""

    run: Callable[[], None]
    quantities: frozenset[str] | None   # names it provides; None: any name no stage declares


class Stages:
    def __init__(self) -> None:
        self.all: list[Stage] = []
        self.pending: list[Stage] = []

    def add(self, stage: Stage) -> None:
        self.all.append(stage)
        self.pending.append(stage)

    def run(self, method: Callable[[], None]) -> None:
        """Run the stage ``method`` is, if it is pending (a stage the robot does not have, or one
        that ran, does nothing): its typed result is read next."""
        for stage in self.pending:
            if stage.run == method:
                self.pending.remove(stage)
                stage.run()
                return

    def need(self, name: str | None) -> None:
        """Run the pending stages that provide the quantity ``name``; every pending stage when
        ``name`` is None."""
        declared = {k for s in self.all if s.quantities is not None for k in s.quantities}
        for stage in list(self.pending):
            if stage not in self.pending:   # ran meanwhile, as another stage's dependency
                continue
            provides = stage.quantities
            if name is None and provides is not None and not provides:
                continue   # gives nothing here (kinematics): runs only as another stage's input
            if name is None or (provides is None and name not in declared) or (provides and name in provides):
                self.pending.remove(stage)
                stage.run()


class LazyMapping(MutableMapping[str, Any]):
    """A dict whose values are derived on first access, stage by stage: ``d["h"]`` of a
    large planar robot builds the maximal model only, never the generalized equations.
    Iterating (the sheet, the JSON) derives everything."""

    def __init__(self, stages: Stages):
        self._stages = stages
        self._data: dict[str, Any] = {}
        self._rank: dict[str, tuple[int, int]] = {}

    def __getitem__(self, key: str) -> Any:
        if key not in self._data:
            self._stages.need(key)
        return self._data[key]

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str) and key not in self._data:
            self._stages.need(key)
        return key in self._data

    def __iter__(self) -> Iterator[str]:
        self._stages.need(None)
        return iter(sorted(self._data, key=self._rank.__getitem__))

    def __len__(self) -> int:
        self._stages.need(None)
        return len(self._data)

    def __setitem__(self, key: str, value: Any) -> None:
        if key not in self._rank:
            self._rank[key] = quantity_rank(key, len(self._rank))
        self._data[key] = value

    def __delitem__(self, key: str) -> None:
        del self._data[key]
        del self._rank[key]
