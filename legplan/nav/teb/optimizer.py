"""TEB optimization (Sec. IV, eq. (24)): rounds of band resizing and sparse LM on R(B) = Σ γ_k R_k(B).

Each outer round resizes the band (`resize`), builds the least-squares problem over the free poses
and all ΔT_i (bounded below by dt_min) — or refreshes a cached one of the same structure
(`problems.py`) — and runs `inner_iterations` LM iterations of the solver core (CHOLMOD).
Terms (weights w multiply squared residuals, so rows are scaled by √w):

* velocity / angular velocity limits of eq. (23), TEB interval penalty with margin ε; forward and
  lateral rows weighted by γ_forward, γ_lateral;
* acceleration / angular acceleration limits of eq. (23) (plus start and goal velocity rows when given);
* time optimality ΔT_i; attraction to the global path; repulsion from obstacles (lower bounds
  min_obstacle_distance with ε and inflation_distance on the distance field); via points; the
  yaw-change penalty; the differential-drive residual when `omnidirectional` is False.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from legplan.geometry.angles import wrap_angle
from legplan.geometry.polyline import arc_length
from legplan.nav.teb.band import Band
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.objective import Weighted, weighted
from legplan.nav.teb.problems import ProblemCache
from legplan.nav.teb.residuals import (BAND, AccelerationTerm, ClearanceTerm, NonholonomicTerm, PathTerm, TimeTerm,
                                       VelocityTerm, ViaPointTerm, YawChangeTerm, split_vector)
from legplan.nav.teb.resize import resize
from legplan.robots.navigation import KinodynamicLimits
from legplan.solve import LMParams, solve_lm

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ViaPoint:
    """A point the band passes through; `heading` (rad, NaN = free) is held there."""

    xy: tuple[float, float]
    heading: float = float("nan")


@dataclass
class Scene:
    """What the band is optimized against: global path, obstacle distance, via points, and the
    body-frame velocities at the start and goal (None = free)."""

    path: GlobalPath | None = None
    distance: DistanceField | None = None
    via: tuple[ViaPoint, ...] = ()
    start_velocity: np.ndarray | None = None
    goal_velocity: np.ndarray | None = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class RoundStats:
    poses: int
    iterations: int
    seconds: float
    initial_norm: float
    final_norm: float


@dataclass
class TebResult:
    band: Band
    rounds: list[RoundStats]
    seconds: float

    @property
    def iterations(self) -> int:
        return sum(r.iterations for r in self.rounds)


def optimize_band(band: Band, limits: KinodynamicLimits, params: TebParams = TebParams(),
                  scene: Scene = Scene(), cache: ProblemCache | None = None) -> TebResult:
    """Refine `band` by up to `params.outer_iterations` rounds of resize + LM (see module docstring;
    the rounds stop early when one no longer lowers ‖h‖ by `round_tolerance` and leaves a band
    that resizing would not change). Pass the same `cache` to successive calls (control cycles)
    to reuse their problems."""
    clock = time.perf_counter()
    cache = ProblemCache() if cache is None else cache
    rounds = []
    lm = LMParams(max_iterations=params.inner_iterations * params.tries_per_iteration, tolerance=0.0,
                  step_tolerance=params.step_tolerance, lambda_boost=params.lambda_boost, assembly="blocks")
    band = resize(band, params)
    for k in range(params.outer_iterations):
        t0 = time.perf_counter()
        problem = cache.problem(band, objective_terms(band, limits, params, scene), params.dt_min)
        result = solve_lm(problem, lm)
        poses, dt = split_vector(result.values[BAND], band.n)
        poses[:, 2] = wrap_angle(poses[:, 2])
        band = Band(poses, dt, band.fixed)
        resized = resize(band, params) if k + 1 < params.outer_iterations else band
        rounds.append(RoundStats(band.n, result.iterations, time.perf_counter() - t0, result.initial_norm, result.norm))
        settled = resized.n == band.n and np.array_equal(resized.dt, band.dt)
        if settled and result.initial_norm - result.norm <= params.round_tolerance * result.initial_norm:
            break
        band = resized
    log.debug("TEB: %d rounds, %d poses, %.1f ms", len(rounds), band.n, 1e3 * (time.perf_counter() - clock))
    return TebResult(band, rounds, time.perf_counter() - clock)


def objective_terms(band: Band, limits: KinodynamicLimits, params: TebParams, scene: Scene) -> list[Weighted]:
    """The weighted terms of eq. (24) (see module docstring); weights enter as √w."""
    n = band.n
    eps = params.epsilon
    m = n - 1
    v_lower = np.tile([-limits.v_x_min, -limits.v_y_max, -limits.omega_max], m)
    v_upper = np.tile([limits.v_x_max, limits.v_y_max, limits.omega_max], m)
    v_weight = np.tile(np.sqrt([params.weight_velocity * params.gamma_forward,
                                params.weight_velocity * params.gamma_lateral, params.weight_omega]), m)
    terms = [weighted(VelocityTerm(n), v_weight, v_lower, v_upper, eps)]
    accel = AccelerationTerm(n, scene.start_velocity, scene.goal_velocity)
    if accel.size:
        rows = accel.size // 3
        a_bound = np.tile([limits.a_x_max, limits.a_y_max, limits.alpha_max], rows)
        a_weight = np.tile(np.sqrt([params.weight_acceleration * params.gamma_forward,
                                    params.weight_acceleration * params.gamma_lateral, params.weight_alpha]), rows)
        terms.append(weighted(accel, a_weight, -a_bound, a_bound, eps))
    terms.append(weighted(TimeTerm(n), np.sqrt(params.weight_time)))
    if scene.path is not None and params.weight_path > 0:
        terms.append(weighted(_path_term(band, scene.path, params), np.sqrt(params.weight_path)))
    if scene.distance is not None:
        clearance = ClearanceTerm(n, scene.distance)
        terms.append(weighted(clearance, np.sqrt(params.weight_obstacle), params.min_obstacle_distance, np.inf, eps))
        if params.weight_inflation > 0:
            terms.append(weighted(clearance, np.sqrt(params.weight_inflation), params.inflation_distance, np.inf))
    if scene.via:
        via = _via_term(band, scene.via)
        if via is not None:
            k = len(via.index)
            terms.append(weighted(via, np.concatenate([np.full(2 * k, np.sqrt(params.weight_viapoint)),
                                                       np.full(len(via.with_heading),
                                                               np.sqrt(params.weight_via_heading))])))
    if params.weight_yaw_change > 0:
        terms.append(weighted(YawChangeTerm(n), np.sqrt(params.weight_yaw_change)))
    if not params.omnidirectional:
        terms.append(weighted(NonholonomicTerm(n), np.sqrt(params.weight_nonholonomic)))
    return terms


def _path_term(band: Band, path: GlobalPath, params: TebParams) -> PathTerm:
    """Attraction block; pose i searches the path within ±path_window of arc length around the
    point at the same fraction of the path's length as pose i is of the band's (chord) length. Band
    and path are the same curve up to local deviations, but not the same timing: the band is
    re-timed (time optimality), so a window placed by time fraction would miss the pose's stretch."""
    chord = arc_length(band.poses[:, :2])
    s_path = path.arc_length
    s_i = chord / max(chord[-1], 1e-12) * s_path[-1]
    first = np.searchsorted(s_path, s_i - params.path_window, side="right") - 1
    width = int(np.ceil(2 * params.path_window / path.spacing)) + 2
    return PathTerm(band.n, path.points, np.maximum(first, 0), width)


