"""OMPL baselines of `legplan nav search`: geometric planners in R² and control planners on the
2D double integrator, returning the nav layer's `SearchResult` so nav.h5 and its metrics are shared.

Hard constraint: the nav search's own (`legplan.nav.NavGrid`): a position is valid when its 3×3
cell block holds no lethal cell (distance to the nearest obstacle < l1, the inscribed radius) and
it lies inside the map (`NavGrid.blocked_at`). Straight motions are checked by `SegmentValidator`
at points at most one cell apart, which by the NavGrid argument keeps the whole segment out of
lethal cells — the guarantee the A* planners have.

Geometric planners ("rrtconnect", "rrtstar", "prmstar") plan positions in the map's bounding box
with OMPL's path-length objective, shortcut the solution (`og.PathSimplifier`, `simplify_time`)
and time-parametrize the polyline exactly like the grid A* baseline of the nav package
(`legplan.nav.trajectory.trapezoidal_polyline`: stop at every vertex, trapezoidal speed under the
per-axis v_max, a_max). RRT* and PRM* are anytime: they use the whole `time_budget`; the time to
their first solution is measured by a second run with the same seed whose cost threshold accepts
any solution (OMPL stops there), so the sample sequence up to that solution is the same.

Control planners ("kpiece-control" with an orthogonal position projection, "rrt-control") plan
states (p, v) ∈ R⁴ with controls a ∈ [−a_max, a_max]² held for 1..`max_control_steps` steps of
`propagation_step` s; propagation is the exact constant-acceleration solution p + v t + a t²/2,
v + a t (no ODE loop), every step's state checked (position as above, |v_d| ≤ v_max). The
propagation step makes consecutive checked positions at most one cell apart at full speed. The goal
is reached within `goal_tolerance` of the goal state (Euclidean in (p, v), m and m/s mixed);
the solution's controls are exactly the nav `Trajectory` segments (constant a, zero jerk).

`expansions` in the result counts the planner's motion checks (geometric) or propagation steps
(control), OMPL's nearest analogue of A* node expansions. OMPL's seed: `legplan.baselines.runtime`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from legplan.baselines.names import GEOMETRIC_PLANNERS, NAV_PLANNERS
from legplan.baselines.runtime import ompl_modules, real_vector_bounds, seed_ompl
from legplan.nav.collision import NavGrid
from legplan.nav.params import NavParams
from legplan.nav.result import SearchResult, endpoint_problem
from legplan.nav.trajectory import Trajectory, trapezoidal_polyline
from legplan.parameters import Parameters, inherit, param

ANYTIME = ("rrtstar", "prmstar")

_ob, _og, _oc = ompl_modules().ob, ompl_modules().og, ompl_modules().oc


@dataclass(frozen=True)
class NavBaselineParams(Parameters):
    what = "nav baseline"

    planner: str = param("rrtconnect", NAV_PLANNERS)
    time_budget: float = param(1.0, "(0, 86400]", doc="s of OMPL solve() per query")
    seed: int = param(0, "[0, 4294967295]", doc="query i is planned with OMPL seed `seed + i`")
    v_max: float = inherit(NavParams, "v_max")  # the nav search's limits (`NavParams.for_robot`)
    a_max: float = inherit(NavParams, "a_max")
    simplify_time: float = param(0.2, "[0, 86400]", doc="s of shortcutting of a geometric solution")
    goal_tolerance: float = param(0.25, "(0, inf)", doc="control planners: distance to the goal state (m, m/s mixed)")
    max_control_steps: int = param(10, "[1, 10000]", doc="control planners: a control lasts 1..this many steps")
    projection_cell: float = param(0.5, "(0, inf)", doc="m, KPIECE1 grid cell of the position projection")

    @property
    def label(self) -> str:
        return f"ompl-{self.planner}"


@dataclass(frozen=True)
class BaselineOutcome:
    """A `SearchResult` plus what only a sampling-based planner has."""

    result: SearchResult
    time_to_first_solution: float  # s (NaN when none was found)
    final_cost: float  # OMPL objective of the returned path: its length (geometric) or NaN
    goal_error: float  # distance of the trajectory's end state to the goal state (m, m/s)
    seed: int

    def attrs(self) -> dict:
        return {"time_to_first_solution": self.time_to_first_solution, "final_cost": self.final_cost,
                "goal_error": self.goal_error, "seed": self.seed}


class SegmentValidator(_ob.MotionValidator):
    """Straight motions in R² checked at points ≤ one cell apart against `NavGrid.blocked_at`."""

    def __init__(self, si, grid: NavGrid):
        super().__init__(si)
        self.grid = grid
        self.calls = 0

    def checkMotion(self, a, b):
        self.calls += 1
        p = np.array([a[0], a[1]])
        d = np.array([b[0], b[1]]) - p
        count = int(math.ceil(max(abs(d[0]), abs(d[1])) / self.grid.resolution)) + 1
        s = np.linspace(0.0, 1.0, count + 1)[:, None]
        return not self.grid.blocked_at(p + s * d).any()


def _state(si, values):
    state = si.allocState()
    for i, v in enumerate(values):
        state[i] = float(v)
    return state


def plan_baseline(grid: NavGrid, start, goal, params: NavBaselineParams, seed: int) -> BaselineOutcome:
    """Plan one query (start, goal states (px, py, vx, vy)); never raises for planning failures."""
    clock = time.perf_counter()
    start = np.asarray(start, float).reshape(4)
    goal = np.asarray(goal, float).reshape(4)
    problem = endpoint_problem(grid, start, goal, params.v_max)
    if problem:
        result = SearchResult(False, problem, params.label, start, goal, 0, time.perf_counter() - clock)
        return BaselineOutcome(result, math.nan, math.nan, math.nan, seed)
    if params.planner in GEOMETRIC_PLANNERS:
        return _plan_geometric(grid, start, goal, params, seed, clock)
    return _plan_control(grid, start, goal, params, seed, clock)


def _geometric_run(grid, start, goal, params, seed, first_only: bool):
    """One OMPL run; returns (pdef, si, validator, seconds)."""
    ob, og = _ob, _og
    seed_ompl(seed)
    space = ob.RealVectorStateSpace(2)
    xmin, xmax, ymin, ymax = grid.extent
    space.setBounds(real_vector_bounds([xmin, ymin], [xmax, ymax]))
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: not grid.blocked_at(np.array([s[0], s[1]])))
    validator = SegmentValidator(si, grid)
    si.setMotionValidator(validator)
    si.setup()
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(_state(si, start[:2]), _state(si, goal[:2]))
    objective = ob.PathLengthOptimizationObjective(si)
    if first_only:
        objective.setCostThreshold(ob.Cost(math.inf))
    pdef.setOptimizationObjective(objective)
    planner = {"rrtconnect": og.RRTConnect, "rrtstar": og.RRTstar, "prmstar": og.PRMstar}[params.planner](si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    t0 = time.perf_counter()
    # a C++ termination condition: PRM* checks it from a second thread, which must not need the GIL
    planner.solve(ob.timedPlannerTerminationCondition(float(params.time_budget)))
    return pdef, si, validator, time.perf_counter() - t0


def _plan_geometric(grid, start, goal, params, seed, clock) -> BaselineOutcome:
    pdef, si, validator, seconds = _geometric_run(grid, start, goal, params, seed, first_only=False)
    first = seconds if pdef.hasExactSolution() else math.nan
    if params.planner in ANYTIME and pdef.hasExactSolution():
        probe, _, _, first = _geometric_run(grid, start, goal, params, seed, first_only=True)
        first = first if probe.hasExactSolution() else math.nan
    if not pdef.hasExactSolution():
        reason = f"OMPL {params.planner}: no exact solution within the {params.time_budget:g} s budget"
        result = SearchResult(False, reason, params.label, start, goal, validator.calls, time.perf_counter() - clock)
        return BaselineOutcome(result, math.nan, math.nan, math.nan, seed)
    path = pdef.getSolutionPath()
    if params.simplify_time > 0:
        _og.PathSimplifier(si).simplify(path, float(params.simplify_time))
    waypoints = np.array([[s[0], s[1]] for s in path.getStates()])
    trajectory = trapezoidal_polyline(waypoints, params.v_max, params.a_max)
    cost = float(path.length())
    result = SearchResult(True, "", params.label, start, goal, validator.calls, time.perf_counter() - clock,
                          cost, trajectory, waypoints)
    end_p, end_v = trajectory.end_state()
    error = float(np.linalg.norm(np.r_[end_p, end_v] - goal))
    return BaselineOutcome(result, first, cost, error, seed)


def _plan_control(grid, start, goal, params, seed, clock) -> BaselineOutcome:
    ob, oc = _ob, _oc
    seed_ompl(seed)
    v, a = params.v_max, params.a_max
    xmin, xmax, ymin, ymax = grid.extent
    space = ob.RealVectorStateSpace(4)
    space.setBounds(real_vector_bounds([xmin, ymin, -v, -v], [xmax, ymax, v, v]))
    controls = oc.RealVectorControlSpace(space, 2)
    controls.setBounds(real_vector_bounds([-a, -a], [a, a]))
    si = oc.SpaceInformation(space, controls)
    steps = [0]

    def propagate(state, control, duration, out):
        steps[0] += 1
        ax, ay = control[0], control[1]
        vx, vy = state[2], state[3]
        out[0] = state[0] + duration * (vx + 0.5 * ax * duration)
        out[1] = state[1] + duration * (vy + 0.5 * ay * duration)
        out[2] = vx + ax * duration
        out[3] = vy + ay * duration

    def valid(state):
        if abs(state[2]) > v or abs(state[3]) > v:
            return False
        return not grid.blocked_at(np.array([state[0], state[1]]))

    si.setStatePropagator(propagate)
    si.setStateValidityChecker(valid)
    # consecutive checked positions ≤ one cell apart at the largest speed √2·v_max
    si.setPropagationStepSize(grid.resolution / (math.sqrt(2.0) * v))
    si.setMinMaxControlDuration(1, int(params.max_control_steps))
    if params.planner == "kpiece-control":
        cell = float(params.projection_cell)
        space.registerDefaultProjection(ob.RealVectorOrthogonalProjectionEvaluator(space, [cell, cell], [0, 1]))
    si.setup()
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(_state(si, start), _state(si, goal), float(params.goal_tolerance))
    planner = (oc.KPIECE1 if params.planner == "kpiece-control" else oc.RRT)(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    t0 = time.perf_counter()
    planner.solve(ob.timedPlannerTerminationCondition(float(params.time_budget)))
    seconds = time.perf_counter() - t0
    if not pdef.hasExactSolution():
        reason = (f"OMPL {params.planner}: did not reach the goal within {params.goal_tolerance:g} "
                  f"in the {params.time_budget:g} s budget")
        result = SearchResult(False, reason, params.label, start, goal, steps[0], time.perf_counter() - clock)
        return BaselineOutcome(result, math.nan, math.nan, math.nan, seed)
    path = pdef.getSolutionPath()
    states = [[s[i] for i in range(4)] for s in path.getStates()]
    pieces = [(np.array(x[:2]), np.array(x[2:]), np.array([c[0], c[1]]), np.zeros(2), d)
              for x, c, d in zip(states, path.getControls(), path.getControlDurations())]
    trajectory = Trajectory.from_pieces(pieces)
    end_p, end_v = trajectory.end_state()
    error = float(np.linalg.norm(np.r_[end_p, end_v] - goal))
    result = SearchResult(True, "", params.label, start, goal, steps[0], time.perf_counter() - clock,
                          trajectory=trajectory)
    return BaselineOutcome(result, seconds, math.nan, error, seed)


def plan_queries(grid: NavGrid, queries: np.ndarray, params: NavBaselineParams, progress=None) -> list[BaselineOutcome]:
    """Plan every query row (start px py vx vy, goal px py vx vy); query i with seed `params.seed + i`."""
    outcomes = []
    for index, query in enumerate(np.asarray(queries, float).reshape(-1, 8)):
        if progress is not None:
            progress(index, len(queries), f"query {index}")
        outcomes.append(plan_baseline(grid, query[:4], query[4:], params, params.seed + index))
    if progress is not None:
        progress(len(outcomes), len(outcomes))
    return outcomes


def outcome_record(outcome: BaselineOutcome, grid: NavGrid | None) -> dict:
    """The nav record of one query (`legplan.nav.artefact.query_record`) plus the attrs
    time_to_first_solution (s), final_cost, goal_error and seed."""
    from legplan.nav.artefact import query_record

    return {**query_record(outcome.result, grid), **outcome.attrs()}


class NavBaselineWorker:
    """A worker's context of `baseline nav` items ((index, query row), `legplan.nav.items.query_items`):
    the map's `NavGrid`, loaded once, and the parameters."""

    def __init__(self, map_path: str, lethal_radius: float, params: NavBaselineParams):
        self.grid = NavGrid.from_map(map_path, lethal_radius=lethal_radius)
        self.params = params


