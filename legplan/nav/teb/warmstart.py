"""Warm start of the receding-horizon TEB: the previous cycle's band, shifted by the elapsed time.

As in TEB's update of the band between control cycles, the poses the robot has already passed
(pose times ≤ elapsed) are dropped, the robot's current pose becomes the new fixed start (the
first kept interval shortened by the part already travelled), and the fixed goal pose is moved
to the new local goal (its interval scaled with the length of the last segment). The band is
reported invalid (None: re-initialize from the global path) when the robot is farther than
`max_offset` from where the band expected it, when the goal jumped by more than `max_goal_jump`,
or when fewer than two poses would remain.
"""

from __future__ import annotations

import numpy as np

from legplan.nav.teb.band import Band

MAX_OFFSET = 0.5  # m between the robot and the band's pose at the elapsed time
MAX_GOAL_JUMP = 1.0  # m (TEB's force-reinit distance for a new goal)


def shift_band(band: Band, elapsed: float, pose, goal_pose, dt_min: float, max_offset: float = MAX_OFFSET,
               max_goal_jump: float = MAX_GOAL_JUMP) -> Band | None:
    """`band` advanced by `elapsed` s with start `pose` and goal `goal_pose` (x, y, θ), or None."""
    pose, goal_pose = np.asarray(pose, float).reshape(3), np.asarray(goal_pose, float).reshape(3)
    times = band.times
    if elapsed < 0 or elapsed >= times[-1]:
        return None
    expected = np.array([np.interp(elapsed, times, band.poses[:, 0]), np.interp(elapsed, times, band.poses[:, 1])])
    if np.hypot(*(pose[:2] - expected)) > max_offset:
        return None
    old_goal = band.poses[-1, :2]
    if np.hypot(*(goal_pose[:2] - old_goal)) > max_goal_jump:
        return None
    k = int(np.searchsorted(times, elapsed, side="right"))  # first pose still ahead of the robot
    first = times[k] - elapsed
    if first < dt_min and k + 1 < band.n:  # the robot is (almost) at pose k: drop it as well
        k, first = k + 1, times[k + 1] - elapsed
    poses = np.vstack([pose, band.poses[k:]])
    dt = np.concatenate([[max(first, dt_min)], band.dt[k:]])
    if len(poses) < 2:
        return None
    before = np.hypot(*(old_goal - poses[-2, :2]))
    after = np.hypot(*(goal_pose[:2] - poses[-2, :2]))
    if before > 1e-9:
        dt[-1] = max(dt[-1] * after / before, dt_min)
    poses[-1] = goal_pose
    return Band(poses, dt)
