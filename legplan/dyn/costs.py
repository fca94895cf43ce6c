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

With the phase durations optimized, the force terms' polynomials change length with them:
`TimedForceIntegralBlock` is the same quadratic form with its Jacobian in the durations too.

``stair_edge`` (Sec. III-A-2): Σ exp(−d²/2σ²) over the footholds, d the distance to the nearest
terrain edge; as a residual exp(−d²/4σ²) per stance node. ``swing_height``: apex z minus each
adjacent stance z (the cost that keeps swings low; the constraint keeps them above a clearance).

``stance_width`` (ours): each foothold's lateral offset from the base, in the base's heading frame at
the middle of its stance, minus the nominal stance's. Where the Newton–Euler rows hold between the
knots, a diagonal support pair can balance the weight's moment about its line only by horizontal
forces, by turning the base, or by footholds drawn in under the base; with the angular-velocity and
force terms on, the last is free, and the plan narrows its stance until the executed trot falls
over its support line. This term prices that third way.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from legplan.dyn.euler import complex_step
from legplan.dyn.formulation import Formulation
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import invalid_timing
from legplan.geometry.hermite import NodeSpline, SampledJacobian, hermite_gram
from legplan.parameters import Parameters, param
from legplan.solve import ResidualBlock
from legplan.solve.auglag import CostTerm
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

    `reference` gives one constant x_ref per segment (only for derivative 0). Rows: segment after
    segment, axis after axis, the 4 rows of L."""
    segments = [(k, seg) for k, seg in enumerate(spline.segments) if not seg.constant]
    count, axes = len(segments), np.asarray(axes)
    L = np.array([_segment_factor(seg.t1 - seg.t0, derivative, derivative_weight)
                  for _, seg in segments]).reshape(count, 4, 4)
    ref = np.zeros(count) if reference is None else np.asarray(reference, float)[[k for k, _ in segments]]
    c_ref = (L[:, :, 0] + L[:, :, 2]) * ref[:, None]  # L (ref, 0, ref, 0)
    a, b = (6 * np.array([getattr(seg, end) for _, seg in segments], int).reshape(count, 1) for end in "ab")
    node_cols = np.hstack([a, a + 3, b, b + 3])  # (p_a, v_a, p_b, v_b) of axis 0
    shape = (count, axes.size, 4, 4)  # segment, axis, row of L, node column
    cols = np.broadcast_to(node_cols[:, None, None, :] + axes[None, :, None, None], shape).reshape(-1)
    vals = np.broadcast_to(L[:, None], shape).reshape(-1)
    rows = np.repeat(np.arange(count * axes.size * 4), 4)
    n_cols = 6 * spline.nodes if columns is None else columns
    return (sp.csr_matrix((vals, (rows, cols)), shape=(count * axes.size * 4, n_cols)),
            np.broadcast_to(c_ref[:, None, :], shape[:3]).reshape(-1))


@dataclass(frozen=True)
class CostWeights(Parameters):
    """Weights ω_i of the paper's cost terms (0 = off) and their derivative weight ω_d (module docstring)."""

    what = "cost weight"

    base_z_velocity: float = param(0.0, "[0, inf)", "ω", "∫ ż² + ω_d z̈² of the base (eq. (1))")
    base_angular_velocity: float = param(0.0, "[0, inf)", "ω", "∫ ‖ė‖² + ω_d ‖ë‖² of the base's Euler rates (eq. (1))")
    force: float = param(0.0, "[0, inf)", "ω", "∫ ‖f‖² + ω_d ‖ḟ‖² of every stance force, in m·g (eq. (1))")
    force_rate: float = param(0.0, "[0, inf)", "ω", "∫ ‖ḟ‖² + ω_d ‖f̈‖², in m·g/s (eq. (1))")
    normal_force: float = param(0.0, "[0, inf)", "ω", "∫ (f_z − m·g / stance feet)² + ω_d ḟ_z², in m·g (eq. (1))")
    derivative_weight: float = param(0.0, "[0, inf)", "ω_d", "weight of the derivative in every integral term")
    stair_edge: float = param(0.0, "[0, inf)", "ω", "Σ exp(−d²/2σ²) over the footholds, d to the nearest edge")
    stair_edge_sigma: float = param(0.05, "(0, inf)", "σ", "m: the width of the stair-edge term")
    swing_height: float = param(0.0, "[0, inf)", "ω", "swing apex z above each adjacent foothold, squared")
    stance_width: float = param(0.0, "[0, inf)", "ω", (
        "each foothold's lateral offset from the base (in its heading frame, at the stance's middle) "
        "minus the nominal stance's, squared (m²; ours, not the paper's)"))

    @property
    def active(self) -> bool:
        return any(getattr(self, k) > 0 for k in ("base_z_velocity", "base_angular_velocity", "force",
                                                  "force_rate", "normal_force", "stair_edge", "swing_height",
                                                  "stance_width"))


