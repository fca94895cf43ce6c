"""Parameters of the nav search (kinodynamic A*, Sec. III, and the grid A* reference).

Limits. The paper plans p, ṗ in the world frame with |v_d| ≤ v_max and |a_d| ≤ u_max per axis
d ∈ {x, y} (U = [-u_max, u_max]², Sec. III-A) and leaves heading to the TEB back end. We take the
forward limits of Table I for both axes: v_max = v_x max = 0.75 m/s, a_max = a_x max = 1.0 m/s²
(the robot turns to face its direction of travel; the lateral limits 0.20 m/s, 0.17 m/s² bound
only side-stepping, which TEB handles). Per-axis bounds let a diagonal motion reach √2·v_max; set
`v_max` lower with `--param` if the speed itself must stay below 0.75 m/s.

Search. `mu` gives (2μ+1)² inputs of duration `tau` (eq. (6)); `rho` weighs time against effort
(eq. (5)); `rho_c` weighs the collision cost (eq. (19)); `weight` ≥ 1 multiplies the heuristic
(weighted A*, cost ≤ weight × optimal on the lattice); `geodesic_bound` (default on) adds an
obstacle-aware lower bound of the time to the goal to the heuristic (`heuristic.GeodesicTimeBound`:
one breadth-first search over the map per query; it keeps h admissible and consistent, so the
weight's bound holds, and makes streets and aisles cheap to search); `restarts` lets a search that
stalls restart with weight 1.5× then 2.5× (`kinoastar`, bound: the weight that found the path).
States are hashed on a grid of
`pos_res` (m) × `vel_res` (m/s). Nodes within `oneshot_radius` of the goal try the analytic
expansion. `goal_tolerance`/`goal_vel_tolerance` > 0 also accept a node that lands that close to
the goal state (the tests use it for exact lattice goals).

Budget. `max_expansions` > 0 caps the expansions of either planner; 0 (default) scales the cap with
the map: one expansion per map cell, at least `MIN_EXPANSIONS` (`expansion_budget`). Grid A* expands
each cell at most once, so the scaled cap never stops it early; the kinodynamic search with the
geodesic bound needs a few expansions per cell of its route (nav_scale in `BENCHMARKS.md`).
"""

from __future__ import annotations

from dataclasses import dataclass

from legplan.parameters import Parameters, param
from legplan.specio import apply_overrides

MIN_EXPANSIONS = 200_000  # the auto budget's floor (the former fixed limit)


@dataclass(frozen=True)
class NavParams(Parameters):
    what = "nav"

    v_max: float = param(0.75, "(0, inf)", "v_max", "m/s per axis (Table I v_x max)")
    a_max: float = param(1.0, "(0, inf)", "u_max", "m/s² per axis (Table I a_x max)")
    mu: int = param(2, "[1, 20]", "μ", "(2μ+1)² motion primitives")
    tau: float = param(0.4, "(0, 3600]", "τ", "s, primitive duration")
    rho: float = param(1.0, "(0, inf)", "ρ", "time weight of eq. (5)")
    rho_c: float = param(0.01, "[0, inf)", "ρ_c", "collision-cost weight of eq. (19) (C_max = 100 → ρ_c·F ≤ 1)")
    weight: float = param(2.0, "[1, inf)",
                          doc="heuristic weight (1 = A*); cost ≤ weight (restarts: 2.5·weight) × opt.")
    time_bound: bool = True  # heuristic minimizes over T ≥ max|Δp_d| / v_max
    geodesic_bound: bool = True  # ... and over T ≥ the time around obstacles (one BFS per query)
    restarts: bool = True  # with geodesic_bound: restart a stalled search with a larger weight
    pos_res: float = param(0.1, "(0, inf)", doc="m, state hash grid")
    vel_res: float = param(0.2, "(0, inf)", doc="m/s, state hash grid")
    oneshot_radius: float = param(5.0, "[0, inf)", doc="m")
    goal_tolerance: float = param(0.0, "[0, inf)", doc="m")
    goal_vel_tolerance: float = param(0.0, "[0, inf)", doc="m/s")
    max_expansions: int = param(0, "[0, 100000000]", doc="0: scale with the map (`expansion_budget`)")

    @classmethod
    def for_robot(cls, navigation) -> NavParams:
        """Defaults with v_max, a_max from a robot's `navigation.limits` (forward values)."""
        limits = navigation.limits
        return cls(v_max=float(limits.v_x_max), a_max=float(limits.a_x_max))

    def expansion_budget(self, cells: int) -> int:
        """The expansion cap on a map of `cells` cells: `max_expansions`, or when 0 the larger of
        `cells` and `MIN_EXPANSIONS` (module doc)."""
        return self.max_expansions or max(cells, MIN_EXPANSIONS)

    def with_overrides(self, overrides: dict[str, str], source: str = "--param") -> NavParams:
        """A copy with `key=value` text overrides converted to each field's type
        (`legplan.specio.apply_overrides`)."""
        return apply_overrides(self, overrides, source, "nav")
