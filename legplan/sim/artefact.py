"""The sim.h5 layout (kind "sim") written by `legplan dyn simulate`: one group per executed task.

Root attributes: the standard provenance (ARCHITECTURE.md), `params` (the `SimParams` and options),
`robot`, `legs` and `joints` (comma-separated, the order of every per-leg / per-joint axis),
`model_warnings` (what building the MuJoCo model repaired or does not enforce, one per line).
`/tasks/NNNN` (the traj artefact's task NNNN), attributes:
    success, reason, index, planned (the plan's own success), skipped (not executed because the
    plan did not succeed), fell, fall_time (s, NaN if none), goal_error (m), yaw_error (rad) at the
    end, peak_torque (N m), saturation (fraction of 400 Hz ticks with a joint at its effort limit),
    qp_failures (ticks whose QP was not solved: the relaxed QP ran), qp_held (ticks whose relaxed
    QP failed too: the last torques held), peak_speed_ratio (largest |joint rate| / its velocity
    limit), speed_limited_time (s with a joint at its velocity limit), overspeed_time (s with a joint
    more than 5 % over it), impulse (N s, the pushes'
    total), unplanned_contact_time (s),
    unplanned_contacts (comma-separated sphere names: shin, thigh or trunk touching the terrain),
    max/rms_position_error (m), max/rms_orientation_error (rad), simulated (s), wall (s) —
    NaN/empty when the task had no trajectory to execute.
  datasets: series/<name> every `record_every` ticks (`legplan.sim.run.SERIES_UNITS`): t, base_pos,
    base_quat, base_vel, base_ang_vel, joint_pos, joint_vel, torque, foot_forces, position_error,
    orientation_error (the base tracking errors of the paper's Fig. 4 (e)-(f)).
    With `dyn simulate --replan`: replans/<name>, one row per replan (`legplan.sim.run.REPLAN_UNITS`):
    t, trigger, the measured base_pos, base_euler, base_vel, base_ang_vel, feet_pos, iterations,
    cpu_seconds, violation, scaled_violation, recovery, extension, success, status (converged,
    max_iterations, time_limit, stalled, numerical_failure), tracked.
`/summary`: tasks, succeeded, success_rate, skipped, falls, median rms position/orientation error,
    worst max errors, peak torque, median saturation, QP failures and held ticks (totals), worst
    joint speed ratio, tasks with unplanned contacts, simulated seconds per wall second.
"""

from __future__ import annotations

import numpy as np

from legplan.artefacts import open_artefact, require, require_attrs, write_artefact, write_dataset, write_summary
from legplan.errors import LegplanError
from legplan.sim.run import REPLAN_UNITS, SERIES_UNITS

NAN = float("nan")
SCALARS = {"fall_time": "s", "goal_error": "m", "yaw_error": "rad", "peak_torque": "N m", "saturation": "",
           "qp_failures": "", "qp_held": "", "peak_speed_ratio": "", "speed_limited_time": "s", "overspeed_time": "s",
           "impulse": "N s",
           "unplanned_contact_time": "s", "max_position_error": "m",
           "rms_position_error": "m", "max_orientation_error": "rad", "rms_orientation_error": "rad",
           "simulated": "s", "wall": "s"}


def sim_record(index: int, planned: bool, result) -> dict:
    """The record of an executed task: a `SimResult`."""
    return {"index": int(index), "planned": bool(planned), "skipped": False, "success": bool(result.success),
            "reason": str(result.reason), "fell": bool(result.fell),
            "unplanned_contacts": ",".join(result.unplanned_contacts),
            **{name: float(getattr(result, name)) for name in SCALARS},
            "series": {name: np.asarray(value) for name, value in result.series.items()},
            "replans": dict(result.replans)}