def _via_term(band: Band, via: tuple[ViaPoint, ...]) -> ViaPointTerm | None:
    """Each via point is assigned to its nearest free pose (re-assigned every round, as in TEB)."""
    free = np.flatnonzero(~band.fixed)
    if free.size == 0:
        return None
    points = np.array([v.xy for v in via], float)
    d = np.sum((band.poses[free, None, :2] - points[None]) ** 2, axis=2)
    index = free[np.argmin(d, axis=0)]
    return ViaPointTerm(band.n, index, points, [v.heading for v in via])


def limit_violations(band: Band, limits: KinodynamicLimits) -> dict[str, float]:
    """Largest excess over each Table I limit (≥ 0; 0 = satisfied), in the limit's units."""
    v = band.velocities()
    a = band.accelerations()
    out = {"v_x_max": v[:, 0].max(initial=0.0) - limits.v_x_max,
           "v_x_min": -v[:, 0].min(initial=0.0) - limits.v_x_min,
           "v_y_max": np.abs(v[:, 1]).max(initial=0.0) - limits.v_y_max,
           "omega_max": np.abs(v[:, 2]).max(initial=0.0) - limits.omega_max,
           "a_x_max": np.abs(a[:, 0]).max(initial=0.0) - limits.a_x_max,
           "a_y_max": np.abs(a[:, 1]).max(initial=0.0) - limits.a_y_max,
           "alpha_max": np.abs(a[:, 2]).max(initial=0.0) - limits.alpha_max}
    return {k: max(float(x), 0.0) for k, x in out.items()}
