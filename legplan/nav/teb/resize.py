"""Band resizing between optimization rounds (TEB's autoResize, Sec. IV).

An interval longer than dt_ref + hysteresis is split at its midpoint (a new pose halfway in
position and in wrapped yaw, ΔT halved); an interval shorter than dt_ref − hysteresis is merged
with its successor by removing the pose between them (with its predecessor for the last interval,
so the goal pose stays). Fixed poses (start, goal) are never removed; the band keeps between
`min_poses` and `max_poses` poses. Passes repeat until nothing changes.
"""

from __future__ import annotations

import numpy as np

from legplan.geometry.angles import wrap_angle
from legplan.nav.teb.band import Band
from legplan.nav.teb.params import TebParams

MAX_PASSES = 100


def resize(band: Band, params: TebParams) -> Band:
    """A resized copy of `band` (see module docstring)."""
    poses, dt, fixed = list(band.poses), list(band.dt), list(band.fixed)
    upper, lower = params.dt_ref + params.dt_hysteresis, params.dt_ref - params.dt_hysteresis
    for _ in range(MAX_PASSES):
        changed = False
        i = 0
        while i < len(dt):
            if dt[i] > upper and len(poses) < params.max_poses:
                a, b = poses[i], poses[i + 1]
                mid = np.array([(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, wrap_angle(a[2] + wrap_angle(b[2] - a[2]) / 2)])
                poses.insert(i + 1, mid)
                fixed.insert(i + 1, False)
                dt[i] /= 2
                dt.insert(i + 1, dt[i])
                changed = True
                i += 2
                continue
            if dt[i] < lower and len(poses) > params.min_poses:
                if i + 1 < len(dt) and not fixed[i + 1]:  # remove pose i+1
                    dt[i] += dt.pop(i + 1)
                    poses.pop(i + 1)
                    fixed.pop(i + 1)
                    changed = True
                elif i > 0 and not fixed[i]:  # last interval: remove pose i, keep the goal
                    dt[i - 1] += dt.pop(i)
                    poses.pop(i)
                    fixed.pop(i)
                    changed = True
            i += 1
        if not changed:
            break
    return Band(np.array(poses), np.array(dt), np.array(fixed))
