"""The local planner of the receding-horizon run: a TEB band over the next metres of the global path."""

from __future__ import annotations

import numpy as np

from legplan.nav.simulate.mission import Goal, NavRunParams
from legplan.nav.simulate.robot import Robot
from legplan.nav.simulate.world import World
from legplan.nav.teb.band import Band
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.problems import ProblemCache
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.warmstart import shift_band
from legplan.nav.teb.yaw import YawPolicy
from legplan.robots.navigation import KinodynamicLimits


def _local_path(path: GlobalPath, index: int, end: int, xy: np.ndarray, speed: float) -> GlobalPath:
    """The robot's position followed by path points index … end − 1, with the points behind the
    robot or within half a spacing of it pruned (TEB prunes the global plan behind the robot).
    Timing: the path's own, shifted so that the first kept point is reached after gap / speed."""
    lo = index
    while lo + 1 < min(end, len(path.points)):
        ahead = np.dot(xy - path.points[lo], path.points[lo + 1] - path.points[lo]) > 0
        if not (ahead or np.hypot(*(path.points[lo] - xy)) < 0.5 * path.spacing):
            break
        lo += 1
    end = max(end, lo + 1)
    gap = float(np.hypot(*(path.points[lo] - xy)))
    times = np.concatenate([[0.0], path.times[lo:end] - path.times[lo] + max(gap / max(speed, 0.1), 1e-3)])
    return GlobalPath(np.vstack([xy, path.points[lo:end]]), times, path.spacing)


class LocalPlanner:
    """The TEB of the receding horizon: each cycle optimizes a local band over the next `window`
    metres of the global path. The band is warm-started from the previous cycle's band shifted by
    the elapsed time (`shift_band`); it is re-initialized from the global path after a (re)plan,
    for a new goal, while holding at a goal, and when the shifted band is invalid."""

    def __init__(self, limits: KinodynamicLimits, teb: TebParams, params: NavRunParams):
        self.limits, self.teb, self.params = limits, teb, params
        self.policy = YawPolicy(params.yaw, heading=params.heading, target=params.target or (0.0, 0.0))
        self.band: Band | None = None
        self.band_time = 0.0
        self.cold_starts = 0
        self.problems = ProblemCache()  # least-squares problems reused across cycles

    def reset(self) -> None:
        """Forget the previous band (the next cycle re-initializes)."""
        self.band = None

    def command(self, world: World, path: GlobalPath, index: int, robot: Robot, goal: Goal, t: float,
                hold: bool) -> tuple[np.ndarray, int, int]:
        """One cycle: the first interval's body velocity, the band size and the LM iterations."""
        params, teb = self.params, self.teb
        s = path.arc_length
        end = int(np.searchsorted(s, s[index] + params.window, side="right"))
        local = _local_path(path, index, end, robot.pose[:2], float(np.hypot(*robot.velocity[:2])))
        at_goal_window = end >= len(path.points)
        heading = goal.heading if at_goal_window and np.isfinite(goal.heading) else None
        local_goal = np.array(goal.xy) if at_goal_window else local.points[-1]
        if hold or np.hypot(*(robot.pose[:2] - goal.xy)) < params.goal_tolerance and at_goal_window:
            local = GlobalPath(np.array([robot.pose[:2], goal.xy]), np.array([0.0, 0.0]), path.spacing)
            self.band = None
        cold = initial_band(local, teb.dt_ref, self.policy, start_pose=robot.pose, goal_heading=heading)
        cold.poses[-1, :2] = local_goal
        if cold.n == 2 and heading is None:
            cold.poses[-1, 2] = robot.pose[2]
        band = None
        if params.warm_start and self.band is not None and not hold:
            band = shift_band(self.band, t - self.band_time, robot.pose, cold.poses[-1], teb.dt_min)
        if band is None:
            band = cold
            self.cold_starts += 1
        scene = Scene(path=local, distance=world.distance, start_velocity=robot.velocity.copy(),
                      goal_velocity=np.zeros(3) if at_goal_window else None)
        result = optimize_band(band, self.limits, teb, scene, self.problems)
        self.band = None if hold else result.band
        self.band_time = t
        return result.band.velocities()[0], result.band.n, result.iterations
