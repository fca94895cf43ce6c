"""The traj.h5 layout (kind "traj") written by `legplan dyn plan`: one group per task, and its reader.

Root attributes: the standard provenance (ARCHITECTURE.md), `params` = `settings.settings_record`
plus the task options; `robot`, `legs` (comma-separated, the order of every per-leg axis).
`/tasks/NNNN` (one group per task, in input order), attributes:
    success (bool: the solver converged and the independent check passed), solved (bool: the solver
    converged), reason (why the solver stopped, or the error; "check: <failed metrics>; " before it
    when the check failed), index, gait, strides, duration (s),
    iterations (LM, all stages), outer_iterations, solve_seconds (= timings/total),
    first_iteration_seconds, setup_seconds (building the problems), max_violation (the solver's, at
    its sampled rows), cost (final total), variables (free variables, ours),
    paper_variables (the paper's N = 12T/dt + 20S + 120), peak_force (largest |f| of a foot, N),
    peak_roll_pitch_rate (largest |ω_x|, |ω_y| of the base, rad/s) — NaN when the planner raised.
  datasets: start, goal (x m, y m, yaw rad); com_offset (m: the CoM in the base frame, about which the
    plan's dynamics hold; the samples are the base origin's);
    timings/{evaluate,assemble,factorize,solve,total} (s) — the solve time split;
    violations/<constraint> — the solver's largest violation of each constraint, in its own units;
    costs/<term> — the final value of every cost term (as the solver reports it);
    check/<metric> — the independent check (`legplan.validate.trajectory`) of the 10 ms samples:
        the worst value, attrs units, tolerance, bound ("upper": worst ≤ tolerance passes, "lower":
        worst ≥ tolerance) and passed; group attr passed;
    phases/durations (P,) s, phases/stance (P, legs) — the gait's whole-body phases;
    nodes/<block>/{value, fixed, span} for base_lin, base_ang, feet, forces — the node values
        ((nodes, value|derivative, xyz) flattened), the fixed mask, and each node's [first, last]
        time (s) as an end of a polynomial or the value of a constant one; nodes/{feet,forces}/leg
        each node's leg;
    samples/<name> — the solution every 10 ms (`legplan.dyn.planner.sample_solution`): t,
        base_pos, base_vel, base_acc, base_euler (roll, pitch, yaw), base_euler_rate, base_ang_vel
        (world ω), base_ang_acc, feet_pos, feet_vel, forces (n, legs, 3), contact (n, legs);
    history/<column> — one row per outer iteration of the solver (strings as UTF-8 bytes).
A task whose planner raised has only the attributes and start/goal.
`/summary`: tasks, succeeded, success_rate, median/max solve time, median first-iteration and setup
    time, median iterations, worst max_violation, median variables and paper_variables, peak force
    and roll/pitch rate, median of every cost term, and per check metric its worst over the
    solved tasks (`check_<metric>`) with `check_passed` (solved tasks passing every check).
"""

from __future__ import annotations

from dataclasses import asdict

import h5py
import numpy as np

from legplan.artefacts import (check_finite, open_artefact, require, require_attrs, write_artefact, write_dataset,
                               write_summary)
from legplan.geometry.ordered import median as ordered_median
from legplan.validate.trajectory import MINIMA as CHECK_MINIMA

NAN = float("nan")
NODE_BLOCKS = ("base_lin", "base_ang", "feet", "forces")
SAMPLE_UNITS = {"t": "s", "base_pos": "m", "base_vel": "m/s", "base_acc": "m/s^2", "base_euler": "rad",
                "base_euler_rate": "rad/s", "base_ang_vel": "rad/s", "base_ang_acc": "rad/s^2",
                "feet_pos": "m", "feet_vel": "m/s", "forces": "N", "contact": ""}
