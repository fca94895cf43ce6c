"""Test helper: a plan that stands still, in the layout of traj.h5's samples."""

import numpy as np


def standing(robot, seconds=1.0):
    """Samples of the nominal stance held still for `seconds`: the weight split over the four feet."""
    c = robot.centroidal
    t = np.arange(0.0, seconds + 1e-9, 0.01)
    n, zero = len(t), np.zeros((len(t), 3))
    forces = np.zeros((n, 4, 3))
    forces[..., 2] = c.mass * 9.81 / 4
    return {"t": t, "base_pos": np.tile([0.0, 0.0, c.base_height], (n, 1)), "base_vel": zero, "base_acc": zero,
            "base_euler": zero, "base_ang_vel": zero, "base_ang_acc": zero,
            "feet_pos": np.tile(c.nominal_feet + [0.0, 0.0, c.base_height], (n, 1, 1)),
            "feet_vel": np.zeros((n, 4, 3)), "forces": forces, "contact": np.ones((n, 4), bool)}
