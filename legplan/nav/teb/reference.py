"""`GlobalPath`: the front end's path as TEB sees it — positions with a timing, resampled by arc length.

Kinodynamic A* gives a timed trajectory (`legplan.nav.trajectory.Trajectory`): the band starts from
its positions *and* timing (Sec. IV). The grid A* gives position-only waypoints: as in TEB's usual
initialization they are timed at a constant nominal speed. Either way the path is stored as points
(K, 2) at times (K,), evenly spaced in arc length (`spacing`), which is also the polyline the
attraction term (`PathTerm`) measures against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.geometry.polyline import arc_length, resample_by_arc_length
from legplan.nav.trajectory import Trajectory


@dataclass(frozen=True)
class GlobalPath:
    points: np.ndarray  # (K, 2) m
    times: np.ndarray  # (K,) s, non-decreasing
    spacing: float  # m between consecutive points (the last gap may be shorter)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    @property
    def arc_length(self) -> np.ndarray:
        return arc_length(self.points)

    @property
    def length(self) -> float:
        return float(self.arc_length[-1])

    @classmethod
    def from_samples(cls, times: np.ndarray, points: np.ndarray, spacing: float = 0.1) -> GlobalPath:
        """Resample densely timed points (t, p) to `spacing` in arc length (stops collapse to one point)."""
        points = np.asarray(points, float).reshape(-1, 2)
        times = np.asarray(times, float).reshape(-1)
        total = arc_length(points)[-1]
        if total <= 0.0:
            return cls(points[[0, -1]], times[[0, -1]], spacing)
        lengths = np.unique(np.concatenate([np.arange(0.0, total, spacing), [total]]))
        new_points, new_times = resample_by_arc_length(points, lengths, times)
        new_times[-1] = times[-1]
        return cls(new_points, new_times, spacing)

    @classmethod
    def from_trajectory(cls, trajectory: Trajectory, spacing: float = 0.1, time_step: float = 0.02) -> GlobalPath:
        t, p, _, _ = trajectory.sample(time_step)
        return cls.from_samples(t, p, spacing)

    @classmethod
    def from_waypoints(cls, waypoints: np.ndarray, speed: float, spacing: float = 0.1) -> GlobalPath:
        """Position-only waypoints timed at constant `speed` (TEB's initialization of a plain path)."""
        waypoints = np.asarray(waypoints, float).reshape(-1, 2)
        return cls.from_samples(arc_length(waypoints) / speed, waypoints, spacing)

    def at_time(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Positions (m, 2) and velocities (m, 2) at times t, piecewise linear between points."""
        t = np.clip(np.atleast_1d(np.asarray(t, float)), self.times[0], self.times[-1])
        p = np.column_stack([np.interp(t, self.times, self.points[:, 0]), np.interp(t, self.times, self.points[:, 1])])
        dt = np.diff(self.times)
        seg_v = np.where(dt[:, None] > 0, np.diff(self.points, axis=0) / np.maximum(dt, 1e-12)[:, None], 0.0)
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(dt) - 1) if len(dt) else None
        v = seg_v[k] if k is not None else np.zeros_like(p)
        return p, v

    def nearest_index(self, point, lo: int = 0, hi: int | None = None) -> int:
        """Index of the path point nearest to `point` among points lo … hi − 1."""
        hi = len(self.points) if hi is None else hi
        d = np.sum((self.points[lo:hi] - np.asarray(point, float)) ** 2, axis=1)
        return lo + int(np.argmin(d))

