"""Motion primitives of the kinodynamic A* (Sec. III-A) and their vectorized expansion.

Inputs: the lattice {-u_max, -(μ-1)/μ u_max, …, 0, …, u_max}² of (2μ+1)² constant accelerations.
A primitive applies u_m for τ from (p0, v0): p(t) = u_m t²/2 + v0 t + p0 (eq. (6)), costing
(||u_m||² + ρ) τ (eq. (8)). `PrimitiveSet.expand` evaluates every primitive of a node at once:
positions and speeds at I + 1 samples (Sec. III-C / eq. (17): spacing v_max τ / I ≤ R per axis),
end states, hard-constraint mask and the collision cost of eq. (18), using one costmap gather.

Velocity is linear in t within a primitive, so its per-axis extrema are the end points: the start
(already feasible) and v0 + u_m τ. Acceleration is the constant u_m, within ±u_max by construction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from legplan.nav.collision import NavGrid


def input_lattice(mu: int, a_max: float) -> np.ndarray:
    """The (2μ+1)² inputs u_m as rows (M, 2), m/s²."""
    levels = np.linspace(-a_max, a_max, 2 * mu + 1)
    ux, uy = np.meshgrid(levels, levels, indexing="ij")
    return np.stack([ux.ravel(), uy.ravel()], axis=1)


def sample_count(v_max: float, duration: float, resolution: float) -> int:
    """I + 1 samples over `duration` so that v_max·duration / I ≤ resolution (eq. (17))."""
    return max(int(math.ceil(v_max * duration / resolution - 1e-9)), 1) + 1


@dataclass(frozen=True)
class PrimitiveSet:
    inputs: np.ndarray  # (M, 2)
    tau: float
    samples: int
    rho: float
    resolution: float  # m, of the grid the samples are checked on
    base_cost: np.ndarray = field(init=False)  # (M,) (||u||² + ρ) τ, eq. (8)
    _times: np.ndarray = field(init=False, repr=False)  # (S, 1)
    _half_ut2: np.ndarray = field(init=False, repr=False)  # (M, S, 2)
    _ut: np.ndarray = field(init=False, repr=False)  # (M, S, 2)
    _half_ut2_cells: np.ndarray = field(init=False, repr=False)  # (M, S, 2) in cells

    def __post_init__(self):
        t = np.linspace(0.0, self.tau, self.samples)[:, None]
        u = self.inputs[:, None, :]
        setter = object.__setattr__
        setter(self, "base_cost", ((self.inputs**2).sum(axis=1) + self.rho) * self.tau)
        setter(self, "_times", t)
        setter(self, "_half_ut2", 0.5 * u * t**2)
        setter(self, "_ut", u * t)
        setter(self, "_half_ut2_cells", self._half_ut2 / self.resolution)

    @classmethod
    def build(cls, mu: int, a_max: float, tau: float, v_max: float, resolution: float,
              rho: float) -> PrimitiveSet:
        return cls(input_lattice(mu, a_max), tau, sample_count(v_max, tau, resolution), rho,
                   resolution)

    def expand(self, grid: NavGrid, p0: np.ndarray, v0: np.ndarray, v_max: float, rho_c: float):
        """All children of (p0, v0): end positions (M, 2), end velocities (M, 2), edge costs (M,)
        including ρ_c × collision cost (eqs. (8), (18)), and the feasibility mask (M,)."""
        cells = grid.to_cells(p0) + (v0 / self.resolution) * self._times + self._half_ut2_cells
        index = grid.flat_index_cells(cells)
        velocities = v0 + self._ut
        end_v = velocities[:, -1]
        feasible = ~grid.blocked_flat[index].any(axis=1) & (np.abs(end_v).max(axis=1) <= v_max)
        cost = self.base_cost
        if rho_c:
            speed = np.sqrt((velocities * velocities).sum(axis=2))
            dt = self.tau / (self.samples - 1)
            cost = cost + (rho_c * dt) * (grid.cost_flat[index] * speed).sum(axis=1)
        end_p = p0 + v0 * self.tau + self._half_ut2[:, -1]
        return end_p, end_v, cost, feasible
