"""What the TEB stages add to a "nav" artefact.

`legplan nav refine` copies every `/queries/NNNN` group of the search artefact unchanged
(`legplan.nav.artefact` layout) and adds, to each successful query, a subgroup `teb/`:
    poses (n, 3) [x m, y m, θ rad]; dt (n − 1,) s; t (n,) s;
    velocity (n − 1, 3) body-frame [v_x m/s, v_y m/s, ω rad/s] (eq. (23));
    acceleration (n − 2, 3) body-frame [a_x, a_y m/s², α rad/s²] (eq. (23));
    round_poses, round_iterations (int), round_seconds (s) — one entry per outer round;
  attrs: total_time (s), effort (m²/s³, Σ (a_x² + a_y²)·Δt), min_clearance (m), iterations,
    seconds (wall), max_violation and violation_<limit> (excess over each Table I limit; 0 = met).
A failed query keeps its search group and gets no `teb/`.

`legplan nav simulate` writes `/simulation`:
    t (k,) s; state (k, 6) [x, y, θ, v_x, v_y, ω] (body-frame velocities); command (c, 3);
    cycle_t (c,) s; compute_seconds (c,) s (TEB wall time per cycle); band_poses (c,);
    band_iterations (c,) (LM iterations per cycle);
    goal_times (g,) s (arrival at each goal, before its dwell);
  attrs: success, reason, running_time (s), effort (m²/s³), collisions, replans, replan_seconds,
    cold_starts (cycles whose band was initialized from the global path), median/max_cycle_seconds.
"""

from __future__ import annotations

import h5py
import numpy as np

from legplan.artefacts import write_dataset
from legplan.errors import ArtefactError
from legplan.nav.teb.refine import Refinement


def refinable_queries(nav_path) -> list[dict]:
    """The queries of a `nav search` / `baseline nav` artefact to refine (`read_queries`, arrays
    checked), or an `ArtefactError` naming the file: already refined (a query has `teb/`), or a
    successful query without its `segments`."""
    from legplan.artefacts import open_artefact
    from legplan.nav.artefact import read_queries

    with open_artefact(nav_path, kind="nav") as handle:
        queries = read_queries(handle)
    for query in queries:
        where = f"{nav_path}: query '{query['name']}'"
        if query["band"] is not None:
            raise ArtefactError(f"{where} is already refined (has 'teb/'); refine the nav search output")
        if query.get("success") and query["trajectory"] is None:
            raise ArtefactError(f"{where} succeeded but has no dataset 'segments'")
    return queries


def write_refinement(group: h5py.Group, refinement: Refinement) -> dict[str, float]:
    """Write `teb/` into a query group; returns its scalar metrics."""
    band, result = refinement.band, refinement.result
    teb = group.create_group("teb")
    write_dataset(teb, "poses", band.poses, units="m,m,rad")
    write_dataset(teb, "dt", band.dt, units="s")
    write_dataset(teb, "t", band.times, units="s")
    write_dataset(teb, "velocity", band.velocities(), units="m/s,m/s,rad/s")
    write_dataset(teb, "acceleration", band.accelerations(), units="m/s^2,m/s^2,rad/s^2")
    write_dataset(teb, "round_poses", np.array([r.poses for r in result.rounds]))
    write_dataset(teb, "round_iterations", np.array([r.iterations for r in result.rounds]))
    write_dataset(teb, "round_seconds", np.array([r.seconds for r in result.rounds]), units="s")
    metrics = {"total_time": band.duration, "effort": band.effort(), "min_clearance": refinement.min_clearance,
               "iterations": result.iterations, "seconds": result.seconds,
               "max_violation": max(refinement.violations.values())}
    for name, value in metrics.items():
        teb.attrs[name] = value
    for name, value in refinement.violations.items():
        teb.attrs[f"violation_{name}"] = value
    return metrics


def write_simulation(handle: h5py.File, result) -> dict[str, float]:
    """Write `/simulation` for a `NavRunResult`; returns its scalar metrics."""
    group = handle.create_group("simulation")
    write_dataset(group, "t", result.times, units="s")
    write_dataset(group, "state", result.states, units="m,m,rad,m/s,m/s,rad/s")
    write_dataset(group, "command", result.commands, units="m/s,m/s,rad/s")
    write_dataset(group, "cycle_t", result.cycle_times, units="s")
    write_dataset(group, "compute_seconds", result.compute_seconds, units="s")
    write_dataset(group, "band_poses", result.band_poses)
    write_dataset(group, "band_iterations", result.band_iterations)
    write_dataset(group, "goal_times", np.array(result.goal_times), units="s")
    metrics = {"running_time": result.running_time, "effort": result.effort(), "collisions": result.collisions,
               "replans": result.replans, "replan_seconds": result.replan_seconds, "cold_starts": result.cold_starts,
               "median_cycle_seconds": float(np.median(result.compute_seconds)) if len(result.compute_seconds) else np.nan,
               "max_cycle_seconds": float(np.max(result.compute_seconds)) if len(result.compute_seconds) else np.nan}
    group.attrs["success"] = bool(result.success)
    group.attrs["reason"] = result.reason
    for name, value in metrics.items():
        group.attrs[name] = value
    return metrics
