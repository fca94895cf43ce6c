"""The centroidal planner's parameters, `DynParams`, declared once with their ranges (`legplan.parameters`),
the presets, and the one route that sets them: `dyn_params(costs, overrides)`.

Presets: ``paper`` — `PAPER`, the paper's costs with its swing-height and base-clearance
constraints; ``none`` — TOWR's formulation with our defaults, `DynParams()` (leg clearance and the
between-knot dynamics on). A costs file is one source of overrides: a YAML mapping of `CostWeights`
fields (missing fields are 0 = off) plus optional `swing_height_min`, `base_clearance` and
`leg_clearance` (m; null = off; missing = `DynParams()`'s); with `preset: NAME` the missing fields are
the preset's instead (null still switches a constraint off), e.g.

    base_angular_velocity: 20.0
    force_rate: 1.0e-4
    swing_height_min: 0.05

or the paper's settings with the legs kept 6 cm off the terrain:

    preset: paper
    leg_clearance: 0.06

`--param KEY=VALUE` (repeatable) is the other: any field, nested ones by dotted name
(`--param dt=0.05`, `--param costs.force=0.5`, `--param solver.inner.max_iterations=30`), the value
converted to the field's declared type (`null` switches an optional constraint off). Both go through
`legplan.specio.override`, the one route of every stage's parameters: unknown fields, wrong types and
values outside the declared range are one-line errors naming the file (or `--param`) and the field.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

from legplan.dyn.costs import CostWeights
from legplan.errors import LegplanError
from legplan.parameters import Parameters, param
from legplan.solve.auglag import ALParams
from legplan.solve.hinged import HingedParams
from legplan.specio import FieldReader, override, read_yaml_mapping

WARM_STAGES = ("costs", "projection", "polish")
ACCURATE_MODEL_DECREASE = 1e-2
"""`HingedParams.lambda_decrease` of a projection: λ falls by up to this factor after a step whose gain
ratio ρ is near 1. Near a feasible point the constraints are nearly linear and the hinge model exact, so
ρ ≈ 1 at every step, yet Nielsen's update lowers λ by at most a factor 3: a Marquardt-damped step keeps
the share λ/(σ² + λ) of the residual's component along each scaled singular value σ of J (eq. (13)),
and where the residual lies along σ² near λ each accepted step removes only part of it. Marquardt's own
rule divides λ by 10 or more after a success; here the fast decrease is taken only where the model
predicted the decrease (ρ near 1), while λ₀ stays as it is: the first step from a guess still damps
the directions J determines weakly, which keeps the guess's shape."""


