"""Planned and executed motions as time series at a chosen rate, for a controller, a plot or rviz.

`export_series(path, rate)` reads a motion.h5 (`step plan`, `baseline step`), traj.h5 (`dyn plan`)
or sim.h5 (`dyn simulate`) and returns one `Series` per item, sampled every 1/rate s from 0 to the
item's end (its last sample included):

    t          (n,)          s, from the item's start
    base_pos   (n, 3)        m, world frame (z up)
    base_quat  (n, 4)        base orientation, (x, y, z, w), base to world
    joint_pos  (n, joints)   rad, in `joint_names` order (the robot's URDF order)
    feet_pos   (n, legs, 3)  m, world positions of the foot frames, in `leg_names` order
    contact    (n, legs)     1 where the foot is in stance (planned; for sim.h5, foot force > 0)

How each kind gets there:

* motion: a step's Bézier curve (or a baseline's waypoint path) is geometric, parametrized by
  s in [0, 1] (Bézier paper eq. (1)); each step is given `step_duration` seconds, uniform in s, and
  the steps follow each other in index order. Base and joints are the curve's x = [p, rotation
  vector, joints]; feet by pinocchio forward kinematics; contact is the step's `stance` (legs held
  on their footholds). A step without a curve (failed before its first solve) is held at q_start.
* traj: the 10 ms samples (base position, Euler angles R = Rz Ry Rx, feet, contact), linearly
  interpolated; the plan holds no joints, so they come from inverse kinematics: per sample, the
  joints that put every foot frame at the planned contact point lifted by the foot sphere's radius
  (the controller's reference of `legplan.sim.reference`, with the terrain normal taken as z),
  damped Gauss-Newton warm-started from the previous sample; `ik_error` (n,) m is the largest
  foot-frame distance left.
* sim: the recorded series (base, joints), linearly interpolated; feet by forward kinematics.

`write_series(series, output, overwrite=...)` writes them as CSV (one row per sample, an `item`
column, `legplan.export.csv_header`) or HDF5 (kind "series": `/series/<item>/<column>` with units),
by the output's suffix.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from legplan.errors import ArtefactError, LegplanError

UNITS = {"t": "s", "base_pos": "m", "base_quat": "(x, y, z, w)", "joint_pos": "rad", "feet_pos": "m",
         "contact": "", "ik_error": "m"}
SUFFIXES = {".csv": "csv", ".h5": "hdf5", ".hdf5": "hdf5"}
IK_ITERATIONS = 30
IK_DAMPING = 1e-6
IK_TOLERANCE = 1e-6  # m


@dataclass
class Series:
    """One item's time series (module docstring): `columns` by name, `item` its group name in the
    source artefact (e.g. "tasks/0000"), `joint_names` and `leg_names` the orders of its axes."""

    item: str
    joint_names: tuple[str, ...]
    leg_names: tuple[str, ...]
    columns: dict[str, np.ndarray] = field(default_factory=dict)


def sample_times(end: float, rate: float) -> np.ndarray:
    """0, 1/rate, ... up to `end`, with `end` itself as the last sample."""
    if not rate > 0 or not np.isfinite(rate):
        raise LegplanError(f"--rate: must be a positive number of samples per second, got {rate}")
    t = np.arange(0.0, end, 1.0 / rate)
    return np.append(t, end) if not len(t) or end - t[-1] > 1e-9 else t


def export_series(path: str | os.PathLike, rate: float, *, step_duration: float = 1.0) -> list[Series]:
    """The time series of every item of a motion, traj or sim artefact (module docstring)."""
    from legplan.artefacts import open_artefact, read_provenance

    with open_artefact(path, kind=("motion", "traj", "sim")) as handle:
        kind = read_provenance(handle)["kind"]
        robot_name = str(handle.attrs.get("robot", ""))
    if not robot_name:
        raise ArtefactError(f"{path}: missing root attribute 'robot'")
    from legplan.robots import load_robot

    robot = load_robot(robot_name)
    if kind == "motion":
        if not step_duration > 0:
            raise LegplanError(f"--step-duration: must be positive, got {step_duration}")
        return [_motion_series(path, robot, rate, step_duration)]
    if kind == "traj":
        return _traj_series(path, robot, rate)
    return _sim_series(path, robot, rate)


def _series(item: str, robot, t, base_pos, base_quat, joints, contact, **extra) -> Series:
    Q = np.concatenate([base_pos, base_quat, joints], axis=1)
    columns = {"t": t, "base_pos": base_pos, "base_quat": base_quat, "joint_pos": joints,
               "feet_pos": robot.foot_positions(Q), "contact": np.asarray(contact, np.int8), **extra}
    return Series(item, tuple(robot.joint_names), tuple(leg.name for leg in robot.legs), columns)


def _interpolate(t_new: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of `values` (n, ...) sampled at `t` onto `t_new`."""
    flat = values.reshape(len(t), -1)
    out = np.stack([np.interp(t_new, t, column) for column in flat.T], axis=1)
    return out.reshape((len(t_new),) + values.shape[1:])