def baseline_item(worker: NavBaselineWorker, item) -> dict:
    """Plan query item (i, row) with OMPL seed `params.seed + i` (in any process: the seed is set
    per query); its `outcome_record`."""
    index, query = item
    params = worker.params
    return outcome_record(plan_baseline(worker.grid, query[:4], query[4:], params, params.seed + int(index)),
                          worker.grid)


def failed_baseline(params: NavBaselineParams, item, reason: str) -> dict:
    """The record of a query whose planning raised or whose worker died (use with
    `functools.partial(failed_baseline, params)`)."""
    index, query = item
    result = SearchResult(False, reason, params.label, query[:4], query[4:], 0, math.nan)
    return outcome_record(BaselineOutcome(result, math.nan, math.nan, math.nan, params.seed + int(index)), None)


def write_nav_baseline(path, records: list[dict], params: NavBaselineParams, robot: str, *, inputs=(),
                       overwrite: bool = False) -> list[dict]:
    """nav.h5 of `outcome_record`s through the nav search's writer (`legplan.nav.artefact.write_nav`),
    root attrs planner and robot; returns the summary rows."""
    from legplan.nav.artefact import write_nav

    return write_nav(path, records, {**params.as_dict(), "planner": params.label, "robot": robot},
                     seed=params.seed, inputs=inputs, overwrite=overwrite,
                     attrs={"planner": params.label, "robot": robot})
