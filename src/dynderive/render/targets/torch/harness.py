"""The PyTorch module behind the NumPy module's calling convention (``simulate --backend torch``,
``check --backend torch`` and the registry's agreement test): NumPy arrays (and numbers, lists)
become float64 tensors, tensors in the results NumPy arrays, tuples entry by entry; the
module's constants and anything else are its own."""

from __future__ import annotations

import types
from typing import Any


def module_from_source(source: str, name: str) -> types.ModuleType:
    """Execute generated source (ours, checked by ``render_module``, never user text) as a fresh
    module."""
    module = types.ModuleType(name)
    exec(compile(source, f"<{name}.py>", "exec"), module.__dict__)  # noqa: S102
    return module


def _to_torch(value: Any) -> Any:
    import numpy as np
    import torch

    if isinstance(value, np.ndarray) or (isinstance(value, np.generic) and not isinstance(value, np.bool_)):
        array = np.asarray(value)
        return torch.from_numpy(np.array(array, dtype=np.float64)) if array.dtype.kind in "fiu" else value
    if isinstance(value, dict):
        return {key: _to_torch(item) for key, item in value.items()}
    return value


def _to_numpy(value: Any) -> Any:
    import torch

    if isinstance(value, torch.Tensor):
        return value.detach().cpu().numpy()
    if isinstance(value, tuple):
        return tuple(_to_numpy(item) for item in value)
    return value


class NumpyFacade:
    """A PyTorch module's functions taking and returning NumPy arrays, in float64."""

    def __init__(self, module: types.ModuleType) -> None:
        self.module = module

    def __getattr__(self, name: str) -> Any:
        value = getattr(self.module, name)
        if not callable(value) or name.startswith("_"):
            return value

        def call(*args: Any, **kwargs: Any) -> Any:
            args = tuple(_to_torch(a) for a in args)
            kwargs = {key: _anchors(item) if key == "anchors" else _to_torch(item) for key, item in kwargs.items()}
            return _to_numpy(value(*args, **kwargs))

        call.__name__ = call.__qualname__ = name
        call.__doc__ = value.__doc__
        return call


def _anchors(anchors: Any) -> Any:
    """``anchors``: a sequence of arrays, one per contact."""
    return anchors if anchors is None else [_to_torch(a) for a in anchors]
