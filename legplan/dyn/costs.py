"""The analytical costs of the TOWR-costs paper (Sec. III-A-1, III-A-2) as least-squares blocks.

Eq. (1), J_i = ∫_0^T (x_i − x_i^ref)² + ω_d ẋ_i² dt, over a cubic Hermite polynomial with node
values c = (p_a, v_a, p_b, v_b) is the quadratic form (c − c_ref)ᵀ(Q₀ + ω_d Q₁)(c − c_ref) with the
closed-form Gram matrices Q_d of `hermite_gram`, so it is exactly ‖L(c − c_ref)‖² with LᵀL = Q₀ + ω_d Q₁:
a linear residual block with a constant Jacobian, summed over the polynomials of the spline.
The terms (x_i and its reference):

* ``base_z_velocity`` — ż of the base (reference 0); its "derivative" term is z̈.
* ``base_angular_velocity`` — the Euler-angle rates ė (reference 0), which equal the body angular
  velocity to first order around a level base; derivative term ë.
* ``force`` — each stance force f (reference 0); derivative term ḟ.
* ``force_rate`` — ḟ alone (the force derivatives), derivative term f̈.
* ``normal_force`` — f_z minus m·g shared over the feet in stance at the polynomial's midpoint.

Force terms integrate f / (m·g), so that every weight is per unit of a dimensionless force, like the
motion terms' m/s and rad/s: a weight of 1 on a base moving at 0.1 m/s for 5 s costs 0.05.

``stair_edge`` (Sec. III-A-2): Σ exp(−d²/2σ²) over the footholds, d the distance to the nearest
terrain edge; as a residual exp(−d²/4σ²) per stance node. ``swing_height``: apex z minus each
adjacent stance z (the cost that keeps swings low; the constraint keeps them above a clearance).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.dyn.euler import complex_step
from legplan.dyn.formulation import Formulation
from legplan.dyn.terrain import TerrainModel
from legplan.geometry.hermite import NodeSpline, SampledJacobian, hermite_gram
from legplan.solve import ResidualBlock
from legplan.solve.blocks import LinearBlock

GRAVITY = 9.81


@functools.lru_cache(maxsize=256)
def _segment_factor(h: float, derivative: int, derivative_weight: float) -> np.ndarray:
    """L with LᵀL = Q₀ + ω_d Q₁ of eq. (1) on a segment of duration h (eigen-decomposition of the
    positive semi-definite 4 × 4 Gram matrix), read-only. Cached: a spline's segments share a few
    durations, and every task of a task space has the same ones (it was half of a pallet problem's
    build time)."""
    q = hermite_gram(h, derivative) + derivative_weight * hermite_gram(h, derivative + 1)
    w, v = np.linalg.eigh(q)
    L = np.sqrt(np.clip(w, 0.0, None))[:, None] * v.T
    L.flags.writeable = False
    return L


def integral_rows(spline: NodeSpline, axes: list[int], derivative: int, derivative_weight: float,
                  reference: list[float] | None = None, columns: int | None = None):
    """(L matrix over the flattened node array, offset) of eq. (1) on the Hermite segments of `spline`
    for the given axes: x = the `derivative`-th time derivative, its derivative weighted by ω_d.

    `reference` gives one constant x_ref per segment (only for derivative 0)."""
    rows, cols, vals, offset = [], [], [], []
    row = 0
    for k, seg in enumerate(spline.segments):
        if seg.constant:
            continue
        L = _segment_factor(seg.t1 - seg.t0, derivative, derivative_weight)
        ref = 0.0 if reference is None else reference[k]
        c_ref = L @ np.array([ref, 0.0, ref, 0.0])
        for axis in axes:
            node_cols = [6 * seg.a + axis, 6 * seg.a + 3 + axis, 6 * seg.b + axis, 6 * seg.b + 3 + axis]
            for i in range(4):
                rows += [row] * 4
                cols += node_cols
                vals += list(L[i])
                offset.append(c_ref[i])
                row += 1
    n_cols = 6 * spline.nodes if columns is None else columns
    return sp.csr_matrix((vals, (rows, cols)), shape=(row, n_cols)), np.array(offset)


@dataclass(frozen=True)
class CostWeights:
    """Weights ω_i of the paper's cost terms (0 = off) and their derivative weights ω_d."""

    base_z_velocity: float = 0.0
    base_angular_velocity: float = 0.0
    force: float = 0.0
    force_rate: float = 0.0
    normal_force: float = 0.0
    derivative_weight: float = 0.0  # ω_d of eq. (1), shared by the integral terms
    stair_edge: float = 0.0
    stair_edge_sigma: float = 0.05  # m
    swing_height: float = 0.0

    @property
    def active(self) -> bool:
        return any(getattr(self, k) > 0 for k in ("base_z_velocity", "base_angular_velocity", "force",
                                                  "force_rate", "normal_force", "stair_edge", "swing_height"))


