"""Execute a planned centroidal motion in MuJoCo under the whole-body controller:
`simulate(samples, robot, terrain_map, params, goal) -> SimResult`.

The paper's validation (Sec. III-C, Fig. 4 (e)-(f); Sec. V-A, Fig. 8) runs each plan through its
whole-body controller in a physics simulator and calls a trial a success when the robot reaches the
goal without falling. Here:

1. The robot starts at the plan's first base pose and velocity, its joints from leg IK
   (`legplan.robots.leg_reach`) putting the foot spheres on the planned footholds.
2. Every 2.5 ms (400 Hz) the controller (`legplan.sim.controller`) computes torques from the
   simulated state and the plan's reference at that time; MuJoCo integrates 5 steps of 0.5 ms with
   them held, clipped to the effort limits. The motors respect the joints' velocity limits the way
   a motor's torque–speed limit does, in its crudest form: at or beyond its limit a joint's motor
   brakes but does not drive it faster (its torque in the direction of motion is cut to zero).
3. After the plan's duration the controller holds the final pose for `settle` seconds (closed loop:
   after the tracked plan's, which a replan may make longer, `ReplanParams.extension`).
4. A fall ends the run: the base lower than `fall_height` × the nominal base height above the
   terrain under it, its z axis tilted more than `fall_tilt` from the vertical, or the trunk (a
   robot geom on the root link or a link fixed to it) touching the terrain.
5. Success: no fall, and at the end the base within `goal_distance` (horizontal) and `goal_yaw`
   (yaw) of the goal (default: the plan's last pose; the task's goal when given).

Perturbations, so that robustness is measured: `pushes` (t, f_x, f_y, duration) — a horizontal
world force (N) on the root link's centre of mass from t (s, the plan's clock) for `duration` (an
impulse f × duration); `friction_scale` multiplies the simulated friction and `mass_scale` every
body's mass and inertia while the controller keeps the plan's μ and the URDF's masses (model error).

Recorded every `record_every` ticks (default 4: 100 Hz): time, base pose and velocity, joint
positions/velocities/torques, contact forces on each foot (world, N), and the tracking errors of the
base — position ‖p − p_plan‖ (m) and orientation ‖log(R_planᵀ R)‖ (rad) — as Fig. 4 (e)-(f).
Per run: peak joint torque, torque saturation, QP failures and ticks whose torques were held
(`legplan.sim.controller`'s fallbacks), the peak joint speed over its limit and the time a joint
spent at it, and unplanned contacts (robot geoms other than the feet touching the terrain).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import mujoco
import numpy as np
import pinocchio as pin

from legplan.dyn.terrain import TerrainModel
from legplan.errors import LegplanError
from legplan.parameters import Parameters, param
from legplan.robots import leg_reach
from legplan.sim.controller import Gains, WholeBodyController
from legplan.sim.model import ModelOptions, build_model
from legplan.sim.reference import LIFT_RATE, Reference

CONTROL_DT = 0.0025   # s, 400 Hz (paper Sec. III-B)
OVERSPEED = 1.05      # × a joint's velocity limit counted as over it (`SimResult.overspeed_time`)


@dataclass(frozen=True)
class SimParams(Parameters):
    """Settings of a simulated execution (module docstring); `friction` None = the robot's μ."""

    what = "simulation"

    settle: float = param(0.5, "[0, inf)", doc="s held at the final pose after the plan")
    fall_height: float = param(0.5, "[0, inf)", doc="× nominal base height, above the terrain under the base")
    fall_tilt: float = param(0.8, "(0, 3.1416]", doc="rad, base z axis from the vertical")
    goal_distance: float = param(0.10, "(0, inf)", doc="m")
    goal_yaw: float = param(0.20, "(0, inf)", doc="rad")
    record_every: int = param(4, "[1, 1000]", doc="control ticks per recorded row (4: 100 Hz)")
    friction: float | None = param(None, "(0, inf)", "μ", "friction of the simulation and the controller")
    friction_scale: float = param(1.0, "(0, inf)", doc="× the simulated friction only (the controller keeps μ)")
    mass_scale: float = param(1.0, "(0, inf)",
                              doc="× every simulated mass and inertia (the controller keeps the URDF's)")
    lift_rate: float = param(LIFT_RATE, "(0, inf)", doc=(
        "m/s: largest rate of a swing foot's lift over the terrain's edges (legplan.sim.reference)"))
    pushes: tuple = ()                # ((t s, f_x N, f_y N, duration s), ...) on the root link
    zero_torque: bool = False         # apply no torques (a planted fall, for tests)
    model: ModelOptions = field(default_factory=ModelOptions)
    gains: Gains = field(default_factory=Gains)

    def __post_init__(self):
        super().__post_init__()
        for push in self.pushes:
            if len(push) != 4 or not np.all(np.isfinite(push)) or push[0] < 0 or push[3] <= 0:
                raise LegplanError(f"simulation parameter 'pushes': {tuple(push)} is not (t >= 0, f_x, f_y, "
                                   "duration > 0) with finite numbers")


