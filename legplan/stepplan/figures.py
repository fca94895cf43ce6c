"""Figures of a planned motion: foot and CoM tracks over the terrain (side view) and the per-step
planning-time histograms of the paper's Fig. 4 (all steps; detail below 10 s; failures in red)."""

from __future__ import annotations

import numpy as np

from legplan.artefacts.publish import save_figure
from legplan.geometry.bezier import evaluate


def sampled_tracks(robot, records, samples: int = 60):
    """Foot positions (n, L, 3) and CoM (n, 3) along all planned steps, in order."""
    feet, com = [], []
    t = np.linspace(0.0, 1.0, samples)
    for r in records:
        if "control_points" not in r:
            continue
        Q = robot.from_vector(evaluate(r["control_points"], t))
        feet.append(robot.foot_positions(Q))
        com.append(robot.com(Q))
    if not feet:
        return np.zeros((0, len(robot.legs), 3)), np.zeros((0, 3))
    return np.concatenate(feet), np.concatenate(com)


def plot_motion(path, robot, terrain, records, *, overwrite: bool = False) -> None:
    """Write a PNG: side view (x–z) of the terrain profile under the tracks, and Fig. 4 histograms."""
    from matplotlib.figure import Figure

    feet, com = sampled_tracks(robot, records)
    fig = Figure(figsize=(11, 7.5))
    grid = fig.add_gridspec(2, 2, height_ratios=(1.3, 1.0))
    side = fig.add_subplot(grid[0, :])
    height = np.asarray(terrain.height)
    x0, y0 = np.asarray(terrain.grid.origin, float)[:2]
    res = float(terrain.grid.resolution)
    xs = x0 + res * np.arange(height.shape[1])
    if len(feet):
        ys = y0 + res * np.arange(height.shape[0])
        ylo, yhi = feet[..., 1].min() - 0.05, feet[..., 1].max() + 0.05
        band = (ys >= ylo) & (ys <= yhi)
        band = band if band.any() else np.ones(len(ys), bool)
    else:
        band = np.ones(height.shape[0], bool)
    top, low = height[band].max(axis=0), height[band].min(axis=0)
    floor = max(float(low.min()), -0.15) - 0.02
    side.fill_between(xs, floor, np.maximum(low, floor), color="0.6", step="mid",
                      label="terrain, lowest in the robot's y band")
    side.fill_between(xs, np.maximum(low, floor), top, color="0.85", step="mid",
                      label="highest in the band (beams, pillars)")
    for leg in range(feet.shape[1]):
        side.plot(feet[:, leg, 0], feet[:, leg, 2], lw=1.0, label=robot.legs[leg].name)
    if len(com):
        side.plot(com[:, 0], com[:, 2], "k--", lw=1.5, label="CoM")
        side.set_xlim(min(feet[..., 0].min(), com[:, 0].min()) - 0.2, max(feet[..., 0].max(), com[:, 0].max()) + 0.2)
    side.set_xlabel("x [m]")
    side.set_ylabel("z [m]")
    side.set_title("Foot and CoM tracks, side view")
    side.legend(fontsize=7, ncol=4, loc="upper left")
    times = np.array([r["seconds"] for r in records], float)
    ok = np.array([bool(r["success"]) for r in records])
    for ax, limit, title in ((fig.add_subplot(grid[1, 0]), None, "(a) all steps"),
                             (fig.add_subplot(grid[1, 1]), 10.0, "(b) steps under 10 s")):
        if limit is not None and not (times >= limit).any():  # (b) would repeat (a)
            ax.text(0.5, 0.5, f"every step under {limit:g} s:\n(b) is (a)", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_title(f"Fig. 4{title}")
            ax.set_axis_off()
            continue
        sel = times if limit is None else times[times < limit]
        top = max(float(sel.max()) if len(sel) else 1.0, 1e-3)
        bins = np.linspace(0.0, top * 1.0001, 21)
        mask = np.ones_like(times, bool) if limit is None else times < limit
        ax.hist([times[mask & ok], times[mask & ~ok]], bins=bins, stacked=True,
                color=["tab:blue", "tab:red"], label=["succeeded", "failed"])
        ax.set_xlabel("planning time [s]")
        ax.set_ylabel("steps")
        ax.set_title(f"Fig. 4{title}")
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, overwrite=overwrite, dpi=120)
