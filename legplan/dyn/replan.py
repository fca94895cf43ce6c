"""Online replanning: the rest of a centroidal plan, from a measured state at time t (issue 39 item 3).

    previous = Previous.from_plan(result)                  # or Previous.from_record(traj task group)
    state = MeasuredState(t=1.2, base_pos=..., base_euler=..., base_vel=..., base_ang_vel=..., feet_pos=...)
    out = replan(previous, state, model, terrain, params)
    out.success, out.iterations, out.cpu_seconds, out.plan.samples   # samples on the new time axis, 0 = t

The rest of the motion is the previous plan's problem on [t, T] (model predictive control, as the
TOWR-costs paper motivates its fast solves with, Sec. I): the gait's remaining phases with their
durations (the phase holding t shortened to what is left of it), the remaining footholds in their
order, the same goal. Its first node is the measured state: the CoM's pose and velocity (the base
spline is the CoM's, `problem.about_com`: c = p + R o, ċ = ṗ + ω × R o), every foot in stance fixed
where it stands. A foot in the air at t starts the new problem with a short stance at its measured
position (`AIRBORNE_HOLD`, zero force, off the terrain constraint), then the rest of its swing: the
formulation's feet start in stance.

The guess is the previous solution shifted in time (`ShiftedInit`): every node of the new splines
takes the previous splines' value and rate at its own time t + τ, so after the phase holding t the
new splines are the previous ones.

A pushed base (`ReplanParams.recovery_velocity`: its measured CoM velocity that far from the previous
plan's) recovers: every foot in the air at t lands within `ReplanParams.recovery_swing` and stands
until its planned touchdown (`early_touchdown`), the rest of the gait unchanged. With the timing
fixed, a walk pushed while a diagonal pair carries it tips over about that pair before the third
foot lands as planned, and no rest of the motion from there converges; a foot down sooner gives
the capture point (Pratt et al. 2006) a support polygon to stop in, and the replan places it.
A recovering replan also stands every flight of the rest on every foot (`grounded_flights`,
`ReplanParams.recovery_support`): a flying trot pushed sideways would otherwise spend its flights
with no force to stop the base, and the pair landing while the other pair still stands gives the
capture point the whole support polygon.

A foot the plan has in stance at t that the robot senses off the ground, above the terrain (a late
touchdown: `MeasuredState.contact`, `lifted_feet`, `ReplanParams.touchdown_height`), is in the air
at t as a swing foot is: held where it is with no force, it swings down within
`ReplanParams.late_swing` and stands from there to its planned lift-off. Taken as in stance, the
replan would stand it on the terrain at once, centimetres from where it is, and push on it: a
support the robot does not have.

A base pushed faster than the rest of its steps can stop may need more steps
(`ReplanParams.extension`, off by default): a recovering replan then inserts whole strides of the
plan's gait (`gait_stride`, `insert_strides`) before its last one, as many as the linear inverted
pendulum needs to stop the measured velocity error with its feet at the edge of their range of
motion and walk back (`recovery_time`), within the extension left; the goal stays, the motion ends
later. The guess repeats the stride before the inserted ones for the feet and forces and holds the
base at rest there.

What the measured state itself violates is not the replan's to undo at once: a foot outside its
range-of-motion box at t (tracking error, a push) may stay outside by that excess, shrinking
linearly to none over `ReplanParams.settle`; what is left of a swing at t has no swing-height rows.
A foot standing at t stands where it was measured, and through the stance under way each of its
leg's spheres may keep the clearance deficit the measured state has (a foot at the foot of a step's
side) (`ReplanTask._stance_under_way`).

Optional receding horizon (`ReplanParams.horizon`, off by default: freezing the tail leaves the
free part less room and the solve converges no faster), model predictive control with a terminal
constraint: the feet move only within the first h seconds. Every foothold touched down at or after h (with the
forces of its stance) and every swing apex at or after h keep the shifted previous value
(`frozen_tail`), and so does the base from the first knot at or after the last time a free foot
node reaches (a foothold until the end of its stance and the apex of its next swing), `Tail.until`.
The base state there is the previous plan's (the terminal constraint), and what follows is the
previous plan itself, which was feasible. The constraints are sampled only up to `Tail.until`:
after it every sample reads frozen nodes alone.

Optional sampling window (`ReplanParams.window`, off by default): the constraints are sampled only
within the first w seconds and nothing is frozen; the nodes no row reads keep the shifted previous
plan (but for what the knots' continuity rows carry over) until later replans reach them — model
predictive control without a terminal constraint, which plans myopically: a pushed base's momentum
is left for after the window.

One solve, no stages: the constraints alone (`DynParams.projection_solver`, "projection") or the
costs under them (`warm_solver`, "costs") from the shifted guess, capped at
`ReplanParams.max_iterations` LM iterations and `ReplanParams.cpu_budget` CPU seconds, whichever
comes first (an online replanner's bounds: a replan stopped by either ends at the point its solve
reached, the best so far) (`ReplanParams.geodesic_acceleration` may switch the
solver's geodesic acceleration off: its curvature probe costs a residual evaluation per step). A
replan succeeds when every constraint row it samples (in its window, with the relaxations above)
is within the solver's `violation_tolerance` or within `ReplanParams.scaled_tolerance` of its row
scale (`auglag.row_tolerances`: a force row may keep that share of the robot's weight, where 1e-3 N
alone asks iterations no tracking controller notices) (CONVERGED). What it does not do, and the
planner does: the range-of-motion exchange stages and the fallback stages from the heuristic guess;
the independent check of a whole plan (`legplan.validate`) runs on `dyn replan`'s output, and in
the simulator the execution judges it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from legplan.dyn.capture import capture_step, recovery_time
from legplan.dyn.constraints import GRAVITY
from legplan.dyn.costs import CostWeights
from legplan.dyn.euler import rotation, world_rates
from legplan.dyn.formulation import Formulation, Pose
from legplan.dyn.gait import Gait
from legplan.dyn.planner import PlanResult, StageOutcome, sample_solution
from legplan.dyn.problem import build_problem, gait_formulation
from legplan.dyn.rest_gait import (EPS, PHASE_END, Insertion, early_touchdown, gait_stride, grounded_flights,
                                   insert_strides, remaining_gait)
from legplan.dyn.settings import DynParams
from legplan.dyn.shifted_init import ShiftedInit
from legplan.parameters import Parameters, param
from legplan.solve.auglag import Constraint, solve_augmented_lagrangian
from legplan.solve.auglag import scaled_violation as max_scaled_violation
from legplan.solve.lm import Status

SHORT_FIRST = 0.3  # share of dt: a shorter first base polynomial of a replan is merged into the next


@dataclass(frozen=True)
class ReplanParams(Parameters):
    """Settings of one replan (module docstring)."""

    what = "replan"

    horizon: float | None = param(None, "(0, inf)", doc=(
        "s after the measured state within which footholds and swings move; the base moves until "
        "their stances end, after that the previous plan is kept (`frozen_tail`, a terminal "
        "constraint); None: the whole rest moves"))
    window: float | None = param(None, "(0, inf)", doc=(
        "s after the measured state within which the replan samples its constraints (`ReplanTask."
        "sample_until`), nothing frozen: the nodes after it keep the shifted previous plan and are "
        "replanned as later replans reach them (receding horizon without a terminal constraint); "
        "None: the whole rest"))
    max_iterations: int = param(25, "[1, 10000]", doc="LM iterations of a replan, at most")
    cpu_budget: float | None = param(3.0, "(0, inf)", doc=(
        "CPU s of a replan, building included, at most: no LM step starts after it (`Status."
        "TIME_LIMIT`) and the replan ends where its solve is, as at `max_iterations` (an online "
        "replanner must answer in time; the iteration budget alone bounds a replan's work, not its "
        "time). A replan it stops depends on the machine's speed; None: no time limit"))
    scaled_tolerance: float = param(1e-3, "[0, inf)", doc=(
        "a replan's row also counts as converged when its violation is within this share of its "
        "solver scale (`ALParams.scaled_tolerance`, replacing the solver's: forces and torques per the "
        "robot's weight, where the solver's violation_tolerance asks for 1e-3 N); 0: the solver's "
        "violation_tolerance alone"))
    geodesic_acceleration: float | None = param(None, "[0, inf)", "α", doc=(
        "the replan's LM geodesic acceleration (`HingedParams.geodesic_acceleration`), replacing the "
        "solver's: each step's curvature probe costs one more residual evaluation, and without it "
        "pushed replans land elsewhere (0: off); None: the solver's"))
    track_violation: float = param(float("inf"), "[0, inf]", doc=(
        "closed loop (`legplan.sim.replanning`): the controller also tracks a replan that ran out of "
        "iterations or stalled when its largest constraint violation, each row in the solver's "
        "scale (`ReplanResult.scaled_violation`: forces per the robot's weight, lengths per 10 cm, "
        "accelerations per g), is within this; inf (default): every one, since it starts from the "
        "measured state and the last plan from a state the robot has left (a push); 0: converged "
        "replans only"))
    recovery_velocity: float | None = param(0.2, "(0, inf)", doc=(
        "m/s: a replan whose measured CoM velocity is this far from the previous plan's at t (a "
        "push) recovers: every foot in the air lands within `recovery_swing` (`early_touchdown`) "
        "and stands until its planned lift-off; None: the feet keep their planned swings"))
    recovery_swing: float = param(0.12, "(0, inf)", doc=(
        "s: in a recovering replan, what a foot in the air at t has left of its swing, at most"))
    recovery_support: bool = param(True, (False, True), doc=(
        "in a recovering replan, every flight of the rest (no foot down, a flying trot's) stands on "
        "every foot instead (`grounded_flights`): a pushed base is stopped by forces, and a flight "
        "has none; False: the gait's flights stay"))
    touchdown_height: float | None = param(0.01, "(0, inf)", doc=(
        "m: a foot the plan has in stance at t that the measured state senses out of contact "
        "(`MeasuredState.contact`) with its contact point more than this above the terrain is in the "
        "air (a late touchdown, `lifted_feet`): it lands within `late_swing`; None: every foot as "
        "its plan says"))
    late_swing: float = param(0.05, "(0, inf)", doc=(
        "s: what a late foot (`touchdown_height`) swings after its hold before it stands, at most "
        "(its stance then goes on as planned)"))
    step_adaptation: float = param(0.0, "[0, inf)", doc=(
        "× the capture-point shift of the next foothold of every foot in the replan's guess "
        "(`capture_step` of the CoM's horizontal velocity error against the previous plan at t): a "
        "pushed base needs its next steps where they can stop it; 0: the previous footholds"))
    extension: float = param(0.0, "[0, inf)", doc=(
        "s: how much later than planned a pushed motion may end, at most, all its replans together: "
        "a recovering replan inserts whole strides of the plan's gait (`Previous.stride`) before its "
        "last one, as many as `recovery_time` asks within what is left of this (a base pushed faster "
        "than the rest of its steps can stop needs more steps to stop and walk back; the goal stays); "
        "the closed loop runs as long as its plan; 0: the plan's end is fixed"))
    settle: float = param(0.2, "(0, inf)", doc=(
        "s: a measured foot outside its range-of-motion box (tracking error, a push) may stay "
        "outside by its measured excess, shrinking linearly to none over this time"))
    tube_position: float | None = param(None, "(0, inf)", doc=(
        "closed loop (`legplan.sim.replanning`): m, the base's distance from the tracked plan "
        "beyond which a replan starts at once, not only every period (event-triggered model "
        "predictive control); None: off"))
    tube_velocity: float | None = param(0.2, "(0, inf)", doc=(
        "closed loop: m/s, the base's velocity error against the tracked plan beyond which a "
        "replan starts at once (a push shows in the velocity first; the unpushed plans' tracking "
        "stays within it); None: off"))
    trigger_gap: float = param(0.05, "(0, inf)", doc=(
        "closed loop: s, the shortest time from one replan to a replan the tube triggers (a "
        "state that stays outside the tube, e.g. while a push lasts, replans at most this often)"))


@dataclass(frozen=True)
class Tail:
    """What a replan keeps of the previous plan (`frozen_tail`): per base, foot and force node
    whether it is frozen, and `until`, the last time (s) a free node reaches (None: no tail)."""

    until: float | None
    base: np.ndarray
    feet: np.ndarray
    forces: np.ndarray


def frozen_tail(form: Formulation, horizon: float | None) -> Tail:
    """The nodes a replan keeps (module docstring): every foothold touched down at or after
    `horizon` with its stance's forces, every swing apex at or after it, and the base from the first
    knot at or after the last time a free foot node reaches (a foothold the apex of its next swing
    and the end of its stance, a swing apex the swing's end), so that the free base can carry the
    free feet's stances. None of it when that knot is the last."""
    base = np.zeros(form.base.nodes, bool)
    feet = np.zeros(form.motion_nodes, bool)
    forces = np.zeros(form.force_nodes, bool)
    if horizon is None:
        return Tail(None, base, feet, forces)
    reach = float(horizon)
    for foot in form.feet:
        stances = [p for p in foot.phases if p.stance]
        swings = [p for p in foot.phases if not p.stance]
        for k, (node, phase, ids) in enumerate(zip(foot.stance_nodes, stances, foot.force_nodes)):
            if phase.t0 >= horizon - EPS:
                feet[node] = True
                forces[ids] = True
            else:
                apex = 0.5 * (swings[k].t0 + swings[k].t1) if k < len(swings) else form.duration
                reach = max(reach, apex, phase.t1)
        for node, phase in zip(foot.swing_nodes, swings):
            if 0.5 * (phase.t0 + phase.t1) >= horizon - EPS:
                feet[node] = True
            else:
                reach = max(reach, phase.t1)
    k = int(np.searchsorted(form.knots, reach - EPS))
    if k >= form.knots.size - 1:
        return Tail(None, np.zeros_like(base), np.zeros_like(feet), np.zeros_like(forces))
    base[k:] = True
    return Tail(float(form.knots[k]), base, feet, forces)


@dataclass(frozen=True)
class MeasuredState:
    """The robot at time `t` (s, on the previous plan's time axis): base origin `base_pos` (m),
    `base_euler` (roll, pitch, yaw, rad), `base_vel` (m/s), world angular velocity `base_ang_vel`
    (rad/s) and the feet `feet_pos` (legs, 3) (m), in the previous plan's leg order."""

    t: float
    base_pos: np.ndarray
    base_euler: np.ndarray
    base_vel: np.ndarray
    base_ang_vel: np.ndarray
    feet_pos: np.ndarray
    contact: np.ndarray | None = None
    """(legs,) bool: which feet the robot senses on the ground (a simulator's contacts, a robot's
    contact sensing); None: not sensed, every foot as its plan says (`lifted_feet`)."""

    def __post_init__(self):
        # copies: a simulator hands views of its live state (MuJoCo's qvel), which move on after the replan
        for name in ("base_pos", "base_euler", "base_vel", "base_ang_vel"):
            object.__setattr__(self, name, np.array(getattr(self, name), float).reshape(3))
        object.__setattr__(self, "feet_pos", np.array(self.feet_pos, float).reshape(-1, 3))
        object.__setattr__(self, "t", float(self.t))
        if self.contact is not None:
            object.__setattr__(self, "contact", np.array(self.contact, bool).reshape(self.feet_pos.shape[0]))

    @classmethod
    def from_samples(cls, samples: dict[str, np.ndarray], t: float) -> MeasuredState:
        """The state a plan's samples (`planner.sample_solution`) hold at their sample nearest t."""
        k = int(np.argmin(np.abs(samples["t"] - t)))
        return cls(float(samples["t"][k]), samples["base_pos"][k], samples["base_euler"][k], samples["base_vel"][k],
                   samples["base_ang_vel"][k], samples["feet_pos"][k])

    def record(self) -> dict[str, np.ndarray | float]:
        return {"t": self.t, "base_pos": self.base_pos, "base_euler": self.base_euler, "base_vel": self.base_vel,
                "base_ang_vel": self.base_ang_vel, "feet_pos": self.feet_pos}


@dataclass(frozen=True)
class Previous:
    """A plan to replan: its formulation (gait, timing, knots), its node values, its goal (x, y, yaw)
    and the CoM in the base frame it was planned with."""

    form: Formulation
    values: dict[str, np.ndarray]
    goal: tuple[float, float, float]
    com_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stride: Gait | None = None
    """One stride of the first plan's gait (`gait_stride`), what a recovering replan may insert
    (`ReplanParams.extension`); None: no stride found, the end stays."""
    extended: float = 0.0
    """s: how much later than the first plan this plan ends (inserted strides)."""

    def __post_init__(self):
        if self.stride is None:
            object.__setattr__(self, "stride", gait_stride(self.form.gait))

    @classmethod
    def from_plan(cls, result: PlanResult, stride: Gait | None = None, extended: float = 0.0) -> Previous:
        """A plan's solution; `stride` and `extended` those of the plan it replans (a first plan:
        its own stride, none extended)."""
        p = result.problem
        return cls(p.form, {k: np.asarray(v, float) for k, v in result.solve.values.items()},
                   tuple(float(v) for v in p.task.goal), np.asarray(p.com_offset, float), stride, extended)

    @classmethod
    def from_record(cls, task: dict, com_offset, dt: float = 0.1) -> Previous:
        """From a traj.h5 task group read by `artefact.read_tasks`: the gait's phases, the base knots
        (each base node's first time) and the node values."""
        gait = Gait(str(task["gait"]), np.asarray(task["phases"]["durations"], float),
                    np.asarray(task["phases"]["stance"], bool))
        knots = np.asarray(task["nodes"]["base_lin"]["span"], float)[:, 0]
        form = Formulation(gait, dt, knots)
        values = {name: np.asarray(task["nodes"][name]["value"], float)
                  for name in ("base_lin", "base_ang", "feet", "forces")}
        return cls(form, values, tuple(float(v) for v in task["goal"]), np.asarray(com_offset, float))

    def goal_pose(self) -> Pose:
        """The CoM's goal pose of the previous solution (its last base node)."""
        lin = self.values["base_lin"].reshape(-1, 2, 3)
        ang = self.values["base_ang"].reshape(-1, 2, 3)
        return Pose(lin[-1, 0].copy(), ang[-1, 0].copy())


def lifted_feet(gait: Gait, state: MeasuredState, terrain, height: float | None) -> np.ndarray:
    """Which feet (legs,) `gait` has in stance at `state.t` while the measured state senses them out
    of contact (`MeasuredState.contact`) and their contact points stand more than `height` m above
    the terrain under them (a late touchdown: the foot has not reached the ground its plan stands
    on); none with `height` None or no contact sensed."""
    lifted = np.zeros(state.feet_pos.shape[0], bool)
    if height is None or state.contact is None:
        return lifted
    ends = np.cumsum(gait.durations)
    k = min(int(np.searchsorted(ends, state.t + PHASE_END, side="right")), len(ends) - 1)
    feet = state.feet_pos
    ground = np.asarray(terrain.height(feet[:, 0], feet[:, 1]), float)
    return gait.stance[k] & ~state.contact & (feet[:, 2] - ground > height)


@dataclass
class ReplanTask:
    """The rest of a plan from a measured state, as `problem.build_problem` reads a task (`setup`,
    `constrain`); `start`, `goal`, `gait`, `strides`, `duration` name it like a `DynTask`."""

    previous: Previous
    state: MeasuredState
    gait_rest: Gait
    airborne: np.ndarray
    horizon: float | None = None
    settle: float = ReplanParams.settle
    window: float | None = None
    insertion: Insertion | None = None
    strides: int = 0
    tail: Tail | None = None  # set by `setup`

    @property
    def sample_until(self) -> float | None:
        """The last constraint sample time (`build_problem`): where the free nodes stop reaching,
        or the end of the sampling window (`ReplanParams.window`), whichever comes first."""
        ends = [x for x in (None if self.tail is None else self.tail.until, self.window) if x is not None]
        return min(ends) if ends else None

    @property
    def gait(self) -> str:
        return self.gait_rest.name

    @property
    def duration(self) -> float:
        return self.gait_rest.duration

    @property
    def start(self) -> tuple[float, float, float]:
        return (*self.state.base_pos[:2], self.state.base_euler[2])

    @property
    def goal(self) -> tuple[float, float, float]:
        return self.previous.goal

    def com_state(self) -> tuple[Pose, np.ndarray, np.ndarray]:
        """The CoM's pose, velocity and Euler rates at the measured state (`measured_com`)."""
        return measured_com(self.state, self.previous.com_offset)

    def setup(self, model, terrain, params: DynParams):
        form = gait_formulation(self.gait_rest, params, self.knots(params))
        self.tail = frozen_tail(form, self.horizon)
        start, _, _ = self.com_state()
        return form, start, self.previous.goal_pose(), self.state.feet_pos.copy()

    def knots(self, params: DynParams) -> np.ndarray | None:
        """The previous plan's base knots after t, shifted to start at 0 (a first polynomial shorter
        than `SHORT_FIRST` of `dt` merged into the next, unless it ends where the feet's contacts
        change in the rest of the motion, `gait_rest`: a cubic across a lift-off into a flight
        cannot follow the forces there and then −g): the shifted guess is then the previous base
        spline itself after its first polynomial. A contact change of the previous plan within
        `PHASE_END` after t is no change of the rest (`remaining_gait` takes that phase as over),
        and a polynomial that short would ask accelerations of its dynamics rows no solve can meet.
        None (the formulation's own) with `phase_knots`."""
        if params.phase_knots:
            return None
        later = self.previous.form.knots[self.previous.form.knots > self.state.t] - self.state.t
        boundaries = np.cumsum(self.gait_rest.durations)
        if (later.size > 1 and later[0] < SHORT_FIRST * params.dt
                and not np.isclose(later[0], boundaries, rtol=0.0, atol=1e-9).any()):
            later = later[1:]
        if self.insertion is not None:  # the inserted strides repeat the knots of the stride before them
            ins = self.insertion
            own = self.previous.form.knots - self.state.t
            offsets = own[(own >= ins.at - ins.period - EPS) & (own < ins.at - EPS)] - (ins.at - ins.period)
            block = (ins.at + ins.period * np.arange(ins.count)[:, None] + offsets[None]).reshape(-1)
            later = np.concatenate([later[later < ins.at - EPS], block, later[later >= ins.at - EPS] + ins.length])
        later[-1] = self.gait_rest.duration
        return np.concatenate([[0.0], later])

    def constrain(self, problem) -> None:
        """The measured velocities on the first base node; a foot in the air held where it is, with
        zero force, its first stance node off the terrain constraint and the rest of its swing free
        of the swing-height rows (what is left of a swing need not rise); the tail frozen."""
        _, velocity, rates = self.com_state()
        blocks = {v.name: v for v in problem.variables}
        blocks["base_lin"].value.reshape(-1, 2, 3)[0, 1] = velocity
        blocks["base_ang"].value.reshape(-1, 2, 3)[0, 1] = rates
        if self.tail is not None:
            for name, frozen in (("base_lin", self.tail.base), ("base_ang", self.tail.base),
                                 ("feet", self.tail.feet), ("forces", self.tail.forces)):
                blocks[name].fixed.reshape(-1, 2, 3)[frozen] = True
        feet = blocks["feet"]
        forces = blocks["forces"]
        for leg in np.flatnonzero(self.airborne):
            foot = problem.form.feet[leg]
            node = foot.stance_nodes[0]
            feet.value.reshape(-1, 2, 3)[node, 0] = self.state.feet_pos[leg]
            feet.fixed.reshape(-1, 2, 3)[node] = True
            ids = foot.force_nodes[0]
            forces.value.reshape(-1, 2, 3)[ids] = 0.0
            forces.fixed.reshape(-1, 2, 3)[ids] = True
        on_terrain = [i for i, c in enumerate(problem.constraints) if c.name == "stance_on_terrain"]
        for leg in np.flatnonzero(self.airborne):
            c = problem.constraints[on_terrain[leg]]
            lower, upper = c.lower.copy(), c.upper.copy()
            lower[0], upper[0] = -np.inf, np.inf  # the first stance node, in the air
            problem.constraints[on_terrain[leg]] = Constraint(c.block, lower, upper, c.name, c.scale)
        self._stance_under_way(problem)
        self._settle_range(problem)
        heights = [i for i, c in enumerate(problem.constraints) if c.name == "swing_height"]
        if heights and self.airborne.any():
            c = problem.constraints[heights[0]]
            lower = c.lower.copy()
            first = np.cumsum([0] + [2 * len(foot.swing_nodes) for foot in problem.form.feet])
            for leg in np.flatnonzero(self.airborne):  # 2 rows per swing, feet in order
                lower[first[leg]:first[leg] + 2] = -np.inf
            problem.constraints[heights[0]] = Constraint(c.block, lower, c.upper, c.name, c.scale)

    def _stance_under_way(self, problem) -> None:
        """Through the stance under way each standing leg's spheres keep the clearance deficit the
        measured state has at t (a foot at the foot of a step's side: the shank there cannot clear
        it while the foot stands where it was measured, `Formulation.variables` fixes its x, y).
        Without it the solve lifts the standing foot off the ground to clear the rows, a plan the
        robot cannot follow, and stalls there."""
        standing = np.flatnonzero(~self.airborne)
        if not standing.size:
            return
        clearance = [i for i, c in enumerate(problem.constraints) if c.name == "leg_clearance"]
        if len(clearance) != problem.form.legs:
            return
        values = {v.name: v.value for v in problem.variables}
        for leg in standing:
            i = clearance[leg]
            c = problem.constraints[i]
            times = np.asarray(c.block.times, float)
            if not times.size or times[0] > EPS:
                continue
            rows = np.asarray(c.block.evaluate([values[v] for v in c.block.variables], False)[0], float)
            rows = rows.reshape(times.size, -1)
            lower = np.broadcast_to(np.asarray(c.lower, float), rows.size).reshape(rows.shape).copy()
            deficit = np.maximum(lower[0] - rows[0], 0.0)
            if not deficit.any():
                continue
            until = problem.form.feet[leg].phases[0].t1
            lower[times <= until + EPS] -= deficit
            problem.constraints[i] = Constraint(c.block, lower.reshape(-1), c.upper, c.name, c.scale)

    def _settle_range(self, problem) -> None:
        """Widen each foot's range-of-motion box by the measured state's excess over it at time 0
        (Rᵀ(p_i − c) − p̄_i of the measured base and feet, `RangeOfMotionBlock`'s rows), shrinking
        linearly to none at `settle`: the measured state is no plan to be made feasible, the plan
        leads the feet back into their boxes; and by the displacement of a foothold kept to the end
        (`_kept_footholds`)."""
        pose, _, _ = self.com_state()
        turn = rotation(pose.euler[None])[0]
        offsets = (self.state.feet_pos - pose.position) @ turn - problem.model.nominal_feet
        kept = self._kept_footholds()
        boxes = [i for i, c in enumerate(problem.constraints) if c.name == "range_of_motion"]
        for leg, i in enumerate(boxes):  # one per leg, in leg order
            c = problem.constraints[i]
            if not c.block.times.size or c.block.times[0] > EPS:
                continue
            excess = np.maximum(np.abs(offsets[leg]) - c.upper[:3], 0.0)
            if not (excess.any() or kept[leg].any()):
                continue
            share = np.clip(1.0 - c.block.times / self.settle, 0.0, None)
            widen = (share[:, None] * excess[None] + kept[leg][None]).reshape(-1)
            problem.constraints[i] = Constraint(c.block, c.lower - widen, c.upper + widen, c.name, c.scale)

    def _kept_footholds(self) -> np.ndarray:
        """Per leg (legs, 3): how far, in the goal's base frame, the measured foot stands from the
        previous plan's foothold when it stays down to the end. The base ends at the goal, so that
        displacement of a foot that does not step again can reach the last samples' boxes: the plan
        cannot undo it, as it cannot undo a measured foot's excess at t."""
        out = np.zeros((self.previous.form.legs, 3))
        turn = rotation(self.previous.goal_pose().euler[None])[0]
        nodes = self.previous.values["feet"].reshape(-1, 2, 3)
        for leg in np.flatnonzero(self.gait_rest.stance.all(axis=0) & ~self.airborne):
            planned = nodes[self.previous.form.feet[leg].stance_nodes[-1], 0]
            out[leg] = np.abs((self.state.feet_pos[leg] - planned) @ turn)
        return out


def euler_rates(euler: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """ė of a world angular velocity ω at Euler angles e (`euler.world_rates` is linear in ė)."""
    m = np.column_stack([world_rates(euler[None], np.eye(3)[k][None])[0] for k in range(3)])
    return np.linalg.solve(m, omega)


@dataclass
class ReplanResult:
    """One replan: the measured state it started from, the plan of the rest (time 0 = `state.t`),
    LM iterations, CPU seconds (process time: building and solving), success and status."""

    state: MeasuredState
    plan: PlanResult
    cpu_seconds: float
    wall_seconds: float
    scaled_violation: float = float("nan")
    """The largest constraint violation, each row times its solver scale (`Constraint.scale`):
    rows of different units (N, m, m/s²) on one scale, so that one bound judges how near a
    replan came to feasible (`ReplanParams.track_violation`)."""
    recovery: bool = False
    """Whether the replan recovered from a push (`ReplanParams.recovery_velocity`, `early_touchdown`)."""
    extension: float = 0.0
    """s by which the replan's strides inserted (`ReplanParams.extension`) made the motion longer."""

    @property
    def success(self) -> bool:
        return self.plan.success

    @property
    def status(self) -> Status:
        return self.plan.status

    @property
    def iterations(self) -> int:
        return int(self.plan.solve.iterations)

    @property
    def violation(self) -> float:
        """The largest constraint violation of the replan's rows (in their own units)."""
        return float(self.plan.solve.max_violation)

    @property
    def reason(self) -> str:
        """Why the solve stopped (the solver's own words: converged, stalled, iteration budget)."""
        return str(self.plan.solve.reason)

    def record(self) -> dict:
        return {**{f"state_{k}": v for k, v in self.state.record().items()}, "iterations": self.iterations,
                "cpu_seconds": self.cpu_seconds, "wall_seconds": self.wall_seconds, "success": self.success,
                "violation": self.violation, "scaled_violation": self.scaled_violation,
                "recovery": self.recovery, "extension": self.extension,
                "status": self.status.name.lower(), "reason": self.reason}


def replan(previous: Previous | PlanResult, state: MeasuredState, model, terrain, params: DynParams = DynParams(),
           warm_stage: str = "projection", settings: ReplanParams = ReplanParams()) -> ReplanResult:
    """Plan the rest of `previous` from `state` (module docstring), warm-started from `previous`
    shifted to `state.t` (its next footholds moved by `settings.step_adaptation`), moving it within
    `settings.horizon`. The remaining phases keep their durations (`optimize_phases` is off).
    `warm_stage` "projection" (default) solves the constraints alone from the shifted guess — it
    already minimizes the costs, the measured state only needs it made feasible again; "costs"
    solves the costs under the constraints too (`warm_solver`)."""
    if isinstance(previous, PlanResult):
        previous = Previous.from_plan(previous)
    if state.feet_pos.shape[0] != previous.form.legs:
        raise ValueError(f"measured state: {state.feet_pos.shape[0]} feet, the plan has {previous.form.legs}")
    if warm_stage not in ("projection", "costs"):
        raise ValueError(f"warm_stage must be 'projection' or 'costs', got {warm_stage!r}")
    lifted = lifted_feet(previous.form.gait, state, terrain, settings.touchdown_height)
    gait_rest, airborne = remaining_gait(previous.form.gait, state.t, lifted=lifted, late_swing=settings.late_swing)
    error = velocity_error(previous, state)
    recovers = recovering(error, settings)
    if recovers:
        gait_rest = early_touchdown(gait_rest, airborne, settings.recovery_swing)
    insertion = None
    if recovers and previous.stride is not None and settings.extension > previous.extended:
        period = previous.stride.duration
        count = min(int(np.ceil(recovery_time(error, model) / period - EPS)),
                    int(np.floor((settings.extension - previous.extended) / period + EPS)))
        gait_rest, insertion = insert_strides(gait_rest, previous.stride, count)
    if recovers and settings.recovery_support:  # after the strides: they are found by the gait's own phases
        gait_rest = grounded_flights(gait_rest)
    task = ReplanTask(previous, state, gait_rest, airborne, settings.horizon, settings.settle, settings.window,
                      insertion)
    costs = warm_stage == "costs"
    solver = params.warm_solver if costs else params.projection_solver
    stage_params = replace(params, optimize_phases=False, costs=params.costs if costs else CostWeights())
    cpu, wall = time.process_time(), time.perf_counter()
    deadline = None if settings.cpu_budget is None else cpu + settings.cpu_budget
    guess = ShiftedInit(previous, state.t, adapted_step(error, model, settings), insertion)
    problem = build_problem(task, model, terrain, stage_params, guess)
    setup = time.perf_counter() - wall
    solved = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints,
                                        replace(solver, max_iterations=settings.max_iterations,
                                                scaled_tolerance=settings.scaled_tolerance,
                                                inner=replace(solver.inner, geodesic_acceleration=(
                                                    solver.inner.geodesic_acceleration
                                                    if settings.geodesic_acceleration is None
                                                    else settings.geodesic_acceleration))),
                                        deadline=deadline)
    samples = sample_solution(problem.form, solved.values, com_offset=problem.com_offset)
    if airborne.any():  # the hold of a foot in the air is no contact (zero force, off the terrain)
        hold = samples["t"] < gait_rest.durations[0] - 1e-9
        samples["contact"][np.ix_(hold, airborne)] = False
    result = PlanResult(problem, [StageOutcome(warm_stage, solved.status, solved, problem, setup)], solved, samples,
                        setup)
    return ReplanResult(state, result, time.process_time() - cpu, time.perf_counter() - wall,
                        solved.scaled_violation, recovers, 0.0 if insertion is None else insertion.length)


def recovering(error: np.ndarray, settings: ReplanParams) -> bool:
    """Whether a replan recovers (`early_touchdown`): the horizontal CoM velocity `error` against
    the previous plan (`velocity_error`) beyond `settings.recovery_velocity`."""
    return (settings.recovery_velocity is not None
            and float(np.hypot(error[0], error[1])) > settings.recovery_velocity)


def measured_com(state: MeasuredState, com_offset) -> tuple[Pose, np.ndarray, np.ndarray]:
    """The CoM's pose (p + R o), velocity (ṗ + ω × R o) and Euler rates at a measured base state, o
    the CoM in the base frame."""
    arm = rotation(state.base_euler[None])[0] @ np.asarray(com_offset, float)
    return (Pose(state.base_pos + arm, state.base_euler.copy()), state.base_vel + np.cross(state.base_ang_vel, arm),
            euler_rates(state.base_euler, state.base_ang_vel))


def velocity_error(previous: Previous, state: MeasuredState) -> np.ndarray:
    """The measured CoM velocity (`measured_com`) less the previous plan's at `state.t` (3,), m/s."""
    at = np.array([min(state.t, previous.form.duration)])
    planned = (previous.form.base_matrix(at, 1) @ previous.values["base_lin"].reshape(-1, 3))[0]
    return measured_com(state, previous.com_offset)[1] - planned


def adapted_step(error: np.ndarray, model, settings: ReplanParams) -> np.ndarray:
    """The step adaptation of a replan (`ReplanParams.step_adaptation`): `capture_step` of the
    measured CoM velocity's `error` against the previous plan's (`velocity_error`), within the
    range of motion."""
    if settings.step_adaptation == 0.0:
        return np.zeros(3)
    limit = np.r_[np.asarray(model.range_of_motion, float)[:2], 0.0]
    return capture_step(error, float(np.sqrt(model.base_height / GRAVITY)), limit, settings.step_adaptation)


def scaled_violation(constraints, values: dict[str, np.ndarray]) -> float:
    """The largest row violation of `constraints` at the variable values `values`, each row times
    its scale (`auglag.scaled_violation`)."""
    return max_scaled_violation(constraints, [
        np.asarray(k.block.evaluate([values[v] for v in k.block.variables], False)[0], float) if k.block.size
        else np.zeros(0) for k in constraints])
