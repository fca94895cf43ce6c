"""Per-kind figure functions for `legplan report`, reusing each stage's own plotting code where it
exists (stepplan.figures, stepseq.plot) and the generic plots otherwise."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from legplan.artefacts import open_artefact, require
from legplan.report.inputs import recorded_input
from legplan.report.items import read_items
from legplan.report.plots import datasets_figure, grid_extent, grid_figure, items_figure, new_figure
from legplan.report.registry import figure

MAP_LAYERS = [("terrain/height", "height", "terrain"), ("terrain/foothold", "foothold mask", "Greens"),
              ("nav/costmap", "costmap (eqs. (15)-(16))", "magma")]


@figure("*", "datasets")
def fallback(path: Path, png: Path) -> str:
    return datasets_figure(path, png)


@figure("map", "layers")
def map_layers(path: Path, png: Path) -> str | None:
    return grid_figure(path, png, MAP_LAYERS)


@figure("motion", "steps")
def motion_steps(path: Path, png: Path) -> str | None:
    """Foot slip per step; the time histogram only when `motion_tracks` cannot draw its Fig. 4."""
    return items_figure(path, png, "seconds", "dense/foot_slip", "m", "step", histogram=not _tracks_drawable(path))


def _tracks_drawable(path: Path) -> bool:
    """The motion records its robot and a map input, so `motion_tracks` draws the Fig. 4 histograms."""
    from legplan.artefacts import read_provenance

    with open_artefact(path, kind="motion") as handle:
        robot = str(handle.attrs.get("robot", ""))
        maps = [r for r in read_provenance(handle)["inputs"] if r["kind"] == "map"]
    return bool(robot and maps)


@figure("motion", "tracks")
def motion_tracks(path: Path, png: Path) -> str | None:
    """Foot/CoM side view and Fig. 4 histograms by `legplan step show`'s plotting code."""
    from legplan.robots import load_robot
    from legplan.stepplan.batch import read_motion
    from legplan.stepplan.figures import plot_motion
    from legplan.terrain import load_map

    terrain = recorded_input(path, "map")
    with open_artefact(path, kind="motion") as handle:
        robot = str(handle.attrs.get("robot", ""))
    if terrain is None or not robot:
        return None
    plot_motion(png, load_robot(robot), load_map(terrain), read_motion(path))
    return f"Foot and CoM tracks of robot '{robot}' over {terrain.name}, with Fig. 4 time histograms."


@figure("steps", "top")
def steps_top(path: Path, png: Path) -> str | None:
    """Footholds, support polygons and CoM track, by `legplan steps show`'s plotting code."""
    from legplan.robots import load_robot
    from legplan.stepseq import read_steps
    from legplan.stepseq.plot import plot_steps
    from legplan.terrain import load_map

    terrain = recorded_input(path, "map")
    if terrain is None:
        return None
    seq = read_steps(path)
    plot_steps(seq, load_robot(seq.robot).com(seq.q), load_map(terrain), png)
    return f"Footholds (top view) of {len(seq)} configurations over {terrain.name}."


@figure("nav", "queries")
def nav_queries(path: Path, png: Path) -> str | None:
    """Per query: the search's planning time and clearance or, for a refined artefact (`nav refine`:
    queries with `teb/`), the refinement's own (its `seconds` and `min_clearance`), the numbers its
    summary reports."""
    with open_artefact(path, kind="nav") as handle:
        queries = handle["queries"] if "queries" in handle else {}
        refined = {name: dict(queries[name]["teb"].attrs) for name in queries if "teb" in queries[name]}
        items = read_items(handle)
    if not refined:
        return items_figure(path, png, "planning_time", "min_clearance", "m", "query")
    teb = {}
    for name, item in items.items():
        attrs = refined.get(name.split("/")[-1])
        if attrs is not None:
            teb[name] = {"success": item["success"], "seconds": float(attrs["seconds"]),
                         "min_clearance": float(attrs["min_clearance"])}
    return items_figure(path, png, "seconds", "min_clearance", "m", "query", items=teb, what="TEB refinement")


