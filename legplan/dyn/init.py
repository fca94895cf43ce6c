"""Initial guesses of the centroidal problem: y₀ = A(x) of eq. (2) of the TOWR-costs paper.

An initializer is a callable ``(form, model, terrain, start, goal, start_feet) -> guess`` returning the
full value vectors of ``base_lin``, ``base_ang``, ``feet`` and ``forces`` (fixed entries are then
overwritten from the task). `heuristic` is the paper's *Heuristic* (Sec. IV): the base linearly
interpolated from start to goal, footsteps evenly spaced along it and timed by the gait, forces m·g
shared equally over the feet in stance; in a phase whose load starts and ends at zero
(`formulation.unloaded_phases`: a trot's support pair) a parabola that carries the weight over the
phase and its flights instead, and the base's height then hops with those forces (`_unloaded_hop`)
(both ours). A learned initializer plugs in with the same signature.
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
    hop = _unloaded_hop(form.gait, form.knots)
    if hop is not None:
        lin[:, :, 2] += hop
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
            bump = _unloaded_bump(form.gait, t)
            if bump is not None:
                forces[ids, :, 2] = model.mass * GRAVITY * bump
    return {"base_lin": lin.reshape(-1), "base_ang": ang.reshape(-1), "feet": feet.reshape(-1),
            "forces": forces.reshape(-1)}


def _unloaded_bump(gait, t: np.ndarray) -> np.ndarray | None:
    """Per node time t of a stance inside one of the gait's `unloaded_phases` (a trot's support
    pair): the value and rate, in units of m·g, of the foot's share of the parabola that vanishes at
    the phase's ends and carries the weight over the phase and the flights next to it (the impulse
    that leaves the base's vertical velocity as it was); None for a stance that does not lie in one
    such phase."""
    from legplan.dyn.formulation import unloaded_phases

    bounds = np.concatenate([[0.0], np.cumsum(gait.durations)])
    k = int(np.clip(np.searchsorted(bounds, 0.5 * (t[0] + t[-1]), side="right") - 1, 0, gait.durations.size - 1))
    if not unloaded_phases(gait)[k] or t[0] < bounds[k] - 1e-9 or t[-1] > bounds[k + 1] + 1e-9:
        return None
    t0, t1 = bounds[k], bounds[k + 1]
    span = t1 - t0
    carried = span + sum(0.5 * gait.durations[j] for j in (k - 1, k + 1)
                         if 0 <= j < gait.durations.size and not gait.stance[j].any())
    a = 6.0 * carried / span ** 3 / gait.stance[k].sum()
    return np.column_stack([a * (t - t0) * (t1 - t), a * (t0 + t1 - 2 * t)])


HOP_GRID = 1e-3  # s: the grid on which `_unloaded_hop` integrates the guess's vertical acceleration


def _unloaded_hop(gait, times: np.ndarray) -> np.ndarray | None:
    """(n, 2): the height offset and vertical rate at `times` that the guess's forces give the base
    (eq. (1) of Winkler et al. 2018, m z̈ = Σf_z − m g): −g in a flight, the `_unloaded_bump`
    parabolas' lift minus g in the `unloaded_phases`, 0 where the feet share m·g; integrated twice
    and its linear trend removed, so that the offset vanishes at the start and the end. The base
    guess then hops with its force guess, where a level base against the bumps starts the solver
    far from the dynamics (it flattens the bumps into two humps per support pair, a force that dips
    mid-stance). None for a gait without unloaded phases."""
    from legplan.dyn.formulation import unloaded_phases

    unloaded = unloaded_phases(gait)
    if not unloaded.any():
        return None
    bounds = np.concatenate([[0.0], np.cumsum(gait.durations)])
    t = np.linspace(0.0, bounds[-1], int(np.ceil(bounds[-1] / HOP_GRID)) + 1)
    k = np.clip(np.searchsorted(bounds, t, side="right") - 1, 0, gait.durations.size - 1)
    acc = np.zeros(t.size)
    for j in range(gait.durations.size):
        here = k == j
        if not gait.stance[j].any():
            acc[here] = -GRAVITY
        elif unloaded[j]:
            lift = _unloaded_bump(gait, np.array([bounds[j], bounds[j + 1]]))  # the share's (value, rate) at the ends
            rate = lift[0, 1] * gait.stance[j].sum()  # a·n·span: the summed parabola's rate at its start
            span = bounds[j + 1] - bounds[j]
            acc[here] = GRAVITY * (rate / span * (t[here] - bounds[j]) * (bounds[j + 1] - t[here]) - 1.0)
    dt = np.diff(t)
    vel = np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * dt)])
    z = np.concatenate([[0.0], np.cumsum(0.5 * (vel[1:] + vel[:-1]) * dt)])
    drift = z[-1] / t[-1]
    return np.column_stack([np.interp(times, t, z - drift * t), np.interp(times, t, vel - drift)])


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