def _embedded(matrix: sp.csr_matrix, offset_nodes: int, total_nodes: int) -> sp.csr_matrix:
    m = sp.csr_matrix(matrix)
    return sp.csr_matrix((m.data, m.indices + 6 * offset_nodes, m.indptr), shape=(m.shape[0], 6 * total_nodes))


def integral_costs(form: Formulation, w: CostWeights, mass: float, timing=None) -> list[CostTerm]:
    """The eq. (1) terms with a positive weight as `CostTerm`s; with a `PhaseTiming` the force terms
    are `TimedForceIntegralBlock`s."""
    if timing is not None:
        out = integral_costs(form, replace(w, force=0.0, force_rate=0.0, normal_force=0.0), mass)
        for name, weight, axes, derivative in (("force", w.force, [0, 1, 2], 0), ("force_rate", w.force_rate, [0, 1, 2], 1),
                                               ("normal_force", w.normal_force, [2], 0)):
            if weight > 0:
                block = TimedForceIntegralBlock(timing, axes, derivative, w.derivative_weight, mass, name == "normal_force")
                out.append(CostTerm(name, block, weight))
        return out
    out = []
    wd = w.derivative_weight
    if w.base_z_velocity > 0:
        m, b = integral_rows(form.base, [2], 1, wd)
        out.append(CostTerm("base_z_velocity", LinearBlock(("base_lin",), [m], b), w.base_z_velocity))
    if w.base_angular_velocity > 0:
        m, b = integral_rows(form.base, [0, 1, 2], 1, wd)
        out.append(CostTerm("base_angular_velocity", LinearBlock(("base_ang",), [m], b), w.base_angular_velocity))
    weight_force = mass * GRAVITY  # force terms are integrals of f / (m·g)
    for name, weight, derivative in (("force", w.force, 0), ("force_rate", w.force_rate, 1)):
        if weight > 0:
            parts = [_embedded(integral_rows(foot.force, [0, 1, 2], derivative, wd)[0], foot.force_offset,
                               form.force_nodes) for foot in form.feet]
            out.append(CostTerm(name, LinearBlock(("forces",), [sp.vstack(parts).tocsr() / weight_force]), weight))
    if w.normal_force > 0:
        mats, offsets = [], []
        for foot in form.feet:
            mids = [0.5 * (s.t0 + s.t1) for s in foot.force.segments]
            share = mass * GRAVITY / np.maximum(form.gait.contact(mids).sum(axis=1), 1)
            m, b = integral_rows(foot.force, [2], 0, wd, reference=list(share))
            mats.append(_embedded(m, foot.force_offset, form.force_nodes)), offsets.append(b)
        out.append(CostTerm("normal_force", LinearBlock(("forces",), [sp.vstack(mats).tocsr() / weight_force],
                                                        np.concatenate(offsets) / weight_force), w.normal_force))
    return out


@functools.lru_cache(maxsize=8)
def _unit_factor(derivative: int) -> np.ndarray:
    """L̂ with L̂ᵀL̂ = Q_d(1): on a segment of duration h, Q_d(h) = h^(1−2d) S Q_d(1) S with S = diag(1, h,
    1, h) (`hermite_gram`), so L_d(h) = h^((1−2d)/2) L̂ S is a factor smooth in h."""
    w, v = np.linalg.eigh(hermite_gram(1.0, derivative))
    factor = np.sqrt(np.clip(w, 0.0, None))[:, None] * v.T
    factor.flags.writeable = False
    return factor


