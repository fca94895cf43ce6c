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
Collisions are counted against the *true* occupancy (known + hidden) with the collision disc that
the planners also plan with (`world.World`); a run with any collision is not a success. A run also
ends unsuccessfully, with the reason recorded, after `max_time` simulated seconds, after
`max_wall_seconds` of wall time, or when the robot stalls (moves < `stall_distance` in `stall_time`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from legplan.nav.simulate.local import LocalPlanner
from legplan.nav.simulate.mission import Goal, NavRunParams
from legplan.nav.simulate.planners import GlobalPlanner
from legplan.nav.simulate.robot import Robot
from legplan.nav.simulate.world import World
from legplan.geometry.angles import wrap_angle
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.robots.navigation import KinodynamicLimits



@dataclass
class NavRunResult:
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
    collisions: int  # substeps with an occupied cell of the true map in the collision disc
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


def run_navigation(world: World, planner: GlobalPlanner, start_pose, goals: list[Goal], limits: KinodynamicLimits,
             teb: TebParams = TebParams(), params: NavRunParams = NavRunParams(), progress=None) -> NavRunResult:
    """Drive from `start_pose` (x, y, θ) through `goals` (see module docstring); never raises for
    planning failures (they end the run with `success=False` and a reason). The TEB keeps the
    world's collision radius plus `params.clearance_margin` from obstacles (`min_obstacle_distance`
    and the inflation distance raised by as much): its obstacle term is a penalty and the robot
    lags its command, so a band at exactly the radius lets the disc graze obstacles (Table II with
    hidden boxes: 4 of 8 runs collided)."""
    shift = max(world.collision_radius + params.clearance_margin - teb.min_obstacle_distance, 0.0)
    teb = teb.replace(min_obstacle_distance=teb.min_obstacle_distance + shift,
                      inflation_distance=teb.inflation_distance + shift)  # the inflation band moves along
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
        return NavRunResult(success, reason, np.array(log_t), np.array(log_s), np.array(commands).reshape(-1, 3),
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
    if collisions:
        return finish(False, f"reached the goal with {collisions} substeps in collision (disc of "
                             f"radius {world.collision_radius:g} m)")
    return finish(True, "")


def _arrived(robot: Robot, goal: Goal, params: NavRunParams, final: bool) -> bool:
    close = np.hypot(*(robot.pose[:2] - goal.xy)) <= params.goal_tolerance
    heading_ok = not np.isfinite(goal.heading) or abs(wrap_angle(robot.pose[2] - goal.heading)) <= params.heading_tolerance
    resting = np.abs(robot.velocity[:2]).max() <= params.stop_speed or (not final and goal.dwell == 0)
    return bool(close and heading_ok and resting)


def _advance(path: GlobalPath, xy: np.ndarray, index: int, window: float) -> int:
    """Progress along the path: nearest point to the robot within the next `window` metres."""
    s = path.arc_length
    hi = int(np.searchsorted(s, s[index] + window, side="right"))
    return path.nearest_index(xy, index, max(hi, index + 1))
