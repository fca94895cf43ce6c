"""The data of the report's animated 3D view: terrain and one frame per time sample.

A scene is plain JSON for `legplan.report.viewer` (lengths in integer millimetres to keep the page
small):

    {"title", "dt" (s per frame), "terrain": {"x0", "y0", "step", "nx", "ny", "z": [ny * nx]} | null,
     "radii": [mm per sphere], "colours": [CSS colour per sphere],
     "frames": [{"label", "s": spheres (S*3), "c": CoM or base point (3), "p": support polygon (k*3),
                 "b": base box corners (8*3, dyn only), "a": force arrows (m*6, dyn only)}]}

`motion_scene` draws step-plan motions (robot collision spheres, feet black, CoM, the stance
polygon); `traj_scene` draws `dyn` trajectories (base box, feet, contact forces). Both draw the
robot's links (`legplan.report.links`: per frame "k" skeleton and "l" link placements, and the
scene's "links"), by forward kinematics of the step's joints or, for a dyn plan that holds no
joints, of the joints `legplan.export.traj_configurations` finds by leg IK.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

MAX_FRAMES = 400           # frames of one scene (with the links' placements a view stays well below 1 MB)
TERRAIN_CELLS = 72         # terrain samples along the longer side
FORCE_SCALE = 1e-3         # m of arrow per N
LEG_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf"]


def motion_scene(path: str | os.PathLike) -> dict | None:
    """Every planned step of a motion artefact (Bézier control points, or an OMPL baseline's
    waypoints) sampled along its path; None without a robot, a map input or any path."""
    from legplan.artefacts import open_artefact
    from legplan.baselines.step import polyline_samples
    from legplan.geometry.bezier import evaluate
    from legplan.report.inputs import recorded_input
    from legplan.report.links import links_frames, links_static
    from legplan.robots import load_robot
    from legplan.stepplan.batch import read_motion
    from legplan.terrain import load_map

    with open_artefact(path, kind="motion") as handle:
        robot_name = str(handle.attrs.get("robot", ""))
    records = [r for r in read_motion(path) if "control_points" in r or "waypoints" in r]
    terrain_path = recorded_input(path, "map")
    if not robot_name or terrain_path is None or not records:
        return None
    robot = load_robot(robot_name)
    per_step = int(np.clip(MAX_FRAMES // len(records), 2, 24))
    frames = []
    for r in records[: MAX_FRAMES // per_step]:
        x = evaluate(r["control_points"], np.linspace(0.0, 1.0, per_step)) if "control_points" in r \
            else polyline_samples(r["waypoints"], per_step)
        q = robot.from_vector(x)
        links = links_frames(robot, q)
        spheres, com = robot.sphere_centres(q), robot.com(q)
        support = polygon(np.asarray(r["footholds"])[np.asarray(r["stance"], bool)])
        label = f"step {int(r['index'])}" + ("" if r["success"] else f" (failed: {r['reason']})")
        frames += [{"label": label, "s": mm(spheres[k]), "c": mm(com[k]), "p": support, **links[k]}
                   for k in range(per_step)]
    spheres = robot.spheres
    colours = ["#222" if foot else "#999" if leg < 0 else LEG_COLOURS[leg % len(LEG_COLOURS)]
               for foot, leg in zip(spheres.is_foot, spheres.leg_index)]
    points = np.array([f["s"] for f in frames], float).reshape(-1, 3) / 1000
    shown = len(frames) // per_step
    steps = f"{shown} steps" if shown == len(records) else f"the first {shown} of {len(records)} steps"
    return {"title": f"{Path(path).name}: {steps} of {robot_name}",
            "dt": 1.0 / per_step, "terrain": terrain_patch(load_map(terrain_path), points),
            "radii": mm(spheres.radii), "colours": colours, "links": links_static(robot), "frames": frames}


def traj_scene(path: str | os.PathLike) -> dict | None:
    """The first task with a solution of a traj artefact, every 10 ms sample up to `MAX_FRAMES`
    (spread over the whole motion); None when no task has a solution."""
    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.euler import rotation
    from legplan.export import traj_configurations
    from legplan.report.inputs import recorded_input
    from legplan.report.links import links_frames, links_static
    from legplan.robots import load_robot
    from legplan.terrain import load_map

    attrs, tasks = read_tasks(path)
    shown = next((index for index, task in enumerate(tasks) if "samples" in task), None)
    if shown is None:
        return None
    s = tasks[shown]["samples"]
    pick = np.unique(np.linspace(0, len(s["t"]) - 1, min(len(s["t"]), MAX_FRAMES)).astype(int))
    feet, forces, contact = s["feet_pos"][pick], s["forces"][pick], np.asarray(s["contact"], bool)[pick]
    robot = load_robot(str(attrs["robot"]))
    base_pos, base_quat, joints, _ = traj_configurations(robot, s, np.asarray(s["t"], float)[pick])
    links = links_frames(robot, np.concatenate([base_pos, base_quat, joints], axis=1))
    boxes = base_box(robot, s["base_pos"][pick], rotation(s["base_euler"][pick]))
    frames = []
    for k in range(len(pick)):
        arrows = [[*feet[k, leg], *(feet[k, leg] + FORCE_SCALE * forces[k, leg])]
                  for leg in np.flatnonzero(contact[k]) if np.linalg.norm(forces[k, leg]) > 1.0]
        frames.append({"label": f"task {shown}, t = {s['t'][pick[k]]:.2f} s", "s": mm(feet[k]),
                       "c": mm(s["base_pos"][pick[k]]), "p": polygon(feet[k, contact[k]]),
                       "b": mm(boxes[k]), "a": mm(np.array(arrows).reshape(-1)), **links[k]})
    terrain_path = recorded_input(path, "map")
    points = np.concatenate([feet.reshape(-1, 3), boxes.reshape(-1, 3)])
    legs = feet.shape[1]
    return {"title": f"{Path(path).name}: task {shown} of {len(tasks)} (forces: 1 m = {1 / FORCE_SCALE:g} N)",
            "dt": float(np.mean(np.diff(s["t"][pick]))) if len(pick) > 1 else 0.01,
            "terrain": terrain_patch(load_map(terrain_path), points) if terrain_path else None,
            "radii": [30] * legs, "colours": LEG_COLOURS[:legs], "links": links_static(robot), "frames": frames}


def base_box(robot, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(n, 8, 3) corners of the base drawn as a box spanning the nominal feet in x and y, 0.16 m
    high, at `positions` (n, 3) turned by `rotations` (n, 3, 3) or unit quaternions (n, 4) (x, y, z, w)."""
    from scipy.spatial.transform import Rotation

    rotations = np.asarray(rotations, float)
    if rotations.ndim == 2:
        rotations = Rotation.from_quat(rotations).as_matrix()
    half = np.array([*np.abs(robot.centroidal.nominal_feet[:, :2]).max(axis=0), 0.08])
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    return np.asarray(positions, float)[:, None, :] + np.einsum("nij,kj->nki", rotations, corners)


