"""The simulated robot: a base that tracks body-velocity commands under the Table I limits."""

from __future__ import annotations

import numpy as np

from legplan.geometry.angles import wrap_angle
from legplan.robots.navigation import KinodynamicLimits


class Robot:
    """Body-velocity tracking base: each substep moves v toward the command by at most a·h per axis
    (an omnidirectional base, or a differential-drive one: lateral velocity zero)."""

    def __init__(self, pose, limits: KinodynamicLimits, omnidirectional: bool = True):
        self.pose = np.asarray(pose, float).copy()
        self.velocity = np.zeros(3)
        self.limits = limits
        self.omnidirectional = omnidirectional
        self.accel = np.array([limits.a_x_max, limits.a_y_max, limits.alpha_max])
        self.v_lower = np.array([-limits.v_x_min, -limits.v_y_max, -limits.omega_max])
        self.v_upper = np.array([limits.v_x_max, limits.v_y_max, limits.omega_max])

    def step(self, command: np.ndarray, h: float) -> None:
        target = np.clip(command, self.v_lower, self.v_upper)
        if not self.omnidirectional:
            target[1] = 0.0
        self.velocity = self.velocity + np.clip(target - self.velocity, -self.accel * h, self.accel * h)
        c, s = np.cos(self.pose[2]), np.sin(self.pose[2])
        vx, vy, w = self.velocity
        self.pose = self.pose + h * np.array([c * vx - s * vy, s * vx + c * vy, w])
        self.pose[2] = wrap_angle(self.pose[2])

    def world_velocity(self) -> np.ndarray:
        c, s = np.cos(self.pose[2]), np.sin(self.pose[2])
        vx, vy, _ = self.velocity
        return np.array([c * vx - s * vy, s * vx + c * vy])
