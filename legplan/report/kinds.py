"""Per-kind figure functions for `legplan report`, reusing each stage's own plotting code where it
exists (stepplan.figures, stepseq.plot) and the generic plots otherwise."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from legplan.artefacts import open_artefact, require
from legplan.report.plots import grid_extent, grid_figure, datasets_figure, items_figure, map_input, new_figure
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
    return items_figure(path, png, "seconds", "dense/foot_slip", "m", "step")


@figure("motion", "tracks")
def motion_tracks(path: Path, png: Path) -> str | None:
    """Foot/CoM side view and Fig. 4 histograms by `legplan step show`'s plotting code."""
    from legplan.robots import load_robot
    from legplan.stepplan.batch import read_motion
    from legplan.stepplan.figures import plot_motion
    from legplan.terrain import load_map

    terrain = map_input(path)
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

    terrain = map_input(path)
    if terrain is None:
        return None
    seq = read_steps(path)
    plot_steps(seq, load_robot(seq.robot).com(seq.q), load_map(terrain), png)
    return f"Footholds (top view) of {len(seq)} configurations over {terrain.name}."


@figure("nav", "queries")
def nav_queries(path: Path, png: Path) -> str | None:
    return items_figure(path, png, "planning_time", "min_clearance", "m", "query")


@figure("nav", "paths")
def nav_paths(path: Path, png: Path) -> str | None:
    """Every successful query's path over the map's costmap, and its speed profile |v|(t)."""
    with open_artefact(path, kind="nav") as handle:
        tracks = [(name, group["t"][()], group["p"][()], group["v"][()])
                  for name, group in require(handle, "queries").items() if "p" in group]
    if not tracks:
        return None
    fig = new_figure(11.0, 4.5)
    top, speed = fig.subplots(1, 2)
    terrain = map_input(path)
    if terrain is not None:
        with open_artefact(terrain, kind="map") as handle:
            costmap = require(handle, "nav/costmap")
            top.imshow(costmap[()], origin="lower", extent=grid_extent(costmap), cmap="magma",
                       interpolation="nearest")
    for name, t, p, v in tracks:
        top.plot(p[:, 0], p[:, 1], lw=1.2, label=name)
        speed.plot(t, np.linalg.norm(v, axis=1), lw=1.0, label=name)
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title("Paths over the costmap" if terrain is not None else "Paths")
    top.set_aspect("equal")
    speed.set_xlabel("t [s]")
    speed.set_ylabel("|v| [m/s]")
    speed.set_title("Velocity profiles")
    if len(tracks) <= 10:
        speed.legend(fontsize=7)
    fig.savefig(png, dpi=100)
    return f"{len(tracks)} planned paths and their speed profiles."