def polygon(points: np.ndarray) -> list[int]:
    """Stance points ordered around their centroid (the support polygon of a convex stance)."""
    points = np.asarray(points, float).reshape(-1, 3)
    if len(points) < 3:
        return []
    centre = points.mean(axis=0)
    order = np.argsort(np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0]))
    return mm(points[order])


def terrain_patch(terrain, points: np.ndarray, margin: float = 0.3) -> dict:
    """The heightmap around `points` (m), subsampled to at most `TERRAIN_CELLS` along a side."""
    height = np.asarray(terrain.height, float)
    x0, y0 = np.asarray(terrain.grid.origin, float)[:2]
    res = float(terrain.grid.resolution)
    low, high = points[:, :2].min(axis=0) - margin, points[:, :2].max(axis=0) + margin
    i0, i1 = (np.clip(np.floor((np.array([low[1], high[1]]) - y0) / res), 0, height.shape[0] - 1)).astype(int)
    j0, j1 = (np.clip(np.floor((np.array([low[0], high[0]]) - x0) / res), 0, height.shape[1] - 1)).astype(int)
    stride = max(1, int(np.ceil(max(i1 - i0 + 1, j1 - j0 + 1) / TERRAIN_CELLS)))
    z = height[i0:i1 + 1:stride, j0:j1 + 1:stride]
    return {"x0": round((x0 + j0 * res) * 1000), "y0": round((y0 + i0 * res) * 1000),
            "step": round(stride * res * 1000, 3), "nx": int(z.shape[1]), "ny": int(z.shape[0]),
            "z": mm(z)}


def mm(values) -> list[int]:
    """Flattened metres as integer millimetres."""
    return np.rint(np.asarray(values, float).reshape(-1) * 1000).astype(int).tolist()