NODE_UNITS = {"base_lin": "m|m/s", "base_ang": "rad|rad/s", "feet": "m|m/s", "forces": "N|N/s"}
NODE_LAYOUT = "(nodes, value|derivative, xyz) flattened"
POSE_UNITS = "m, m, rad"
SCALARS = ("iterations", "outer_iterations", "solve_seconds", "first_iteration_seconds", "setup_seconds",
           "max_violation", "cost", "variables", "paper_variables", "peak_force", "peak_roll_pitch_rate")


def task_fields(index: int, task) -> dict:
    """The record fields naming one task (a `DynTask`), in the order they are written."""
    return {"index": int(index), "gait": task.gait, "strides": int(task.strides), "duration": float(task.duration),
            "start": np.asarray(task.start, float), "goal": np.asarray(task.goal, float)}


def trajectory_record(index: int, task, result, check) -> dict:
    """The record of a planned task: a `PlanResult` and its `CentroidalCheck` (layout above). A plan
    that converged but fails its check is no success: what is executed is what the check judged."""
    solve, form, samples = result.solve, result.problem.form, result.samples
    reason = str(result.reason)
    if result.success and not check.ok:
        reason = f"check: {', '.join(check.failures())}; {reason}"
    return {**task_fields(index, task), "success": bool(result.success and check.ok),
            "solved": bool(result.success), "reason": reason,
            "iterations": int(solve.iterations), "outer_iterations": int(solve.outer_iterations),
            "solve_seconds": float(solve.timings.total),
            "first_iteration_seconds": float(solve.first_iteration_seconds),
            "setup_seconds": float(result.setup_seconds), "max_violation": float(solve.max_violation),
            "cost": float(solve.cost),
            "variables": int(sum(int((~block.fixed).sum()) for block in result.problem.variables)),
            "paper_variables": int(form.paper_variable_count()),
            "peak_force": float(np.linalg.norm(samples["forces"], axis=-1).max()),
            "peak_roll_pitch_rate": float(np.abs(samples["base_ang_vel"][:, :2]).max()),
            "com_offset": np.asarray(result.problem.com_offset, float),
            "timings": {name: float(value) for name, value in asdict(solve.timings).items()},
            "violations": {name: float(value) for name, value in solve.violations.items()},
            "costs": {name: float(value) for name, value in solve.cost_terms.items()},
            "check": {"worst": dict(check.worst), "units": dict(check.units), "tolerance": dict(check.tolerance),
                      "passed": dict(check.passed), "ok": bool(check.ok)},
            "phases": {"durations": np.asarray(form.gait.durations, float),
                       "stance": np.asarray(form.gait.stance, bool)},
            "nodes": {block.name: {"value": np.asarray(solve.values[block.name], float),
                                   "fixed": np.asarray(block.fixed, bool), **_node_layout(form, block.name)}
                      for block in result.problem.variables},
            "samples": {name: np.asarray(value) for name, value in samples.items()},
            "history": _history_columns(solve.history)}


def failed_record(index: int, task, reason: str) -> dict:
    """The record of a task whose planning raised or whose worker died: no solution, NaN numbers."""
    return {**task_fields(index, task), "success": False, "solved": False, "reason": reason,
            **dict.fromkeys(SCALARS, NAN)}


def _node_layout(form, block: str) -> dict[str, np.ndarray]:
    """`span`: (nodes, 2) first and last time (s) at which each node of a variable block is a
    polynomial's end or a constant polynomial's value (NaN for a node of no polynomial); for the
    per-foot blocks also `leg`: each node's leg (index into the artefact's `legs`)."""
    if block.startswith("base"):
        splines, total = [(form.base, 0)], form.base.nodes
    elif block == "feet":
        splines, total = [(foot.motion, foot.motion_offset) for foot in form.feet], form.motion_nodes
    else:
        splines, total = [(foot.force, foot.force_offset) for foot in form.feet], form.force_nodes
    span, leg = np.full((total, 2), NAN), np.full(total, -1)
    for k, (spline, offset) in enumerate(splines):
        leg[offset:offset + spline.nodes] = k
        for seg in spline.segments:
            ends = [(seg.a, seg.t0, seg.t1)] if seg.constant else [(seg.a, seg.t0, seg.t0), (seg.b, seg.t1, seg.t1)]
            for node, first, last in ends:
                span[offset + node] = np.fmin(span[offset + node, 0], first), np.fmax(span[offset + node, 1], last)
    return {"span": span} if block.startswith("base") else {"span": span, "leg": leg}