@dataclass
class SimResult:
    """One execution: `success`, `reason`, `fell`, `fall_time` (s, NaN), final `goal_error` (m) and
    `yaw_error` (rad); time series in `series` (name -> array, rows every `record_every` ticks, with
    units in `SERIES_UNITS`); scalars `peak_torque` (N m), `saturation` (fraction of ticks with a
    joint at its limit), `qp_failures` (ticks whose QP was not solved), `qp_held` (ticks whose
    relaxed QP failed too: last torques held), `peak_speed_ratio` (largest |joint rate| / its
    velocity limit, NaN with no limits), `speed_limited_time` (s with a joint at or over its velocity
    limit), `overspeed_time` (s with a joint more than `OVERSPEED` × its limit at the end of a
    tick: what the motors could not prevent, e.g. an impact back-driving a knee), `impulse` (N s,
    the pushes' total), `unplanned_contact_time` (s), `unplanned_contacts` (names of the robot geoms
    other than the feet that touched), `max_position_error`, `max_orientation_error`, `rms_position_error`,
    `rms_orientation_error`, `simulated` (s), `wall` (s)."""

    success: bool
    reason: str
    fell: bool
    fall_time: float
    goal_error: float
    yaw_error: float
    series: dict
    peak_torque: float
    saturation: float
    qp_failures: int
    qp_held: int
    peak_speed_ratio: float
    speed_limited_time: float
    overspeed_time: float
    impulse: float
    unplanned_contact_time: float
    unplanned_contacts: list
    max_position_error: float
    max_orientation_error: float
    rms_position_error: float
    rms_orientation_error: float
    simulated: float
    wall: float
    replans: dict = field(default_factory=dict)  # `REPLAN_UNITS` columns


SERIES_UNITS = {"t": "s", "base_pos": "m", "base_quat": "(x, y, z, w)", "base_vel": "m/s (world)",
                "base_ang_vel": "rad/s (world)", "joint_pos": "rad", "joint_vel": "rad/s", "torque": "N m",
                "foot_forces": "N (world, on the foot)", "position_error": "m", "orientation_error": "rad"}
REPLAN_UNITS = {"t": "s", "trigger": "", "base_pos": "m", "base_euler": "rad", "base_vel": "m/s (world)",
                "base_ang_vel": "rad/s (world)", "feet_pos": "m", "iterations": "", "cpu_seconds": "s",
                "violation": "", "scaled_violation": "", "recovery": "", "extension": "s", "success": "", "status": "",
                "tracked": ""}
"""The columns of `SimResult.replans`, one row per replan (`legplan.sim.replanning.Replanner`): its
time and trigger ("period" or "tube"), the measured state it started from, LM iterations, CPU
seconds, its largest violation (rows in their own units, and in the solver's scale), whether it
converged, whether it recovered from a push (`recovery`: the feet in the air landed early,
`legplan.dyn.rest_gait.early_touchdown`), how much later the tracked replan ends than the plan before
it (`extension`, strides inserted: `ReplanParams.extension`), why the solve stopped (`status`: converged, max_iterations,
time_limit, stalled, numerical_failure) and whether the controller tracked it."""
TEXT_COLUMNS = ("trigger", "status")
"""The `REPLAN_UNITS` columns that hold words (bytes in sim.h5)."""


