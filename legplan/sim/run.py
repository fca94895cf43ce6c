"""Execute a planned centroidal motion in MuJoCo under the whole-body controller:
`simulate(samples, robot, terrain_map, params, goal) -> SimResult`.

The paper's validation (Sec. III-C, Fig. 4 (e)-(f); Sec. V-A, Fig. 8) runs each plan through its
whole-body controller in a physics simulator and calls a trial a success when the robot reaches the
goal without falling. Here:

1. The robot starts at the plan's first base pose and velocity, its joints from leg IK
   (`legplan.robots.leg_reach`) putting the foot spheres on the planned footholds.
2. Every 2.5 ms (400 Hz) the controller (`legplan.sim.controller`) computes torques from the
   simulated state and the plan's reference at that time; MuJoCo integrates 5 steps of 0.5 ms with
   them held (torque motors clipped to the URDF effort limits).
3. After the plan's duration the controller holds the final pose for `settle` seconds.
4. A fall ends the run: the base lower than `fall_height` × the nominal base height above the
   terrain under it, its z axis tilted more than `fall_tilt` from the vertical, or the trunk (a
   collision sphere of the root link) touching the terrain.
5. Success: no fall, and at the end the base within `goal_distance` (horizontal) and `goal_yaw`
   (yaw) of the goal (default: the plan's last pose; the task's goal when given).

Recorded every `record_every` ticks (default 4: 100 Hz): time, base pose and velocity, joint
positions/velocities/torques, contact forces on each foot (world, N), and the tracking errors of the
base — position ‖p − p_plan‖ (m) and orientation ‖log(R_planᵀ R)‖ (rad) — as Fig. 4 (e)-(f).
Per run: peak joint torque, torque saturation, QP failures, and unplanned contacts (robot spheres
other than the feet touching the terrain: shin, thigh, trunk).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np
import pinocchio as pin

from legplan.dyn.terrain import TerrainModel
from legplan.parameters import Parameters, param
from legplan.robots import leg_reach
from legplan.sim.controller import Gains, WholeBodyController
from legplan.sim.model import build_model
from legplan.sim.reference import Reference

CONTROL_DT = 0.0025   # s, 400 Hz (paper Sec. III-B)


@dataclass(frozen=True)
class SimParams(Parameters):
    """Settings of a simulated execution (module docstring); `friction` None = the robot's μ."""

    what = "simulation"

    settle: float = param(0.5, "[0, inf)", doc="s held at the final pose after the plan")
    fall_height: float = param(0.5, "[0, inf)", doc="× nominal base height, above the terrain under the base")
    fall_tilt: float = param(0.8, "[0, 3.141592653589793]", doc="rad, base z axis from the vertical")
    goal_distance: float = param(0.10, "[0, inf)", doc="m")
    goal_yaw: float = param(0.20, "[0, 3.141592653589793]", doc="rad")
    record_every: int = param(4, "[1, inf)", doc="control ticks per recorded row (100 Hz)")
    friction: float | None = param(None, "(0, inf)", "μ", "None: the robot's")
    zero_torque: bool = param(False, (False, True), doc="apply no torques (a planted fall, for tests)")
    effort_scale: float = param(1.0, "(0, inf)", doc="× the URDF effort limits (which limits would a plan need)")
    gains: Gains = field(default_factory=Gains, metadata={"range": None, "symbol": None, "doc": "controller gains"})


@dataclass
class SimResult:
    """One execution: `success`, `reason`, `fell`, `fall_time` (s, NaN), final `goal_error` (m) and
    `yaw_error` (rad); time series in `series` (name -> array, rows every `record_every` ticks, with
    units in `SERIES_UNITS`); scalars `peak_torque` (N m), `saturation` (fraction of ticks with a
    joint at its limit), `qp_failures`, `unplanned_contact_time` (s), `unplanned_contacts` (names of
    the spheres that touched), `max_position_error`, `max_orientation_error`, `rms_position_error`,
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
    unplanned_contact_time: float
    unplanned_contacts: list
    max_position_error: float
    max_orientation_error: float
    rms_position_error: float
    rms_orientation_error: float
    simulated: float
    wall: float


SERIES_UNITS = {"t": "s", "base_pos": "m", "base_quat": "(x, y, z, w)", "base_vel": "m/s (world)",
                "base_ang_vel": "rad/s (world)", "joint_pos": "rad", "joint_vel": "rad/s", "torque": "N m",
                "foot_forces": "N (world, on the foot)", "position_error": "m", "orientation_error": "rad"}


def simulate(samples: dict, robot, terrain_map, params: SimParams = SimParams(), goal=None) -> SimResult:
    """Run the plan `samples` (traj.h5 `samples/` of one task) with `robot` (a `RobotModel` with a
    `centroidal` section) on `terrain_map`; `goal` (x, y, yaw) or None for the plan's last pose."""
    started = time.perf_counter()
    mu = robot.centroidal.friction if params.friction is None else params.friction
    sim = build_model(robot, terrain_map, mu, params.effort_scale)
    terrain = TerrainModel(terrain_map)
    reference = Reference(samples, sim.foot_radius, terrain)
    controller = WholeBodyController(robot, sim.effort, mu, params.gains)
    model = sim.model
    data = mujoco.MjData(model)
    _initial_state(data, sim, robot, reference)
    if goal is None:
        end = reference.at(reference.t[-1])
        goal = (*end.pos[:2], np.arctan2(end.rot[1, 0], end.rot[0, 0]))
    substeps = int(round(CONTROL_DT / model.opt.timestep))
    ticks = int(np.ceil((reference.duration + params.settle) / CONTROL_DT))
    min_height = params.fall_height * robot.centroidal.base_height
    names = {int(g): model.geom(int(g)).name for g in sim.body_geoms}

    rows = {name: [] for name in SERIES_UNITS}
    peak, saturated, unplanned_ticks, touched = 0.0, 0, 0, set()
    fell, fall_time, reason = False, float("nan"), ""
    tau = np.zeros(robot.n_joints)
    for tick in range(ticks):
        t = reference.t[0] + tick * CONTROL_DT
        q, v = _pinocchio_state(data, sim)
        ref = reference.at(t)
        if not params.zero_torque:
            tau = controller.torques(q, v, ref, touching(data, sim))
        data.ctrl[:] = tau
        peak = max(peak, float(np.abs(tau).max()))
        saturated += bool(np.any(np.abs(tau) >= sim.effort * (1 - 1e-6)))
        mujoco.mj_step(model, data, substeps)
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
                     qp_failures=controller.qp_failures, unplanned_contact_time=unplanned_ticks * CONTROL_DT,
                     unplanned_contacts=sorted(names[g] for g in touched),
                     max_position_error=float(pe.max()), max_orientation_error=float(oe.max()),
                     rms_position_error=float(np.sqrt(np.mean(pe ** 2))),
                     rms_orientation_error=float(np.sqrt(np.mean(oe ** 2))),
                     simulated=float(data.time), wall=time.perf_counter() - started)


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