@dataclass(frozen=True)
class DynParams(Parameters):
    """Discretization (TOWR's, with `dt_range` halved and the box shrunk by `range_margin` for what
    remains between the samples), our between-node sampling, the paper's additions, the stages'
    solvers (`legplan.dyn.planner`).

    Points every `swing_dt` (at most) inside each swing polynomial keep the foot above the terrain
    between nodes (`swing_clearance` above its column envelope) and inside its range of motion. The
    force bounds and the friction pyramid hold at the Bézier control points of every force
    polynomial, hence along all of it (the terrain normal is that of the stance foothold, constant
    over the stance). `stance_slope_max` bounds `TerrainModel.stance_slope` (the smoothed terrain
    slope) under every free stance foothold, which keeps footholds off the heightmap's edge ramps,
    where the terrain normal tilts so far that the friction pyramid cannot carry the weight and the
    raw slope gives the solver no direction off the ramp.
    """

    what = "dyn planner"

    dt: float = param(0.1, "(0, inf)", "Δt", "s: spacing of the base spline's nodes (TOWR's)")
    dynamics_points: int = param(10, "[1, 1000]", doc=(
        "points per base interval (the knot that opens it included, equally spaced) at which the "
        "Newton–Euler rows are constrained: to zero at the knots (TOWR's collocation), inside "
        "±dynamics_band at the others (1: TOWR's alone). Between the knots the base acceleration is "
        "linear while the forces are cubics that vanish at every touchdown and lift-off, so equality "
        "along a whole interval over-constrains the problem; a band bounds what the executing "
        "controller must absorb at the times it executes"))
    dynamics_band: float = param(0.04, "(0, 1]", doc=(
        "share of m·g (force rows) and of m·g·ℓ (torque rows, ℓ the largest horizontal distance of a "
        "nominal foot from the CoM) the Newton–Euler residual may reach between the knots; below the "
        "independent check's bound by a margin for the solver's tolerance"))
    unloaded_polynomials: int | None = param(8, "[1, 1000]", doc=(
        "base polynomials (at least) in every phase next to a boundary where no foot stays in contact "
        "(formulation.unloaded_phases: a trot's support pairs), whose summed force rises from or falls "
        "to zero; the knots then sit at every phase boundary of the gait's timing (formulation.phase_knots), "
        "or, with optimize_phases, which moves the phases, are spaced evenly as densely everywhere "
        "(formulation.dense_knots). None = knots every dt, as for gaits without such phases"))
    unloaded_dt: float = param(0.035, "(0, inf)", doc=(
        "s: the longest base polynomial in those phases (formulation.phase_knots): a slow trot's long "
        "pairs get more than unloaded_polynomials"))
    phase_knots: bool = param(False, (False, True), doc=(
        "base knots at the gait's phase boundaries too (formulation.phase_knots), not only evenly "
        "spaced: the contact set is then constant on every base polynomial"))
    dt_range: float = param(0.04, "(0, inf)", doc="s: spacing of the range-of-motion samples")
    range_margin: float = param(0.002, "[0, inf)", doc="m: the range-of-motion box shrunk by this at the samples")
    swing_dt: float = param(0.01, "(0, inf)", doc="s: largest spacing of the samples inside a swing")
    swing_clearance: float = param(0.0, "[0, inf)", doc="m: swing feet above the terrain's column envelope")
    stance_slope_max: float | None = param(0.5, "(0, inf)",
                                           doc="largest smoothed terrain slope under a free foothold; None = off")
    towr_swing: bool = param(False, (False, True), doc=(
        "TOWR's swing constraint (apex x, y halfway between the footholds, apex velocity = step / swing "
        "time): a regularizer that can over-constrain a tight gait; the planner's second attempt "
        "switches it"))
    cost_solver: ALParams = param(
        ALParams(mu_init=10.0, cost_tolerance=1e-2,
                 inner=HingedParams(max_iterations=20, tolerance=0.0, function_tolerance=1e-3)),
        doc="the costs stage from a feasible point: short subproblems let the multipliers follow, a "
            "moderate μ₀ keeps the feasible start")
    warm_solver: ALParams = param(
        ALParams(mu_init=1e3, cost_tolerance=1e-2, multipliers="least_squares",
                 inner=HingedParams(max_iterations=5, tolerance=0.0, function_tolerance=1e-3)),
        doc="the costs from a near-solution guess: multipliers estimated at the guess, a stiff penalty "
            "and short subproblems keep the steps near the constraints")
    warm_stage: str = param("costs", WARM_STAGES, doc=(
        "from a near-solution guess: 'costs' the whole problem by warm_solver; 'projection' the "
        "constraints alone by projection_solver (the plan keeps the guess's shape); 'polish' the "
        "projection, then the costs where it costs more than the initializer's training filter kept "
        "(eq. (4))"))
    polish_tolerance: float = param(2.0, "[0, inf)", doc=(
        "'polish' optimizes the costs of a projected plan that costs more than ĝ(x) + this × the "
        "threshold of the network's training filter (eq. (4); 1: the filter's own bound)"))
    costs: CostWeights = param(CostWeights(), doc="the paper's cost weights (Sec. III-A-1, III-A-2)")
    swing_height_min: float | None = param(None, "[0, inf)",
                                           doc="m: swing apex above both adjacent footholds (paper); None = off")
    base_clearance: float | None = param(0.005, "[0, inf)", doc=(
        "m: base z minus every foot's z, leg by leg at its samples (the paper's rows; its preset 0.2): on "
        "by default, since the independent check judges `base_above_feet` >= 0 on every plan, with a margin "
        "for the solver's feasibility tolerance; None = off"))
    leg_clearance: float | None = param(0.02, "[0, inf)", doc=(
        "m: the surfaces of the legs' collision spheres (all but the feet) stay this far above the "
        "terrain's envelope at the range-of-motion samples (LegClearanceBlock): on by default, since the "
        "independent check judges every leg sphere against the terrain, with a margin for the tracking "
        "error of the executing controller; None = off"))
    line_support: float | None = param(1.6, "(0, inf)", doc=(
        "× √(h/g) (h the model's base height): the longest a trot stands on one diagonal pair; a trot "
        "scaled to longer pairs gets four-leg support in place of the pairs' excess and its flights "
        "(`legplan.dyn.gait`, a slow trot with overlapping pairs), below the independent check's "
        "`line_support` bound, since the executing controller cannot balance longer on the line "
        "between two feet; above the pairs of the flying trots that execute (a flying trot within it "
        "keeps its flights); None = the pairs as scaled"))
    torque_margin: float = param(0.05, "[0, 1)", doc=(
        "share of each joint's torque limit (Centroidal.torque_limits) the planned forces leave free "
        "(JointTorqueBlock): for what the legs' own motion and the controller's corrections need on "
        "top of holding the contact forces, which the independent check judges against the full limit"))
    solver: ALParams = param(
        ALParams(inner=replace(ALParams().inner, geodesic_acceleration=0.0)),
        doc="the feasibility stages (the constraints alone); no geodesic acceleration: on these problems "
            "the curvature probe's acceleration is refused (2‖a‖ > α‖d‖) at the first, strongly curved "
            "steps and negligible at the later ones, while each probe costs a residual evaluation")
    projection_solver: ALParams = param(
        ALParams(exact_rows=True, inner=replace(ALParams().inner, lambda_decrease=ACCURATE_MODEL_DECREASE)), doc=(
            "the 'projection' warm stage and the projections after a warm costs stage or of a replan: "
            "the constraints alone, stopped by the exact per-row test (a last stage: no next stage "
            "profits from more precision), from a start near a feasible point: λ falls fast after a step "
            "the model predicted (`ACCURATE_MODEL_DECREASE`)"))
    optimize_phases: bool = param(False, (False, True), doc=(
        "optimize the phase durations too (2S more variables, `legplan.dyn.timing`); a guess with "
        "durations sets the timing either way (kept fixed without this)"))
    phase_min: float = param(0.2, "(0, inf)", doc="s: the shortest phase of a foot when the durations are optimized")
    iteration_budget: int | None = param(None, "[0, 100000]", "N", doc=(
        "LM iterations of the whole plan, all stages together (Algorithm 1's N: N_h = 100, N_θ = 25); "
        "None = each stage's own cap"))


