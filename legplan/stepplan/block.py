"""The stacked path constraint F̃_ε,N(P, ξ) of eq. (12) as one structured residual block.

Per sample t_k (eq. (10)) the configuration is x_k = Σ_i B_i^d(t_k) p_i (eq. (6)) with the end
points p_0 = x(q_start), p_d = x(q_end) fixed entries of variable "P" (row-major (d+1) × nx), so only
the d − 1 inner control points are unknown, together with the slacks ξ_k of the stance feet
(variable "xi", 3·(stance legs) per sample, eq. (11)).

`SampleConstraints` returns per-sample residuals r_k (m,) and Jacobians G_k = ∂r_k/∂x (m × nx),
S_k = ∂r_k/∂ξ_k (m × s). By the chain rule ∂r_k/∂p_i = B_i^d(t_k) G_k, so

    JᵀJ restricted to P = Σ_k kron(b_k b_kᵀ, G_kᵀ G_k)      (dense, every sample touches every p_i)
    P–ξ coupling           = [b_k ⊗ G_kᵀ S_k]_k
    ξ–ξ                    = blockdiag(S_kᵀ S_k)              (eliminated by the solver's Schur path)

which `legplan.solve.SampledCurveBlock.normal_terms` forms without a sparse JᵀJ product; the
solver's Schur path eliminates ξ and factorises only the (d−1)·nx control-point unknowns.
"""

from __future__ import annotations

import numpy as np

from legplan.contact.terms import (ContactMode, collision_terms, com_terms, joint_limit_terms, nearest_end,
                                   sphere_margins, stance_foot_terms, swing_foot_margin)
from legplan.geometry.bezier import bernstein_matrix
from legplan.solve.curve import SampledCurveBlock
from legplan.solve.inequality import hinge


def _hinge(g: np.ndarray, jac: np.ndarray | None):
    """eq. (8b): g ≤ 0 as the residual max(g, 0), Jacobian rows scaled by the hinge slope."""
    r, slope = hinge(g)
    return r, (None if jac is None else jac * slope[..., None])


class _ValuesOnly:
    """The robot seen through `legplan.contact.terms` when only residual values are wanted.

    LM evaluates every trial point without Jacobians (Algorithm 1, line 5), and most trial points
    are rejected. The contact terms always return Jacobians, so this view gives them Jacobians of
    zero width: `tangent_map` is (n, nv, 0) and the kinematic Jacobians are broadcast zeros, so every
    J_x product is empty and only the values (one forward-kinematics pass, no Jacobians) cost time.
    """

    def __init__(self, robot):
        self._robot = robot

    def __getattr__(self, name):
        return getattr(self._robot, name)

    def _zeros(self, positions):
        return np.broadcast_to(np.zeros(1), positions.shape + (self._robot.nv,))

    def foot_jacobians(self, Q):
        return self._zeros(self._robot.foot_positions(Q))

    def sphere_jacobians(self, Q):
        return self._zeros(self._robot.sphere_centres(Q))

    def com_jacobian(self, Q):
        return self._zeros(self._robot.com(Q))

    def tangent_map(self, X):
        return np.zeros((len(X), self._robot.nv, 0))


