"""`SearchResult`: what either nav planner returns for one query, and start/goal validation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.trajectory import Trajectory


@dataclass(frozen=True)
class SearchResult:
    """One query's outcome. `start`/`goal` are states (px, py, vx, vy); `trajectory` is None on
    failure; `waypoints` (K, 2) is the position-only path of the grid planner (None for kinoastar);
    `cost` is the search objective g of the returned path; `planning_time` wall seconds."""

    success: bool
    reason: str
    planner: str
    start: np.ndarray
    goal: np.ndarray
    expansions: int
    planning_time: float
    cost: float = float("nan")
    trajectory: Trajectory | None = None
    waypoints: np.ndarray | None = None

    @property
    def time_per_expansion(self) -> float:
        return self.planning_time / self.expansions if self.expansions else float("nan")


def endpoint_problem(grid: NavGrid, start: np.ndarray, goal: np.ndarray, v_max: float) -> str:
    """Why a query cannot be planned at all ("" when it can): blocked or out-of-limit endpoints.

    The collision rule is the one every planner applies to every sample of its trajectories
    (`NavGrid.blocked_at`): no lethal cell (obstacle distance < l1) in the 3×3 block around the
    point's cell. An endpoint that breaks it cannot be left or reached by any of them (its
    primitive, segment or cubic would have a blocked sample), so it is refused here with the rule
    named; a free cell next to a lethal one is refused although the disc of radius l1 there may be
    clear — the one-cell margin that lets the planners check samples instead of swept discs."""
    for name, state in (("start", start), ("goal", goal)):
        if not np.all(np.isfinite(state)):
            return f"{name} state is not finite"
        if grid.blocked_at(state[:2]):
            inside = grid.extent[0] <= state[0] <= grid.extent[1] and \
                grid.extent[2] <= state[1] <= grid.extent[3]
            return (f"{name} in collision (a cell within one cell of it is lethal: obstacle "
                    f"distance < l1 = {grid.l1:g} m)") if inside else f"{name} outside the map"
        if np.max(np.abs(state[2:])) > v_max + 1e-12:
            return f"{name} velocity exceeds v_max={v_max} m/s per axis"
    return ""