def simulate(samples: dict, robot, terrain_map, params: SimParams = SimParams(), goal=None,
             replanner=None) -> SimResult:
    """Run the plan `samples` (traj.h5 `samples/` of one task) with `robot` (a `RobotModel` with a
    `centroidal` section) on `terrain_map`; `goal` (x, y, yaw) or None for the plan's last pose;
    with a `legplan.sim.replanning.Replanner`, closed loop: its new plans become the reference."""
    started = time.perf_counter()
    mu = robot.centroidal.friction if params.friction is None else params.friction
    sim = build_model(robot, terrain_map, mu, params.model)
    terrain = TerrainModel(terrain_map)
    reference = Reference(samples, sim.foot_radius, terrain, params.lift_rate)
    controller = WholeBodyController(robot, sim.effort, mu, params.gains, velocity_limit=sim.velocity_limit,
                                     damping=sim.damping, armature=sim.armature)
    model = sim.model
    data = mujoco.MjData(model)
    perturb(sim, data, params)
    _initial_state(data, sim, robot, reference)
    if goal is None:
        end = reference.at(reference.t[-1])
        goal = (*end.pos[:2], np.arctan2(end.rot[1, 0], end.rot[0, 0]))
    substeps = int(round(CONTROL_DT / model.opt.timestep))
    ticks = int(np.ceil((reference.duration + params.settle) / CONTROL_DT))
    min_height = params.fall_height * robot.centroidal.base_height
    names = {int(g): model.geom(int(g)).name for g in sim.body_geoms}
    limited = np.isfinite(sim.velocity_limit)

    rows = {name: [] for name in SERIES_UNITS}
    peak, saturated, unplanned_ticks, touched = 0.0, 0, 0, set()
    peak_speed, speed_ticks, overspeed_ticks = 0.0, 0, 0
    fell, fall_time, reason = False, float("nan"), ""
    tau = np.zeros(robot.n_joints)
    start = reference.t[0]
    for tick in itertools.count():  # to the end of the tracked plan + settle (`ticks`), or a fall
        t = start + tick * CONTROL_DT
        q, v = _pinocchio_state(data, sim)
        ref = reference.at(t)
        if replanner is not None:
            trigger = replanner.due(t, float(np.linalg.norm(q[:3] - ref.pos)),
                                    float(np.linalg.norm(data.qvel[:3] - ref.vel)))
            if trigger:
                replanned = _replanned(replanner, t, data, sim, q, v, terrain, params.lift_rate, trigger)
                if replanned is not None:
                    reference = replanned
                    ref = reference.at(t)
                    ticks = _extended(ticks, start, reference.t[-1], params.settle)
        if not params.zero_torque:
            tau = controller.torques(q, v, ref, touching(data, sim))
        peak = max(peak, float(np.abs(tau).max()))
        saturated += bool(np.any(np.abs(tau) >= sim.effort * (1 - 1e-6)))
        at_limit = False
        for step in range(substeps):
            data.xfrc_applied[sim.root_body, :3] = push_force(params.pushes, t + step * model.opt.timestep)
            rates = data.qvel[sim.dof_index]
            over = limited & (np.abs(rates) >= sim.velocity_limit)
            at_limit |= bool(over.any())
            data.ctrl[:] = np.where(over & (tau * rates > 0), 0.0, tau)
            mujoco.mj_step(model, data)
        speed_ticks += at_limit
        if limited.any():
            ratio = float(np.max(np.abs(data.qvel[sim.dof_index][limited]) / sim.velocity_limit[limited]))
            peak_speed = max(peak_speed, ratio)
            overspeed_ticks += ratio > OVERSPEED
        pairs = data.contact.geom[:data.ncon]
        hits = set(pairs[np.isin(pairs, sim.body_geoms)].tolist())
        unplanned_ticks += bool(hits)
        touched |= hits
        q, v = _pinocchio_state(data, sim)
        rot = pin.Quaternion(q[3:7]).normalized().matrix()
        pos_err = float(np.linalg.norm(q[:3] - ref.pos))
        rot_err = float(np.linalg.norm(pin.log3(ref.rot.T @ rot)))
        if tick % params.record_every == 0 or tick == ticks - 1:
            _record(rows, t + CONTROL_DT, data, sim, q, v, rot, tau, pos_err, rot_err)
        height = q[2] - float(terrain.height(q[0:1], q[1:2])[0])
        tilt = float(np.arccos(np.clip(rot[2, 2], -1.0, 1.0)))
        trunk = bool(np.isin(sim.trunk_geoms, pairs).any())
        if height < min_height or tilt > params.fall_tilt or trunk:
            fell, fall_time = True, t + CONTROL_DT
            reason = (f"fell at {fall_time:.2f} s: base {height:.2f} m above the terrain (fall below "
                      f"{min_height:.2f} m), tilt {tilt:.2f} rad (fall above {params.fall_tilt:.2f} rad)"
                      + (", trunk on the terrain" if trunk else ""))
            if tick % params.record_every:
                _record(rows, fall_time, data, sim, q, v, rot, tau, pos_err, rot_err)
            break
        if tick + 1 >= ticks:
            break
    series = {name: np.asarray(value) for name, value in rows.items()}
    q, _ = _pinocchio_state(data, sim)
    rot = pin.Quaternion(q[3:7]).normalized().matrix()
    goal_error = float(np.hypot(q[0] - goal[0], q[1] - goal[1]))
    yaw_error = float(abs(np.angle(np.exp(1j * (np.arctan2(rot[1, 0], rot[0, 0]) - goal[2])))))
    if not fell:
        if goal_error > params.goal_distance or yaw_error > params.goal_yaw:
            reason = (f"missed the goal: {goal_error:.3f} m (tolerance {params.goal_distance} m), "
                      f"yaw {yaw_error:.3f} rad (tolerance {params.goal_yaw} rad)")
        else:
            reason = "reached the goal"
    pe, oe = series["position_error"], series["orientation_error"]
    return SimResult(success=not fell and reason == "reached the goal", reason=reason, fell=fell,
                     fall_time=fall_time, goal_error=goal_error, yaw_error=yaw_error, series=series,
                     peak_torque=peak, saturation=saturated / max(tick + 1, 1),
                     qp_failures=controller.qp_failures, qp_held=controller.qp_held,
                     peak_speed_ratio=peak_speed if limited.any() else float("nan"),
                     speed_limited_time=speed_ticks * CONTROL_DT, overspeed_time=overspeed_ticks * CONTROL_DT,
                     impulse=float(sum(np.hypot(p[1], p[2]) * p[3] for p in params.pushes)),
                     unplanned_contact_time=unplanned_ticks * CONTROL_DT,
                     unplanned_contacts=sorted(names[g] for g in touched),
                     max_position_error=float(pe.max()), max_orientation_error=float(oe.max()),
                     rms_position_error=float(np.sqrt(np.mean(pe ** 2))),
                     rms_orientation_error=float(np.sqrt(np.mean(oe ** 2))),
                     simulated=float(data.time), wall=time.perf_counter() - started,
                     replans=replanner.columns() if replanner is not None else {})


