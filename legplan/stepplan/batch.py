"""Plan consecutive pairs of a step sequence (per-item task functions for `legplan.batch`) and write motion.h5.

motion.h5 (kind "motion"):
  root attrs   robot, parametrization ("x = [p, rotation vector, joints]")
  /steps/NNNN  one group per planned pair (q_NNNN → q_NNNN+1), attrs success, reason, degree,
               seconds, norm, index; datasets
                 control_points (d+1, nx) x-space,  q_start / q_end (nq,) pinocchio order,
                 stance (n_legs,) legs held on their footholds, footholds (n_legs, 3),
                 lm_iterations (per degree tried, from d = 1), degree_norms ‖F̃‖ per degree,
                 timings/{evaluate,assemble,factorize,solve} s,
                 dense/{foot_slip, com_margin, joint_excess, shortfall_* per constraint,
                        length, roughness2, roughness3} (`legplan.stepplan.measure`)
               A record of another planner (legplan.baselines) carries `waypoints` (k, nx), a
               piecewise-linear x-space path, instead of control_points / degree / LM data, and
               its own attrs (`record["attrs"]`); `dense` and `timings` are written for both.
  root attr    requirements (JSON): what the dense re-check requires, `legplan.validate.judge`
  /summary     Table II rows (see `table2`) and the tolerance of each judged constraint.
"""

from __future__ import annotations

import json
import logging
import time
import traceback
from collections.abc import Callable, Sequence

import numpy as np

from legplan.artefacts import open_artefact, require, require_attrs, write_artefact, write_dataset, write_summary
from legplan.artefacts.memo import by_file
from legplan.errors import ArtefactError
from legplan.stepplan.measure import DENSE_UNITS, dense_check, judged, requirements
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import plan_step, terrain_distance

log = logging.getLogger(__name__)

PARAMETRIZATION = "x = [base position (3), base rotation vector (3), joints]; quaternion = exp(rotation vector)"
POLYLINE = "piecewise-linear path through these x-space waypoints, uniform in x-space arc length; " + PARAMETRIZATION


def motion_stance(stance_a, stance_b, footholds_a, footholds_b, tol: float = 1e-6) -> np.ndarray:
    """Legs that stay on one foothold for the whole motion: in stance at both ends, same foothold."""
    same = np.all(np.abs(np.asarray(footholds_a) - np.asarray(footholds_b)) <= tol, axis=-1)
    return np.asarray(stance_a, bool) & np.asarray(stance_b, bool) & same


class StepWorker:
    """Everything one process needs: robot, exact terrain distance and independent validator, loaded once."""

    def __init__(self, robot_name: str, map_path: str, params: StepPlanParams):
        from legplan.robots import load_robot
        from legplan.terrain import load_map

        self._hold(load_robot(robot_name), load_map(map_path), params)

    @classmethod
    def of(cls, robot, terrain, params: StepPlanParams) -> StepWorker:
        """A worker on the robot and map the caller has already loaded (what `__init__` would load)."""
        worker = cls.__new__(cls)
        worker._hold(robot, terrain, params)
        return worker

    def _hold(self, robot, terrain, params: StepPlanParams) -> None:
        from legplan.validate.checks import Validator

        self.robot = robot
        self.terrain = terrain
        self.distance = terrain_distance(self.robot, self.terrain, params)
        self.validator = Validator(self.robot, self.terrain)
        self.params = params
        self.required = requirements(params)

    def plan(self, index: int, q_start, q_end, stance, footholds) -> dict:
        """Plan one step and judge it; never raises (a failure is a record with a reason)."""
        t0 = time.perf_counter()
        record = {"index": index, "q_start": np.asarray(q_start), "q_end": np.asarray(q_end),
                  "stance": np.asarray(stance, bool), "footholds": np.nan_to_num(np.asarray(footholds), nan=0.0)}
        try:
            plan = plan_step(self.robot, self.distance, q_start, q_end, stance, record["footholds"], self.params)
        except Exception as exc:  # a bad pair must not stop the batch
            log.debug("step %d raised:\n%s", index, traceback.format_exc())
            record.update(success=False, reason=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - t0)
            return record
        record.update(success=plan.success, reason=plan.reason, seconds=plan.seconds, degree=plan.degree,
                      norm=plan.norm, control_points=plan.control_points, timings=plan.timings,
                      lm_iterations=np.array([d.iterations for d in plan.degrees]),
                      degree_norms=np.array([d.norm for d in plan.degrees]))
        check = dense_check(self.robot, self.validator, plan.control_points, stance, record["footholds"],
                            self.params.dense_samples, self.required)
        return judged(record, check, self.required)


