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
  ε_num before MaxIt (`legplan.solve.LMParams.stall_window`). Use `--param stall_window=10`. It
  changes the start of every later degree, so most swings then end at a higher degree:
  `bench/swing_stops.py` sets it, and degree-2 passes cut at a fixed iteration (what any early
  termination test of that pass gives), against Algorithm 1 on every whole swing.
* `linear_solver`, `assembly`: passed to `legplan.solve.LMParams` (`assembly="blocks"` uses the
  structured JᵀJ of the Bézier block, whose dense pieces reach the Schur elimination without a sparse
  JᵀJ being assembled, `legplan.solve.SchurParts`; "stacked" forms JᵀJ from the sparse Jacobian — the
  general path).
  `linear_solver="dense"`: LM eliminates the slacks (Schur complement), and what is left, (d − 1)·nx
  control-point unknowns that every sample couples, is a small dense matrix, for which LAPACK's
  Cholesky costs less than CHOLMOD and the conversion to a sparse matrix it needs. The choice of
  factorisation changes rounding only, not Algorithm 1.
"""

from __future__ import annotations

from dataclasses import dataclass

from legplan.parameters import Parameters, param
from legplan.specio import apply_overrides


@dataclass(frozen=True)
class StepPlanParams(Parameters):
    what = "step planner"

    samples: int = param(100, "[2, 100000]", "N", "eq. (10): constraints are sampled at t_i = i/N, i = 1..N-1")
    max_degree: int = param(10, "[1, 50]", "d_max")
    max_iterations: int = param(100, "[1, 1000000]", "MaxIt", "of SolveLM")
    lambda_init: float = param(1.0, "(0, inf)", "λ_init")
    lambda_drop: float = param(0.1, "(0, 1)", "λ_drop")
    lambda_boost: float = param(1.5, "(1, inf)", "λ_boost")
    epsilon: float = param(1e-3, "(0, inf)", "ε", "eq. (11b), m: allowed stance-foot deviation per foot")
    eps_num: float = param(1e-5, "(0, inf)", "ε_num", "of Algorithm 1")
    slack_fraction: float = param(0.95, "(0, 1]", doc="sample-level slack bound = slack_fraction·ε")
    clearance: float = param(0.02, "[-1, 10]", doc="m, sphere-terrain margin")
    clearance_headroom: float = param(0.1, "[0, inf)",
                                      doc="m·N: swing feet keep clearance + clearance_headroom / N at the samples")
    relax_radius: float = param(0.05, "(0, inf)", doc="m, swing-foot margin relaxation around its footholds")
    com_margin: float = param(0.0, "[-1, 10]", doc="m, CoM distance to every support-polygon edge")
    dense_samples: int = param(1000, "[2, 10000000]", doc="independent re-check of the finished path")
    judge_tolerance: float = param(1e-5, "[0, inf)",
                                   doc="m | rad, allowed dense miss of CoM margin, clearance, joint limits")
    stall_window: int = param(0, "[0, 1000000]", doc="opt-in SolveLM stall stop (departure from Algorithm 1); 0 = off")
    linear_solver: str = "dense"
    assembly: str = "blocks"

    @classmethod
    def from_overrides(cls, overrides: dict[str, str] | None = None, source: str = "--param") -> StepPlanParams:
        """Defaults with `key=value` strings applied (`legplan.specio.apply_overrides`)."""
        return apply_overrides(cls, overrides, source, "step planner")

    @property
    def sample_clearance(self) -> float:
        """The largest clearance required at a sample (see `clearance_headroom`)."""
        return self.clearance + self.clearance_headroom / self.samples