def _held(t_new: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The value of the last sample at or before each of `t_new` (flags, not interpolated)."""
    return values[np.clip(np.searchsorted(t, t_new + 1e-9, side="right") - 1, 0, len(t) - 1)]


def _unit_quats(quat: np.ndarray) -> np.ndarray:
    return quat / np.linalg.norm(quat, axis=1, keepdims=True)


# -- motion.h5 -----------------------------------------------------------------------------------
def _step_curve(record: dict, robot, s: np.ndarray) -> np.ndarray:
    """x(s) of one step: its Bézier curve, a baseline's waypoint path uniform in arc length, or
    q_start held."""
    from legplan.geometry.bezier import evaluate

    if "control_points" in record:
        return evaluate(record["control_points"], s)
    if "waypoints" in record:
        points = np.asarray(record["waypoints"], float)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        arc = arc / arc[-1] if arc[-1] > 0 else np.linspace(0.0, 1.0, len(points))
        return _interpolate(s, arc, points)
    return np.repeat(robot.to_vector(record["q_start"][None]), len(s), axis=0)


def _motion_series(path, robot, rate: float, step_duration: float) -> Series:
    from legplan.stepplan.batch import read_motion

    records = sorted(read_motion(path), key=lambda r: int(r["index"]))
    t = sample_times(step_duration * len(records), rate)
    step = np.minimum((t / step_duration).astype(int), len(records) - 1)
    X = np.empty((len(t), robot.nx))
    contact = np.zeros((len(t), robot.n_legs), bool)
    for k, record in enumerate(records):
        rows = step == k
        X[rows] = _step_curve(record, robot, t[rows] / step_duration - k)
        contact[rows] = np.asarray(record.get("stance", np.ones(robot.n_legs)), bool)
    Q = robot.from_vector(X)
    return _series("steps", robot, t, Q[:, :3], Q[:, 3:7], Q[:, 7:], contact)


# -- traj.h5 -------------------------------------------------------------------------------------
def foot_radii(robot) -> np.ndarray:
    """(legs,) radius of each leg's foot sphere (0 where a leg has none)."""
    spheres = robot.spheres
    radii = np.zeros(robot.n_legs)
    for k in range(len(spheres.radii)):
        if spheres.is_foot[k] and spheres.leg_index[k] >= 0:
            radii[spheres.leg_index[k]] = spheres.radii[k]
    return radii


def joints_by_ik(robot, base_pos, base_quat, feet_targets) -> tuple[np.ndarray, np.ndarray]:
    """Joints (n, joints) putting the foot frames at `feet_targets` (n, legs, 3) with the base at
    its pose, and the largest distance left per sample (n,): damped Gauss-Newton on the joints
    (pinocchio foot Jacobians), joint limits clipped, warm-started from the previous sample."""
    n = len(base_pos)
    joints = np.empty((n, robot.nq - 7))
    errors = np.empty(n)
    q = np.array(robot.q_nominal, float)[7:]
    lower, upper = np.asarray(robot.lower, float), np.asarray(robot.upper, float)
    for i in range(n):
        for _ in range(IK_ITERATIONS):
            Q = np.concatenate([base_pos[i], base_quat[i], q])[None]
            kin = robot.kinematics(Q)
            residual = (feet_targets[i] - kin.foot_positions[0]).reshape(-1)
            if np.abs(residual).max() < IK_TOLERANCE:
                break
            J = kin.foot_jacobians[0].reshape(-1, robot.nv)[:, 6:]
            step = np.linalg.solve(J.T @ J + IK_DAMPING * np.eye(J.shape[1]), J.T @ residual)
            q = np.clip(q + step, lower, upper)
        Q = np.concatenate([base_pos[i], base_quat[i], q])[None]
        errors[i] = float(np.linalg.norm(feet_targets[i] - robot.foot_positions(Q)[0], axis=1).max())
        joints[i] = q
    return joints, errors


def traj_configurations(robot, samples: dict, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """(base_pos, base_quat (x, y, z, w), joints, ik_error) of a traj task's `samples` at times `t`
    (the samples' own clock): interpolated base and feet, joints by `joints_by_ik` (module docstring)."""
    from scipy.spatial.transform import Rotation

    t_plan = np.asarray(samples["t"], float)
    lift = foot_radii(robot)[None, :, None] * np.array([0.0, 0.0, 1.0])
    base_pos = _interpolate(t, t_plan, np.asarray(samples["base_pos"], float))
    euler = _interpolate(t, t_plan, np.asarray(samples["base_euler"], float))
    base_quat = Rotation.from_euler("ZYX", euler[:, ::-1]).as_quat()  # R = Rz(yaw) Ry(pitch) Rx(roll)
    feet = _interpolate(t, t_plan, np.asarray(samples["feet_pos"], float)) + lift
    joints, errors = joints_by_ik(robot, base_pos, base_quat, feet)
    return base_pos, base_quat, joints, errors


def _traj_series(path, robot, rate: float) -> list[Series]:
    from legplan.dyn.artefact import read_tasks

    _, tasks = read_tasks(path)
    out = []
    for index, task in enumerate(tasks):
        samples = task.get("samples")
        if samples is None:
            continue  # the planner raised: nothing to export (its reason is in traj.h5)
        t_plan = np.asarray(samples["t"], float)
        t = sample_times(float(t_plan[-1] - t_plan[0]), rate) + t_plan[0]
        base_pos, base_quat, joints, errors = traj_configurations(robot, samples, t)
        contact = _held(t, t_plan, np.asarray(samples["contact"], bool))
        out.append(_series(f"tasks/{int(task.get('index', index)):04d}", robot, t - t_plan[0], base_pos, base_quat,
                           joints, contact, ik_error=errors))
    if not out:
        raise ArtefactError(f"{path}: no task has samples (every planner raised); nothing to export")
    return out


# -- sim.h5 --------------------------------------------------------------------------------------
def _sim_series(path, robot, rate: float) -> list[Series]:
    from legplan.artefacts import open_artefact, read_array

    out = []
    with open_artefact(path, kind="sim") as handle:
        joints_attr = handle.attrs.get("joints", "")
        names = (joints_attr.decode() if isinstance(joints_attr, bytes) else str(joints_attr)).split(",")
        order = [names.index(name) for name in robot.joint_names] if set(robot.joint_names) <= set(names) else None
        if order is None:
            raise ArtefactError(f"{path}: root attribute 'joints' does not name the joints of {robot.name}")
        tasks = handle.get("tasks", {})
        for name in sorted(tasks):
            group = tasks[name]
            if "series" not in group:
                continue  # nothing was executed (its reason is in sim.h5)
            series = {key: read_array(group["series"], key) for key in ("t", "base_pos", "base_quat", "joint_pos",
                                                                        "foot_forces")}
            t_sim = series["t"]
            t = sample_times(float(t_sim[-1] - t_sim[0]), rate) + t_sim[0]
            base_quat = _unit_quats(_interpolate(t, t_sim, series["base_quat"]))
            joints = _interpolate(t, t_sim, series["joint_pos"][:, order])
            forces = np.linalg.norm(series["foot_forces"], axis=-1) > 0
            out.append(_series(f"tasks/{name}", robot, t - t_sim[0], _interpolate(t, t_sim, series["base_pos"]),
                               base_quat, joints, _held(t, t_sim, forces)))
    if not out:
        raise ArtefactError(f"{path}: no task was executed; nothing to export")
    return out


# -- writing -------------------------------------------------------------------------------------
def output_format(output: str | os.PathLike) -> str:
    """'csv' or 'hdf5' by the output's suffix; a `LegplanError` for any other."""
    fmt = SUFFIXES.get(Path(output).suffix.lower())
    if fmt is None:
        raise LegplanError(f"{output}: unknown export format (expected {', '.join(SUFFIXES)})")
    return fmt


def csv_header(series: Series) -> list[str]:
    """item, t, base_x/y/z, base_qx/qy/qz/qw, one column per joint, <leg>_x/y/z, <leg>_contact (and
    ik_error for a traj)."""
    legs = series.leg_names
    header = ["item", "t", "base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw",
              *series.joint_names, *(f"{leg}_{axis}" for leg in legs for axis in "xyz"),
              *(f"{leg}_contact" for leg in legs)]
    return header + (["ik_error"] if "ik_error" in series.columns else [])


def _rows(series: Series):
    c = series.columns
    n = len(c["t"])
    numbers = np.concatenate([c["t"][:, None], c["base_pos"], c["base_quat"], c["joint_pos"],
                              c["feet_pos"].reshape(n, -1)], axis=1)
    for i in range(n):
        yield [series.item, *(f"{v:.9g}" for v in numbers[i]), *(str(int(v)) for v in c["contact"][i]),
               *([f"{c['ik_error'][i]:.9g}"] if "ik_error" in c else [])]


def write_series(series: list[Series], output: str | os.PathLike, *, source: str | os.PathLike,
                 params: dict | None = None, overwrite: bool = False) -> None:
    """Write `series` to `output` (CSV or HDF5 by suffix), published atomically."""
    from legplan.artefacts import write_artefact, write_dataset
    from legplan.artefacts.publish import staged_output

    if output_format(output) == "csv":
        with staged_output(output, overwrite=overwrite) as temp, temp.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(csv_header(series[0]))
            for one in series:
                writer.writerows(_rows(one))
        return
    with write_artefact(output, "series", params=params, inputs=[source], overwrite=overwrite) as handle:
        handle.attrs["joints"] = ",".join(series[0].joint_names)
        handle.attrs["legs"] = ",".join(series[0].leg_names)
        for one in series:
            group = handle.create_group(f"series/{one.item}")
            for name, values in one.columns.items():
                write_dataset(group, name, values, units=UNITS[name])
