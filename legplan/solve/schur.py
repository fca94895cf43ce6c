"""Schur-complement elimination of block-diagonal variables (e.g. the slacks ξ_i of eq. (11)).

Order the unknowns of the damped system of eq. (13) as (kept k, eliminated e):

    [A + βI   B     ] [x_k]   [b_k]
    [Bᵀ       D + βI] [x_e] = [b_e],   D block-diagonal with m×m blocks.

Then (A + βI − B (D+βI)⁻¹ Bᵀ) x_k = b_k − B (D+βI)⁻¹ b_e and x_e = (D+βI)⁻¹ (b_e − Bᵀ x_k).
(D+βI)⁻¹ is a batch of m×m blocks, so the only sparse factorisation is of the reduced system.
Per linearisation (`set_matrix`) the blocks are eigendecomposed once, D = V diag(e) Vᵀ, and
U = B·blockdiag(V) is formed; then for every β (`refactor`, one per LM iteration)
(D+βI)⁻¹ = V diag(1/(e+β)) Vᵀ and the reduced matrix is A + βI − U diag(1/(e+β)) Uᵀ: one scaled
product, no per-β block inverses.
`SchurSolver` is a `LinearSolver` wrapping another one, so LM does not know it is there. A problem
of one structured block over a kept and an eliminated variable (the Bézier step) can hand over
A, B and the blocks of D directly (`set_parts`, `legplan.solve.problem.SchurParts`): the same
numbers as gathered from the assembled H, without H.
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
        self._a_flat = self._a_rows * self.keep.size + self._a_cols
        self._pattern = (H.indptr.copy(), H.indices.copy())

    def set_matrix(self, H):
        """Per-linearisation work: D = V diag(e) Vᵀ (batched eigh), U = B·blockdiag(V), A.

        With these, (D + βI)⁻¹ = V diag(1/(e+β)) Vᵀ and B (D+βI)⁻¹ Bᵀ = U diag(1/(e+β)) Uᵀ, so a
        new β (a rejected LM step) costs one scaled product and the inner factorisation.
        """
        H = sp.csc_matrix(H)
        if self._pattern is None or not (np.array_equal(self._pattern[0], H.indptr)
                                         and np.array_equal(self._pattern[1], H.indices)):
            self._analyze(H)
        count, m, _ = self._d_shape
        nk, ne = self.keep.size, self.eliminate.size
        D = np.zeros(self._d_shape)
        D[self._dd_index] = H.data[self._dd_slots]
        if not np.all(np.isfinite(D)):
            raise NotPositiveDefiniteError("an eliminated block is not finite")
        self._e, self._V = np.linalg.eigh(D)  # reads the lower triangle, like a Cholesky factorisation
        self._e_scale = np.abs(self._e).max(axis=1, initial=0.0)
        slots, kr, ec = self._ke
        aslots = self._aa[0]
        a_values = np.concatenate([H.data[aslots], np.zeros(nk)])
        if self.dense:
            B = np.zeros((nk, ne))
            B[kr, ec] = H.data[slots]
            self._B = B
            self._U = (B.reshape(nk, count, m).transpose(1, 0, 2) @ self._V).transpose(1, 0, 2).reshape(nk, ne)
            self._A = np.bincount(self._a_flat, weights=a_values, minlength=nk * nk).reshape(nk, nk)
            return
        vblocks = sp.bsr_matrix((self._V, np.arange(count), np.arange(count + 1)), shape=(ne, ne))
        self._B = self._b_assembler.assemble(kr, ec, H.data[slots]).tocsr()
        self._U = (self._B @ vblocks).tocsr()
        self._A = self._a_assembler.assemble(self._a_rows, self._a_cols, a_values)

    def set_parts(self, parts) -> None:
        """`set_matrix` for H given as its dense Schur pieces (`legplan.solve.problem.SchurParts`: A, B and
        the diagonal blocks D, kept columns first): the same D = V diag(e) Vᵀ, U = B·blockdiag(V) and A as
        `set_matrix` takes from the assembled H, without H."""
        A, B, D = parts.kept, parts.coupling, parts.blocks
        count, m, _ = D.shape
        nk, ne = B.shape
        if m != self.block or ne != self.eliminate.size:
            raise ValueError(f"Schur parts of {ne} eliminated columns in blocks of {m}, expected "
                             f"{self.eliminate.size} in blocks of {self.block}")
        if self._pattern is not None or getattr(self, "keep", None) is None or self.keep.size != nk:
            kept = np.ones(nk + ne, bool)
            kept[self.eliminate] = False
            self.keep = np.flatnonzero(kept)
            self._pattern = None  # a later `set_matrix` analyses its H again
        self._d_shape = (count, m, m)
        self.dense = True
        if not np.all(np.isfinite(D)):
            raise NotPositiveDefiniteError("an eliminated block is not finite")
        self._e, self._V = np.linalg.eigh(D)
        self._e_scale = np.abs(self._e).max(axis=1, initial=0.0)
        self._B = B
        self._U = (B.reshape(nk, count, m).transpose(1, 0, 2) @ self._V).transpose(1, 0, 2).reshape(nk, ne)
        self._A = A

    def refactor(self, beta):
        """Factorise the reduced system A + βI − U diag(1/(e+β)) Uᵀ for this β."""
        shifted = self._e + beta
        scale = self._e_scale + abs(beta)
        if not np.all(shifted > self.block * np.finfo(float).eps * scale[:, None]):
            raise NotPositiveDefiniteError(f"an eliminated {self.block}×{self.block} block is not positive definite")
        self._s = 1.0 / shifted  # (count, m)
        s = self._s.reshape(-1)
        if self.dense:
            reduced = self._A - (self._U * s) @ self._U.T
        else:
            reduced = self._A - (self._U @ sp.diags(s)) @ self._U.T
        self.inner.factorize(reduced, beta)

    def _dinv(self, v: np.ndarray) -> np.ndarray:
        """(D + βI)⁻¹ v per block, v (count, m): V diag(s) Vᵀ v."""
        vt = (self._V.transpose(0, 2, 1) @ v[:, :, None])[:, :, 0] * self._s
        return (self._V @ vt[:, :, None])[:, :, 0]

    def _columns(self):
        """(kept, eliminated) as index arrays, or as slices when the kept columns come first."""
        if getattr(self, "_sliced", None) is None or self._sliced[0] is not self.keep:
            nk = self.keep.size
            first = (np.array_equal(self.keep, np.arange(nk))
                     and np.array_equal(self.eliminate, nk + np.arange(self.eliminate.size)))
            self._sliced = (self.keep, (slice(0, nk), slice(nk, nk + self.eliminate.size)) if first
                            else (self.keep, self.eliminate))
        return self._sliced[1]

    def solve(self, rhs):
        kept, eliminated = self._columns()
        bk, be = rhs[kept], rhs[eliminated]
        count, m, _ = self._d_shape
        vbe = (self._V.transpose(0, 2, 1) @ be.reshape(count, m, 1))[:, :, 0] * self._s
        xk = self.inner.solve(bk - self._U @ vbe.reshape(-1))
        r = (be - self._B.T @ xk).reshape(count, m)
        x = np.empty_like(rhs)
        x[kept] = xk
        x[eliminated] = self._dinv(r).reshape(-1)
        return x