def _embedded(matrix: sp.csr_matrix, offset_nodes: int, total_nodes: int) -> sp.csr_matrix:
    m = sp.csr_matrix(matrix)
    return sp.csr_matrix((m.data, m.indices + 6 * offset_nodes, m.indptr), shape=(m.shape[0], 6 * total_nodes))


def integral_costs(form: Formulation, w: CostWeights, mass: float) -> list[tuple[str, ResidualBlock, float]]:
    """The eq. (1) terms with a positive weight as (name, block, weight)."""
    out = []
    wd = w.derivative_weight
    if w.base_z_velocity > 0:
        m, b = integral_rows(form.base, [2], 1, wd)
        out.append(("base_z_velocity", LinearBlock(("base_lin",), [m], b), w.base_z_velocity))
    if w.base_angular_velocity > 0:
        m, b = integral_rows(form.base, [0, 1, 2], 1, wd)
        out.append(("base_angular_velocity", LinearBlock(("base_ang",), [m], b), w.base_angular_velocity))
    weight_force = mass * GRAVITY  # force terms are integrals of f / (m·g)
    for name, weight, derivative in (("force", w.force, 0), ("force_rate", w.force_rate, 1)):
        if weight > 0:
            parts = [_embedded(integral_rows(foot.force, [0, 1, 2], derivative, wd)[0], foot.force_offset,
                               form.force_nodes) for foot in form.feet]
            out.append((name, LinearBlock(("forces",), [sp.vstack(parts).tocsr() / weight_force]), weight))
    if w.normal_force > 0:
        mats, offsets = [], []
        for foot in form.feet:
            mids = [0.5 * (s.t0 + s.t1) for s in foot.force.segments]
            share = mass * GRAVITY / np.maximum(form.gait.contact(mids).sum(axis=1), 1)
            m, b = integral_rows(foot.force, [2], 0, wd, reference=list(share))
            mats.append(_embedded(m, foot.force_offset, form.force_nodes)), offsets.append(b)
        out.append(("normal_force", LinearBlock(("forces",), [sp.vstack(mats).tocsr() / weight_force],
                                                np.concatenate(offsets) / weight_force), w.normal_force))
    return out


class StairEdgeBlock(ResidualBlock):
    """exp(−d(x, y)²/4σ²) per stance node, d the distance to the nearest terrain edge (Sec. III-A-2)."""

    variables = ("feet",)

    def __init__(self, terrain: TerrainModel, selector: sp.csr_matrix, sigma: float):
        self.terrain, self.selector, self.sigma = terrain, sp.csr_matrix(selector), float(sigma)
        self.n = self.selector.shape[0]
        self.size = self.n
        self.jacobian = SampledJacobian([self.selector], 1, self.n, 3 * self.selector.shape[1])

    def _gauss(self, q):
        d = self.terrain.edge_distance(q[:, 0], q[:, 1])
        return np.exp(-d * d / (4 * self.sigma ** 2))[:, None]

    def evaluate(self, values, jacobians):
        q = self.selector @ np.asarray(values[0]).reshape(-1, 3)
        if not jacobians:
            return self._gauss(q)[:, 0], None
        r, (j,) = complex_step(self._gauss, (q,), (0,))
        return r[:, 0], [self.jacobian([j])]
