"""Yaw policies for initializing band headings (Sec. IV: TEB "takes yaw into account").

The global path is position-only (x, y); the heading θ_i of every initial pose comes from a policy:
* `velocity` — face the direction of travel (atan2 of the path velocity; where the path is at rest
  the last moving heading is held, before the first motion the first moving heading is used);
* `heading`  — hold a fixed world heading;
* `target`   — face a fixed world point (e.g. the object a via point inspects, Table III).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.errors import LegplanError

YAW_MODES = ("velocity", "heading", "target")
MOVING_SPEED = 1e-3  # m/s, below this the path is taken to be at rest


@dataclass(frozen=True)
class YawPolicy:
    mode: str = "velocity"
    heading: float = 0.0  # rad, for mode "heading"
    target: tuple[float, float] = (0.0, 0.0)  # m, for mode "target"

    def __post_init__(self):
        if self.mode not in YAW_MODES:
            raise LegplanError(f"yaw policy: mode must be one of {', '.join(YAW_MODES)}, got {self.mode!r}")

    def angles(self, points: np.ndarray, velocities: np.ndarray, fallback: float = 0.0) -> np.ndarray:
        """Heading (n,) at path points (n, 2) with path velocities (n, 2); `fallback` when never moving."""
        points = np.asarray(points, float).reshape(-1, 2)
        if self.mode == "heading":
            return np.full(len(points), float(self.heading))
        if self.mode == "target":
            delta = np.asarray(self.target, float) - points
            return np.arctan2(delta[:, 1], delta[:, 0])
        velocities = np.asarray(velocities, float).reshape(-1, 2)
        moving = np.hypot(velocities[:, 0], velocities[:, 1]) > MOVING_SPEED
        if not moving.any():
            return np.full(len(points), float(fallback))
        index = np.where(moving, np.arange(len(points)), -1)
        index = np.maximum.accumulate(index)  # last moving sample so far
        index[index < 0] = np.argmax(moving)
        chosen = velocities[index]
        return np.arctan2(chosen[:, 1], chosen[:, 0])
