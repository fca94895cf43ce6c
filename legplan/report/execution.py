"""The report's sim section: a plan against its execution in MuJoCo (sim.h5 of `dyn simulate`).

For the first executed task of a sim artefact (the task group that holds `series`):

* `execution_figure`: base position (x, y, z) and foot heights over time, planned (dashed, from the
  traj artefact the sim recorded as its input, same task index) against executed (solid); the top
  view of base and feet tracks; the contact timeline, per leg the planned stance above the
  executed one (foot force > 0); the fall marked on every time axis (`fall_time`).
* `execution_scene`: the replay for the 3D view: the executed configurations (joint positions
  of sim.h5's series) drawn with their links (`legplan.report.links`), feet, base box and the
  support polygon of the feet in contact; frames after the fall are labelled so.

Executed feet come from forward kinematics of the recorded base and joints (`legplan.export`)
lowered by the foot sphere's radius, so they are contact points like the planned `feet_pos`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from legplan.report.scene import LEG_COLOURS

REPLAY_RATE = 100.0  # Hz of the executed series used for figures and replay (decimated to MAX_FRAMES)


def executed_task(path: str | os.PathLike, with_plan: bool = True):
    """(robot, executed Series, task attrs, planned samples or None, traj path or None) of the first
    executed task; None when no task was executed. The plan is looked up (`recorded_input`, an
    `ArtefactError` when recorded but not found) only `with_plan`."""
    from legplan.artefacts import open_artefact
    from legplan.dyn.artefact import read_tasks
    from legplan.export import export_series, foot_radii
    from legplan.report.inputs import recorded_input
    from legplan.robots import load_robot

    with open_artefact(path, kind="sim") as handle:
        tasks = handle.get("tasks", {})
        executed = [name for name in sorted(tasks) if "series" in tasks[name]]
        if not executed:
            return None
        attrs = dict(tasks[executed[0]].attrs)
        robot = load_robot(str(handle.attrs["robot"]))
    series = next(s for s in export_series(path, REPLAY_RATE) if s.item == f"tasks/{executed[0]}")
    series.columns["feet_pos"] = series.columns["feet_pos"] - foot_radii(robot)[None, :, None] * [0.0, 0.0, 1.0]
    traj = recorded_input(path, "traj") if with_plan else None
    planned = None
    if traj is not None:
        _, plans = read_tasks(traj)
        index = int(attrs.get("index", int(executed[0])))
        planned = next((p["samples"] for k, p in enumerate(plans)
                        if int(p.get("index", k)) == index and "samples" in p), None)
    return robot, series, attrs, planned, traj


def _fall(attrs: dict) -> float | None:
    fall = float(attrs.get("fall_time", np.nan))
    return fall if bool(attrs.get("fell", False)) and np.isfinite(fall) else None


def execution_figure(path: Path, png: Path) -> str | None:
    """Planned against executed base, feet and contacts of the first executed task (module doc)."""
    from legplan.report.plots import new_figure

    found = executed_task(path)
    if found is None:
        return None
    robot, series, attrs, planned, traj = found
    c, fall = series.columns, _fall(attrs)
    legs = [leg.name for leg in robot.legs]
    fig = new_figure(12.0, 8.0)
    (base_ax, feet_ax), (top_ax, contact_ax) = fig.subplots(2, 2)
    for axis, colour in zip(range(3), ("tab:red", "tab:green", "tab:blue")):
        base_ax.plot(c["t"], c["base_pos"][:, axis], color=colour, lw=1.2, label=f"{'xyz'[axis]} executed")
        if planned is not None:
            base_ax.plot(planned["t"], planned["base_pos"][:, axis], color=colour, lw=1.0, ls="--",
                         label=f"{'xyz'[axis]} planned")
    base_ax.set_title("Base position")
    base_ax.set_ylabel("m")
    for leg, name in enumerate(legs):
        colour = LEG_COLOURS[leg % len(LEG_COLOURS)]
        feet_ax.plot(c["t"], c["feet_pos"][:, leg, 2], color=colour, lw=1.0, label=name)
        top_ax.plot(c["feet_pos"][:, leg, 0], c["feet_pos"][:, leg, 1], color=colour, lw=1.0)
        if planned is not None:
            feet_ax.plot(planned["t"], planned["feet_pos"][:, leg, 2], color=colour, lw=0.9, ls="--")
            top_ax.plot(planned["feet_pos"][:, leg, 0], planned["feet_pos"][:, leg, 1], color=colour, lw=0.9, ls="--")
    feet_ax.set_title("Foot heights (solid executed, dashed planned)")
    feet_ax.set_ylabel("m")
    top_ax.plot(c["base_pos"][:, 0], c["base_pos"][:, 1], "k-", lw=1.4, label="base executed")
    if planned is not None:
        top_ax.plot(planned["base_pos"][:, 0], planned["base_pos"][:, 1], "k--", lw=1.0, label="base planned")
    top_ax.set_aspect("equal", adjustable="datalim")
    top_ax.set_title("Top view")
    top_ax.set_xlabel("x [m]")
    top_ax.set_ylabel("y [m]")
    for leg, name in enumerate(legs):
        colour = LEG_COLOURS[leg % len(LEG_COLOURS)]
        rows = [(np.asarray(c["t"]), np.asarray(c["contact"][:, leg], bool), 2 * leg, 1.0)]
        if planned is not None:
            rows.append((np.asarray(planned["t"]), np.asarray(planned["contact"][:, leg], bool), 2 * leg + 1, 0.45))
        for t, flags, row, alpha in rows:
            contact_ax.broken_barh(_intervals(t, flags), (row + 0.1, 0.8), color=colour, alpha=alpha)
    contact_ax.set_yticks(np.arange(2 * len(legs)) + 0.5,
                          [f"{name} {kind}" for name in legs for kind in ("executed", "planned")], fontsize=7)
    contact_ax.set_title("Contact timeline (executed: foot force > 0)")
    contact_ax.set_xlabel("t [s]")
    for ax in (base_ax, feet_ax, contact_ax):
        if fall is not None:
            ax.axvline(fall, color="#b00", lw=1.5, ls=":")
            ax.text(fall, 1.0, " fall", color="#b00", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
        ax.set_xlabel("t [s]")
    if fall is not None:
        k = int(np.searchsorted(c["t"], fall))
        k = min(k, len(c["t"]) - 1)
        top_ax.plot(*c["base_pos"][k, :2], "x", color="#b00", ms=10, mew=2, label="fall")
    base_ax.legend(fontsize=7, ncol=2)
    feet_ax.legend(fontsize=7)
    top_ax.legend(fontsize=7)
    fig.savefig(png, dpi=100)
    against = f"planned ({Path(traj).name}, dashed)" if planned is not None else "no plan found (the sim records no traj input)"
    state = f"fell at t = {fall:.2f} s (red)" if fall is not None else "did not fall"
    return (f"Task {series.item.split('/')[-1]} executed in MuJoCo against {against}: {state}; "
            f"{attrs.get('reason', '')}.")


def _intervals(t: np.ndarray, flags: np.ndarray) -> list[tuple[float, float]]:
    """(start, width) of each run of True in `flags` sampled at `t` (a run lasts to the next sample)."""
    if not len(t):
        return []
    edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    end_times = np.append(t, t[-1])[ends]
    return [(float(t[s]), float(end_times[k] - t[s])) for k, s in enumerate(starts)]


def execution_scene(path: str | os.PathLike) -> dict | None:
    """The replay of the first executed task for the 3D view (module doc); None without one."""
    from legplan.report.inputs import recorded_input
    from legplan.report.links import links_frames, links_static
    from legplan.report.scene import MAX_FRAMES, base_box, mm, polygon, terrain_patch
    from legplan.terrain import load_map

    found = executed_task(path, with_plan=False)  # the replay needs no plan
    if found is None:
        return None
    robot, series, attrs, _, _ = found
    c, fall = series.columns, _fall(attrs)
    pick = np.unique(np.linspace(0, len(c["t"]) - 1, min(len(c["t"]), MAX_FRAMES)).astype(int))
    Q = np.concatenate([c["base_pos"], c["base_quat"], c["joint_pos"]], axis=1)[pick]
    links = links_frames(robot, Q)
    boxes = base_box(robot, c["base_pos"][pick], Q[:, 3:7])
    feet, contact = c["feet_pos"][pick], np.asarray(c["contact"][pick], bool)
    task = series.item.split("/")[-1]
    frames = []
    for k, i in enumerate(pick):
        after = fall is not None and c["t"][i] >= fall
        frames.append({"label": f"task {task} executed, t = {c['t'][i]:.2f} s" + (" (fallen)" if after else ""),
                       "s": mm(feet[k]), "c": mm(c["base_pos"][i]), "p": polygon(feet[k, contact[k]]),
                       "b": mm(boxes[k]), **links[k]})
    terrain_path = recorded_input(path, "map")
    points = np.concatenate([feet.reshape(-1, 3), boxes.reshape(-1, 3)])
    state = f", fell at {fall:.2f} s" if fall is not None else ""
    return {"title": f"{Path(path).name}: replay of task {task} as executed in MuJoCo{state}",
            "dt": float(np.mean(np.diff(c["t"][pick]))) if len(pick) > 1 else 0.01,
            "terrain": terrain_patch(load_map(terrain_path), points) if terrain_path else None,
            "radii": [30] * robot.n_legs, "colours": LEG_COLOURS[:robot.n_legs], "links": links_static(robot),
            "frames": frames}
