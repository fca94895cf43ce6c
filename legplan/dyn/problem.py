"""One centroidal planning problem: task, parameters, and its costs and constraints on the splines.

`build_problem` turns a `DynTask` (start and goal base pose, gait, strides, duration) on a terrain into
the variable blocks of a `Formulation` (initialized by an `Initializer`), the weighted cost blocks of
`costs` and the bounded constraint blocks of `constraints` — the NLP of Sec. III-A of the TOWR-costs
paper, stated as constrained least squares for `legplan.solve.solve_augmented_lagrangian`. With
`DynParams.optimize_phases` the phase durations are variables too (`legplan.dyn.timing`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from legplan.dyn.constraints import (GRAVITY, BaseAboveFeetBlock, DynamicsBlock, ForceBlock, LegClearanceBlock,
                                     RangeOfMotionBlock, StanceSlopeBlock, TerrainHeightBlock, acceleration_continuity,
                                     swing_constraint, swing_height)
from legplan.dyn.costs import CostWeights, StairEdgeBlock, integral_costs
from legplan.dyn.formulation import Formulation, Pose
from legplan.dyn.gait import make_gait
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import PHASES, PhaseTiming, TimedControlPoints, TimedSamples
from legplan.solve import VariableBlock
from legplan.solve.auglag import ALParams, Constraint
from legplan.solve.hinged import HingedParams


@dataclass(frozen=True)
class DynTask:
    """Start and goal base (x, y, yaw), the gait, its strides and the total duration (s)."""

    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    gait: str = "trot"
    strides: int = 4
    duration: float = 2.4


@dataclass(frozen=True)
class DynParams:
    """Discretization (TOWR's defaults but for `dt_range`: 0.04 s instead of 0.08 s, at which stance
    feet left the range-of-motion box by up to 4 mm between points; the box is also shrunk by
    `range_margin` for what remains between points), our between-node sampling, the paper's
    additions, the solver.

    Points every `swing_dt` (at most) inside each swing polynomial keep the foot above the terrain
    between nodes (`swing_clearance` m above its column envelope) and inside its range of motion
    (which TOWR checks every `dt_range` only: swing feet left the box by 1.3 cm in between). The force bounds and the friction pyramid (inscribed in the Coulomb cone, `ForceBlock`) hold at the
    Bézier control points of every force polynomial, hence along all of it (the terrain normal is
    that of the stance foothold, constant over the stance). `towr_swing` adds TOWR's swing constraint (apex x, y halfway
    between the footholds, apex velocity = step / swing time); off by default: it is a regularizer,
    not in the issue's constraint list, and it over-constrains tight gaits (measured on the bench
    cases: with it the 2-stride trot and the stairs walk stall, without it they converge, and no
    case needs it; `planner.plan` drops it when a solve with it stalls). `swing_height_min` (m above both adjacent footholds) and
    `base_clearance` (base z minus foot z, m) are the paper's constraints, None = off.
    `stance_slope_max` bounds `TerrainModel.stance_slope` (smoothed terrain slope) under every free
    stance foothold, which keeps them about 4 cm off a pallet's edge (a foot's radius is 3 cm): on the
    heightmap's one-cell edge ramp the terrain normal tilts by up to 86°, the friction pyramid cannot
    carry the weight and the raw slope gives the solver no direction off the ramp (measured: the
    double-pallet walk stalled there at 4 N; with the bound it converges, and the stairs walk's
    stance foot no longer stands 8.4 mm inside a riser's column). None = off.
    """

    dt: float = 0.1
    dynamics_points: int = 10
    """Points per base interval (the knot that opens it included, equally spaced) at which the
    Newton–Euler rows are constrained: to zero at the knots (TOWR's collocation), inside
    ±`dynamics_band` at the others (1: TOWR's alone). Between the knots the base acceleration is
    linear while the forces are cubics whose pieces start and end at the phase times, vanishing with
    zero slope at every touchdown and lift-off: the residual cannot be zero along a whole interval
    that holds a touchdown (a flying trot's flight needs m(p̈ + g) = 0 on part of a linear piece,
    hence on all of it), and equality at several points per interval over-constrains the problem.
    A band keeps what the executing controller must absorb bounded at the times it executes
    (the 10 ms samples at 10 points per 0.1 s interval), where an integrated formulation (zero
    impulse per interval) would let the residual swing both ways inside each interval. The rows
    share the variables of their interval, so the normal equations keep their sparsity; only
    evaluation and assembly grow, and hinged rows inside the band cost nothing in the step."""
    dynamics_band: float = 0.04
    """Share of m·g (force rows) and of m·g·ℓ (torque rows, ℓ the largest horizontal distance of a
    nominal foot from the CoM) the Newton–Euler residual may reach between the knots; below the
    independent check's bound (`CheckTolerances.between`) by a margin for the solver's tolerance."""
    phase_knots: bool = False
    """Base knots at the gait's phase boundaries too (`formulation.phase_knots`), not only evenly
    spaced: the contact set is then constant on every base polynomial."""
    dt_range: float = 0.04
    range_margin: float = 0.002
    swing_dt: float = 0.01
    swing_clearance: float = 0.0
    stance_slope_max: float | None = 0.5
    towr_swing: bool = False
    cost_solver: ALParams = ALParams(mu_init=10.0, cost_tolerance=1e-2,
                                     inner=HingedParams(max_iterations=20, tolerance=0.0, function_tolerance=1e-3))
    """The cost stage (`planner.plan`) starts feasible; short subproblems let the multipliers follow
    (31-90 iterations in all on the pallet cases instead of 120-130 with the feasibility stage's
    settings). μ₀ = 10: with 100 or 1000 the single-pallet walk stalled 0.02 N short of feasible,
    a local minimum that a feasibility stage from there could not leave either (measured)."""
    warm_solver: ALParams = ALParams(mu_init=1e3, cost_tolerance=1e-2, multipliers="least_squares",
                                     inner=HingedParams(max_iterations=5, tolerance=0.0, function_tolerance=1e-3))
    """The one-stage solve from a guess that is itself a solution of a nearby task (the learned
    initializer, `planner.direct`): multipliers estimated at the guess, a stiff penalty and short
    subproblems keep the steps near the constraints (measured from a network trained on 21 pallet
    tasks, after a feasibility stage: μ₀ = 100 with 20-iteration subproblems left the first one
    17-64 N off the dynamics and spent the 25-iteration budget; 10³ with 5: 2 of 4 converged)."""
    warm_stage: str = "costs"
    """What `planner.direct` solves from a near-solution guess (the learned initializer): "costs" —
    the whole problem, the costs under the constraints, by `warm_solver`; "projection" — the
    constraints alone, by `projection_solver` (Gauss-Newton onto the constraints from the guess: the
    plan keeps the guess's shape and its cost is not optimized). "polish" — the projection, then
    where its cost exceeds what the network's training filter kept for the task (the initializer's
    `cost_bound`, at `polish_tolerance`, eq. (4)) the costs from it (`planner.polish`). Measured from
    the n = 1000 cycle-3 network on 200 held-out single-pallet tasks (`bench/learn.py` at 42a56b2),
    converged / median iterations / largest cost ÷ median: "costs" 96 % / 11 / 1.95×; "projection"
    98 % / 4 / 2.78× (its costs +11.7 % against the same task's "costs" solve); "polish" 97.5 % / 4 /
    1.90× (+7.9 %). One core, median CPU s to a converged plan (the bench's 20 tasks; the first 100
    by hand, twice): "costs" 0.68, "projection" 0.21 (0.21–0.24), "polish" 0.20 (0.22–0.23)."""
    polish_tolerance: float = 2.0
    """"polish" optimizes the costs of a projected plan that costs more than ĝ(x) + this × the
    threshold of the network's training filter (eq. (4), `learn.network.CostBound`; 1: the filter's
    own bound). Chosen on 100 validation tasks (seed 2; neither training nor held-out) with the
    n = 1000 cycle-3 network of the run at e31ada3 (tolerance: polished / converged / median
    iterations / median CPU s / median cost / largest ÷ median): 1: 56 / 95 % / 13 / 0.56 / 3.32 / 2.53;
    1.5: 41 / 95 % / 6.5 / 0.23 / 3.49 / 2.41; 2: 27 / 95 % / 4 / 0.21 / 3.59 / 2.34; 3: 16 / 95 % / 4 /
    0.20 / 3.63 / 2.31. The projections of that network cost more than the filter's bound on most
    tasks; at 2 the ones well beyond it are polished."""
    costs: CostWeights = CostWeights()
    swing_height_min: float | None = None
    base_clearance: float | None = None
    leg_clearance: float | None = 0.02
    """m: the surfaces of the legs' collision spheres (all but the feet) stay this far above the
    terrain's envelope at the range-of-motion samples (`LegClearanceBlock`): on by default, since the
    independent check judges every leg sphere against the terrain, with a margin for the tracking
    error of the executing controller. Left out on a level map, where no terrain rises to the legs
    (the check still judges them). None = off."""
    solver: ALParams = ALParams()
    projection_solver: ALParams = ALParams(exact_rows=True)
    """The "projection" warm stage's: the constraints alone, stopped by the exact per-row test (a last
    stage: no next stage profits from more precision, see `ALParams.exact_rows`)."""
    optimize_phases: bool = False
    """Optimize the phase durations too (`legplan.dyn.timing`: 2S more variables), from the gait's
    timing or the guess's; the swing samples move with their swing, the other samples stay at their
    times. TOWR's swing constraint (`towr_swing`) then keeps the swing durations of the timing it
    was built at. A guess with durations (a previous stage's, or a network's that predicts them)
    sets the timing either way: without this, the plan keeps it fixed (the paper's Fig. 8, dotted)."""
    phase_min: float = 0.2
    """s: the shortest phase of a foot when the durations are optimized (TOWR's lower bound)."""
    iteration_budget: int | None = None
    """LM iterations of the whole plan, all stages and both attempts (`planner.plan`) together: the
    paper's N of Algorithm 1 (N_h = 100, N_θ = 25); None = only each stage's own cap."""

    def __post_init__(self):
        if self.warm_stage not in WARM_STAGES:
            raise ValueError(f"DynParams.warm_stage: one of {', '.join(WARM_STAGES)}, not {self.warm_stage!r}")
        if not self.polish_tolerance >= 0:
            raise ValueError(f"DynParams.polish_tolerance: ≥ 0, not {self.polish_tolerance!r}")
        if not (isinstance(self.dynamics_points, int) and self.dynamics_points >= 1):
            raise ValueError(f"DynParams.dynamics_points: an integer ≥ 1, not {self.dynamics_points!r}")
        if not self.dynamics_band > 0:
            raise ValueError(f"DynParams.dynamics_band: > 0, not {self.dynamics_band!r}")


WARM_STAGES = ("costs", "projection", "polish")


LENGTH = 0.1  # m: the row scale of geometric constraints (a violation of 10 cm weighs 1)
LEVER = 0.056  # m: torques are scaled as forces at this lever arm: I/m of ANYmal, i.e. both rows in accelerations

PAPER_COSTS = CostWeights(base_z_velocity=1.0, base_angular_velocity=1.0, force=1.0, force_rate=0.01,
                          normal_force=1.0, derivative_weight=0.01, stair_edge=1.0, stair_edge_sigma=0.05,
                          swing_height=1.0)
"""Weights of the "paper" preset. The paper gives none; these were chosen on the single and double
pallet (force terms in units of m·g, see `costs`): all lower the peak base roll/pitch rate, and the
peak horizontal force, against no costs."""

PAPER = DynParams(costs=PAPER_COSTS, swing_height_min=0.05, base_clearance=0.2)
"""The paper's additions (Sec. III-A-1, III-A-2): its costs, swing apexes 5 cm above both adjacent
footholds, the base 20 cm above every foot (0.3 m, nearer the nominal 0.42 m, conflicts with the
range of motion when the base pitches on a climb: measured infeasible on both pallets)."""


@dataclass
class Problem:
    """Everything the solver needs, plus what the sampling and the checks need to read the solution."""

    task: DynTask
    form: Formulation
    terrain: TerrainModel
    model: object
    start: Pose
    goal: Pose
    start_feet: np.ndarray
    variables: list[VariableBlock]
    costs: list = field(default_factory=list)
    constraints: list[Constraint] = field(default_factory=list)
    timing: PhaseTiming | None = None
    """Set when the phase durations are variables (`DynParams.optimize_phases`); `form` then has the
    timing of the last solution (`planner.Budget.solve` moves it)."""
    durations: np.ndarray | None = None
    """The foot durations (``phases`` values) of a timing the guess set, None for the gait's: kept
    fixed when not optimized, and handed on with the solution so later stages keep it."""
    range_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    """The extra range-of-motion sample times (s) it was built with (`build_problem`)."""
    com_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """The CoM in the base frame (m): the base spline is the CoM's, `model` is `about_com`'s."""


RANGE_CHECK_DT = 0.001  # s: the grid on which `range_excess_times` looks for a foot outside its box


def range_excess_times(problem: Problem, values: dict[str, np.ndarray], above: float = 0.0) -> np.ndarray:
    """The times on the `RANGE_CHECK_DT` grid at which some foot's excess over its range-of-motion
    box (the model's box, not the planner's margin-reduced one) has a local maximum above `above`
    (m; 0: the foot is outside)."""
    form, model = problem.form, problem.model
    t = np.append(np.arange(0.0, form.duration, RANGE_CHECK_DT), form.duration)
    found = []
    for leg in range(form.legs):
        block = RangeOfMotionBlock(form, leg, model.nominal_feet[leg], t)
        offset = block.evaluate([values[v] for v in block.variables], False)[0].reshape(-1, 3)
        excess = np.pad((np.abs(offset) - model.range_of_motion).max(axis=1), 1, constant_values=-np.inf)
        peak = (excess[1:-1] > above) & (excess[1:-1] >= excess[:-2]) & (excess[1:-1] >= excess[2:])
        found.append(t[peak])
    return np.unique(np.concatenate(found))


def start_feet(model, pose: Pose, terrain: TerrainModel) -> np.ndarray:
    """Nominal stance under a base pose, rotated by its yaw, on the terrain (legs, 3)."""
    yaw = pose.euler[2]
    rz = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    xy = pose.position[:2] + model.nominal_feet[:, :2] @ rz.T
    return np.column_stack([xy, terrain.height(xy[:, 0], xy[:, 1])])


def task_poses(task: DynTask, model, terrain: TerrainModel) -> tuple[Pose, Pose]:
    """The CoM's start and goal poses of a task, whose x, y, yaw are the base's: the base at nominal
    height above the terrain under it, the CoM at `Centroidal.com_offset` in the base frame (goal
    height an initial guess)."""
    offset = np.asarray(model.com_offset, float)
    poses = []
    for x, y, yaw in (task.start, task.goal):
        z = float(terrain.height(np.array([x]), np.array([y]))[0]) + model.base_height
        turn = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
        poses.append(Pose(np.array([x, y, z]) + turn @ offset, np.array([0.0, 0.0, yaw])))
    return poses[0], poses[1]


def about_com(model):
    """The centroidal model seen from its CoM: nominal feet relative to the CoM (`com_offset`
    subtracted), CoM offset zero. The planner's base spline is the CoM's (the single rigid body's
    dynamics hold about it, Winkler et al. 2018 eq. (1)); the range-of-motion box stays where it is
    in the base frame, around p̄_i − o from the CoM."""
    offset = np.asarray(model.com_offset, float)
    if not offset.any():
        return model
    return replace(model, nominal_feet=model.nominal_feet - offset, com_offset=np.zeros(3))


def sample_times(form: Formulation, params: DynParams) -> dict:
    """Constraint sample times: dynamics at the base knots and at `DynParams.dynamics_points` − 1
    equally spaced points inside every base interval ("between"), range of motion every dt_range."""
    rom = np.unique(np.append(np.arange(0.0, form.duration, params.dt_range), form.duration))
    start, width = form.knots[:-1], np.diff(form.knots)
    inside = np.arange(1, params.dynamics_points) / params.dynamics_points
    return {"dynamics": form.knots.copy(), "between": (start[:, None] + width[:, None] * inside).reshape(-1),
            "range": rom}


def build_problem(task: DynTask, model, terrain: TerrainModel, params: DynParams, initializer,
                  range_times: np.ndarray = (), near_range: float | None = None) -> Problem:
    """The constrained least-squares problem of one task (see module docstring); `range_times` are
    extra range-of-motion sample times (s), where the planner found a foot outside its box between
    the regular ones (`range_excess_times`); with `near_range` (m) also those where the
    initializer's guess comes within that of a box (`planner.GUESS_RANGE_NEAR`)."""
    form = Formulation(make_gait(task.gait, task.strides, task.duration), params.dt,
                       aligned=params.phase_knots)
    start, goal = task_poses(task, model, terrain)
    offset, legs = np.asarray(model.com_offset, float), model.leg_kinematics
    model = about_com(model)
    feet0 = start_feet(model, start, terrain)
    guess = initializer(form, model, terrain, start, goal, feet0)
    durations = None
    if PHASES in guess or params.optimize_phases:  # a previous stage's or a network's timing, optimized
        gait_timing = PhaseTiming(form, params.phase_min)  # from or kept at; or the gait's, in the bounds
        durations = gait_timing.admissible(guess.get(PHASES, gait_timing.initial()))
        form = gait_timing.formulation(durations)
    timing = PhaseTiming(form, params.phase_min) if params.optimize_phases else None
    problem = Problem(task, form, terrain, model, start, goal, feet0, form.variables(start, goal, feet0, guess),
                      timing=timing, durations=durations, range_times=np.asarray(range_times, float),
                      com_offset=offset)
    if near_range is not None:
        guess_values = {v.name: v.value for v in problem.variables}
        problem.range_times = np.union1d(problem.range_times, range_excess_times(problem, guess_values, -near_range))
    times = sample_times(form, params)
    k = problem.constraints
    if timing is not None:
        problem.variables.append(timing.variable(durations))
        k.append(Constraint(timing.last_phase_block(), params.phase_min, np.inf, name="last_phase", scale=1.0 / LENGTH))
    weight = model.mass * GRAVITY
    k.append(Constraint(DynamicsBlock(form, model.mass, model.inertia, times["dynamics"], timing), name="dynamics",
                        scale=np.tile(np.repeat([1.0 / weight, 1.0 / (weight * LEVER)], 3), times["dynamics"].size)))
    if times["between"].size:
        lever = float(np.linalg.norm(model.nominal_feet[:, :2], axis=1).max())
        band = np.tile(np.repeat([params.dynamics_band * weight, params.dynamics_band * weight * lever], 3),
                       times["between"].size)
        k.append(Constraint(DynamicsBlock(form, model.mass, model.inertia, times["between"], timing), -band, band,
                            name="dynamics_between",
                            scale=np.tile(np.repeat([1.0 / weight, 1.0 / (weight * LEVER)], 3), times["between"].size)))
    for var in ("base_lin", "base_ang"):
        k.append(Constraint(acceleration_continuity(form, var), name="acceleration_continuity", scale=1.0 / GRAVITY))
    if params.towr_swing and form.footsteps:
        k.append(Constraint(swing_constraint(form), name="swing", scale=np.tile([1.0 / LENGTH, 1.0], 2 * form.footsteps)))
    relief = bool(np.ptp(terrain.height_grid) > 0)  # on a level map the legs stand above the feet
    for leg, foot in enumerate(form.feet):
        swing_t = _swing_times(foot, params.swing_dt)
        rom_t = np.union1d(np.union1d(times["range"], swing_t),  # swing feet move fastest: also between
                           problem.range_times)  # the dt_range points
        box = np.tile(model.range_of_motion - params.range_margin, rom_t.size)
        k.append(Constraint(RangeOfMotionBlock(form, leg, model.nominal_feet[leg], rom_t, timing), -box, box,
                            name="range_of_motion", scale=1.0 / LENGTH))
        k.append(Constraint(TerrainHeightBlock(terrain, form.node_selector(foot.stance_nodes, form.motion_nodes)),
                            name="stance_on_terrain", scale=1.0 / LENGTH))
        if params.stance_slope_max is not None and len(foot.stance_nodes) > 1:  # the first is the start
            k.append(Constraint(StanceSlopeBlock(terrain, form.node_selector(foot.stance_nodes[1:], form.motion_nodes)),
                                -np.inf, params.stance_slope_max, name="stance_off_edges"))
        if swing_t.size:
            swing = form.foot_matrix(leg, swing_t) if timing is None else \
                TimedSamples(timing, "motion", leg, swing_t, moving=True)  # they move with their swing
            k.append(Constraint(TerrainHeightBlock(terrain, swing, envelope=True),
                                params.swing_clearance, np.inf, name="swing_above_terrain", scale=1.0 / LENGTH))
        points, stance_node = form.force_control_points(leg)
        lower, upper = ForceBlock.bounds(points.shape[0], model.max_normal_force)
        k.append(Constraint(ForceBlock(terrain, model.friction, points if timing is None else TimedControlPoints(timing, leg),
                                       form.node_selector(stance_node, form.motion_nodes)),
                            lower, upper, name="force", scale=1.0 / weight))
        if params.leg_clearance is not None and relief:
            if legs is None:
                raise ValueError("DynParams.leg_clearance needs the robot's legs (Centroidal.leg_kinematics)")
            k.append(Constraint(LegClearanceBlock(form, leg, legs, terrain, rom_t, timing, offset),
                                params.leg_clearance, np.inf, name="leg_clearance", scale=1.0 / LENGTH))
    if params.swing_height_min is not None and form.footsteps:
        k.append(Constraint(swing_height(form), params.swing_height_min, np.inf, name="swing_height",
                            scale=1.0 / LENGTH))
    if params.base_clearance is not None:
        k.append(Constraint(BaseAboveFeetBlock(form, times["range"], timing), params.base_clearance, np.inf,
                            name="base_clearance", scale=1.0 / LENGTH))
    problem.costs = cost_blocks(form, terrain, model, params.costs, timing)
    return problem


def cost_blocks(form: Formulation, terrain: TerrainModel, model, w: CostWeights, timing: PhaseTiming | None = None
                ) -> list:
    """The weighted cost blocks (name, block, weight) of the weights `w` with a positive weight."""
    costs = integral_costs(form, w, model.mass, timing)
    if w.stair_edge > 0 and terrain.has_edges:
        nodes = [n for foot in form.feet for n in foot.stance_nodes]
        costs.append(("stair_edge", StairEdgeBlock(terrain, form.node_selector(nodes, form.motion_nodes),
                                                   w.stair_edge_sigma), w.stair_edge))
    if w.swing_height > 0 and form.footsteps:
        costs.append(("swing_height", swing_height(form), w.swing_height))
    return costs


def _swing_times(foot, dt: float) -> np.ndarray:
    """Times strictly inside each of the two polynomials of every swing, at most `dt` apart."""
    out = []
    for p in foot.phases:
        if not p.stance:
            half = 0.5 * p.duration
            count = max(1, int(np.ceil(half / dt)) - 1)
            s = np.arange(1, count + 1) / (count + 1)
            out += list(p.t0 + half * s) + list(p.t0 + half + half * s)
    return np.array(out)