PAPER_COSTS = CostWeights(base_z_velocity=1.0, base_angular_velocity=1.0, force=1.0, force_rate=0.01,
                          normal_force=1.0, derivative_weight=0.01, stair_edge=1.0, stair_edge_sigma=0.05,
                          swing_height=1.0, stance_width=100.0)
"""Weights of the "paper" preset (the paper gives none; force terms in units of m·g, see
`legplan.dyn.costs`), with our `stance_width` term: with the Newton–Euler rows held between the knots,
the angular-velocity term alone draws a trot's footholds in under the base (`legplan.dyn.costs`)."""

PAPER = DynParams(costs=PAPER_COSTS, swing_height_min=0.05, base_clearance=0.2)
"""The paper's additions (Sec. III-A-1, III-A-2): its costs, swing apexes 5 cm above both adjacent
footholds, the base 20 cm above every foot (below the nominal 0.42 m, so that the range of motion
leaves room when the base pitches on a climb)."""

PRESETS = {"paper": PAPER, "none": DynParams()}
CONSTRAINT_FIELDS = ("swing_height_min", "base_clearance", "leg_clearance")


def costs_file(costs: str) -> Path | None:
    """The costs file `--costs` names, or None for a preset."""
    return None if costs in PRESETS else Path(costs)


def dyn_params(costs: str, overrides: dict | None = None) -> DynParams:
    """The planner parameters of `--costs` (a preset name or a costs file, see module docstring) with
    `overrides` (`--param`: dotted field names, values as text or as Python values) applied."""
    path = costs_file(costs)
    if path is None:
        params = PRESETS[costs]
    elif not path.is_file():
        raise LegplanError(f"--costs: '{costs}' is neither a preset ({', '.join(PRESETS)}) nor a file")
    else:
        params = _read_costs_file(path)
    if overrides:
        params = override(params, overrides, FieldReader("--param"))
    return params


def _read_costs_file(path: Path) -> DynParams:
    data = read_yaml_mapping(path, "costs file")
    reader = FieldReader(path)
    weights = [f.name for f in fields(CostWeights)]
    reader.unknown(data, ("preset", *weights, *CONSTRAINT_FIELDS))
    base = PRESETS[reader.choice(data["preset"], "preset", tuple(PRESETS))] if "preset" in data else DynParams()
    costs = override(base.costs, {name: data[name] for name in weights if name in data}, reader)
    return override(dataclasses.replace(base, costs=costs), {name: data[name] for name in CONSTRAINT_FIELDS
                                                            if name in data}, reader)


def settings_record(costs: str, init: str, params: DynParams) -> dict:
    """The JSON-able settings of a run: `--costs` as given, `--init`, and every planner parameter."""
    return {"costs": os.fspath(costs), "init": init, "dyn": asdict(params)}
