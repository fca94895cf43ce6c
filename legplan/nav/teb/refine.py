"""Refine one front-end query's trajectory with the TEB (what `legplan nav refine` runs per query).

The band starts from the query's global path — the kinodynamic A* trajectory with its timing, or
the grid A* waypoints timed at v_x max — with yaw from the policy, and is optimized against the
path, the map's obstacle distance and the Table I limits, at rest at both ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.nav.teb.band import Band
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, TebResult, limit_violations, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.yaw import YawPolicy
from legplan.nav.trajectory import Trajectory
from legplan.robots.spec import KinodynamicLimits


def query_path(trajectory: Trajectory | None, waypoints: np.ndarray | None, speed: float) -> GlobalPath:
    """The global path of a query: the trajectory when there is one, else the timed waypoints."""
    if waypoints is not None:
        return GlobalPath.from_waypoints(waypoints, speed)
    return GlobalPath.from_trajectory(trajectory)


@dataclass
class Refinement:
    result: TebResult
    violations: dict[str, float]  # excess over each Table I limit (0 = satisfied)
    min_clearance: float  # m, distance field at the band poses

    @property
    def band(self) -> Band:
        return self.result.band


def refine_path(path: GlobalPath, limits: KinodynamicLimits, params: TebParams = TebParams(),
                distance: DistanceField | None = None, yaw: YawPolicy = YawPolicy(),
                start_heading: float | None = None, goal_heading: float | None = None) -> Refinement:
    """Optimize a band initialized from `path` (at rest at start and goal)."""
    start_pose = None
    if start_heading is not None:
        start_pose = np.array([*path.points[0], start_heading])
    band = initial_band(path, params.dt_ref, yaw, start_pose=start_pose, goal_heading=goal_heading)
    scene = Scene(path=path, distance=distance, start_velocity=np.zeros(3), goal_velocity=np.zeros(3))
    result = optimize_band(band, limits, params, scene)
    clearance = float(distance.values(result.band.poses[:, :2]).min()) if distance is not None else float("nan")
    return Refinement(result, limit_violations(result.band, limits), clearance)
