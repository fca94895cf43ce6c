"""Residuals sampled along a curve that is a fixed linear combination of control points.

The Bézier step planner (eqs. (10)-(12)) evaluates constraints at N samples q_i = Σ_k B_ik P_k of
the curve, B_ik the Bernstein weights b_k(t_i), plus per-sample slacks ξ_i (eq. (11)). With
G_i = ∂r_i/∂q_i and S_i = ∂r_i/∂ξ_i the Jacobian is J_P = [B_ik G_i] and the normal-equation blocks
are

    H_PP = Σ_i kron(b_i b_iᵀ, G_iᵀG_i),   H_Pξ_i = b_i ⊗ G_iᵀS_i,   H_ξξ = blockdiag(S_iᵀS_i),
    g_P  = Σ_i b_i ⊗ G_iᵀr_i,             g_ξ_i = S_iᵀr_i,

which `SampledCurveBlock.normal_terms` computes without ever forming J. Give the slack variable
`schur_block=slack_dim` to have LM eliminate it. `sample` treats the samples independently (row i
depends on q_i, ξ_i and the block's data for sample i only): trial points are evaluated in sample
groups (`residual_chunks`) so that LM can reject a worse point before evaluating every sample.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np
import scipy.sparse as sp

from legplan.solve.blocks import BlockDiagonal, NormalTerms, StructuredBlock


class SampledCurveBlock(StructuredBlock):
    """m residuals per sample, r_i(q_i, ξ_i), over control points (K·dim, point-major) and slacks.

    `basis` is the (N, K) weight matrix B. `variables` is (points,) or (points, slack) with the
    slack variable holding N·slack_dim entries, sample-major. Subclasses implement `sample`.
    """

    def __init__(self, variables: tuple[str, ...], basis: np.ndarray, dim: int, rows: int, slack_dim: int = 0):
        if len(variables) != (2 if slack_dim else 1):
            raise ValueError("variables must be (points,) or (points, slack) matching slack_dim")
        self.variables = tuple(variables)
        self.basis = np.asarray(basis, float)
        self.dim, self.rows, self.slack_dim = int(dim), int(rows), int(slack_dim)
        self.size = self.basis.shape[0] * self.rows
        self._chunks: tuple[int, list[np.ndarray]] | None = None

    @abstractmethod
    def sample(self, q: np.ndarray, xi: np.ndarray | None, jacobians: bool, index: slice | np.ndarray
               ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """r (n, m) and, if `jacobians`, G = ∂r/∂q (n, m, dim) and S = ∂r/∂ξ (n, m, slack_dim) or None.

        q, xi hold the samples `index` (a slice or sample numbers into the rows of `basis`), for
        blocks with per-sample data; row i must depend on q_i, ξ_i (and that data) only.
        """

    def _sample(self, values, jacobians):
        n = self.basis.shape[0]
        q = self.basis @ values[0].reshape(-1, self.dim)
        xi = values[1].reshape(n, self.slack_dim) if self.slack_dim else None
        return self.sample(q, xi, jacobians, slice(None))

    def sample_groups(self) -> list[np.ndarray]:
        """The sample numbers of `residual_chunks`' groups, in their order: 1/8, 1/8, 1/4 and 1/2 of
        the samples, interleaved along the curve."""
        n = self.basis.shape[0]
        if self._chunks is None or self._chunks[0] != n:
            order = np.concatenate([np.arange(k, n, 8) for k in range(8)])
            ends = [np.arange(k, n, 8).size for k in range(8)]
            cuts = np.cumsum(ends)[[0, 1, 3, 7]]
            self._chunks = (n, np.split(order, cuts[:-1]))
        return self._chunks[1]

    def residual_chunks(self, values):
        """Residuals of interleaved sample groups (`sample_groups`), spread along the curve, so a
        trial point that is worse overall is usually detected early."""
        n = self.basis.shape[0]
        points = values[0].reshape(-1, self.dim)
        xi = values[1].reshape(n, self.slack_dim) if self.slack_dim else None
        for idx in self.sample_groups():
            if idx.size:
                yield self.sample(self.basis[idx] @ points, None if xi is None else xi[idx], False, idx)[0].reshape(-1)

    def evaluate(self, values, jacobians):
        r, G, S = self._sample(values, jacobians)
        if not jacobians:
            return r.reshape(-1), None
        n, m = r.shape
        jp = (G[:, :, None, :] * self.basis[:, None, :, None]).reshape(n * m, -1)
        jacs = [jp]
        if self.slack_dim:
            s = self.slack_dim
            rows = np.broadcast_to(np.arange(n * m).reshape(n, m, 1), S.shape)
            cols = np.broadcast_to(np.arange(n)[:, None, None] * s + np.arange(s), S.shape)
            jacs.append(sp.csr_matrix((S.ravel(), (rows.ravel(), cols.ravel())), shape=(n * m, n * s)))
        return r.reshape(-1), jacs

    def normal_terms(self, values):
        return self.curve_terms(*self._sample(values, True))

    def curve_terms(self, r, G, S):
        """`NormalTerms` of per-sample residuals r (n, m), G (n, m, dim), S (n, m, slack_dim) (rows whose
        G and S are both zero may be left out: the products do not see them; the residual is r as given)."""
        B = self.basis
        n, k, d = B.shape[0], B.shape[1], self.dim
        gt = G.transpose(0, 2, 1)
        gtg = (gt @ G).reshape(n, d * d)
        bb = (B[:, :, None] * B[:, None, :]).reshape(n, k * k)
        h_pp = (bb.T @ gtg).reshape(k, k, d, d).transpose(0, 2, 1, 3).reshape(k * d, k * d)
        hessian = {(0, 0): h_pp}
        gradient = [(B.T @ (gt @ r[:, :, None])[:, :, 0]).reshape(-1)]
        if self.slack_dim:
            s = self.slack_dim
            st = S.transpose(0, 2, 1)
            hessian[(0, 1)] = (B.T[:, None, :, None] * (gt @ S).transpose(1, 0, 2)[None]).reshape(k * d, n * s)
            hessian[(1, 1)] = BlockDiagonal(st @ S)
            gradient.append((st @ r[:, :, None]).reshape(-1))
        return NormalTerms(r.reshape(-1), hessian, gradient)
