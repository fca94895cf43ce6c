"""Figure of nav.h5 results: the costmap with lethal cells, each query's path and velocity arrows
(a refined query: its TEB band with heading arrows, over the searched path dotted)."""

from __future__ import annotations

import os

import numpy as np

from legplan.artefacts.publish import save_figure
from legplan.nav.collision import NavGrid


def render_nav(grid: NavGrid, queries: list[dict], path: str | os.PathLike, dpi: int = 120,
               arrows: int = 25, *, overwrite: bool = False) -> None:
    """Draw `queries` (from `legplan.nav.artefact.read_queries`) over `grid`'s costmap (PNG)."""
    import matplotlib
    from matplotlib.figure import Figure

    ny, nx = grid.shape
    width = 7.0
    figure = Figure(figsize=(width, width * ny / nx + 0.6))
    axes = figure.subplots()
    cost = np.ma.masked_where(grid.costmap <= 0, grid.costmap)
    axes.imshow(cost, origin="lower", extent=grid.extent, cmap="Oranges", alpha=0.8,
                interpolation="nearest")
    axes.imshow(np.ma.masked_where(~grid.lethal, grid.lethal), origin="lower", extent=grid.extent,
                cmap="Greys", vmin=0, vmax=1, interpolation="nearest")
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for number, query in enumerate(queries):
        colour = colours[number % len(colours)]
        start, goal = np.asarray(query["start"]), np.asarray(query["goal"])
        axes.plot(*start[:2], "o", color=colour, markersize=5)
        axes.plot(*goal[:2], "*", color=colour, markersize=9)
        trajectory = query["trajectory"]
        if trajectory is None:
            axes.plot(*np.stack([start[:2], goal[:2]]).T, ":", color=colour, linewidth=1,
                      label=f"{query['name']} failed: {query['reason']}")
            continue
        _, p, v, _ = trajectory.sample(0.05)
        searched = f"{query['name']} {query['planner']}: T={query['duration']:.1f} s, " \
                   f"J={query['effort']:.2f}"
        band = query.get("band")
        if band is not None:  # a refined artefact: the TEB band is the result, the search its seed
            axes.plot(p[:, 0], p[:, 1], ":", color=colour, linewidth=1.0, label=searched)
            poses = band["poses"]
            axes.plot(poses[:, 0], poses[:, 1], "-", color=colour, linewidth=1.5,
                      label=f"{query['name']} TEB band: T={band['total_time']:.1f} s, "
                            f"J={band['effort']:.2f}")
            pick = np.linspace(0, len(poses) - 1, min(arrows, len(poses))).astype(int)
            axes.quiver(poses[pick, 0], poses[pick, 1], np.cos(poses[pick, 2]),
                        np.sin(poses[pick, 2]), color=colour, angles="xy", scale_units="xy",
                        scale=2.0, width=0.003)
            continue
        axes.plot(p[:, 0], p[:, 1], "-", color=colour, linewidth=1.5, label=searched)
        pick = np.linspace(0, len(p) - 1, min(arrows, len(p))).astype(int)
        axes.quiver(p[pick, 0], p[pick, 1], v[pick, 0], v[pick, 1], color=colour, angles="xy",
                    scale_units="xy", scale=0.5, width=0.003)
    axes.set_xlim(grid.extent[0], grid.extent[1])
    axes.set_ylim(grid.extent[2], grid.extent[3])
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    refined = any(query.get("band") is not None for query in queries)
    axes.set_title("nav paths (arrows: velocity, 1 m/s = 2 m"
                   + ("; TEB bands: heading, 0.5 m)" if refined else ")"))
    if queries:
        axes.legend(loc="upper left", fontsize=7, framealpha=0.8)
    figure.tight_layout()
    save_figure(figure, path, overwrite=overwrite, dpi=dpi)
