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

from dataclasses import dataclass

from legplan.parameters import Parameters, param


@dataclass(frozen=True)
class TebParams(Parameters):
    what = "teb"

    # band resolution and iteration counts (TEB defaults)
    dt_ref: float = param(0.3, "(0, 3600]", doc="s")
    dt_hysteresis: float = param(0.1, "[0, dt_ref)", doc="s")
    dt_min: float = param(0.01, "(0, dt_merge_below)", doc="s, lower bound of every ΔT_i")
    min_poses: int = param(3, "[2, 100000]")
    max_poses: int = param(500, "[min_poses, 100000]")
    outer_iterations: int = param(4, "[1, 1000000]")
    inner_iterations: int = param(5, "[1, 1000000]")
    tries_per_iteration: int = param(3, "[1, 1000]", doc="LM iterations (accepted or rejected) per TEB inner iteration")
    lambda_boost: float = param(3.0, "(1, inf)", doc="LM damping increase after a rejected step")
    round_tolerance: float = param(0.01, "[0, inf)",
                                   doc="stop the rounds once one lowers ‖h‖ by less than this fraction")
    step_tolerance: float = param(1e-6, "[0, inf)",
                                  doc="LM stops a round when a step is below this fraction of ‖z‖")
    epsilon: float = param(0.01, "[0, inf)", "ε", "penalty margin (m/s, rad/s, m/s², rad/s²)")
    # kinematics
    omnidirectional: bool = True
    # weights (multiply squared residuals)
    weight_velocity: float = param(100.0, "[0, inf)")
    weight_omega: float = param(100.0, "[0, inf)")
    weight_acceleration: float = param(50.0, "[0, inf)")
    weight_alpha: float = param(50.0, "[0, inf)")
    gamma_forward: float = param(2.0, "[0, inf)", "γ", "on forward (x) rows")
    gamma_lateral: float = param(1.0, "[0, inf)", "γ", "on lateral (y) rows")
    weight_time: float = param(1.0, "[0, inf)")
    weight_path: float = param(0.5, "[0, inf)", doc="attraction to the global path")
    weight_obstacle: float = param(50.0, "[0, inf)")
    weight_inflation: float = param(0.5, "[0, inf)")
    weight_viapoint: float = param(20.0, "[0, inf)")
    weight_via_heading: float = param(20.0, "[0, inf)")
    weight_yaw_change: float = param(0.2, "[0, inf)", doc="the paper's yaw-change penalty")
    weight_nonholonomic: float = param(1000.0, "[0, inf)")
    # obstacles (distance of the robot centre to the nearest obstacle)
    min_obstacle_distance: float = param(0.35, "[0, inf)", doc="m")
    inflation_distance: float = param(0.6, "[min_obstacle_distance, inf)", doc="m")
    path_window: float = param(1.0, "(0, inf)",
                               doc="m of arc length around a pose's reference point searched for attraction")

    @property
    def dt_merge_below(self) -> float:
        """ΔT below which resizing removes a pose (merges two intervals): dt_ref − dt_hysteresis."""
        return self.dt_ref - self.dt_hysteresis
