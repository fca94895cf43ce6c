"""2D navigation planners of the kinodynamic A* + TEB paper: the search front end (Sec. III).

    grid = NavGrid.from_map("map.h5", lethal_radius=robot.navigation.inscribed_radius)
    params = NavParams.for_robot(robot.navigation).with_overrides({"weight": "2"})
    result = plan_kinodynamic(grid, start=(1, 1, 0, 0), goal=(28, 28, 0, 0), params=params)
    t, p, v, a = result.trajectory.sample(0.02)          # piecewise-polynomial Trajectory

`plan_grid` is the traditional 8-connected A* with a trapezoidal time parametrization. Both return
a `SearchResult`; `legplan.nav.artefact` writes/reads nav.h5. The TEB back end lives in `nav.teb`.
"""

from legplan.nav.collision import NavGrid
from legplan.nav.gridastar import plan_grid
from legplan.nav.heuristic import min_time_cost
from legplan.nav.kinoastar import plan_kinodynamic
from legplan.nav.params import NavParams
from legplan.nav.result import SearchResult
from legplan.nav.trajectory import SEGMENT_COLUMNS, Trajectory, trapezoidal_polyline

PLANNERS = {"kinoastar": plan_kinodynamic, "astar": plan_grid}

__all__ = ["PLANNERS", "SEGMENT_COLUMNS", "NavGrid", "NavParams", "SearchResult", "Trajectory",
           "min_time_cost", "plan_grid", "plan_kinodynamic", "trapezoidal_polyline"]