class TimedForceIntegralBlock(ResidualBlock):
    """Eq. (1) over every stance force polynomial (``force``, ``force_rate`` or ``normal_force`` of
    `integral_costs`) while the phase durations are variables: the polynomials' durations h, and with
    them the Gram matrices, move with ``phases``. Rows L_d(h)(c − c_ref) and √ω_d L_(d+1)(h)(c − c_ref)
    (the two parts of Q₀ + ω_d Q₁ stacked, each factor smooth in h, see `_unit_factor`), scaled by
    1/(m·g). `normal_force`: axis z, reference m·g over the feet in stance at the polynomial's middle
    (piecewise constant in the durations; its derivative is taken as 0)."""

    variables = ("forces", "phases")

    def __init__(self, timing, axes: list[int], derivative: int, derivative_weight: float, mass: float,
                 normal_force: bool = False):
        self.timing, self.axes, self.normal_force = timing, list(axes), normal_force
        self.mass = float(mass)
        self.terms = [(derivative, 1.0)] + ([(derivative + 1, np.sqrt(derivative_weight))] if derivative_weight > 0 else [])
        form = timing.form
        self.total = 6 * form.force_nodes
        self.segments = []  # per leg: indices, a, b (global nodes) of its Hermite force segments
        for foot in form.feet:
            k = np.array([i for i, seg in enumerate(foot.force.segments) if not seg.constant])
            self.segments.append((k, np.array([foot.force_offset + foot.force.segments[i].a for i in k]),
                                  np.array([foot.force_offset + foot.force.segments[i].b for i in k])))
        self.size = sum(k.size for k, _, _ in self.segments) * len(self.terms) * len(self.axes) * 4

    def evaluate(self, values, jacobians):
        nodes = np.asarray(values[0]).reshape(-1, 2, 3)
        d = np.asarray(values[1], float)
        gait = self.timing.gait(d) if self.normal_force else None
        rows, node_j, phase_j = [], [], []
        row = 0
        for leg, (k, a, b) in enumerate(self.segments):
            t0, t1 = self.timing.segment_ends("force", leg, d)
            h = (t1 - t0)[k]
            if np.any(h <= 1e-6):
                return invalid_timing(self, jacobians)
            c = np.stack([nodes[a, 0], nodes[a, 1], nodes[b, 0], nodes[b, 1]], axis=1)[:, :, self.axes]  # (K, 4, A)
            if self.normal_force:
                mids = 0.5 * (t0 + t1)[k]
                share = self.mass * GRAVITY / np.maximum(gait.contact(mids).sum(axis=1), 1)
                c[:, 0::2, :] -= share[:, None, None]
            scale = np.stack([np.ones_like(h), h, np.ones_like(h), h], axis=1)  # S(h)
            _, a0, _, a1 = self.timing.ends["force"][leg]
            dh = (a1 - a0)[k]  # ∂h/∂d_leg (K, count)
            for r, weight in self.terms:
                e = 0.5 - r
                lhat = weight * _unit_factor(r) / (self.mass * GRAVITY)
                hp = h ** e
                res = hp[:, None, None] * np.einsum("ij,kja->kia", lhat, scale[:, :, None] * c)  # (K, 4, A)
                rows.append(res.transpose(0, 2, 1).reshape(-1))  # (segment, axis, row)
                if jacobians:
                    v_only = c * np.array([0.0, 1.0, 0.0, 1.0])[None, :, None]
                    d_res = e / h[:, None, None] * res + hp[:, None, None] * np.einsum("ij,kja->kia", lhat, v_only)
                    node_j.append((row, h, hp, lhat, a, b))
                    phase_j.append((row, leg, d_res.transpose(0, 2, 1).reshape(k.size * len(self.axes) * 4), dh))
                row += res.size
        r = np.concatenate(rows)
        if not jacobians:
            return r, None
        return r, [self._node_jacobian(node_j), self._phase_jacobian(phase_j)]

    def _node_jacobian(self, parts) -> sp.csr_matrix:
        rows, cols, vals = [], [], []
        n_axes = len(self.axes)
        for row, h, hp, lhat, a, b in parts:
            scale = np.stack([np.ones_like(h), h, np.ones_like(h), h], axis=1)
            # entry (segment k, axis α, row i; node column j) = hp_k L̂[i, j] S_kj
            coef = hp[:, None, None] * lhat[None, :, :] * scale[:, None, :]  # (K, 4, 4)
            node_cols = np.stack([6 * a, 6 * a + 3, 6 * b, 6 * b + 3], axis=1)  # (K, 4): p_a, v_a, p_b, v_b
            for m, axis in enumerate(self.axes):
                r_idx = row + (np.arange(h.size)[:, None] * n_axes + m) * 4 + np.arange(4)[None, :]  # (K, 4)
                rows.append(np.repeat(r_idx[:, :, None], 4, axis=2).reshape(-1))
                cols.append(np.broadcast_to((node_cols + axis)[:, None, :], coef.shape).reshape(-1))
                vals.append(coef.reshape(-1))
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(self.size, self.total))

    def _phase_jacobian(self, parts) -> sp.csr_matrix:
        """Rows of a foot's polynomials against that foot's durations, every entry kept (zeros too),
        so the pattern does not depend on the values."""
        rows, cols, vals = [], [], []
        n_axes = len(self.axes)
        for row, leg, d_res, dh in parts:
            per_segment = np.repeat(dh, n_axes * 4, axis=0)  # (K·A·4, count)
            block = d_res[:, None] * per_segment
            r, c = np.indices(block.shape)
            rows.append((row + r).reshape(-1)), cols.append((self.timing.offsets[leg] + c).reshape(-1))
            vals.append(block.reshape(-1))
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(self.size, self.timing.size))


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


