"""Top view of a step sequence over its map: heightmap, foothold mask, footholds per leg, support
polygons and the CoM track (matplotlib `Figure`, no pyplot state, written to a PNG)."""

from __future__ import annotations

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from legplan.artefacts.publish import save_figure
from legplan.geometry.polygon import support_polygon


def plot_steps(seq, com: np.ndarray, terrain, path, *, title: str | None = None, overwrite: bool = False) -> None:
    """Write the top view of `seq` (StepSequence) with CoM positions `com` (k, 3) to `path`."""
    height = np.asarray(terrain.height)
    extent = terrain.grid.extent
    fig = Figure(figsize=(10, 10 * (extent[3] - extent[2]) / max(extent[1] - extent[0], 1e-9) + 1))
    ax = fig.subplots()
    image = ax.imshow(height, origin="lower", extent=extent, cmap="gray", interpolation="nearest")
    fig.colorbar(image, ax=ax, label="terrain height [m]", shrink=0.7)
    mask = np.ma.masked_where(~np.asarray(terrain.foothold, bool), np.ones_like(height))
    ax.imshow(mask, origin="lower", extent=extent, cmap="Greens", alpha=0.25, vmin=0, vmax=1.5,
              interpolation="nearest")
    for k in range(len(seq)):
        pts = seq.footholds[k, seq.stance[k], :2]
        if len(pts) >= 3 and (k == 0 or not np.array_equal(seq.stance[k], seq.stance[k - 1])):
            try:
                poly = support_polygon(pts)
            except ValueError:
                continue
            ax.add_patch(Polygon(poly.vertices, closed=True, fill=False, lw=0.6, alpha=0.35,
                                 color="tab:blue"))
    colors = matplotlib.colormaps["tab10"]
    for j, leg in enumerate(seq.leg_names):
        pts = seq.footholds[seq.stance[:, j], j]
        pts = np.unique(np.round(pts, 6), axis=0)
        ax.scatter(pts[:, 0], pts[:, 1], s=28, color=colors(j % 10), edgecolor="k", lw=0.4, label=leg,
                   zorder=3)
    ax.plot(com[:, 0], com[:, 1], "-", color="tab:red", lw=1.5, label="CoM", zorder=4)
    ax.plot(com[0, 0], com[0, 1], "o", color="tab:red", zorder=5)
    ax.plot(com[-1, 0], com[-1, 1], "s", color="tab:red", zorder=5)
    pts = np.concatenate([seq.footholds[seq.stance][:, :2], com[:, :2]])
    low, high = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3  # zoom on the sequence
    ax.set_xlim(max(extent[0], low[0]), min(extent[1], high[0]))
    ax.set_ylim(max(extent[2], low[1]), min(extent[3], high[1]))
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"{seq.robot}: {len(seq)} configurations")
    ax.legend(loc="upper right", fontsize=8, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, overwrite=overwrite, dpi=110)
