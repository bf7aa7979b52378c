"""The installed version of dynderive, from the package metadata (one place: pyproject.toml)."""

from __future__ import annotations

from importlib import metadata

try:
    __version__ = metadata.version("dynderive")
except metadata.PackageNotFoundError:  # pragma: no cover - running from a checkout, not installed
    __version__ = "0+unknown"
