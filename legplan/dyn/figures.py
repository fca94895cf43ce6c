"""Figures of planned centroidal trajectories (matplotlib Agg, no pyplot state), from traj.h5.

* `plot_trajectory` — the paper's Fig. 3: base position, orientation and angular velocity, foot
  heights and foot forces over time, the optimization nodes as red dots on the 10 ms samples, each
  leg's contact phases shaded, and a gait diagram.
* `plot_comparison` — the paper's Fig. 4 (a)–(d): foot forces along x, y, z and the base's roll and
  pitch rates of two runs (e.g. with and without costs) on shared axes; with their executions in
  MuJoCo (`legplan dyn simulate`'s sim.h5), Fig. 4 (e)–(f) too: the norms of the base's position and
  orientation tracking errors, and (g)–(h) the executed roll and pitch rates, a fall marked where it
  ended the run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from legplan.artefacts.publish import save_figure
from legplan.dyn.artefact import read_tasks
from legplan.errors import LegplanError

AXES = "xyz"
NODE_STYLE = {"color": "red", "marker": "o", "ls": "none", "ms": 3.0, "zorder": 3}


def shown_task(path, index: int) -> tuple[str, list[str], dict]:
    """(label, leg names, task group) of task `index` of a traj artefact; a one-line error when the
    task is missing or has no solution to draw."""
    attrs, tasks = read_tasks(path)
    if not 0 <= index < len(tasks):
        raise LegplanError(f"{path}: --task {index}: the artefact has {len(tasks)} task(s)")
    task = tasks[index]
    if "samples" not in task:
        raise LegplanError(f"{path}: task {index} has no solution to draw ({task['reason']})")
    costs = json.loads(attrs["params"]).get("costs", "?")
    label = f"{Path(path).name} (costs: {costs}, task {index}{'' if task['success'] else ', failed'})"
    return label, str(attrs["legs"]).split(","), task


def _shade_contact(ax, t, contact) -> None:
    ax.fill_between(t, 0, 1, where=contact, transform=ax.get_xaxis_transform(), color="0.88", lw=0, step="post")


def _nodes(task, block: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(node values (n, 3), spans (n, 2), legs (n,) or -1) of a variable block."""
    group = task["nodes"][block]
    values = np.asarray(group["value"]).reshape(-1, 2, 3)[:, 0]
    legs = np.asarray(group["leg"]) if "leg" in group else np.full(len(values), -1)
    return values, np.asarray(group["span"]), legs


def plot_trajectory(output, label: str, legs: list[str], task: dict, *, overwrite: bool = False) -> None:
    """Fig. 3 of one task: base (left column), foot heights (middle), forces (right), one row per leg."""
    s = task["samples"]
    t, contact = s["t"], np.asarray(s["contact"], bool)
    n = len(legs)
    fig = Figure(figsize=(15, 2.3 * max(n, 4)), layout="constrained")
    grid = fig.add_gridspec(max(n, 4), 3)
    base_panels = [("base_pos", "base_lin", "base position [m]"), ("base_euler", "base_ang", "base orientation [rad]")]
    for row, (name, block, title) in enumerate(base_panels):
        ax = fig.add_subplot(grid[row, 0])
        values, span, _ = _nodes(task, block)
        for k, axis in enumerate(("x", "y", "z") if block == "base_lin" else ("roll", "pitch", "yaw")):
            ax.plot(t, s[name][:, k], lw=1.2, label=axis)
            ax.plot(span[:, 0], values[:, k], **NODE_STYLE)
        ax.set_ylabel(title)
        ax.legend(fontsize=7, loc="best")
    ax = fig.add_subplot(grid[2, 0])
    for k, axis in enumerate(("ω_x", "ω_y", "ω_z")):
        ax.plot(t, s["base_ang_vel"][:, k], lw=1.2, label=axis)
    ax.set_ylabel("base angular velocity [rad/s]")
    ax.legend(fontsize=7, loc="best")
    ax = fig.add_subplot(grid[3, 0])
    for leg in range(n):
        ax.fill_between(t, leg - 0.4, leg + 0.4, where=contact[:, leg], color=f"C{leg}", step="post", lw=0)
    ax.set_yticks(range(n), legs)
    ax.set_ylim(n - 0.5, -0.5)
    ax.set_ylabel("stance")
    ax.set_xlabel("t [s]")
    feet, feet_span, feet_leg = _nodes(task, "feet")
    forces, force_span, force_leg = _nodes(task, "forces")
    for leg in range(n):
        ax = fig.add_subplot(grid[leg, 1])
        _shade_contact(ax, t, contact[:, leg])
        ax.plot(t, s["feet_pos"][:, leg, 2], color=f"C{leg}", lw=1.2)
        mine = feet_leg == leg
        ax.plot(feet_span[mine].ravel(), np.repeat(feet[mine, 2], 2), **NODE_STYLE)
        ax.set_ylabel(f"{legs[leg]} foot z [m]")
        ax = fig.add_subplot(grid[leg, 2])
        _shade_contact(ax, t, contact[:, leg])
        for k in range(3):
            ax.plot(t, s["forces"][:, leg, k], lw=1.1, label=f"f_{AXES[k]}")
        instant = (force_leg == leg) & (force_span[:, 0] == force_span[:, 1])
        ax.plot(force_span[instant, 0], forces[instant, 2], **NODE_STYLE)
        ax.set_ylabel(f"{legs[leg]} force [N]")
        if leg == 0:
            ax.legend(fontsize=7, loc="upper right", ncol=3)
    for col in (1, 2):
        fig.axes[-1 if col == 2 else -2].set_xlabel("t [s]")
    fig.suptitle(f"{label}: nodes (red) and 10 ms samples; stance shaded")
    save_figure(fig, output, overwrite=overwrite, dpi=90)


