"""Parameters of the Bézier + Levenberg-Marquardt step planner (paper Table I plus documented extras).

Table I: N = 100, d_max = 10, MaxIt = 100, λ_init = 1, λ_drop = 0.1, λ_boost = 1.5, ε = 1 mm.
Extras (not in Table I, chosen here):

* `eps_num` (ε_num of Algorithm 1): SolveLM stops, and a degree is accepted, once ‖F̃_ε,N‖ ≤ ε_num
  (eq. (12)). 1e-5: every hinge row is then ≤ 10 µm (m or rad), every stance foot within
  slack_fraction·ε + 20 µm of its foothold at the samples. (1e-6 costs up to 100 more LM
  iterations in the linear-convergence tail for no visible gain.)
* `slack_fraction`: the slack bound of eq. (11b) at the samples is slack_fraction·ε, so that the
  curve between samples (checked on the dense re-sampling) stays within ε; 0.95 with N = 100.
* `clearance` = 2 cm (paper Sec. IV collision margin) for every sphere except stance feet; for
  swing-foot spheres it is relaxed within `relax_radius` = 5 cm of the swing leg's lift-off and
  touch-down positions, down to "the tip may touch, within ε" (`SampleConstraints`).
  `com_margin` = 0 (CoM inside the support polygon, Sec. II-B item 2).
* `clearance_headroom`: at the samples the swing-foot ramp rises to `clearance` +
  clearance_headroom / N (1 mm at N = 100; less near the footholds, where the ramp is lower), so
  that the curve between them keeps the ramp (as `slack_fraction` does for ε). The ramp has kinks
  (where it reaches `clearance`, and where the nearer end switches), so a swing foot crossing one
  between two samples comes closer than at both: on the box-swing test scene by 0.38 mm at
  N = 100 and 0.62 mm at N = 60 without headroom, still 0.25 mm at N = 60 with half this one.
  The other spheres need none: their distance is smooth along the path but for edges and corners,
  where it dips below the chord by ~(path step)²/(8·distance), a few µm (2.6 µm at most on the
  gap-crossing whole swings).
* `dense_samples`: parameters t at which the finished path is re-checked independently (≥ 1000);
  a step succeeds only when every constraint is kept there (`legplan.stepplan.measure.judged`):
  stance feet within ε, CoM margin, clearance with the swing-foot ramp and joint limits, the last
  three within `judge_tolerance`.
* `stall_window` (default 0 = off, Algorithm 1 as published): opt-in stall stop of SolveLM, a
  departure from Algorithm 1 — a degree is abandoned (next degree, Algorithm 1 line 4) once the
  decrease of ‖F̃‖ over the last `stall_window` iterations, extrapolated geometrically, cannot reach
  ε_num before MaxIt (`legplan.solve.LMParams.stall_window`). Use `--param stall_window=10`.
* `linear_solver`, `assembly`: passed to `legplan.solve.LMParams` (`assembly="blocks"` uses the
  structured JᵀJ of the Bézier block; "stacked" forms JᵀJ from the sparse Jacobian — the general path).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from legplan.errors import LegplanError
from legplan.specio import apply_overrides


@dataclass(frozen=True)
class StepPlanParams:
    samples: int = 100  # N of eq. (10): constraints are sampled at t_i = i/N, i = 1..N-1
    max_degree: int = 10  # d_max
    max_iterations: int = 100  # MaxIt of SolveLM
    lambda_init: float = 1.0
    lambda_drop: float = 0.1
    lambda_boost: float = 1.5
    epsilon: float = 1e-3  # ε of eq. (11b), m: allowed stance-foot deviation per foot
    eps_num: float = 1e-5  # ε_num of Algorithm 1
    slack_fraction: float = 0.95  # sample-level slack bound = slack_fraction·ε
    clearance: float = 0.02  # m, sphere-terrain margin
    clearance_headroom: float = 0.1  # m·N: swing feet keep clearance + clearance_headroom / N at the samples
    relax_radius: float = 0.05  # m, swing-foot margin relaxation around its footholds
    com_margin: float = 0.0  # m, CoM distance to every support-polygon edge
    dense_samples: int = 1000  # independent re-check of the finished path
    judge_tolerance: float = 1e-5  # m | rad, allowed dense miss of CoM margin, clearance, joint limits
    stall_window: int = 0  # opt-in SolveLM stall stop (departure from Algorithm 1); 0 = off
    linear_solver: str = "cholmod"
    assembly: str = "blocks"

    def __post_init__(self):
        checks = [("samples", self.samples >= 2), ("max_degree", self.max_degree >= 1),
                  ("max_iterations", self.max_iterations >= 0), ("epsilon", self.epsilon > 0),
                  ("eps_num", self.eps_num > 0), ("relax_radius", self.relax_radius > 0),
                  ("slack_fraction", 0 < self.slack_fraction <= 1), ("dense_samples", self.dense_samples >= 2),
                  ("judge_tolerance", self.judge_tolerance >= 0),
                  ("clearance_headroom", self.clearance_headroom >= 0),
                  ("lambda_init", self.lambda_init > 0), ("lambda_drop", 0 < self.lambda_drop < 1),
                  ("lambda_boost", self.lambda_boost > 1), ("stall_window", self.stall_window >= 0)]
        for name, ok in checks:
            if not ok:
                raise LegplanError(f"step planner parameter '{name}' out of range: {getattr(self, name)!r}")

    @classmethod
    def from_overrides(cls, overrides: dict[str, str] | None = None, source: str = "--param") -> StepPlanParams:
        """Defaults with `key=value` strings applied (`legplan.specio.apply_overrides`)."""
        return apply_overrides(cls, overrides, source, "step planner")

    @property
    def sample_clearance(self) -> float:
        """The largest clearance required at a sample (see `clearance_headroom`)."""
        return self.clearance + self.clearance_headroom / self.samples

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)