def _history_columns(history: list[dict]) -> dict[str, np.ndarray]:
    """The solver's per-outer-iteration dicts as columns: numbers as floats (NaN where missing),
    anything else as UTF-8 bytes."""
    columns = {}
    for key in dict.fromkeys(key for row in history for key in row):
        values = [row.get(key) for row in history]
        if all(v is None or (isinstance(v, (int, float, np.number)) and not isinstance(v, bool)) for v in values):
            columns[key] = np.array([NAN if v is None else float(v) for v in values])
        else:
            columns[key] = np.array([("" if v is None else str(v)).encode() for v in values])
    return columns


def write_traj(path, records: list[dict], params: dict, robot: str, legs, *, inputs=(),
               overwrite: bool = False, robot_sha256: str | None = None) -> dict:
    """traj.h5 of one record per task (layout in the module docstring; `robot_sha256`, the robot's
    files' digest, as the root attribute of that name when given); returns the summary rows."""
    summary = summary_rows(records)
    with write_artefact(path, "traj", params=params, inputs=inputs, overwrite=overwrite) as handle:
        handle.attrs["robot"] = robot
        if robot_sha256 is not None:
            handle.attrs["robot_sha256"] = robot_sha256
        handle.attrs["legs"] = ",".join(legs)
        group = handle.create_group("tasks")
        for record in records:
            _write_task(group.create_group(f"{int(record['index']):04d}"), record)
        write_summary(handle, summary)
    return summary


def _write_task(group: h5py.Group, record: dict) -> None:
    for key in ("success", "solved", "reason", "index", "gait", "strides", "duration", *SCALARS):
        group.attrs[key] = record[key]
    write_dataset(group, "start", record["start"], units=POSE_UNITS)
    write_dataset(group, "goal", record["goal"], units=POSE_UNITS)
    if "samples" not in record:
        return
    write_dataset(group, "com_offset", record["com_offset"], units="m")
    for name, value in record["timings"].items():
        write_dataset(group, f"timings/{name}", value, units="s")
    violations = group.create_group("violations")
    violations.attrs["description"] = "the solver's largest violation of each constraint, in its own units"
    for name, value in record["violations"].items():
        write_dataset(violations, name, value)
    costs = group.create_group("costs")
    costs.attrs["description"] = "final value of each cost term, as the solver reports it"
    for name, value in record["costs"].items():
        write_dataset(costs, name, value)
    check = record["check"]
    checked = group.create_group("check")
    checked.attrs["passed"] = bool(check["ok"])
    checked.attrs["description"] = "independent check of the 10 ms samples (legplan.validate.trajectory)"
    for name, value in check["worst"].items():
        judged = {"tolerance": check["tolerance"][name], "passed": bool(check["passed"][name]),
                  "bound": "lower" if name in CHECK_MINIMA else "upper"} if name in check["passed"] else {}
        write_dataset(checked, name, value, units=str(check["units"].get(name, "")), **judged)
    write_dataset(group, "phases/durations", record["phases"]["durations"], units="s")
    write_dataset(group, "phases/stance", record["phases"]["stance"].astype(bool), units="")
    for block, node in record["nodes"].items():
        write_dataset(group, f"nodes/{block}/value", node["value"], units=NODE_UNITS.get(block, ""), layout=NODE_LAYOUT)
        write_dataset(group, f"nodes/{block}/fixed", node["fixed"].astype(bool), units="")
        write_dataset(group, f"nodes/{block}/span", node["span"], units="s")
        if "leg" in node:
            write_dataset(group, f"nodes/{block}/leg", node["leg"], units="")
    for name, value in record["samples"].items():
        write_dataset(group, f"samples/{name}", value, units=SAMPLE_UNITS.get(name, ""))
    history = group.create_group("history")
    for name, value in record["history"].items():
        write_dataset(history, name, value)


