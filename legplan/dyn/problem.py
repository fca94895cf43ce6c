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
from legplan.dyn.settings import PAPER, PAPER_COSTS, DynParams  # noqa: F401 (the planner's parameters, re-exported)
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import PHASES, PhaseTiming, TimedControlPoints, TimedSamples
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
        if params.leg_clearance is not None:
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
    """The cost terms (`CostTerm`) of the weights `w` with a positive weight."""
    costs = integral_costs(form, w, model.mass, timing)
    if w.stair_edge > 0 and terrain.has_edges:
        nodes = [n for foot in form.feet for n in foot.stance_nodes]
        costs.append(CostTerm("stair_edge", StairEdgeBlock(terrain, form.node_selector(nodes, form.motion_nodes),
                                                           w.stair_edge_sigma), w.stair_edge))
    if w.swing_height > 0 and form.footsteps:
        costs.append(CostTerm("swing_height", swing_height(form), w.swing_height))
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
