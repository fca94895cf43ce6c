"""`Trajectory`: a piecewise-polynomial 2D position trajectory, the nav layer's exchange format.

Segment k starts at time t_k = Σ_{i<k} duration_i and, for s ∈ [0, duration_k],

    p(t_k + s) = p0 + v0 s + a0 s²/2 + j s³/6      (per axis x, y; world frame)

so a motion primitive of eq. (6) is a segment with constant input a0 = u_m and j = 0, the one-shot
of eq. (9) is a segment with a0 = β, j = α, and a trapezoidal velocity phase is a segment with
j = 0. The table `segments` (N, 9) holds the columns `SEGMENT_COLUMNS`; it is exactly what nav.h5
stores, so a reader rebuilds the trajectory with `Trajectory(segments)`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SEGMENT_COLUMNS = ("px", "py", "vx", "vy", "ax", "ay", "jx", "jy", "duration")
SEGMENT_UNITS = ("m", "m", "m/s", "m/s", "m/s^2", "m/s^2", "m/s^3", "m/s^3", "s")


@dataclass(frozen=True)
class Trajectory:
    """Segments (N, 9): start position, start velocity, start acceleration, jerk, duration."""

    segments: np.ndarray

    def __post_init__(self):
        segments = np.asarray(self.segments, float).reshape(-1, len(SEGMENT_COLUMNS))
        if np.any(segments[:, 8] < 0):
            raise ValueError("trajectory segment durations must be >= 0")
        object.__setattr__(self, "segments", segments)

    @classmethod
    def from_pieces(cls, pieces) -> Trajectory:
        """From an iterable of (p0, v0, a0, jerk, duration) with 2-vectors."""
        rows = [np.concatenate([p0, v0, a0, jerk, [duration]]) for p0, v0, a0, jerk, duration
                in pieces]
        return cls(np.array(rows).reshape(-1, len(SEGMENT_COLUMNS)))

    @property
    def duration(self) -> float:
        return float(self.segments[:, 8].sum())

    @property
    def knots(self) -> np.ndarray:
        """Segment start times, and the end time last: (N + 1,)."""
        return np.concatenate([[0.0], np.cumsum(self.segments[:, 8])])

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration (len(t), 2) at times t (clamped to [0, duration])."""
        t = np.clip(np.atleast_1d(np.asarray(t, float)), 0.0, self.duration)
        knots = self.knots
        index = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(self.segments) - 1)
        seg = self.segments[index]
        s = (t - knots[index])[:, None]
        p0, v0, a0, jerk = seg[:, 0:2], seg[:, 2:4], seg[:, 4:6], seg[:, 6:8]
        p = p0 + s * (v0 + s * (a0 / 2.0 + s * jerk / 6.0))
        v = v0 + s * (a0 + s * jerk / 2.0)
        a = a0 + s * jerk
        return p, v, a

    def sample(self, max_step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t, p, v, a) on a uniform time grid with step ≤ `max_step`, both ends included."""
        count = max(int(np.ceil(self.duration / max_step)), 1) + 1
        t = np.linspace(0.0, self.duration, count)
        return (t, *self.evaluate(t))

    def effort(self) -> float:
        """J = ∫ ||a||² dt (eq. (4)), exact per segment: a0²T + a0·j T² + j² T³/3."""
        a0, jerk, T = self.segments[:, 4:6], self.segments[:, 6:8], self.segments[:, 8:9]
        return float(np.sum(a0 * a0 * T + a0 * jerk * T**2 + jerk * jerk * T**3 / 3.0))

    def path_length(self, max_step: float = 0.01) -> float:
        """Arc length ∫ ||v|| dt by the trapezoidal rule on a fine time grid, m."""
        t, _, v, _ = self.sample(max_step)
        speed = np.linalg.norm(v, axis=1)
        return float(np.trapezoid(speed, t))

    def end_state(self) -> tuple[np.ndarray, np.ndarray]:
        p, v, _ = self.evaluate([self.duration])
        return p[0], v[0]


def trapezoidal_polyline(points: np.ndarray, v_max: float, a_max: float) -> Trajectory:
    """Time-parametrize a polyline, stopping at every vertex, under per-axis bounds.

    Along a segment of direction d (unit) the speed bound is v_max / max(|d_x|, |d_y|) and the
    acceleration bound a_max / max(|d_x|, |d_y|), so each axis stays within ±v_max and ±a_max.
    Each segment is accelerate / cruise / decelerate (a triangle when too short to reach cruise).
    """
    points = np.asarray(points, float)
    pieces = []
    for start, end in zip(points[:-1], points[1:]):
        delta = end - start
        length = float(np.hypot(*delta))
        if length == 0.0:
            continue
        direction = delta / length
        scale = float(np.max(np.abs(direction)))
        v_lim, a_lim = v_max / scale, a_max / scale
        ramp = min(v_lim / a_lim, np.sqrt(length / a_lim))
        speed = a_lim * ramp
        cruise = (length - a_lim * ramp * ramp) / speed
        zero = np.zeros(2)
        accel = a_lim * direction
        pieces.append((start, zero, accel, zero, ramp))
        mid = start + 0.5 * a_lim * ramp * ramp * direction
        if cruise > 1e-12:
            pieces.append((mid, speed * direction, zero, zero, cruise))
            mid = mid + cruise * speed * direction
        pieces.append((mid, speed * direction, -accel, zero, ramp))
    if not pieces:
        pieces.append((points[0], np.zeros(2), np.zeros(2), np.zeros(2), 0.0))
    return Trajectory.from_pieces(pieces)
