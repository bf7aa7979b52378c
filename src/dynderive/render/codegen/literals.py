"""Number literals of the compiled targets' text."""

from __future__ import annotations

from ..python_module import CodeGenerationError


def double_literal(value: float) -> str:
    """A C (and MATLAB) double literal that reads back as ``value`` exactly (17 significant
    digits)."""
    text = format(value, ".17g")
    if text in ("inf", "-inf", "nan"):
        raise CodeGenerationError(f"no C literal for the number {value}")
    return text if any(c in text for c in ".en") else text + ".0"
