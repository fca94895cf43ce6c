"""Receding-horizon execution of global planner + TEB on a simulated robot (paper Sec. V-C 3).

The global planner (kinodynamic A*, or a position-only planner for the Table II baseline) plans on
the *known* map. At `rate` Hz the TEB optimizes a local band over the next `window` metres of the
global path, starting at the robot's current pose and body velocity (warm-started from the
previous cycle's band, `LocalPlanner`), and the first interval's body-frame velocity is sent as
the command. The robot is an omnidirectional base (or a
differential-drive one: lateral velocity zero) that tracks the command under the Table I velocity
and acceleration limits. Obstacles hidden from the initial map become known once within
`sensing_radius`; the nav layers are then rebuilt and, if the remaining global path now crosses
a lethal cell, the global planner replans from the current state.

A mission is a list of goals; every goal but the last is a via point where the robot stops, turns
to the goal's heading (e.g. facing a target, Table III) and stays `dwell` seconds.
Collisions are counted against the *true* occupancy (known + hidden) with the robot footprint.
A run ends unsuccessfully, with the reason recorded, after `max_time` simulated seconds, after
`max_wall_seconds` of wall time, or when the robot stalls (moves < `stall_distance` in `stall_time`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from legplan.errors import SpecError
from legplan.nav.collision import NavGrid
from legplan.nav.gridastar import plan_grid
from legplan.nav.kinoastar import plan_kinodynamic
from legplan.nav.teb.band import Band, wrap_angle
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.problems import ProblemCache
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.warmstart import shift_band
from legplan.nav.teb.yaw import YawPolicy
from legplan.robots.spec import KinodynamicLimits
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import NavParams as CostmapParams
from legplan.terrain.layers import costmap_from_distance, obstacle_distance
from legplan.terrain.primitives import rasterize
from legplan.specio import read_yaml_mapping

log = logging.getLogger(__name__)

GlobalPlanner = Callable[[NavGrid, np.ndarray, np.ndarray], "GlobalPath | str"]
"""planner(grid, start (px, py, vx, vy), goal (px, py, vx, vy)) -> GlobalPath, or a failure reason."""


@dataclass(frozen=True)
class Goal:
    """Where to go: position, heading (NaN = any), seconds to stay there once reached."""

    xy: tuple[float, float]
    heading: float = float("nan")
    dwell: float = 0.0


@dataclass(frozen=True)
class SimParams:
    rate: float = 10.0  # Hz, TEB cycles
    substeps: int = 10  # robot integration steps per cycle
    window: float = 5.0  # m of global path in the local band
    sensing_radius: float = 4.0  # m
    goal_tolerance: float = 0.1  # m
    heading_tolerance: float = 0.1  # rad
    stop_speed: float = 0.05  # m/s, "at rest" for arrival at a via point
    max_time: float = 300.0  # s of simulated time before the run fails
    stall_time: float = 20.0  # s: the run fails when the robot moved less than `stall_distance` in this time
    stall_distance: float = 0.3  # m
    max_wall_seconds: float = float("inf")  # wall-clock budget of the run
    warm_start: bool = True  # warm-start the local band from the previous cycle
    yaw: str = "velocity"  # yaw policy on the way: "velocity", "target" (face `target`) or "heading"
    target: tuple[float, float] | None = None  # world point faced with yaw "target"
    heading: float = 0.0  # rad, held with yaw "heading"


@dataclass
class SimResult:
    success: bool
    reason: str
    times: np.ndarray  # (k,) s, robot state samples (every substep)
    states: np.ndarray  # (k, 6) x, y, θ, v_x, v_y, ω (body velocities)
    commands: np.ndarray  # (c, 3) commanded body velocities per cycle
    cycle_times: np.ndarray  # (c,) s, simulation time of each cycle
    compute_seconds: np.ndarray  # (c,) s wall time of the TEB per cycle
    band_poses: np.ndarray  # (c,) band sizes
    band_iterations: np.ndarray  # (c,) LM iterations per cycle
    cold_starts: int  # cycles whose band was (re-)initialized from the global path
    replans: int
    replan_seconds: float
    collisions: int  # substeps with the footprint on an occupied cell of the true map
    goal_times: list[float] = field(default_factory=list)  # s, arrival at each goal (before dwell)

    @property
    def running_time(self) -> float:
        return float(self.times[-1]) if self.success else float("nan")

    def effort(self) -> float:
        """∫ ||a||² dt of the executed world-frame translational acceleration (eq. (4))."""
        theta, v = self.states[:, 2], self.states[:, 3:5]
        world = np.column_stack([np.cos(theta) * v[:, 0] - np.sin(theta) * v[:, 1],
                                 np.sin(theta) * v[:, 0] + np.cos(theta) * v[:, 1]])
        dt = np.diff(self.times)
        a = np.diff(world, axis=0) / dt[:, None]
        return float(np.sum(np.sum(a * a, axis=1) * dt))


class World:
    """True and known occupancy on one grid, the known nav layers, and hidden-obstacle sensing."""

    def __init__(self, grid: Grid2D, occupancy: np.ndarray, hidden: np.ndarray, costmap: CostmapParams,
                 footprint: np.ndarray):
        self.grid = grid
        self.true_occupancy = occupancy | hidden
        self.known = occupancy.copy()
        self.hidden = hidden & ~occupancy
        self.costmap_params = costmap
        self.footprint_points = _footprint_samples(np.asarray(footprint, float), grid.resolution / 2)
        X, Y = grid.centres()
        self._centres = np.stack([X, Y], axis=-1)
        self._rebuild()

    def _rebuild(self) -> None:
        c = self.costmap_params
        distance = obstacle_distance(self.known, self.grid.resolution)
        self.distance = DistanceField(distance, self.grid)
        self.nav_grid = NavGrid(costmap_from_distance(distance, c.l1, c.l2, c.c_max, c.lambda_c), distance, c.l1,
                                self.grid.origin, self.grid.resolution)

    def sense(self, xy: np.ndarray, radius: float) -> bool:
        """Reveal hidden obstacle cells within `radius` of `xy`; True when the known map changed."""
        if not self.hidden.any():
            return False
        near = self.hidden & (np.sum((self._centres - xy) ** 2, axis=-1) <= radius * radius)
        if not near.any():
            return False
        self.known |= near
        self.hidden &= ~near
        self._rebuild()
        return True

    def in_collision(self, pose: np.ndarray) -> bool:
        c, s = np.cos(pose[2]), np.sin(pose[2])
        pts = self.footprint_points @ np.array([[c, s], [-s, c]]) + pose[:2]
        iy, ix, inside = self.grid.cell_of(pts)
        return bool(np.any(self.true_occupancy[iy, ix] | ~inside))


def _footprint_samples(polygon: np.ndarray, spacing: float) -> np.ndarray:
    """Points covering a convex footprint polygon (boundary and interior) at ≤ `spacing`."""
    lo, hi = polygon.min(axis=0), polygon.max(axis=0)
    xs = np.linspace(lo[0], hi[0], max(int(np.ceil((hi[0] - lo[0]) / spacing)) + 1, 2))
    ys = np.linspace(lo[1], hi[1], max(int(np.ceil((hi[1] - lo[1]) / spacing)) + 1, 2))
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    edges = np.roll(polygon, -1, axis=0) - polygon
    cross = edges[:, 0] * (pts[:, None, 1] - polygon[:, 1]) - edges[:, 1] * (pts[:, None, 0] - polygon[:, 0])
    inside = np.all(cross >= -1e-9, axis=1) | np.all(cross <= 1e-9, axis=1)
    return pts[inside]


class Robot:
    """Body-velocity tracking base: each substep moves v toward the command by at most a·h per axis."""

    def __init__(self, pose, limits: KinodynamicLimits, omnidirectional: bool = True):
        self.pose = np.asarray(pose, float).copy()
        self.velocity = np.zeros(3)
        self.limits = limits
        self.omnidirectional = omnidirectional
        self.accel = np.array([limits.a_x_max, limits.a_y_max, limits.alpha_max])
        self.v_lower = np.array([-limits.v_x_min, -limits.v_y_max, -limits.omega_max])
        self.v_upper = np.array([limits.v_x_max, limits.v_y_max, limits.omega_max])

    def step(self, command: np.ndarray, h: float) -> None:
        target = np.clip(command, self.v_lower, self.v_upper)
        if not self.omnidirectional:
            target[1] = 0.0
        self.velocity = self.velocity + np.clip(target - self.velocity, -self.accel * h, self.accel * h)
        c, s = np.cos(self.pose[2]), np.sin(self.pose[2])
        vx, vy, w = self.velocity
        self.pose = self.pose + h * np.array([c * vx - s * vy, s * vx + c * vy, w])
        self.pose[2] = wrap_angle(self.pose[2])

    def world_velocity(self) -> np.ndarray:
        c, s = np.cos(self.pose[2]), np.sin(self.pose[2])
        vx, vy, _ = self.velocity
        return np.array([c * vx - s * vy, s * vx + c * vy])


def simulate(world: World, planner: GlobalPlanner, start_pose, goals: list[Goal], limits: KinodynamicLimits,
             teb: TebParams = TebParams(), params: SimParams = SimParams(), progress=None) -> SimResult:
    """Drive from `start_pose` (x, y, θ) through `goals` (see module docstring); never raises for
    planning failures (they end the run with `success=False` and a reason)."""
    robot = Robot(start_pose, limits, teb.omnidirectional)
    h = 1.0 / (params.rate * params.substeps)
    log_t, log_s = [0.0], [np.concatenate([robot.pose, robot.velocity])]
    commands, cycle_t, compute, sizes, iterations, goal_times = [], [], [], [], [], []
    replans, replan_seconds, collisions = 0, 0.0, 0
    t = 0.0
    local_planner = LocalPlanner(limits, teb, params)
    wall_start = time.perf_counter()

    def plan(goal: Goal):
        nonlocal replans, replan_seconds
        clock = time.perf_counter()
        state = np.concatenate([robot.pose[:2], robot.world_velocity()])
        result = planner(world.nav_grid, state, np.array([*goal.xy, 0.0, 0.0]))
        replan_seconds += time.perf_counter() - clock
        replans += 1
        return result

    def finish(success, reason):
        return SimResult(success, reason, np.array(log_t), np.array(log_s), np.array(commands).reshape(-1, 3),
                         np.array(cycle_t), np.array(compute), np.array(sizes), np.array(iterations),
                         local_planner.cold_starts, replans, replan_seconds, collisions, goal_times)

    world.sense(robot.pose[:2], params.sensing_radius)
    for k, goal in enumerate(goals):
        final = k == len(goals) - 1
        path = plan(goal)
        if isinstance(path, str):
            return finish(False, f"global planner failed for goal {k}: {path}")
        progress_index = 0
        dwell_until = None
        local_planner.reset()
        anchor, anchor_t = robot.pose[:2].copy(), t
        while True:
            if t > params.max_time:
                return finish(False, f"time limit {params.max_time} s reached before goal {k}")
            if time.perf_counter() - wall_start > params.max_wall_seconds:
                return finish(False, f"wall-clock budget {params.max_wall_seconds} s used up at t = {t:.1f} s "
                                     f"before goal {k}")
            pose = robot.pose
            if dwell_until is None and _arrived(robot, goal, params, final):
                goal_times.append(t)
                dwell_until = t + goal.dwell
            if dwell_until is not None and t >= dwell_until - 1e-9:
                break
            if dwell_until is not None or np.hypot(*(pose[:2] - anchor)) >= params.stall_distance:
                anchor, anchor_t = pose[:2].copy(), t
            elif t - anchor_t > params.stall_time:
                return finish(False, f"stalled: moved < {params.stall_distance} m in {params.stall_time} s at "
                                     f"({pose[0]:.2f}, {pose[1]:.2f}), t = {t:.1f} s, before goal {k}")
            if world.sense(pose[:2], params.sensing_radius) and world.nav_grid.lethal_at(path.points[progress_index:]).any():
                path = plan(goal)
                if isinstance(path, str):
                    return finish(False, f"replanning failed for goal {k}: {path}")
                progress_index = 0
                local_planner.reset()
            progress_index = _advance(path, pose[:2], progress_index, params.window)
            clock = time.perf_counter()
            command, n_poses, n_iterations = local_planner.command(world, path, progress_index, robot, goal, t,
                                                                   hold=dwell_until is not None)
            compute.append(time.perf_counter() - clock)
            sizes.append(n_poses)
            iterations.append(n_iterations)
            commands.append(command)
            cycle_t.append(t)
            for _ in range(params.substeps):
                robot.step(command, h)
                t += h
                collisions += world.in_collision(robot.pose)
                log_t.append(t)
                log_s.append(np.concatenate([robot.pose, robot.velocity]))
            if progress is not None:
                progress(k, len(goals), f"t = {t:.1f} s")
    reason = "" if collisions == 0 else f"{collisions} substeps in collision"
    return finish(True, reason)


def _arrived(robot: Robot, goal: Goal, params: SimParams, final: bool) -> bool:
    close = np.hypot(*(robot.pose[:2] - goal.xy)) <= params.goal_tolerance
    heading_ok = not np.isfinite(goal.heading) or abs(wrap_angle(robot.pose[2] - goal.heading)) <= params.heading_tolerance
    resting = np.abs(robot.velocity[:2]).max() <= params.stop_speed or (not final and goal.dwell == 0)
    return bool(close and heading_ok and resting)


def _advance(path: GlobalPath, xy: np.ndarray, index: int, window: float) -> int:
    """Progress along the path: nearest point to the robot within the next `window` metres."""
    s = path.arc_length
    hi = int(np.searchsorted(s, s[index] + window, side="right"))
    return path.nearest_index(xy, index, max(hi, index + 1))


def _local_path(path: GlobalPath, index: int, end: int, xy: np.ndarray, speed: float) -> GlobalPath:
    """The robot's position followed by path points index … end − 1, with the points behind the
    robot or within half a spacing of it pruned (TEB prunes the global plan behind the robot).
    Timing: the path's own, shifted so that the first kept point is reached after gap / speed."""
    lo = index
    while lo + 1 < min(end, len(path.points)):
        ahead = np.dot(xy - path.points[lo], path.points[lo + 1] - path.points[lo]) > 0
        if not (ahead or np.hypot(*(path.points[lo] - xy)) < 0.5 * path.spacing):
            break
        lo += 1
    end = max(end, lo + 1)
    gap = float(np.hypot(*(path.points[lo] - xy)))
    times = np.concatenate([[0.0], path.times[lo:end] - path.times[lo] + max(gap / max(speed, 0.1), 1e-3)])
    return GlobalPath(np.vstack([xy, path.points[lo:end]]), times, path.spacing)


