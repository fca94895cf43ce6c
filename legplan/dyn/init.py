"""Initial guesses of the centroidal problem: y₀ = A(x) of eq. (2) of the TOWR-costs paper.

An initializer is a callable ``(form, model, terrain, start, goal, start_feet) -> guess`` returning the
full value vectors of ``base_lin``, ``base_ang``, ``feet`` and ``forces`` (fixed entries are then
overwritten from the task). `heuristic` is the paper's *Heuristic* (Sec. IV): the base linearly
interpolated from start to goal, footsteps evenly spaced along it and timed by the gait, forces m·g
shared equally over the feet in stance. A learned initializer plugs in with the same signature.
"""

from __future__ import annotations

import numpy as np

from legplan.dyn.constraints import GRAVITY
from legplan.dyn.formulation import Formulation, Pose
from legplan.dyn.terrain import TerrainModel

SWING_LIFT = 0.08  # m: initial apex height above the higher adjacent foothold


def _interpolate(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    return a[None, :] + np.asarray(s, float)[:, None] * (b - a)[None, :]


def heuristic(form: Formulation, model, terrain: TerrainModel, start: Pose, goal: Pose,
              start_feet: np.ndarray) -> dict[str, np.ndarray]:
    """The paper's *Heuristic* initial guess (see module docstring)."""
    T = form.duration
    s = form.knots / T
    lin = np.zeros((form.base.nodes, 2, 3))
    ang = np.zeros_like(lin)
    lin[:, 0] = _interpolate(start.position, goal.position, s)
    lin[:, 1] = (goal.position - start.position) / T
    ang[:, 0] = _interpolate(start.euler, goal.euler, s)
    ang[:, 1] = (goal.euler - start.euler) / T
    feet = np.zeros((form.motion_nodes, 2, 3))
    forces = np.zeros((form.force_nodes, 2, 3))
    for leg, foot in enumerate(form.feet):
        stance = [p for p in foot.phases if p.stance]
        for k, (phase, node) in enumerate(zip(stance, foot.stance_nodes)):
            if k == 0:
                feet[node, 0] = start_feet[leg]
                continue
            frac = 1.0 if k == len(stance) - 1 else 0.5 * (phase.t0 + phase.t1) / T
            base_xy = start.position[:2] + frac * (goal.position[:2] - start.position[:2])
            yaw = start.euler[2] + frac * (goal.euler[2] - start.euler[2])
            c, sn = np.cos(yaw), np.sin(yaw)
            xy = base_xy + np.array([[c, -sn], [sn, c]]) @ model.nominal_feet[leg, :2]
            feet[node, 0] = [xy[0], xy[1], float(terrain.height(xy[:1], xy[1:])[0])]
        swings = [p for p in foot.phases if not p.stance]
        for k, (phase, apex) in enumerate(zip(swings, foot.swing_nodes)):
            prev, nxt = feet[foot.stance_nodes[k], 0], feet[foot.stance_nodes[k + 1], 0]
            feet[apex, 0, :2] = 0.5 * (prev[:2] + nxt[:2])
            feet[apex, 0, 2] = max(prev[2], nxt[2]) + SWING_LIFT
            feet[apex, 1, :2] = (nxt[:2] - prev[:2]) / phase.duration
        for ids in foot.force_nodes:
            t = np.array([_node_time(foot, i) for i in ids])
            share = model.mass * GRAVITY / np.maximum(form.gait.contact(t).sum(axis=1), 1)
            forces[ids, 0, 2] = share
    return {"base_lin": lin.reshape(-1), "base_ang": ang.reshape(-1), "feet": feet.reshape(-1),
            "forces": forces.reshape(-1)}


def _node_time(foot, node: int) -> float:
    """Time of a (global) force node: start of the segment it opens, or end of the one it closes."""
    local = node - foot.force_offset
    for seg in foot.force.segments:
        if seg.a == local and not seg.constant:
            return seg.t0
        if seg.b == local:
            return seg.t1
    raise ValueError(f"force node {node} is not a stance node")


INITIALIZERS = {"heuristic": heuristic}
