"""A check's row (what ``dynderive check`` prints and writes as JSON), shared by every check
harness: the engine's, the NumPy module's, Pinocchio's and the targets'."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..model.robot import Robot


@dataclass(frozen=True)
class Row:
    name: str
    status: str        # "pass", "FAIL" or "skip"
    method: str        # "symbolic", "numeric", "engine", or why it was skipped
    residual: float

    def as_dict(self) -> dict[str, Any]:
        """The row for JSON: a residual that is not a number (a skipped check) is null."""
        row = asdict(self)
        row["residual"] = self.residual if np.isfinite(self.residual) else None
        return row


def _row(name: str, passed: bool, method: str, residual: float) -> Row:
    return Row(name, "pass" if passed else "FAIL", method, float(residual))


def peak(array: Any) -> float:
    """The largest absolute entry of ``array`` (0 for an empty one): a residual, or a scale."""
    return float(np.max(np.abs(array), initial=0.0))


def applied(robot: Robot, u: np.ndarray) -> np.ndarray:
    """The efforts ``u`` at their velocity columns (``Robot.effort_columns``)."""
    Y = np.zeros(robot.velocity_count)
    Y[list(robot.effort_columns())] = u
    return Y