@figure("nav", "paths")
def nav_paths(path: Path, png: Path) -> str | None:
    """Every query's path and velocity arrows over the costmap, by `legplan nav show`'s plotting code."""
    from legplan.nav import NavGrid
    from legplan.nav.artefact import read_queries
    from legplan.nav.plot import render_nav

    terrain = recorded_input(path, "map")
    with open_artefact(path, kind="nav") as handle:
        queries = read_queries(handle) if "queries" in handle else []
    if terrain is None or not queries:
        return None
    render_nav(NavGrid.from_map(terrain), queries, png)
    return f"{len(queries)} queries over the costmap of {terrain.name}."


@figure("nav", "profiles")
def nav_profiles(path: Path, png: Path) -> str | None:
    """Speed profiles |v|(t) of every planned query and of a simulated run; the simulated path
    over the map's costmap when the artefact holds a `/simulation`."""
    with open_artefact(path, kind="nav") as handle:
        tracks = [(name, g["t"][()], g["v"][()]) for name, g in handle["queries"].items() if "v" in g] \
            if "queries" in handle else []
        tracks += [(f"{name} TEB", g["teb/t"][:-1], g["teb/velocity"][:, :2])  # a refined artefact
                   for name, g in handle["queries"].items() if "teb" in g] if "queries" in handle else []
        simulated = None
        if "simulation" in handle and "state" in handle["simulation"]:
            state = handle["simulation/state"][()]
            simulated = state[:, :2]
            tracks.append(("simulation", handle["simulation/t"][()], state[:, 3:5]))
    if not tracks:
        return None
    fig = new_figure(11.0 if simulated is not None else 6.0, 4.5)
    axes = fig.subplots(1, 2 if simulated is not None else 1, squeeze=False)[0]
    for name, t, v in tracks:
        axes[0].plot(t, np.linalg.norm(v, axis=1), lw=1.0, label=name)
    axes[0].set_xlabel("t [s]")
    axes[0].set_ylabel("|v| [m/s]")
    axes[0].set_title("Velocity profiles")
    if len(tracks) <= 10:
        axes[0].legend(fontsize=7)
    if simulated is not None:
        terrain = recorded_input(path, "map")
        if terrain is not None:
            with open_artefact(terrain, kind="map") as handle:
                costmap = require(handle, "nav/costmap")
                axes[1].imshow(costmap[()], origin="lower", extent=grid_extent(costmap), cmap="magma",
                               interpolation="nearest")
        axes[1].plot(simulated[:, 0], simulated[:, 1], "c-", lw=1.2)
        axes[1].set_aspect("equal")
        axes[1].set_xlabel("x [m]")
        axes[1].set_ylabel("y [m]")
        axes[1].set_title("Simulated path")
    fig.savefig(png, dpi=100)
    return f"Speed profiles of {len(tracks)} trajectories" + (" and the simulated path." if simulated is not None else ".")


@figure("traj", "tasks")
def traj_tasks(path: Path, png: Path) -> str | None:
    return items_figure(path, png, "solve_seconds", "max_violation", "constraint units", "task")


@figure("traj", "trajectory")
def traj_trajectory(path: Path, png: Path) -> str | None:
    """The first task with a solution: base, feet and forces over time, by `legplan dyn show`'s code."""
    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.figures import plot_trajectory, shown_task

    _, tasks = read_tasks(path)
    drawn = next((index for index, task in enumerate(tasks) if "samples" in task), None)
    if drawn is None:
        return None
    plot_trajectory(png, *shown_task(path, drawn))
    return (f"Task {drawn} of {len(tasks)}: base, foot heights and forces over time with the optimization "
            "nodes (the TOWR-costs paper's Fig. 3).")


@figure("dataset", "outcomes")
def dataset_outcomes(path: Path, png: Path) -> str:
    from legplan.learn.figures import dataset_figure

    return dataset_figure(path, png)


@figure("init", "fit")
def init_fit(path: Path, png: Path) -> str:
    from legplan.learn.figures import init_figure

    return init_figure(path, png)


@figure("sim", "execution")
def sim_execution(path: Path, png: Path) -> str | None:
    from legplan.report.execution import execution_figure

    return execution_figure(path, png)
