"""Global planners of the receding-horizon run: the nav search front ends as `GlobalPlanner`s."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.gridastar import plan_grid
from legplan.nav.kinoastar import plan_kinodynamic
from legplan.nav.teb.reference import GlobalPath

GlobalPlanner = Callable[[NavGrid, np.ndarray, np.ndarray], "GlobalPath | str"]
"""planner(grid, start (px, py, vx, vy), goal (px, py, vx, vy)) -> GlobalPath, or a failure reason."""


def kinodynamic_planner(params) -> GlobalPlanner:
    """Kinodynamic A* (Sec. III) as the global planner; the start velocity is clipped to its v_max."""
    def plan(grid: NavGrid, start: np.ndarray, goal: np.ndarray):
        start = np.concatenate([start[:2], np.clip(start[2:], -params.v_max, params.v_max)])
        result = plan_kinodynamic(grid, start, goal, params)
        return GlobalPath.from_trajectory(result.trajectory) if result.success else result.reason
    return plan


def grid_planner(params, speed: float) -> GlobalPlanner:
    """Traditional (grid) A* as the global planner: its position-only waypoints, timed at `speed`
    as TEB does for a plain path (the Table II baseline)."""
    def plan(grid: NavGrid, start: np.ndarray, goal: np.ndarray):
        start = np.concatenate([start[:2], np.clip(start[2:], -params.v_max, params.v_max)])
        result = plan_grid(grid, start, goal, params)
        return GlobalPath.from_waypoints(result.waypoints, speed) if result.success else result.reason
    return plan