class SampleConstraints:
    """Residual rows of one step at a batch of configurations X (n, nx) with slacks Xi (n, s).

    Rows per configuration, in order: stance-foot equality f − ξ (eq. (11a), 3 per stance leg);
    slack bound max(‖ξ_l‖ − ε, 0) per stance leg (eq. (11b)); CoM inside the support polygon, one
    hinge per edge; sphere clearance vs the SDF, one hinge per checked sphere; joint limits, two
    hinges per joint. Inequalities come from `legplan.contact.terms` (g ≤ 0) through eq. (8b); the
    collision rows of swing-foot spheres get a margin relaxed near the swing footholds, which ramps
    up to `mode.clearance` + `headroom`.
    """

    def __init__(self, robot, sdf, mode: ContactMode, epsilon: float, *, swing_ends=None,
                 relax_radius: float = 0.05, headroom: float = 0.0):
        self.robot = robot
        self.headroom = float(headroom)
        self._values_only = _ValuesOnly(robot)
        self.sdf = sdf
        self.mode = mode
        self.epsilon = float(epsilon)
        self.legs = np.flatnonzero(mode.stance)
        self.slack_size = 3 * len(self.legs)
        self.nx = robot.nv
        self._relaxation(swing_ends, relax_radius)
        probe = self.evaluate(np.atleast_2d(robot.to_vector(robot.q_nominal[None])),
                              np.zeros((1, self.slack_size)), False)[0]
        self.size = probe.shape[1]

    def _relaxation(self, swing_ends, radius: float) -> None:
        """Collision rows of swing-foot spheres whose margin is relaxed near the swing footholds.

        `swing_ends` (2, n_spheres, 3): sphere centres at q_start and q_end. The required clearance
        of a swing-foot sphere follows `legplan.contact.terms.swing_foot_margin` with ε the sample
        slack bound: the tip may touch at either end, `mode.clearance` + `headroom` from
        `relax_radius` on.
        """
        margins = sphere_margins(self.robot, self.mode)
        checked = np.flatnonzero(~np.isnan(margins))
        spheres = self.robot.spheres
        legs = np.asarray(spheres.leg_index)
        swing_foot = np.asarray(spheres.is_foot, bool) & (legs >= 0)
        swing_foot &= ~np.where(legs >= 0, self.mode.stance[np.maximum(legs, 0)], False)
        self.relaxed_spheres = np.flatnonzero(swing_foot) if swing_ends is not None else np.zeros(0, int)
        self.relaxed_rows = np.searchsorted(checked, self.relaxed_spheres)
        self.relax_radius = float(radius)
        if self.relaxed_spheres.size:
            self.relax_ends = np.asarray(swing_ends, float)[:, self.relaxed_spheres]
            self.relax_radii = np.asarray(spheres.radii, float)[self.relaxed_spheres]

    def _relaxed_margin(self, X, Q, jacobians: bool):
        """Margin change (n, k) of the relaxed rows (relative to the term's margin `foot_clearance`)
        and its Jacobian (n, k, nx) (see `_relaxation`)."""
        found = nearest_end(self.robot.sphere_centres(Q)[:, self.relaxed_spheres], self.relax_ends, jacobians)
        d, unit = found if jacobians else (found, None)
        margin, slope = swing_foot_margin(d, self.relax_radii, self.mode.clearance + self.headroom, self.epsilon,
                                          self.relax_radius)
        delta = margin - self.mode.foot_clearance
        if not jacobians:
            return delta, None
        jac_c = np.einsum("nkav,nvx->nkax", self.robot.sphere_jacobians(Q)[:, self.relaxed_spheres],
                          self.robot.tangent_map(X))
        return delta, np.einsum("nk,nka,nkax->nkx", slope, unit, jac_c)

    def evaluate(self, X: np.ndarray, Xi: np.ndarray, jacobians: bool):
        """r (n, m) and, with `jacobians`, G (n, m, nx) and S (n, m, s)."""
        robot, mode = (self.robot if jacobians else self._values_only), self.mode
        X = np.atleast_2d(X)
        n, nx = X.shape
        k = len(self.legs)
        Q = robot.from_vector(X)
        robot.kinematics(Q, jacobians=jacobians)  # one batch pass; the terms below hit its cache
        f, jf = stance_foot_terms(robot, X, mode, Q)
        f = f - Xi
        xi = Xi.reshape(n, k, 3)
        norms = np.linalg.norm(xi, axis=2)
        slack, _ = _hinge(norms - self.epsilon, None)
        collision, jc = collision_terms(robot, X, mode, self.sdf, Q)
        if self.relaxed_spheres.size:
            delta, jd = self._relaxed_margin(X, Q, jacobians)
            collision[:, self.relaxed_rows] += delta
            if jacobians:
                jc[:, self.relaxed_rows] += jd
        ineq = [com_terms(robot, X, mode, Q), (collision, jc), joint_limit_terms(robot, X)]
        hinged = [_hinge(g, j if jacobians else None) for g, j in ineq]
        r = np.concatenate([f, slack] + [h for h, _ in hinged], axis=1)
        if not jacobians:
            return r, None, None
        m = r.shape[1]
        G = np.zeros((n, m, nx))
        G[:, :3 * k] = jf
        row = 4 * k
        for _, j in hinged:
            G[:, row:row + j.shape[1]] = j
            row += j.shape[1]
        S = np.zeros((n, m, self.slack_size))
        S[:, np.arange(3 * k), np.arange(3 * k)] = -1.0
        direction = np.where(norms[..., None] > 0, xi / np.maximum(norms, 1e-300)[..., None], 0.0)
        direction *= (slack > 0)[..., None]
        for leg in range(k):
            S[:, 3 * k + leg, 3 * leg:3 * leg + 3] = direction[:, leg]
        return r, G, S


class BezierConstraintBlock(SampledCurveBlock):
    """F̃_ε,N of eq. (12) for a Bézier curve of `degree` sampled at `t`.

    Variables: "P", all d + 1 control points (row-major (d+1) × nx; give p_0 and p_d as fixed
    entries of the `VariableBlock`), and "xi", the per-sample slacks. The structured normal terms
    (Σ_k kron(b_k b_kᵀ, G_kᵀG_k), …) come from `legplan.solve.SampledCurveBlock`.
    """

    def __init__(self, constraints: SampleConstraints, degree: int, t):
        self.constraints = constraints
        self.degree = int(degree)
        self.t = np.asarray(t, float)
        self.samples = len(self.t)
        super().__init__(("P", "xi"), bernstein_matrix(self.degree, self.t), constraints.nx,
                         constraints.size, constraints.slack_size)

    def sample(self, q, xi, jacobians, index):
        return self.constraints.evaluate(q, xi, jacobians)  # no per-sample data: rows depend on q_k, ξ_k only
