"""Schur-complement elimination of block-diagonal variables (e.g. the slacks ξ_i of eq. (11)).

Order the unknowns of the damped system of eq. (13) as (kept k, eliminated e):

    [A + βI   B     ] [x_k]   [b_k]
    [Bᵀ       D + βI] [x_e] = [b_e],   D block-diagonal with m×m blocks.

Then (A + βI − B (D+βI)⁻¹ Bᵀ) x_k = b_k − B (D+βI)⁻¹ b_e and x_e = (D+βI)⁻¹ (b_e − Bᵀ x_k).
(D+βI)⁻¹ is a batch of m×m inverses, so the only sparse factorisation is of the reduced system.
`SchurSolver` is a `LinearSolver` wrapping another one, so LM does not know it is there.
When B has at most `dense_limit` entries (e.g. few control points coupled to all slacks, as in
the Bézier planner) B and the reduced matrix are dense and the products go to BLAS; otherwise
they stay sparse (e.g. bundle adjustment with many poses).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from legplan.solve.assembly import CooAssembler
from legplan.solve.linsolve import LinearSolver, NotPositiveDefiniteError


class SchurSolver(LinearSolver):
    """Eliminate the columns `eliminate` (block-diagonal in H with blocks of `block` columns)."""

    def __init__(self, inner: LinearSolver, eliminate: np.ndarray, block: int, dense_limit: int = 4_000_000):
        self.inner = inner
        self.name = f"schur+{inner.name}"
        self.eliminate = np.asarray(eliminate, np.int64)
        self.block = int(block)
        if self.eliminate.size % self.block:
            raise ValueError(f"{self.eliminate.size} eliminated columns are not a multiple of block={block}")
        self.dense_limit = dense_limit
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None

    def _analyze(self, H: sp.csc_matrix) -> None:
        n = H.shape[0]
        local = np.full(n, -1, np.int64)  # position among eliminated columns, or -1
        local[self.eliminate] = np.arange(self.eliminate.size)
        self.keep = np.flatnonzero(local < 0)
        klocal = np.full(n, -1, np.int64)
        klocal[self.keep] = np.arange(self.keep.size)
        rows = H.indices.astype(np.int64)
        cols = np.repeat(np.arange(n), np.diff(H.indptr))
        er, ec = local[rows], local[cols]
        m, count = self.block, self.eliminate.size // self.block
        dd = (er >= 0) & (ec >= 0)
        if np.any(er[dd] // m != ec[dd] // m):
            raise ValueError("JᵀJ is not block-diagonal on the Schur-eliminated variables "
                             f"(block size {m}); do not set schur_block on variables that residuals couple")
        self._dd_slots = np.flatnonzero(dd)
        self._dd_index = (er[dd] // m, er[dd] % m, ec[dd] % m)
        self._d_shape = (count, m, m)
        aa = (er < 0) & (ec < 0)
        self._aa = (np.flatnonzero(aa), klocal[rows[aa]], klocal[cols[aa]])
        ke = (er < 0) & (ec >= 0)
        self._ke = (np.flatnonzero(ke), klocal[rows[ke]], ec[ke])
        self.dense = self.keep.size * self.eliminate.size <= self.dense_limit
        self._a_assembler = CooAssembler((self.keep.size, self.keep.size))
        self._b_assembler = CooAssembler((self.keep.size, self.eliminate.size))
        diag = np.arange(self.keep.size)
        self._a_rows = np.concatenate([self._aa[1], diag])
        self._a_cols = np.concatenate([self._aa[2], diag])
        self._pattern = (H.indptr.copy(), H.indices.copy())

    def factorize(self, H, beta):
        H = sp.csc_matrix(H)
        if self._pattern is None or not (np.array_equal(self._pattern[0], H.indptr)
                                         and np.array_equal(self._pattern[1], H.indices)):
            self._analyze(H)
        m = self.block
        D = np.zeros(self._d_shape)
        D[self._dd_index] = H.data[self._dd_slots]
        D += beta * np.eye(m)
        try:
            L = np.linalg.cholesky(D)
        except np.linalg.LinAlgError as exc:
            raise NotPositiveDefiniteError(f"an eliminated {m}×{m} block is not positive definite") from exc
        Linv = np.linalg.inv(L)
        self._dinv = np.einsum("kji,kjl->kil", Linv, Linv)  # (L Lᵀ)⁻¹ = L⁻ᵀ L⁻¹
        count = self._d_shape[0]
        nk, ne = self.keep.size, self.eliminate.size
        slots, kr, ec = self._ke
        aslots = self._aa[0]
        a_values = np.concatenate([H.data[aslots], np.full(nk, beta)])
        if self.dense:
            self._B = np.zeros((nk, ne))
            self._B[kr, ec] = H.data[slots]
            self._W = np.einsum("kbi,bij->kbj", self._B.reshape(nk, count, m), self._dinv).reshape(nk, ne)
            A = np.zeros((nk, nk))
            np.add.at(A, (self._a_rows, self._a_cols), a_values)
            self.inner.factorize(A - self._W @ self._B.T, 0.0)
            return
        dinv = sp.bsr_matrix((self._dinv, np.arange(count), np.arange(count + 1)), shape=(ne, ne))
        self._B = self._b_assembler.assemble(kr, ec, H.data[slots]).tocsr()
        self._W = (self._B @ dinv).tocsr()  # B (D+βI)⁻¹
        A = self._a_assembler.assemble(self._a_rows, self._a_cols, a_values)
        self.inner.factorize(A - self._W @ self._B.T, 0.0)

    def solve(self, rhs):
        bk, be = rhs[self.keep], rhs[self.eliminate]
        xk = self.inner.solve(bk - self._W @ be)
        r = (be - self._B.T @ xk).reshape(self._d_shape[:2])
        x = np.empty_like(rhs)
        x[self.keep] = xk
        x[self.eliminate] = np.einsum("kij,kj->ki", self._dinv, r).reshape(-1)
        return x