def _extended(ticks: int, start: float, end: float, settle: float) -> int:
    """The run's ticks once the tracked plan ends at `end` (s): more when it ends later than the
    ticks reach (a replan inserted strides, `ReplanParams.extension`), never fewer (a replan's end
    differs from its plan's by rounding)."""
    needed = int(np.ceil((end - start + settle) / CONTROL_DT - 1e-6))
    return max(ticks, needed)


def _replanned(replanner, t: float, data, sim, q, v, terrain: TerrainModel, lift_rate: float, trigger: str):
    """The `Reference` of a replan for `trigger` from the simulated state at t (the feet as the
    contact points under the foot spheres), or None when it failed."""
    rot = pin.Quaternion(q[3:7]).normalized().matrix()
    centres = data.geom_xpos[sim.foot_geoms]
    normal = terrain.basis(centres[:, 0], centres[:, 1])[0]
    feet = centres - np.asarray(sim.foot_radius, float)[:, None] * normal
    samples = replanner(t, q[:3], rot, data.qvel[:3], rot @ v[3:6], feet, trigger, touching(data, sim))
    return None if samples is None else Reference(samples, sim.foot_radius, terrain, lift_rate)


def perturb(sim, data, params: SimParams) -> None:
    """Scale the simulated friction and masses (`params.friction_scale`, `mass_scale`); the model's
    derived constants recomputed."""
    model = sim.model
    if params.friction_scale != 1.0:
        model.geom_friction[:, 0] *= params.friction_scale
    if params.mass_scale != 1.0:
        model.body_mass[:] *= params.mass_scale
        model.body_inertia[:] *= params.mass_scale
        mujoco.mj_setConst(model, data)