class LocalPlanner:
    """The TEB of the receding horizon: each cycle optimizes a local band over the next `window`
    metres of the global path. The band is warm-started from the previous cycle's band shifted by
    the elapsed time (`shift_band`); it is re-initialized from the global path after a (re)plan,
    for a new goal, while holding at a goal, and when the shifted band is invalid."""

    def __init__(self, limits: KinodynamicLimits, teb: TebParams, params: SimParams):
        self.limits, self.teb, self.params = limits, teb, params
        self.policy = YawPolicy(params.yaw, heading=params.heading, target=params.target or (0.0, 0.0))
        self.band: Band | None = None
        self.band_time = 0.0
        self.cold_starts = 0
        self.problems = ProblemCache()  # least-squares problems reused across cycles

    def reset(self) -> None:
        """Forget the previous band (the next cycle re-initializes)."""
        self.band = None

    def command(self, world: World, path: GlobalPath, index: int, robot: Robot, goal: Goal, t: float,
                hold: bool) -> tuple[np.ndarray, int, int]:
        """One cycle: the first interval's body velocity, the band size and the LM iterations."""
        params, teb = self.params, self.teb
        s = path.arc_length
        end = int(np.searchsorted(s, s[index] + params.window, side="right"))
        local = _local_path(path, index, end, robot.pose[:2], float(np.hypot(*robot.velocity[:2])))
        at_goal_window = end >= len(path.points)
        heading = goal.heading if at_goal_window and np.isfinite(goal.heading) else None
        local_goal = np.array(goal.xy) if at_goal_window else local.points[-1]
        if hold or np.hypot(*(robot.pose[:2] - goal.xy)) < params.goal_tolerance and at_goal_window:
            local = GlobalPath(np.array([robot.pose[:2], goal.xy]), np.array([0.0, 0.0]), path.spacing)
            self.band = None
        cold = initial_band(local, teb.dt_ref, self.policy, start_pose=robot.pose, goal_heading=heading)
        cold.poses[-1, :2] = local_goal
        if cold.n == 2 and heading is None:
            cold.poses[-1, 2] = robot.pose[2]
        band = None
        if params.warm_start and self.band is not None and not hold:
            band = shift_band(self.band, t - self.band_time, robot.pose, cold.poses[-1], teb.dt_min)
        if band is None:
            band = cold
            self.cold_starts += 1
        scene = Scene(path=local, distance=world.distance, start_velocity=robot.velocity.copy(),
                      goal_velocity=np.zeros(3) if at_goal_window else None)
        result = optimize_band(band, self.limits, teb, scene, self.problems)
        self.band = None if hold else result.band
        self.band_time = t
        return result.band.velocities()[0], result.band.n, result.iterations


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


def hidden_obstacles(spec_path, grid: Grid2D) -> np.ndarray:
    """Cells covered by the obstacles of a YAML spec `obstacles: [<map primitive>, ...]` (the map
    primitives of `legplan.terrain.primitives`; every listed shape is an obstacle)."""
    data = read_yaml_mapping(spec_path, "hidden-obstacles spec")
    entries = data.get("obstacles")
    if not isinstance(entries, list):
        raise SpecError(f"{spec_path}: field 'obstacles' must be a list of map primitives")
    X, Y = grid.centres()
    mask = np.zeros(grid.shape, bool)
    for i, entry in enumerate(entries):
        mask |= rasterize(entry, f"obstacles[{i}]", str(spec_path), X, Y, 0.0).mask
    return mask