def summary_rows(records: list[dict]) -> dict:
    """The `/summary` rows of the module docstring."""
    ok = [r for r in records if r["success"]]

    def median(key, rows=records):
        values = [float(r[key]) for r in rows if np.isfinite(r[key])]
        return ordered_median(values) if values else NAN

    def extreme(values, pick=max):
        return float(pick(values)) if values else NAN

    rows = {"tasks": len(records), "succeeded": len(ok), "success_rate": len(ok) / len(records) if records else NAN,
            "median_solve_time": (median("solve_seconds"), "s"),
            "max_solve_time": (extreme([r["solve_seconds"] for r in records if np.isfinite(r["solve_seconds"])]), "s"),
            "median_first_iteration_time": (median("first_iteration_seconds"), "s"),
            "median_setup_time": (median("setup_seconds"), "s"),
            "median_iterations": median("iterations"),
            "max_violation": extreme([r["max_violation"] for r in ok]),
            "median_variables": median("variables"), "median_paper_variables": median("paper_variables"),
            "peak_force": (extreme([r["peak_force"] for r in ok]), "N"),
            "peak_roll_pitch_rate": (extreme([r["peak_roll_pitch_rate"] for r in ok]), "rad/s")}
    terms = dict.fromkeys(name for r in ok for name in r["costs"])
    rows.update({f"cost_{name}": ordered_median([r["costs"][name] for r in ok if name in r["costs"]])
                 for name in terms})
    checked = [r["check"] for r in records if "check" in r]
    for name in dict.fromkeys(name for c in checked for name in c["worst"]):
        pick = min if name in CHECK_MINIMA else max
        units = next(c["units"].get(name, "") for c in checked if name in c["worst"])
        rows[f"check_{name}"] = (extreme([c["worst"][name] for c in checked if name in c["worst"]], pick), str(units))
    rows["check_passed"] = sum(bool(c["ok"]) for c in checked)
    return rows


def read_tasks(path) -> tuple[dict, list[dict]]:
    """Root attributes and every task group of a traj artefact, each as a nested dict of its
    attributes and datasets (numpy values)."""
    with open_artefact(path, kind="traj") as handle:
        attrs = require_attrs(handle, ("robot", "legs"))
        tasks = require(handle, "tasks")
        for name in sorted(tasks):
            _check_task(tasks[name])
        return attrs, [_read_group(tasks[name]) for name in sorted(tasks)]


def _check_task(group: h5py.Group) -> None:
    """An `ArtefactError` naming the file and item unless a task group holds what its readers
    index: the attributes and start/goal of every task, and the samples and nodes of a solved one."""
    require_attrs(group, ("index", "success", "reason"))
    for name in ("start", "goal"):
        require(group, name)
    if "samples" in group:
        for name in SAMPLE_UNITS:
            require(group["samples"], name)
        for block in NODE_BLOCKS:
            for name in ("value", "fixed", "span"):
                require(group, f"nodes/{block}/{name}")


def check_executable(path, task: dict) -> None:
    """An `ArtefactError` naming the file, task and dataset unless the task's goal and every sample
    array (`samples/*`, what `dyn simulate` executes) are finite; tasks without samples pass."""
    where = f"{path}: task {int(task['index'])}:"
    check_finite(f"{where} dataset 'goal'", np.asarray(task["goal"], float))
    for name, values in task.get("samples", {}).items():
        check_finite(f"{where} dataset 'samples/{name}'", np.asarray(values))


def _read_group(group: h5py.Group) -> dict:
    out = dict(group.attrs)
    for name, node in group.items():
        out[name] = _read_group(node) if isinstance(node, h5py.Group) else node[()]
    return out
