"""Refine one front-end query's trajectory with the TEB (what `legplan nav refine` runs per query).

The band starts from the query's global path — the kinodynamic A* trajectory with its timing, or
the grid A* waypoints timed at v_x max — with yaw from the policy, and is optimized against the
path, the map's obstacle distance and the Table I limits, at rest at both ends.

The usual `outer_iterations` × `inner_iterations` may leave a limit exceeded by more than ε (the
penalty balances against the time term). While it is, refinement continues with more rounds, and,
as TEB's weight adaptation does for obstacles, the limit weights are multiplied by
`WEIGHT_ADAPT_FACTOR` before each further call, up to `max_calls` calls of `optimize_band` in all.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from legplan.nav.teb.band import Band
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, TebResult, limit_violations, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.problems import ProblemCache
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.yaw import YawPolicy
from legplan.nav.trajectory import Trajectory
from legplan.robots.navigation import KinodynamicLimits

WEIGHT_ADAPT_FACTOR = 2.0
LIMIT_WEIGHTS = ("weight_velocity", "weight_omega", "weight_acceleration", "weight_alpha")


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
                start_heading: float | None = None, goal_heading: float | None = None,
                max_calls: int = 6) -> Refinement:
    """Optimize a band initialized from `path` (at rest at start and goal); see module docstring."""
    start_pose = None
    if start_heading is not None:
        start_pose = np.array([*path.points[0], start_heading])
    band = initial_band(path, params.dt_ref, yaw, start_pose=start_pose, goal_heading=goal_heading)
    scene = Scene(path=path, distance=distance, start_velocity=np.zeros(3), goal_velocity=np.zeros(3))
    clock = time.perf_counter()
    problems = ProblemCache()
    result = optimize_band(band, limits, params, scene, problems)
    rounds = list(result.rounds)
    violations = limit_violations(result.band, limits)
    for _ in range(max_calls - 1):
        if max(violations.values()) <= params.epsilon:
            break
        params = params.replace(round_tolerance=0.0, **{w: getattr(params, w) * WEIGHT_ADAPT_FACTOR for w in LIMIT_WEIGHTS})
        result = optimize_band(result.band, limits, params, scene, problems)
        rounds += result.rounds
        violations = limit_violations(result.band, limits)
    result = TebResult(result.band, rounds, time.perf_counter() - clock)
    clearance = float(distance.values(result.band.poses[:, :2]).min()) if distance is not None else float("nan")
    return Refinement(result, violations, clearance)
