"""Parameters of the timed elastic band (TEB) back end (quadruped paper Sec. IV).

Weights follow the g2o convention of TEB: a weight w multiplies the *squared* residual, so the
least-squares rows are scaled by √w. `gamma_forward`/`gamma_lateral` are the direction-dependent
weights γ_k of eq. (24): they multiply the weights of the forward (x) and lateral (y) rows of the
velocity and acceleration penalties ("a greater weight for the forward direction", Sec. V-C 2).

Band resolution follows TEB's defaults: `dt_ref` 0.3 s with hysteresis 0.1 s, 4 outer rounds of
resizing × 5 inner iterations; the rounds stop early (a warm-started band usually needs one or
two) once a round lowers ‖h‖ by less than `round_tolerance` relatively and leaves a band that
resizing would not change. g2o's LM retries a rejected step with more damping inside one
iteration; our LM counts every try, so an inner iteration gets `tries_per_iteration` LM
iterations. `epsilon` is the penalty margin ε of the interval penalty (the penalty becomes active
ε inside each bound, in the bound's own units).

`omnidirectional=False` gives the differential-drive variant of Table III: the non-holonomic
kinematics residual of Rösmann et al. [19] (weight `weight_nonholonomic`) forces lateral velocity
to zero.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from legplan.errors import LegplanError


@dataclass(frozen=True)
class TebParams:
    # band resolution and iteration counts (TEB defaults)
    dt_ref: float = 0.3  # s
    dt_hysteresis: float = 0.1  # s
    dt_min: float = 0.01  # s, lower bound of every ΔT_i
    min_poses: int = 3
    max_poses: int = 500
    outer_iterations: int = 4
    inner_iterations: int = 5
    tries_per_iteration: int = 3  # LM iterations (accepted or rejected) per TEB inner iteration
    lambda_boost: float = 3.0  # LM damping increase after a rejected step
    round_tolerance: float = 0.01  # stop the rounds once one lowers ‖h‖ by less than this fraction
    step_tolerance: float = 1e-6  # LM stops a round when a step is below this fraction of ‖z‖
    epsilon: float = 0.01  # penalty margin ε (m/s, rad/s, m/s², rad/s²)
    # kinematics
    omnidirectional: bool = True
    # weights (multiply squared residuals)
    weight_velocity: float = 100.0
    weight_omega: float = 100.0
    weight_acceleration: float = 50.0
    weight_alpha: float = 50.0
    gamma_forward: float = 2.0  # γ on forward (x) rows
    gamma_lateral: float = 1.0  # γ on lateral (y) rows
    weight_time: float = 1.0
    weight_path: float = 0.5  # attraction to the global path
    weight_obstacle: float = 50.0
    weight_inflation: float = 0.5
    weight_viapoint: float = 20.0
    weight_via_heading: float = 20.0
    weight_yaw_change: float = 0.2  # the paper's yaw-change penalty
    weight_nonholonomic: float = 1000.0
    # obstacles (distance of the robot centre to the nearest obstacle)
    min_obstacle_distance: float = 0.35  # m
    inflation_distance: float = 0.6  # m
    path_window: float = 1.0  # m of arc length around a pose's reference point searched for attraction

    def __post_init__(self):
        checks = [("dt_ref", self.dt_ref > 0), ("dt_hysteresis", 0 <= self.dt_hysteresis < self.dt_ref),
                  ("dt_min", 0 < self.dt_min < self.dt_ref - self.dt_hysteresis),
                  ("min_poses", self.min_poses >= 2), ("max_poses", self.max_poses >= self.min_poses),
                  ("outer_iterations", self.outer_iterations >= 1),
                  ("inner_iterations", self.inner_iterations >= 1), ("epsilon", self.epsilon >= 0),
                  ("tries_per_iteration", self.tries_per_iteration >= 1),
                  ("round_tolerance", self.round_tolerance >= 0), ("step_tolerance", self.step_tolerance >= 0), ("lambda_boost", self.lambda_boost > 1),
                  ("inflation_distance", self.inflation_distance >= self.min_obstacle_distance >= 0),
                  ("path_window", self.path_window > 0)]
        checks += [(f.name, getattr(self, f.name) >= 0) for f in dataclasses.fields(self)
                   if f.name.startswith(("weight_", "gamma_"))]
        for name, ok in checks:
            if not ok:
                raise LegplanError(f"teb parameter '{name}' out of range: {getattr(self, name)!r}")

    def replace(self, **changes) -> TebParams:
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)