class StanceWidthBlock(ResidualBlock):
    """``stance_width`` (module docstring): per stance node i of leg l at the middle t_i of its stance,
    r_i = −sin ψ(t_i) (q_x − c_x(t_i)) + cos ψ(t_i) (q_y − c_y(t_i)) − n_y,l: q the foothold, c the
    base position, ψ its yaw (the base splines at t_i) and n_l the nominal foot in the base frame."""

    variables = ("feet", "base_lin", "base_ang")

    def __init__(self, form: Formulation, nominal_y: np.ndarray):
        nodes, times, offsets = [], [], []
        for leg, foot in enumerate(form.feet):
            for phase, node in zip([p for p in foot.phases if p.stance], foot.stance_nodes):
                nodes.append(node), times.append(0.5 * (phase.t0 + phase.t1)), offsets.append(nominal_y[leg])
        self.selector = form.node_selector(nodes, form.motion_nodes)
        self.base = form.base_matrix(np.array(times))
        self.nominal = np.array(offsets, float)
        self.size = len(nodes)
        self._axis = [sp.csr_matrix(np.eye(3)[a:a + 1]) for a in range(3)]

    def evaluate(self, values, jacobians):
        q = self.selector @ np.asarray(values[0]).reshape(-1, 3)
        c = self.base @ np.asarray(values[1]).reshape(-1, 3)
        psi = (self.base @ np.asarray(values[2]).reshape(-1, 3))[:, 2]
        sn, cs = np.sin(psi), np.cos(psi)
        d = q[:, :2] - c[:, :2]
        r = -sn * d[:, 0] + cs * d[:, 1] - self.nominal
        if not jacobians:
            return r, None
        x, y, z = self._axis
        feet = sp.diags(-sn) @ sp.kron(self.selector, x) + sp.diags(cs) @ sp.kron(self.selector, y)
        lin = sp.diags(sn) @ sp.kron(self.base, x) - sp.diags(cs) @ sp.kron(self.base, y)
        ang = sp.diags(-cs * d[:, 0] - sn * d[:, 1]) @ sp.kron(self.base, z)
        return r, [sp.csr_matrix(feet), sp.csr_matrix(lin), sp.csr_matrix(ang)]
