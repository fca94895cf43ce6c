"""The linear inverted pendulum's capture point (Pratt et al. 2006) for a pushed base: where its next
foothold stops it (`capture_step`, the controller's foothold feedback and a replan's step
adaptation) and how long stopping and walking back takes (`recovery_time`, how many strides a
replan inserts). Its time constant is τ = √(h/g), h the model's base height."""

from __future__ import annotations

import numpy as np

from legplan.dyn.constraints import GRAVITY


def capture_step(error, time_constant: float, limit, gain: float = 1.0) -> np.ndarray:
    """The horizontal shift (3,) of a foothold for a base velocity error (3,) (m/s): `gain` × the
    capture-point offset τ·e of the linear inverted pendulum (τ = √(h/g); Pratt et al. 2006,
    Raibert's foot placement), each horizontal axis within `limit` (the range of motion's
    half-widths), none vertically. The controller's foothold feedback and the replan's step
    adaptation both place feet by it."""
    shift = gain * time_constant * np.asarray(error, float)
    shift[2] = 0.0
    return np.clip(shift, -np.asarray(limit, float), np.asarray(limit, float))


def recovery_time(error: np.ndarray, model) -> float:
    """s a base needs to stop a horizontal CoM velocity error (3,) and walk back to its path: the
    linear inverted pendulum (τ = √(h/g)) over feet at the edge of their range of motion along the
    error stops it at a = g·r/h in |e|/a, having drifted |e|²/2a, and walks that back in
    2·√(|e|²/2a / a) = √2·|e|/a (Pratt et al. 2006's capture point, the feet's reach as its limit)."""
    e = np.asarray(error, float)[:2]
    speed = float(np.hypot(*e))
    if speed == 0.0:
        return 0.0
    box = np.asarray(model.range_of_motion, float)[:2]
    reach = 1.0 / float(np.max(np.abs(e / speed) / box))  # the box's half-extent along e
    return (1.0 + np.sqrt(2.0)) * speed * model.base_height / (GRAVITY * reach)
