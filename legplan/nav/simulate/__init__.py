"""Receding-horizon execution of a global planner + TEB on a simulated robot (paper Sec. V-C 3).

- `mission` — `Goal`s (via points with heading and dwell) and `NavRunParams`;
- `world` — true/known occupancy, the known nav layers, sensing of hidden obstacles, and the one
  collision model (a disc containing the footprint) that planning and judging share;
- `robot` — the base that tracks body-velocity commands under the Table I limits;
- `planners` — kinodynamic A* and grid A* as global planners;
- `local` — the TEB band over the next metres of the global path (warm-started);
- `run` — the control loop `run_navigation` and its `NavRunResult`;
- `obstacles` — hidden obstacles read from a YAML list of map primitives.
"""

from legplan.nav.simulate.local import LocalPlanner
from legplan.nav.simulate.mission import Goal, NavRunParams
from legplan.nav.simulate.obstacles import hidden_obstacles
from legplan.nav.simulate.planners import GlobalPlanner, grid_planner, kinodynamic_planner
from legplan.nav.simulate.robot import Robot
from legplan.nav.simulate.run import NavRunResult, run_navigation
from legplan.nav.simulate.world import World

__all__ = ["GlobalPlanner", "Goal", "LocalPlanner", "Robot", "NavRunParams", "NavRunResult", "World",
           "grid_planner", "hidden_obstacles", "kinodynamic_planner", "run_navigation"]