def step_items(seq, indices: Sequence[int]) -> list[tuple]:
    """The items of pairs (q_i, q_{i+1}), i in `indices`, of a `StepSequence`:
    (i, q_i, q_{i+1}, motion stance, footholds_i), the arguments of a step worker's `plan`."""
    items = []
    for i in indices:
        stance = motion_stance(seq.stance[i], seq.stance[i + 1], seq.footholds[i], seq.footholds[i + 1])
        items.append((int(i), seq.q[i], seq.q[i + 1], stance, seq.footholds[i]))
    return items


def plan_item(worker, item: tuple) -> dict:
    """Plan one item of `step_items` with a step worker (`StepWorker`, or a baseline's): the
    per-item task function that `legplan.batch.Task` runs."""
    return worker.plan(*item)


def failed_item(item: tuple, reason: str) -> dict:
    """The record of an item whose planning raised or whose worker died (`legplan.batch.Task`);
    its planning time is unknown (NaN)."""
    index, q_start, q_end, stance, footholds = item
    return {"index": index, "q_start": np.asarray(q_start), "q_end": np.asarray(q_end),
            "stance": np.asarray(stance, bool), "footholds": np.nan_to_num(np.asarray(footholds, float), nan=0.0),
            "success": False, "reason": reason, "seconds": float("nan")}


def plan_pairs(worker, seq, indices: Sequence[int],
               progress: Callable[[int, int, str], None] | None = None) -> list[dict]:
    """Plan the pairs of `indices` one after another in this process with a step worker; records in
    index order. (The CLI runs the same items through `legplan.batch`, in parallel.)"""
    records: list[dict] = []
    failed = 0
    for item in step_items(seq, indices):
        records.append(plan_item(worker, item))
        failed += not records[-1]["success"]
        if progress is not None:
            progress(len(records), len(indices), f"step {item[0]} {records[-1]['seconds']:.2f}s, {failed} failed")
    return records


def plan_sequence(seq, map_path, params: StepPlanParams, indices: Sequence[int],
                  progress: Callable[[int, int, str], None] | None = None) -> list[dict]:
    """Plan pairs (q_i, q_{i+1}) for i in `indices` of a `StepSequence` in this process; records in index order."""
    return plan_pairs(StepWorker(seq.robot, str(map_path), params), seq, indices, progress)


def table2(records: Sequence[dict]) -> dict:
    """Table II quantities: steps planned / succeeded, worst violation (dense stance-foot slip, all
    steps incl. failed), planning-time mean / median / mean for t < 50 s / mean for 1 s < t < 50 s;
    then the worst dense values and the worst shortfall per judged constraint (> 0: failed)."""
    times = np.array([r["seconds"] for r in records], float)
    dense = [r["dense"] for r in records if "dense" in r]

    def mean(mask):
        return float(times[mask].mean()) if np.any(mask) else float("nan")

    def worst(key, fn):
        values = [d[key] for d in dense]
        return float(fn(values)) if values else float("nan")

    return {
        "steps_planned": len(records),
        "steps_succeeded": int(sum(r["success"] for r in records)),
        "worst_violation": (worst("foot_slip", max), "m"),
        "mean_time": (mean(np.ones_like(times, bool)), "s"),
        "median_time": (float(np.median(times)) if len(times) else float("nan"), "s"),
        "mean_time_below_50s": (mean(times < 50), "s"),
        "mean_time_1s_to_50s": (mean((times > 1) & (times < 50)), "s"),
        "worst_com_margin": (worst("com_margin", min), "m"),
        "worst_joint_excess": (worst("joint_excess", max), "rad"),
        **{f"worst_{key}": (worst(key, max), unit)
           for key, unit in DENSE_UNITS.items() if key.startswith("shortfall_")},
    }