def plot_comparison(output, run_a: tuple, run_b: tuple, *, executed: tuple | None = None,
                    overwrite: bool = False) -> None:
    """Fig. 4 (a)–(d): foot forces along x, y, z per leg and the base's roll and pitch rates, run A
    solid and run B dashed; with `executed` (the sim.h5 records of A and B,
    `legplan.sim.artefact.read_executed`) also (e)–(h) of the module docstring."""
    (label_a, legs, a), (label_b, _, b) = run_a, run_b
    rows = 2 if executed is None else 4
    fig = Figure(figsize=(13, 4 * rows), layout="constrained")
    axes = fig.subplots(rows, 2).ravel()
    for k, ax in enumerate(axes[:3]):
        for leg, name in enumerate(legs):
            ax.plot(a["samples"]["t"], a["samples"]["forces"][:, leg, k], color=f"C{leg}", lw=1.2)
            ax.plot(b["samples"]["t"], b["samples"]["forces"][:, leg, k], color=f"C{leg}", lw=1.0, ls="--")
        ax.set_title(f"({'abc'[k]}) foot forces along {AXES[k]}")
        ax.set_ylabel(f"f_{AXES[k]} [N]")
        ax.legend([Line2D([], [], color=f"C{leg}") for leg in range(len(legs))], legs, fontsize=7, ncol=len(legs))
    ax = axes[3]
    for k, name in enumerate(("roll rate ω_x", "pitch rate ω_y")):
        ax.plot(a["samples"]["t"], a["samples"]["base_ang_vel"][:, k], color=f"C{k}", lw=1.2, label=name)
        ax.plot(b["samples"]["t"], b["samples"]["base_ang_vel"][:, k], color=f"C{k}", lw=1.0, ls="--")
    ax.set_title("(d) base angular velocity, planned")
    ax.set_ylabel("ω [rad/s]")
    ax.legend(fontsize=7)
    if executed is not None:
        _executed_panels(axes[4:], executed)
    for ax in axes:
        ax.set_xlabel("t [s]")
    fig.legend([Line2D([], [], color="k"), Line2D([], [], color="k", ls="--")], [label_a, label_b],
               loc="outside lower center", ncol=2, fontsize=9)
    save_figure(fig, output, overwrite=overwrite, dpi=90)


EXECUTED_PANELS = (("(e) base position tracking error ‖p − p_plan‖", "position_error", None, "[m]"),
                   ("(f) base orientation tracking error ‖log(R_planᵀ R)‖", "orientation_error", None, "[rad]"),
                   ("(g) base roll rate ω_x, executed", "base_ang_vel", 0, "[rad/s]"),
                   ("(h) base pitch rate ω_y, executed", "base_ang_vel", 1, "[rad/s]"))
"""(title, sim.h5 series, component or None, unit) of Fig. 4 (e)–(h)."""


def _executed_panels(axes, executed: tuple) -> None:
    """Fig. 4 (e)–(h) of the two executions (run A solid, B dashed); a fall marked by a cross at its
    time."""
    for ax, (title, name, component, unit) in zip(axes, EXECUTED_PANELS):
        for run, (record, style) in enumerate(zip(executed, ("-", "--"))):
            series = record["series"]
            values = series[name] if component is None else series[name][:, component]
            ax.plot(series["t"], values, color=f"C{run}", ls=style, lw=1.2 - 0.2 * run)
            if record["fell"]:
                ax.plot(series["t"][-1], values[-1], color=f"C{run}", marker="x", ms=9, mew=2, ls="none")
                ax.annotate(f"fell at {float(record['fall_time']):.2f} s", (series["t"][-1], values[-1]),
                            textcoords="offset points", xytext=(4, 4), fontsize=7, color=f"C{run}")
        ax.set_title(title)
        ax.set_ylabel(unit)