def failed_record(index: int, planned: bool, reason: str, skipped: bool = False) -> dict:
    """The record of a task that was not executed (`skipped`: its plan did not succeed; or it has no
    trajectory) or whose simulation raised."""
    return {"index": int(index), "planned": bool(planned), "skipped": bool(skipped), "success": False,
            "reason": reason, "fell": False,
            "unplanned_contacts": "", **dict.fromkeys(SCALARS, NAN)}


def write_sim(path, records: list[dict], params: dict, robot, *, inputs=(), overwrite: bool = False,
              warnings=()) -> dict:
    """sim.h5 of one record per task (module docstring); `warnings`: the model's (`SimModel.warnings`,
    root attribute `model_warnings`, newline-separated); returns the summary rows."""
    summary = summary_rows(records)
    with write_artefact(path, "sim", params=params, inputs=inputs, overwrite=overwrite) as handle:
        handle.attrs["robot"] = robot.name
        handle.attrs["legs"] = ",".join(leg.name for leg in robot.legs)
        handle.attrs["joints"] = ",".join(robot.joint_names)
        handle.attrs["model_warnings"] = "\n".join(warnings)
        tasks = handle.create_group("tasks")
        for record in records:
            group = tasks.create_group(f"{record['index']:04d}")
            for key in ("success", "reason", "index", "planned", "skipped", "fell", "unplanned_contacts", *SCALARS):
                group.attrs[key] = record[key]
            for name, value in record.get("series", {}).items():
                write_dataset(group, f"series/{name}", value, units=SERIES_UNITS[name])
            for name, value in record.get("replans", {}).items():
                write_dataset(group, f"replans/{name}", value, units=REPLAN_UNITS[name])
        write_summary(handle, summary)
    return summary


def summary_rows(records: list[dict]) -> dict:
    """The `/summary` rows of the module docstring."""
    ran = [r for r in records if np.isfinite(r["simulated"])]

    def pick(key, fn):
        values = [r[key] for r in ran]
        return float(fn(values)) if values else NAN

    wall = sum(r["wall"] for r in ran)
    return {"tasks": len(records), "succeeded": sum(r["success"] for r in records),
            "success_rate": sum(r["success"] for r in records) / len(records) if records else NAN,
            "skipped": sum(r["skipped"] for r in records),
            "falls": sum(r["fell"] for r in records),
            "median_rms_position_error": (pick("rms_position_error", np.median), "m"),
            "median_rms_orientation_error": (pick("rms_orientation_error", np.median), "rad"),
            "max_position_error": (pick("max_position_error", np.max), "m"),
            "max_orientation_error": (pick("max_orientation_error", np.max), "rad"),
            "peak_torque": (pick("peak_torque", np.max), "N m"),
            "median_saturation": pick("saturation", np.median),
            "qp_failures": int(sum(r["qp_failures"] for r in ran)), "qp_held": int(sum(r["qp_held"] for r in ran)),
            "peak_speed_ratio": pick("peak_speed_ratio", lambda v: np.nanmax(v) if np.isfinite(v).any() else NAN),
            "unplanned_contact_tasks": sum(bool(r["unplanned_contacts"]) for r in records),
            "realtime_factor": sum(r["simulated"] for r in ran) / wall if wall > 0 else NAN}


def read_executed(path, index: int) -> dict:
    """Task `index` of a sim artefact as a dict of its attributes and `series` (name -> array); a
    one-line error naming the file when the task is missing or was not executed (no series)."""
    with open_artefact(path, kind="sim") as handle:
        tasks = require(handle, "tasks")
        name = f"{int(index):04d}"
        if name not in tasks:
            raise LegplanError(f"{path}: no task {index} (the artefact has {len(tasks)} task(s))")
        group = tasks[name]
        record = require_attrs(group, ("success", "reason", "fell", "fall_time"))
        if "series" not in group:
            raise LegplanError(f"{path}: task {index} was not executed ({record['reason']})")
        record["series"] = {key: require(group["series"], key)[()] for key in SERIES_UNITS}
    return record
