"""A replan's guess: the previous solution shifted in time (`ShiftedInit`, a `legplan.dyn.init`
initializer), so that the rest of the motion starts from the plan it replaces (issue 39 item 3)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from legplan.dyn.formulation import Formulation
from legplan.dyn.rest_gait import EPS, Insertion

if TYPE_CHECKING:
    from legplan.dyn.replan import Previous

NODE_INSIDE = 1e-9  # share of a segment: where a node's value and rate are read from the previous splines


class ShiftedInit:
    """The previous solution shifted in time as an initializer (`legplan.dyn.init` signature): every
    node of the new splines takes the previous splines' value and rate at its time t + τ (clipped to
    the previous plan's end). Its guesses solve a nearby problem (`near_solution`). With strides
    inserted (`Insertion`) the feet and forces in them repeat the stride before them and the base
    waits at rest where they start; after them the previous plan goes on."""

    near_solution = True

    def __init__(self, previous: Previous, t: float, step: np.ndarray | None = None,
                 insertion: Insertion | None = None):
        self.previous, self.t, self.insertion = previous, float(t), insertion
        self.step = np.zeros(2) if step is None else np.asarray(step, float)[:2]

    def __call__(self, form: Formulation, model, terrain, start, goal, start_feet) -> dict[str, np.ndarray]:
        prev = self.previous
        base_t = form.knots
        guess = {name: _sample(lambda times, d: prev.form.base_matrix(times, d), prev.values[name], self._at(base_t))
                 for name in ("base_lin", "base_ang")}
        if self.insertion is not None:  # the base waits in the inserted strides where they start, at rest
            ins = self.insertion
            wait = (base_t >= ins.at - EPS) & (base_t < ins.at + ins.length - EPS)
            for name in ("base_lin", "base_ang"):
                start = _sample(lambda times, d: prev.form.base_matrix(times, d), prev.values[name],
                                np.clip([self.t + ins.at], 0.0, prev.form.duration)).reshape(2, 3)
                nodes = guess[name].reshape(-1, 2, 3)
                nodes[wait, 0], nodes[wait, 1] = start[0], 0.0
        feet = np.zeros((form.motion_nodes, 2, 3))
        forces = np.zeros((form.force_nodes, 2, 3))
        for leg, foot in enumerate(form.feet):
            for spline, offset, out, matrix, values in (
                    (foot.motion, foot.motion_offset, feet, prev.form.foot_matrix, prev.values["feet"]),
                    (foot.force, foot.force_offset, forces, prev.form.force_matrix, prev.values["forces"])):
                nodes, times = _node_times(spline)
                out[offset + nodes] = _sample(lambda tt, d: matrix(leg, tt, d), values,
                                              self._at(times)).reshape(-1, 2, 3)
        if self.step.any():
            self._adapt_steps(form, terrain, feet)
        guess["feet"], guess["forces"] = feet.reshape(-1), forces.reshape(-1)
        return guess

    def _adapt_steps(self, form: Formulation, terrain, feet: np.ndarray) -> None:
        """Move every foot's next foothold (its second stance: the first is where it stands or is
        held) horizontally by `step` onto the terrain there, and the apex of the swing before it
        by half that (the capture point, Pratt et al. 2006: one step there stops the pushed base;
        later steps keep the previous plan's, which lead to the goal)."""
        for foot in form.feet:
            if len(foot.stance_nodes) < 2:
                continue
            node = foot.stance_nodes[1]
            xy = feet[node, 0, :2] + self.step
            feet[node, 0, :2] = xy
            feet[node, 0, 2] = float(terrain.height(xy[:1], xy[1:])[0])
            feet[foot.swing_nodes[0], 0, :2] += 0.5 * self.step

    def _at(self, times: np.ndarray) -> np.ndarray:
        """The previous plan's time of each time of the rest (inserted strides repeat the stride
        before them, `Insertion.previous_time`)."""
        times = np.asarray(times, float)
        if self.insertion is not None:
            times = self.insertion.previous_time(times)
        return np.clip(self.t + times, 0.0, self.previous.form.duration)


def _sample(matrix, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(n, value|rate, xyz) flattened: a spline's value and first derivative at `times`."""
    nodes = values.reshape(-1, 3)
    return np.stack([matrix(times, 0) @ nodes, matrix(times, 1) @ nodes], axis=1).reshape(-1)


def _node_times(spline) -> tuple[np.ndarray, np.ndarray]:
    """Each node of a spline and the time it stands for: the middle of a constant segment (a stance
    foot, a swing's zero force), else the end of a segment it is (first end met wins), read from
    just inside that segment (a force node at a lift-off is the stance's end, not the swing's)."""
    times: dict[int, float] = {}
    for seg in spline.segments:
        if seg.constant:
            times.setdefault(seg.a, 0.5 * (seg.t0 + seg.t1))
    for seg in spline.segments:  # just inside the segment: a node's rate is its own segment's
        if not seg.constant:
            inside = NODE_INSIDE * (seg.t1 - seg.t0)
            times.setdefault(seg.a, seg.t0 + inside)
            times.setdefault(seg.b, seg.t1 - inside)
    nodes = np.array(sorted(times), int)
    return nodes, np.array([times[n] for n in nodes])
