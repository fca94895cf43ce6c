"""Motion primitives of the kinodynamic A* (Sec. III-A) and their vectorized expansion.

Inputs: the lattice {-u_max, -(μ-1)/μ u_max, …, 0, …, u_max}² of (2μ+1)² constant accelerations.
A primitive applies u_m for τ from (p0, v0): p(t) = u_m t²/2 + v0 t + p0 (eq. (6)), costing
(||u_m||² + ρ) τ (eq. (8)). `PrimitiveSet.expand` evaluates every primitive of a node at once.

Everything a child needs before the costmap lookup — the sample positions in cell units and the
sample velocities at I + 1 times (Sec. III-C / eq. (17): spacing v_max τ / I ≤ R per axis), its end
position and end velocity — is affine in the node state (p0, v0), so it is a single product
[1, p0x, p0y, v0x, v0y] · E with a matrix E built once per search. One gather from the grid's
hard-cost array (costmap value, +inf on blocked cells) then yields both the hard constraint and
the collision cost of eq. (18): Σ_i F(p_i)·||v_i||·dt is finite exactly when no sample is blocked.

Velocity is linear in t within a primitive, so its per-axis extrema are the end points: the start
(already feasible) and v0 + u_m τ. Acceleration is the constant u_m, within ±u_max by construction.
"""

from __future__ import annotations

import math

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


class PrimitiveSet:
    """The M primitives of duration τ on one grid, with the per-search constants of `expand`."""

    def __init__(self, inputs: np.ndarray, tau: float, v_max: float, rho: float, rho_c: float,
                 grid: NavGrid):
        self.inputs = np.asarray(inputs, float)  # (M, 2)
        self.tau, self.v_max = float(tau), float(v_max)
        self.samples = sample_count(v_max, tau, grid.resolution)
        self.base_cost = ((self.inputs**2).sum(axis=1) + rho) * tau  # (M,) eq. (8)
        self.collision_weight = rho_c * (tau / (self.samples - 1))  # ρ_c·dt of eqs. (18), (19)
        self.grid = grid
        ny, nx = grid.shape
        self._upper = np.array([nx + 1, ny + 1], float)[:, None, None]
        self._row = nx + 2
        self._basis = self._affine_map(grid)

    @classmethod
    def build(cls, params, grid: NavGrid) -> PrimitiveSet:
        """The lattice of `params.mu`, `params.a_max` with the limits and weights of `params`."""
        return cls(input_lattice(params.mu, params.a_max), params.tau, params.v_max, params.rho,
                   params.rho_c, grid)

    def _affine_map(self, grid: NavGrid) -> np.ndarray:
        """E (5, 4·M·S + 5·M): [1, p0x, p0y, v0x, v0y] · E = sample cells x, y (`to_cells` of
        p0 + v0 t + u t²/2), sample velocities x, y (v0 + u t), each (M, S), then the children
        rows px, py, vx, vy (end state) and the base cost (||u||² + ρ)τ, each (M,)."""
        M, S = len(self.inputs), self.samples
        t = np.linspace(0.0, self.tau, S)
        inv_r = 1.0 / grid.resolution
        samples = np.zeros((5, 4, M, S))
        children = np.zeros((5, 5, M))
        for axis in range(2):
            u = self.inputs[:, axis, None]
            cells, velocity = samples[:, axis], samples[:, 2 + axis]
            end_p, end_v = children[:, axis], children[:, 2 + axis]
            cells[0] = 0.5 * u * t**2 * inv_r + 1.5 - grid.origin[axis] * inv_r
            cells[1 + axis] = inv_r
            cells[3 + axis] = t * inv_r
            velocity[0] = u * t
            velocity[3 + axis] = 1.0
            end_p[0] = 0.5 * u[:, 0] * self.tau**2
            end_p[1 + axis] = 1.0
            end_p[3 + axis] = self.tau
            end_v[0] = u[:, 0] * self.tau
            end_v[3 + axis] = 1.0
        children[0, 4] = self.base_cost
        return np.concatenate([samples.reshape(5, -1), children.reshape(5, -1)], axis=1)

    def expand(self, px: float, py: float, vx: float, vy: float):
        """All children of the node (px, py, vx, vy): a (5, M) block with rows px, py, vx, vy (end
        state) and edge cost (eq. (8) plus ρ_c × the collision cost of eq. (18); not finite when a
        sample is blocked), and the feasibility mask (M,) (no blocked sample, |v_end| ≤ v_max per
        axis). Call under `np.errstate(invalid="ignore")` (a blocked sample at zero speed: ∞·0)."""
        M, S = len(self.inputs), self.samples
        out = np.dot(np.array([1.0, px, py, vx, vy]), self._basis)
        samples = out[:4 * M * S].reshape(4, M, S)
        children = out[4 * M * S:].reshape(5, M)
        cells = np.fmin(np.fmax(samples[:2], 0.0), self._upper).astype(np.intp)
        hard = self.grid.hard_cost_flat[cells[1] * self._row + cells[0]]
        collision = np.vecdot(hard, np.hypot(samples[2], samples[3]))
        children[4] += self.collision_weight * collision
        speed = np.abs(children[2:4])
        feasible = (np.maximum(speed[0], speed[1]) <= self.v_max) & (collision < np.inf)
        return children, feasible
