"""The nav.h5 layout (kind "nav") written by `legplan nav search`, and its reader.

Root attributes: the standard provenance (ARCHITECTURE.md) with `params` = the `NavParams` used
plus "planner" and "robot".
`/queries/NNNN` (one group per query, in input order), attributes:
    success (bool), reason (str, "" on success), planner ("kinoastar" | "astar"),
    start, goal (px, py, vx, vy; m, m/s), expansions, planning_time (s),
    time_per_expansion (s), cost (search objective g), effort J = ∫||a||² dt (m²/s³),
    duration T (s), path_length (m), min_clearance (m, distance field at dense samples),
    max_speed_axis (m/s), max_accel_axis (m/s²) — NaN for the numbers of a failed query.
  datasets (successful queries only):
    segments (N, 9): `SEGMENT_COLUMNS` px py vx vy ax ay jx jy duration, attr `columns`, `units`
        (comma-separated per column) — `Trajectory(segments)` rebuilds the trajectory exactly;
    t (K,) s, p (K, 2) m, v (K, 2) m/s, a (K, 2) m/s² — dense samples, step ≤ `DENSE_STEP`;
    waypoints (W, 2) m — grid A* only: its position-only path.
`/summary`: queries, succeeded, success_rate, median/max planning_time, median expansions,
    median time_per_expansion, median effort, duration, path_length, min of min_clearance.
Later stages (TEB refinement) add their own groups beside `/queries` and read these.
"""

from __future__ import annotations

import h5py
import numpy as np

from legplan.artefacts import read_array, require, require_attrs, write_artefact, write_dataset, write_summary
from legplan.errors import ArtefactError
from legplan.nav.collision import NavGrid
from legplan.nav.result import SearchResult
from legplan.nav.trajectory import SEGMENT_COLUMNS, SEGMENT_UNITS, Trajectory

DENSE_STEP = 0.02  # s
NAN = float("nan")


def trajectory_metrics(trajectory: Trajectory | None, grid: NavGrid) -> dict[str, float]:
    """Effort, duration, path length, clearance and per-axis extrema judged on dense samples."""
    if trajectory is None:
        return {name: NAN for name in ("effort", "duration", "path_length", "min_clearance",
                                       "max_speed_axis", "max_accel_axis")}
    _, p, v, a = trajectory.sample(DENSE_STEP)
    return {"effort": trajectory.effort(), "duration": trajectory.duration,
            "path_length": trajectory.path_length(),
            "min_clearance": float(grid.clearance_at(p).min()),
            "max_speed_axis": float(np.abs(v).max()), "max_accel_axis": float(np.abs(a).max())}


QUERY_ATTRS = ("success", "reason", "planner", "start", "goal", "effort", "duration")
"""Attributes every query group has (`query_record`) and `read_queries` checks for."""
DATASET_UNITS = {"t": "s", "p": "m", "v": "m/s", "a": "m/s^2", "waypoints": "m"}  # and "segments"
KEPT_OUT_OF_ROWS = ("planner", "start", "goal", "segments", *DATASET_UNITS)


def query_record(result: SearchResult, grid: NavGrid | None) -> dict:
    """One query's attributes and arrays (the layout above), in the order they are written: the
    record a batch item returns and `write_query` stores (`grid` may be None for a failed query)."""
    record = {"success": bool(result.success), "reason": result.reason, "planner": result.planner,
              "start": np.asarray(result.start), "goal": np.asarray(result.goal),
              "expansions": result.expansions, "planning_time": result.planning_time,
              "time_per_expansion": result.time_per_expansion, "cost": result.cost,
              **trajectory_metrics(result.trajectory, grid)}
    if result.trajectory is not None:
        record["segments"] = result.trajectory.segments
        record["t"], record["p"], record["v"], record["a"] = result.trajectory.sample(DENSE_STEP)
    if result.waypoints is not None:
        record["waypoints"] = result.waypoints
    return record


