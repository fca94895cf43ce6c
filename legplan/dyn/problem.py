"""One centroidal planning problem: task, parameters, and its costs and constraints on the splines.

`build_problem` turns a `DynTask` (start and goal base pose, gait, strides, duration) on a terrain into
the variable blocks of a `Formulation` (initialized by an `Initializer`), the weighted cost blocks of
`costs` and the bounded constraint blocks of `constraints` — the NLP of Sec. III-A of the TOWR-costs
paper, stated as constrained least squares for `legplan.solve.solve_augmented_lagrangian`. With
`DynParams.optimize_phases` the phase durations are variables too (`legplan.dyn.timing`).

The problem is built from declared names, as TOWR's formulation is: every constraint has a builder
declared under its name (`constraint`, the registry `CONSTRAINTS`, in build order; per leg or per
problem), every cost term beyond eq. (1)'s integrals likewise (`cost`, `COSTS`). A builder reads
`DynParams` and returns no block when its setting switches it off. Adding a constraint is writing
its block (`legplan.dyn.constraints`) and declaring its builder.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from legplan.dyn.constraints import (GRAVITY, BaseAboveFeetBlock, DynamicsBlock, FootTerrainBatch, ForceBatch,
                                     ForceBlock, JointTorqueBlock, LegClearanceBatch, LegClearanceBlock,
                                     RangeOfMotionBlock, StanceSlopeBlock, TerrainHeightBlock, acceleration_continuity,
                                     swing_constraint, swing_height)
from legplan.dyn.costs import CostWeights, StairEdgeBlock, StanceWidthBlock, integral_costs
from legplan.dyn.formulation import Formulation, Pose, dense_knots, unloaded_phases
from legplan.dyn.gait import make_gait
from legplan.dyn.settings import PAPER, PAPER_COSTS, DynParams  # noqa: F401 (the planner's parameters, re-exported)
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import PHASES, PhaseTiming, TimedControlPoints, TimedSamples
from legplan.geometry.ordered import sorted_union, sorted_unique
from legplan.solve import VariableBlock
from legplan.solve.auglag import Constraint, CostTerm


@dataclass(frozen=True)
class DynTask:
    """Start and goal base (x, y, yaw), the gait, its strides and the total duration (s)."""

    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    gait: str = "trot"
    strides: int = 4
    duration: float = 2.4


LENGTH = 0.1  # m: the row scale of geometric constraints (a violation of 10 cm weighs 1)
LEVER = 0.056  # m: torques are scaled as forces at this lever arm: I/m of ANYmal, i.e. both rows in accelerations


@dataclass
class DynProblem:
    """Everything the solver needs, plus what the sampling and the checks need to read the solution."""

    task: DynTask
    form: Formulation
    terrain: TerrainModel
    model: object
    start: Pose
    goal: Pose
    start_feet: np.ndarray
    variables: list[VariableBlock]
    costs: list[CostTerm] = field(default_factory=list)
    constraints: list[Constraint] = field(default_factory=list)
    timing: PhaseTiming | None = None
    """Set when the phase durations are variables (`DynParams.optimize_phases`); `form` then has the
    timing of its solution (the planner's stages move it there)."""
    durations: np.ndarray | None = None
    """The foot durations (``phases`` values) of a timing the guess set, None for the gait's: kept
    fixed when not optimized, and handed on with the solution so later stages keep it."""
    range_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    """The extra range-of-motion sample times (s) it was built with (`build_problem`)."""
    com_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """The CoM in the base frame (m): the base spline is the CoM's, `model` is `about_com`'s."""
    level_legs: bool = False
    """Whether the leg-clearance rows hold on a level map too: left out there, since an upright
    robot's legs stay clear of flat ground, unless a solution's legs touched it
    (`legs_touch_level_ground`, the planner's "range of motion" rounds)."""


SAMPLE_DT = 0.01  # s: the plan's samples, written to traj.h5 and judged by the independent check
RANGE_CHECK_DT = 0.001  # s: the grid on which `range_excess_times` looks for a foot outside its box


def sample_grid(duration: float, dt: float = SAMPLE_DT) -> np.ndarray:
    """t = 0, dt, ..., T: the times of a plan's samples (`planner.sample_solution`), where the
    independent check judges it."""
    return np.append(np.arange(0.0, duration - 1e-9, dt), duration)


def range_excess_times(problem: DynProblem, values: dict[str, np.ndarray], above: float = 0.0) -> np.ndarray:
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
    return sorted_unique(np.concatenate(found))


def legs_touch_level_ground(problem: DynProblem, params: DynParams, values: dict[str, np.ndarray]) -> bool:
    """Whether, on a level map whose problem leaves the leg-clearance rows out, some leg sphere of
    the solution `values` touches the ground at a plan sample (`sample_grid`, where the independent
    check judges `leg_penetration`): a crouched robot's shanks can, and then the rows must hold
    there too, with their `DynParams.leg_clearance` margin. An upright robot's legs that stay off
    the ground, if within the margin, add no rows (nor their cost) to a flat-ground plan."""
    model = problem.model
    if (not problem.terrain.level or problem.level_legs or params.leg_clearance is None
            or model.leg_kinematics is None):
        return False
    form = problem.form
    t = sample_grid(form.duration)
    for leg in range(form.legs):
        block = LegClearanceBlock(form, leg, model.leg_kinematics, problem.terrain, t, problem.timing,
                                  problem.com_offset)
        if block.rows and block.evaluate([values[v] for v in block.variables], False)[0].min() < 0.0:
            return True
    return False


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
    rom = sorted_unique(np.append(np.arange(0.0, form.duration, params.dt_range), form.duration))
    start, width = form.knots[:-1], np.diff(form.knots)
    inside = np.arange(1, params.dynamics_points) / params.dynamics_points
    return {"dynamics": form.knots.copy(), "between": (start[:, None] + width[:, None] * inside).reshape(-1),
            "range": rom}


def task_formulation(task: DynTask, params: DynParams, timed: bool = False,
                     base_height: float | None = None) -> Formulation:
    """The `Formulation` of a task's gait under `params` (its base knots: `DynParams.dt`,
    `phase_knots`, `unloaded_polynomials`; a trot's pairs at most `DynParams.line_support` × √(h/g)
    for the model's `base_height` h, none without it): the one variable layout of the task. `timed`:
    an initializer sets the phase durations (`sets_timing`), so that, as with `optimize_phases`, the
    phases need not stay at the gait's boundaries and the knots are dense everywhere."""
    gait = make_gait(task.gait, task.strides, task.duration, line_support_time(params, base_height))
    moving = params.optimize_phases or timed
    if moving and params.unloaded_polynomials is not None and unloaded_phases(gait).any():
        return gait_formulation(gait, params, dense_knots(gait, params.dt, params.unloaded_polynomials,
                                                          params.unloaded_dt))
    return gait_formulation(gait, params)


def gait_formulation(gait, params: DynParams, knots: np.ndarray | None = None) -> Formulation:
    """The `Formulation` of `gait` under the base-knot settings of `params` (`dt`, `phase_knots`,
    `unloaded_polynomials`, `unloaded_dt`), or on the given `knots`: the one place a plan's and a
    replan's layouts read those settings."""
    return Formulation(gait, params.dt, knots, aligned=params.phase_knots,
                       unloaded_polynomials=params.unloaded_polynomials, unloaded_dt=params.unloaded_dt)


def line_support_time(params: DynParams, base_height: float | None) -> float | None:
    """The longest diagonal-pair stance (s) of a trot, `DynParams.line_support` × √(h/g); None when
    off or no base height h is given."""
    if params.line_support is None or base_height is None:
        return None
    return float(params.line_support * np.sqrt(base_height / GRAVITY))


def sets_timing(initializer) -> bool:
    """Whether an initializer's guesses carry phase durations (`PHASES`: a network trained with them),
    which then set the plan's timing (`legplan.dyn.timing`)."""
    return bool(getattr(initializer, "sets_timing", False))


def build_problem(task: DynTask, model, terrain: TerrainModel, params: DynParams, initializer,
                  range_times: np.ndarray = (), near_range: float | None = None,
                  level_legs: bool = False) -> DynProblem:
    """The constrained least-squares problem of one task (see module docstring); `range_times` are
    extra range-of-motion sample times (s), where the planner found a foot outside its box between
    the regular ones (`range_excess_times`); with `near_range` (m) also those where the
    initializer's guess comes within that of a box (`planner.GUESS_RANGE_NEAR`); `level_legs`: the
    leg-clearance rows on a level map too (`DynProblem.level_legs`)."""
    offset = np.asarray(model.com_offset, float)
    if hasattr(task, "setup"):  # a task that states its own gait, start state and feet (`legplan.dyn.replan`)
        form, start, goal, feet0 = task.setup(model, terrain, params)
        model = about_com(model)
    else:
        form = task_formulation(task, params, timed=sets_timing(initializer), base_height=model.base_height)
        start, goal = task_poses(task, model, terrain)
        model = about_com(model)
        feet0 = start_feet(model, start, terrain)
    guess = initializer(form, model, terrain, start, goal, feet0)
    durations = None
    if PHASES in guess or params.optimize_phases:  # a previous stage's or a network's timing, optimized
        gait_timing = PhaseTiming(form, params.phase_min)  # from or kept at; or the gait's, in the bounds
        durations = gait_timing.admissible(guess.get(PHASES, gait_timing.initial()))
        form = gait_timing.formulation(durations)
    timing = PhaseTiming(form, params.phase_min) if params.optimize_phases else None
    problem = DynProblem(task, form, terrain, model, start, goal, feet0, form.variables(start, goal, feet0, guess),
                         timing=timing, durations=durations, range_times=np.asarray(range_times, float),
                         com_offset=offset, level_legs=level_legs)
    if near_range is not None:
        guess_values = {v.name: v.value for v in problem.variables}
        problem.range_times = sorted_union(problem.range_times, range_excess_times(problem, guess_values, -near_range))
    if timing is not None:
        problem.variables.append(timing.variable(durations))
    until = getattr(task, "sample_until", None)  # a replan's window (`legplan.dyn.replan`): no samples after it
    context = BuildContext(problem, params, _window(sample_times(form, params), until), until=until)
    problem.constraints = declared_constraints(context)
    problem.costs = cost_blocks(form, terrain, model, params.costs, timing)
    if hasattr(task, "constrain"):  # its measured start state beyond what `Formulation.variables` fixes
        task.constrain(problem)
    return problem


@dataclass
class BuildContext:
    """What a constraint builder reads: the problem (formulation, terrain, model, timing, extra range
    samples), the parameters and the regular sample times (`sample_times`); for a per-leg builder
    also the leg, its foot, the sample times strictly inside its swings and its range-of-motion
    sample times (the regular ones, the swing ones and the problem's extra ones)."""

    problem: DynProblem
    params: DynParams
    times: dict
    leg: int | None = None
    foot: object = None
    swing_times: np.ndarray | None = None
    range_times: np.ndarray | None = None
    until: float | None = None
    shared: dict = field(default_factory=dict)  # what the legs' builders share (the same dict for every leg)

    def for_leg(self, leg: int) -> BuildContext:
        foot = self.problem.form.feet[leg]
        swing_t = _window(_swing_times(foot, self.params.swing_dt), self.until)
        rom_t = sorted_union(sorted_union(self.times["range"], swing_t),  # swing feet move fastest: also between
                           _window(self.problem.range_times, self.until))  # the dt_range points
        return replace(self, leg=leg, foot=foot, swing_times=swing_t, range_times=rom_t)


def _window(times, until: float | None):
    """Sample times (an array, or a dict of arrays) up to `until` (s; None: all)."""
    if until is None:
        return times
    if isinstance(times, dict):
        return {name: _window(t, until) for name, t in times.items()}
    return times[times <= until + 1e-9]


CONSTRAINTS: dict[str, tuple[bool, Callable[[BuildContext], list[Constraint]]]] = {}
"""The declared constraints, in build order: name → (per leg, builder). A builder returns the
constraint's blocks for the problem (or for one leg), none where its parameter switches it off;
consecutive per-leg constraints are built leg by leg."""


def constraint(name: str, per_leg: bool = False):
    """Declare the builder of the constraint `name` (a decorator): adding a constraint to the
    centroidal problem is writing its block and declaring its builder here."""
    def declare(builder):
        CONSTRAINTS[name] = (per_leg, builder)
        return builder
    return declare


def declared_constraints(context: BuildContext) -> list[Constraint]:
    """Every declared constraint's blocks for the problem of `context`, in declaration order."""
    out = []
    for per_leg, group in itertools.groupby(CONSTRAINTS.values(), key=lambda entry: entry[0]):
        builders = [builder for _, builder in group]
        for ctx in ([context.for_leg(leg) for leg in range(context.problem.form.legs)] if per_leg else [context]):
            for builder in builders:
                out += builder(ctx)
    return out


@constraint("last_phase")
def _last_phase(c: BuildContext) -> list[Constraint]:
    timing = c.problem.timing
    if timing is None:
        return []
    return [Constraint(timing.last_phase_block(), c.params.phase_min, np.inf, name="last_phase", scale=1.0 / LENGTH)]


@constraint("dynamics")
def _dynamics(c: BuildContext) -> list[Constraint]:
    p, model, t = c.problem, c.problem.model, c.times["dynamics"]
    weight = model.mass * GRAVITY
    return [Constraint(DynamicsBlock(p.form, model.mass, model.inertia, t, p.timing), name="dynamics",
                       scale=np.tile(np.repeat([1.0 / weight, 1.0 / (weight * LEVER)], 3), t.size))]


@constraint("dynamics_between")
def _dynamics_between(c: BuildContext) -> list[Constraint]:
    """Newton–Euler rows inside ±`DynParams.dynamics_band` between the knots."""
    p, model, t = c.problem, c.problem.model, c.times["between"]
    if not t.size:
        return []
    weight = model.mass * GRAVITY
    lever = float(np.linalg.norm(model.nominal_feet[:, :2], axis=1).max())
    band = np.tile(c.params.dynamics_band * np.repeat([weight, weight * lever], 3), t.size)
    return [Constraint(DynamicsBlock(p.form, model.mass, model.inertia, t, p.timing), -band, band,
                       name="dynamics_between", scale=np.tile(np.repeat([1.0 / weight, 1.0 / (weight * LEVER)], 3), t.size))]


@constraint("acceleration_continuity")
def _acceleration_continuity(c: BuildContext) -> list[Constraint]:
    return [Constraint(acceleration_continuity(c.problem.form, var), name="acceleration_continuity",
                       scale=1.0 / GRAVITY) for var in ("base_lin", "base_ang")]


@constraint("swing")
def _towr_swing(c: BuildContext) -> list[Constraint]:
    form = c.problem.form
    if not (c.params.towr_swing and form.footsteps):
        return []
    return [Constraint(swing_constraint(form), name="swing", scale=np.tile([1.0 / LENGTH, 1.0], 2 * form.footsteps))]


@constraint("range_of_motion", per_leg=True)
def _range_of_motion(c: BuildContext) -> list[Constraint]:
    p, model = c.problem, c.problem.model
    box = np.tile(model.range_of_motion - c.params.range_margin, c.range_times.size)
    return [Constraint(RangeOfMotionBlock(p.form, c.leg, model.nominal_feet[c.leg], c.range_times, p.timing), -box, box,
                       name="range_of_motion", scale=1.0 / LENGTH)]


@constraint("stance_on_terrain", per_leg=True)
def _stance_on_terrain(c: BuildContext) -> list[Constraint]:
    form = c.problem.form
    batch = c.shared.setdefault("stance_on_terrain", FootTerrainBatch())  # the legs evaluated together
    return [Constraint(TerrainHeightBlock(c.problem.terrain, form.node_selector(c.foot.stance_nodes, form.motion_nodes)
                                          ).join(batch),
                       name="stance_on_terrain", scale=1.0 / LENGTH)]


@constraint("stance_off_edges", per_leg=True)
def _stance_off_edges(c: BuildContext) -> list[Constraint]:
    form, nodes = c.problem.form, c.foot.stance_nodes
    if c.params.stance_slope_max is None or len(nodes) <= 1:  # the first is the start
        return []
    batch = c.shared.setdefault("stance_off_edges", FootTerrainBatch())
    return [Constraint(StanceSlopeBlock(c.problem.terrain, form.node_selector(nodes[1:], form.motion_nodes)).join(batch),
                       -np.inf, c.params.stance_slope_max, name="stance_off_edges")]


@constraint("swing_above_terrain", per_leg=True)
def _swing_above_terrain(c: BuildContext) -> list[Constraint]:
    p = c.problem
    if not c.swing_times.size:
        return []
    if p.timing is None:  # fixed phases: also at the samples the plan is written and checked at
        times = sorted_union(c.swing_times, _window(_grid_times(c.foot, SAMPLE_DT), c.until))
        swing = p.form.foot_matrix(c.leg, times)
    else:
        swing = TimedSamples(p.timing, "motion", c.leg, c.swing_times, moving=True)  # they move with their swing
    batch = c.shared.setdefault("swing_above_terrain", FootTerrainBatch())
    return [Constraint(TerrainHeightBlock(p.terrain, swing, envelope=True).join(batch), c.params.swing_clearance, np.inf,
                       name="swing_above_terrain", scale=1.0 / LENGTH)]


@constraint("force", per_leg=True)
def _force(c: BuildContext) -> list[Constraint]:
    p, model = c.problem, c.problem.model
    points, stance_node = p.form.force_control_points(c.leg)
    lower, upper = ForceBlock.bounds(points.shape[0], model.max_normal_force)
    batch = c.shared.setdefault("force", ForceBatch())  # the legs evaluated together
    return [Constraint(ForceBlock(p.terrain, model.friction, points if p.timing is None else TimedControlPoints(p.timing, c.leg),
                                  p.form.node_selector(stance_node, p.form.motion_nodes), batch),
                       lower, upper, name="force", scale=1.0 / (model.mass * GRAVITY))]


@constraint("joint_torque", per_leg=True)
def _joint_torque(c: BuildContext) -> list[Constraint]:
    """The leg's joint torques inside its `Centroidal.torque_limits` less `DynParams.torque_margin`,
    at the dynamics samples (knots and between) of its stance phases, their ends included (a stance
    at the motion's start or end carries its load there; the check judges every sample of a stance),
    all of them when the phases move; none for a model without torque limits (TOWR's scalar bound
    alone)."""
    p, model = c.problem, c.problem.model
    limits = getattr(model, "torque_limits", None)
    if limits is None:
        return []
    if model.leg_chains is None:
        raise ValueError("Centroidal.torque_limits need the legs' chains (Centroidal.leg_chains)")
    t = sorted_union(c.times["dynamics"], c.times["between"])
    if p.timing is None:
        inside = np.zeros(t.size, bool)
        for phase in c.foot.phases:
            if phase.stance:
                inside |= (t >= phase.t0) & (t <= phase.t0 + phase.duration)
        t = t[inside]
    if not t.size:
        return []
    bound = np.tile(np.asarray(limits[c.leg], float) * (1.0 - c.params.torque_margin), t.size)
    return [Constraint(JointTorqueBlock(p.form, c.leg, model.leg_chains, t, p.timing, p.com_offset), -bound, bound,
                       name="joint_torque", scale=1.0 / np.tile(np.asarray(limits[c.leg], float), t.size))]


@constraint("leg_clearance", per_leg=True)
def _leg_clearance(c: BuildContext) -> list[Constraint]:
    """Left out on a level map, where no terrain rises to the legs, unless the problem holds them
    there too (`DynProblem.level_legs`: a solution's legs touched the ground)."""
    p, model = c.problem, c.problem.model
    if c.params.leg_clearance is None or (p.terrain.level and not p.level_legs):
        return []
    if model.leg_kinematics is None:
        raise ValueError("DynParams.leg_clearance needs the robot's legs (Centroidal.leg_kinematics)")
    batch = c.shared.setdefault("leg_clearance", LegClearanceBatch())  # the legs evaluated together
    return [Constraint(LegClearanceBlock(p.form, c.leg, model.leg_kinematics, p.terrain, c.range_times, p.timing,
                                         p.com_offset, batch),
                       c.params.leg_clearance, np.inf, name="leg_clearance", scale=1.0 / LENGTH)]


@constraint("swing_height")
def _swing_height(c: BuildContext) -> list[Constraint]:
    form = c.problem.form
    if c.params.swing_height_min is None or not form.footsteps:
        return []
    return [Constraint(swing_height(form), c.params.swing_height_min, np.inf, name="swing_height", scale=1.0 / LENGTH)]


@constraint("base_clearance", per_leg=True)
def _base_clearance(c: BuildContext) -> list[Constraint]:
    """Held at the leg's range-of-motion samples, and with fixed phases also at the plan's samples
    inside its swings (where the independent check judges `base_above_feet` and a foot rises fastest)."""
    p = c.problem
    if c.params.base_clearance is None or not c.range_times.size:
        return []
    times = c.range_times
    if p.timing is None and c.swing_times.size:
        times = sorted_union(times, _window(_grid_times(c.foot, SAMPLE_DT), c.until))
    return [Constraint(BaseAboveFeetBlock(p.form, c.leg, times, p.timing, p.com_offset), c.params.base_clearance, np.inf,
                       name="base_clearance", scale=1.0 / LENGTH)]


COSTS: dict[str, Callable] = {}
"""The declared cost terms beyond eq. (1)'s integral ones (`integral_costs`): name →
builder(form, terrain, model, weights, timing) → `CostTerm`s (none at weight 0)."""


def cost(name: str):
    """Declare the builder of the cost term `name` (a decorator)."""
    def declare(builder):
        COSTS[name] = builder
        return builder
    return declare


def cost_blocks(form: Formulation, terrain: TerrainModel, model, w: CostWeights, timing: PhaseTiming | None = None
                ) -> list[CostTerm]:
    """The cost terms (`CostTerm`) of the weights `w` with a positive weight: eq. (1)'s integral
    terms, then every declared one (`COSTS`)."""
    costs = integral_costs(form, w, model.mass, timing)
    for builder in COSTS.values():
        costs += builder(form, terrain, model, w, timing)
    return costs


@cost("stair_edge")
def _stair_edge(form, terrain, model, w: CostWeights, timing) -> list[CostTerm]:
    if not (w.stair_edge > 0 and terrain.has_edges):
        return []
    nodes = [n for foot in form.feet for n in foot.stance_nodes]
    return [CostTerm("stair_edge", StairEdgeBlock(terrain, form.node_selector(nodes, form.motion_nodes),
                                                  w.stair_edge_sigma), w.stair_edge)]


@cost("stance_width")
def _stance_width(form, terrain, model, w: CostWeights, timing) -> list[CostTerm]:
    """Off while the phases move (`optimize_phases`: the stances' middles move with them)."""
    if not (w.stance_width > 0 and timing is None):
        return []
    return [CostTerm("stance_width", StanceWidthBlock(form, model.nominal_feet[:, 1]), w.stance_width)]


@cost("swing_height")
def _swing_height_cost(form, terrain, model, w: CostWeights, timing) -> list[CostTerm]:
    if not (w.swing_height > 0 and form.footsteps):
        return []
    return [CostTerm("swing_height", swing_height(form), w.swing_height)]


def _grid_times(foot, dt: float) -> np.ndarray:
    """The times k·dt of the plan's sampling (`planner.sample_solution`, the samples the independent
    check judges) strictly inside each swing: a foot crossing an edge between the swing's own
    samples is held above the terrain at the times it is checked at too."""
    out = []
    for p in foot.phases:
        if not p.stance:
            first = int(np.floor(p.t0 / dt + 1e-9)) + 1
            last = int(np.ceil((p.t0 + p.duration) / dt - 1e-9)) - 1
            out.append(np.arange(first, last + 1) * dt)
    return np.concatenate(out) if out else np.zeros(0)


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