def push_force(pushes, t: float) -> np.ndarray:
    """The pushes' total horizontal force (3,) (N, world) at time t (s, the plan's clock)."""
    force = np.zeros(3)
    for start, fx, fy, duration in pushes:
        if start <= t < start + duration:
            force[:2] += fx, fy
    return force


def _initial_state(data, sim, robot, reference: Reference) -> None:
    """The plan's first base pose and velocity; joints by leg IK onto the first foot references."""
    ref = reference.at(reference.t[0])
    reach = leg_reach(robot, ref.pos[None], ref.rot[None], ref.feet_pos[None])
    data.qpos[:3] = ref.pos
    quat = pin.Quaternion(ref.rot)
    data.qpos[3:7] = quat.w, quat.x, quat.y, quat.z
    data.qpos[sim.qpos_index] = reach.joints[0]
    data.qvel[:3] = ref.vel
    data.qvel[3:6] = ref.rot.T @ ref.omega
    mujoco.mj_forward(sim.model, data)


def _pinocchio_state(data, sim) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's free joint (world position, quaternion w x y z; world linear and body angular
    velocity) as pinocchio's q = [p, x y z w, joints], v = [v_lin (body), ω (body), joint rates]."""
    w, x, y, z = data.qpos[3:7]
    q = np.concatenate([data.qpos[:3], [x, y, z, w], data.qpos[sim.qpos_index]])
    rot = pin.Quaternion(w, x, y, z).normalized().matrix()
    v = np.concatenate([rot.T @ data.qvel[:3], data.qvel[3:6], data.qvel[sim.dof_index]])
    return q, v


def _record(rows, t, data, sim, q, v, rot, tau, pos_err, rot_err) -> None:
    rows["t"].append(t)
    rows["base_pos"].append(q[:3].copy())
    rows["base_quat"].append(q[3:7].copy())
    rows["base_vel"].append(data.qvel[:3].copy())
    rows["base_ang_vel"].append(rot @ v[3:6])
    rows["joint_pos"].append(q[7:].copy())
    rows["joint_vel"].append(v[6:].copy())
    rows["torque"].append(np.asarray(tau, float).copy())
    rows["foot_forces"].append(foot_forces(data, sim))
    rows["position_error"].append(pos_err)
    rows["orientation_error"].append(rot_err)


def touching(data, sim) -> np.ndarray:
    """Which foot spheres (n_legs,) are in contact with the terrain now."""
    return np.isin(sim.foot_geoms, data.contact.geom[:data.ncon])


def foot_forces(data, sim) -> np.ndarray:
    """Contact forces (n_legs, 3) the terrain exerts on each foot sphere, world frame (N)."""
    forces = np.zeros((len(sim.foot_geoms), 3))
    wrench = np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        for leg, geom in enumerate(sim.foot_geoms):
            if geom in (contact.geom1, contact.geom2):
                mujoco.mj_contactForce(sim.model, data, i, wrench)
                world = contact.frame.reshape(3, 3).T @ wrench[:3]   # on geom2, normal from geom1 to geom2
                forces[leg] += world if contact.geom2 == geom else -world
    return forces