def write_query(parent: h5py.Group, index: int, record: dict) -> dict:
    """Write one query group from its `query_record` (plus any extra scalar attributes); returns its
    scalar metrics (a summary row)."""
    group = parent.create_group(f"{index:04d}")
    for key, value in record.items():
        if key == "segments":
            write_dataset(group, key, value, units=",".join(SEGMENT_UNITS), columns=",".join(SEGMENT_COLUMNS))
        elif key in DATASET_UNITS:
            write_dataset(group, key, value, units=DATASET_UNITS[key])
        else:
            group.attrs[key] = value
    return {key: value for key, value in record.items() if key not in KEPT_OUT_OF_ROWS}


def write_nav(path, records: list[dict], params: dict, *, inputs=(), overwrite: bool = False, seed=None,
              attrs: dict | None = None) -> list[dict]:
    """nav.h5 of one query record per query (`/queries/NNNN` in record order, `/summary`), with
    extra root `attrs`; returns the summary rows."""
    with write_artefact(path, "nav", params=params, seed=seed, inputs=inputs, overwrite=overwrite) as handle:
        for key, value in (attrs or {}).items():
            handle.attrs[key] = value
        group = handle.create_group("queries")
        rows = [write_query(group, index, record) for index, record in enumerate(records)]
        write_summary_table(handle, rows)
    return rows


def write_summary_table(handle: h5py.File, rows: list[dict]) -> None:
    ok = [row for row in rows if row["success"]]

    def median(name, source=rows):
        values = [row[name] for row in source if np.isfinite(row[name])]
        return float(np.median(values)) if values else NAN

    write_summary(handle, {
        "queries": len(rows), "succeeded": len(ok),
        "success_rate": len(ok) / len(rows) if rows else NAN,
        "median_planning_time": (median("planning_time"), "s"),
        "max_planning_time": (max((r["planning_time"] for r in rows), default=NAN), "s"),
        "median_expansions": median("expansions"),
        "median_time_per_expansion": (median("time_per_expansion"), "s"),
        "median_effort": (median("effort", ok), "m^2/s^3"),
        "median_duration": (median("duration", ok), "s"),
        "median_path_length": (median("path_length", ok), "m"),
        "min_clearance": (min((r["min_clearance"] for r in ok), default=NAN), "m"),
    })


def read_queries(handle: h5py.File) -> list[dict]:
    """Every query of an open nav artefact: attrs as a dict plus `trajectory` (or None),
    `waypoints` (or None) and, in a `nav refine` artefact, `band`: the refined TEB band's poses
    (n, 3) [x, y, θ], times (n,) and its `total_time`, `effort` (or None when not refined)."""
    queries = []
    group = require(handle, "queries")
    for name in sorted(group):
        item = group[name]
        entry = {key: (value.item() if isinstance(value, np.generic) else value)
                 for key, value in require_attrs(item, QUERY_ATTRS).items()}
        entry["name"] = name
        entry["trajectory"] = _read_trajectory(item) if "segments" in item else None
        if entry["trajectory"] is not None:  # a trajectory is stored with its dense samples: all of them
            for key in ("t", "p", "v", "a"):
                require(item, key)
        entry["waypoints"] = read_array(item, "waypoints", ndim=2) if "waypoints" in item else None
        entry["band"] = {"poses": read_array(item, "teb/poses", ndim=2), "t": read_array(item, "teb/t", ndim=1),
                         "total_time": float(item["teb"].attrs["total_time"]),
                         "effort": float(item["teb"].attrs["effort"])} if "teb" in item else None
        queries.append(entry)
    return queries


def _read_trajectory(item: h5py.Group) -> Trajectory:
    """The `segments` of a query group as a `Trajectory`, checked: (N, 9), finite, durations >= 0."""
    segments = read_array(item, "segments", ndim=2)
    where = f"{item.file.filename}: dataset '{item.name}/segments'"
    if segments.shape[1] != len(SEGMENT_COLUMNS):
        raise ArtefactError(f"{where} must have {len(SEGMENT_COLUMNS)} columns, got shape {segments.shape}")
    if np.any(segments[:, 8] < 0):
        raise ArtefactError(f"{where} has a negative segment duration")
    return Trajectory(segments)
