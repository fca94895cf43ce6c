"""Initial band from the global path: positions and timing of the path, yaw from a policy (Sec. IV)."""

from __future__ import annotations

import numpy as np

from legplan.nav.teb.band import Band
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.yaw import YawPolicy


def initial_band(path: GlobalPath, dt_ref: float, yaw: YawPolicy = YawPolicy(), start_pose=None,
                 goal_heading: float | None = None) -> Band:
    """Poses at ≈ dt_ref steps of the path's own timing; `start_pose` (x, y, θ) replaces the first
    pose, `goal_heading` the last yaw. A path with zero duration gives a two-pose band."""
    duration = path.duration
    count = max(int(np.ceil(duration / dt_ref)) + 1, 2)
    t = path.times[0] + np.linspace(0.0, duration, count)
    points, velocities = path.at_time(t)
    fallback = 0.0 if start_pose is None else float(start_pose[2])
    poses = np.column_stack([points, yaw.angles(points, velocities, fallback)])
    if start_pose is not None:
        poses[0] = np.asarray(start_pose, float).reshape(3)
    if goal_heading is not None:
        poses[-1, 2] = goal_heading
    dt = np.full(count - 1, max(duration, dt_ref) / (count - 1))
    return Band(poses, dt)