def write_motion(path, records: Sequence[dict], robot: str, params: StepPlanParams, *, inputs=(),
                 overwrite: bool = False, attrs: dict | None = None) -> dict:
    """Write motion.h5 (layout in the module docstring; `attrs`: extra root attributes, e.g. the
    planner of a baseline); returns the summary rows. `params` is anything with `as_dict()`."""
    required = requirements(params)
    summary = table2(records)
    summary.update({f"tolerance_{key}": (value, DENSE_UNITS[f"shortfall_{key}"])
                    for key, value in required.tolerances().items()})
    with write_artefact(path, "motion", params=params.as_dict(), inputs=inputs, overwrite=overwrite) as f:
        f.attrs["robot"] = robot
        f.attrs["requirements"] = json.dumps(required.as_dict())
        f.attrs["parametrization"] = PARAMETRIZATION
        for key, value in (attrs or {}).items():
            f.attrs[key] = value
        steps = f.create_group("steps")
        for r in records:
            g = steps.create_group(f"{r['index']:04d}")
            g.attrs["index"] = r["index"]
            g.attrs["success"] = bool(r["success"])
            g.attrs["reason"] = r["reason"]
            g.attrs["seconds"] = float(r["seconds"])
            write_dataset(g, "q_start", r["q_start"], units="m|quaternion|rad")
            write_dataset(g, "q_end", r["q_end"], units="m|quaternion|rad")
            write_dataset(g, "stance", r["stance"].astype(np.uint8), units="bool")
            write_dataset(g, "footholds", r["footholds"], units="m")
            for key, value in r.get("attrs", {}).items():
                g.attrs[key] = value
            if "control_points" in r:
                g.attrs["degree"] = int(r["degree"])
                g.attrs["norm"] = float(r["norm"])
                write_dataset(g, "control_points", r["control_points"], units="m|rad", description=PARAMETRIZATION)
                write_dataset(g, "lm_iterations", r["lm_iterations"], description="SolveLM iterations at d = 1, 2, ...")
                write_dataset(g, "degree_norms", r["degree_norms"], description="‖F̃‖ after each degree (eq. (12))")
            if "waypoints" in r:
                write_dataset(g, "waypoints", r["waypoints"], units="m|rad", description=POLYLINE)
            if "timings" in r:
                timing = g.create_group("timings")
                for key, value in r["timings"].items():
                    write_dataset(timing, key, float(value), units="s")
            if "dense" in r:
                dense = g.create_group("dense")
                for key, value in r["dense"].items():
                    write_dataset(dense, key, float(value), units=DENSE_UNITS[key])
        write_summary(f, summary)
    return summary


@by_file
def read_motion(path) -> list[dict]:
    """The per-step records of motion.h5 (control points, success, times, dense checks); read once
    per file version (`legplan.artefacts.memo.by_file`)."""
    out = []
    with open_artefact(path, kind="motion") as f:
        steps = require(f, "steps")
        if not len(steps):
            raise ArtefactError(f"{path}: group '/steps' holds no steps")
        for name, g in steps.items():
            r = require_attrs(g, ("index", "success", "reason", "seconds"))
            planned = r["success"] and "waypoints" not in g  # a baseline's step is its waypoints
            for key in ("q_start", "q_end", "footholds", "stance", *(("control_points",) if planned else ())):
                require(g, key)  # what every step has, and a planned step's curve
            for key in ("q_start", "q_end", "footholds", "stance", "control_points", "waypoints"):
                if key in g:
                    r[key] = g[key][()]
            if "dense" in g:
                r["dense"] = {k: float(v[()]) for k, v in g["dense"].items()}
            out.append(r)
    return out
