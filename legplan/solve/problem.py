"""A least-squares problem: variable blocks plus weighted residual blocks, stacked into h(θ), J(θ).

Three ways to build the normal equations (JᵀJ) Δθ = Jᵀh of eq. (13):

* ``assembly="stacked"`` (general path): stack the weighted Jacobian blocks into one CSC matrix J
  and form JᵀJ with one sparse product.
* ``assembly="jacobian"``: stack J only (as CSR); the solver factorises JᵀJ + λI from J
  (`LinearSolver.set_jacobian`; CHOLMOD does it without a JᵀJ on the Python side).
* ``assembly="blocks"`` (structured path, default): sum per-block contributions. A
  `StructuredBlock` returns its JᵀJ and Jᵀh blocks directly; any other block contributes
  J_iᵀJ_j products of its own Jacobian blocks (dense blocks go to BLAS).

All paths scatter COO triplets through a `CooAssembler`, so index arrays are sorted once per
sparsity pattern and later iterations only refresh values. Sparse products JᵢᵀJⱼ keep the
structural pattern of |Jᵢ|ᵀ|Jⱼ| (scipy drops entries that happen to be zero, e.g. inactive
inequality rows, which would otherwise change the pattern and force a new CHOLMOD analysis).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.solve.assembly import CooAssembler, NonzeroGather, NonzeroPattern, kept_indices, same_indices
from legplan.solve.blocks import BlockDiagonal, Matrix, ResidualBlock, StructuredBlock, default_normal_terms
from legplan.solve.variables import VariableBlock, VariableLayout

ASSEMBLY_MODES = ("blocks", "stacked", "jacobian")


@dataclass
class NormalEquations:
    """h(θ), H = JᵀJ (full symmetric CSC, diagonal always in the pattern) and g = Jᵀh.

    With ``assembly="jacobian"`` H is not formed (None) and `jacobian` holds the stacked J
    (CSR, m × n) instead, for a solver that factorises JᵀJ + λI from J itself.
    """

    residual: np.ndarray
    hessian: sp.csc_matrix | None
    gradient: np.ndarray
    pattern_version: int
    evaluate_seconds: float
    assemble_seconds: float
    jacobian: sp.csr_matrix | None = None
    schur_parts: SchurParts | None = None


@dataclass
class SchurParts:
    """H = JᵀJ of eq. (13) as the dense pieces of the Schur elimination (`SchurSolver.set_parts`), in θ's
    order of the kept and the eliminated columns: H = [[A, B], [Bᵀ, blockdiag(D)]]. Every entry is the
    one the assembled H holds (0 + the block's value, as the sparse sum gives it), so the reduced system,
    and so every LM step, is the same as from H."""

    kept: np.ndarray  # A (kept × kept)
    coupling: np.ndarray  # B (kept × eliminated)
    blocks: np.ndarray  # D (count, m, m), the diagonal blocks of the eliminated columns

    def finite(self) -> bool:
        return bool(np.isfinite(self.kept).all() and np.isfinite(self.coupling).all()
                    and np.isfinite(self.blocks).all())


class Problem:
    """Variable blocks and residual blocks of a nonlinear least-squares problem min ½‖h(θ)‖²."""

    def __init__(self, variables: Iterable[VariableBlock] = ()):
        self._variables: list[VariableBlock] = list(variables)
        self._blocks: list[tuple[ResidualBlock, float | np.ndarray]] = []
        self._layout: VariableLayout | None = None
        self._index_cache: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self.structure_cache: dict[str, object] = {}
        """What a solver derives from the problem's structure (e.g. the pattern of JᵀJ) and reuses
        across its solves of this problem; emptied when a block is added."""

    # --- building -------------------------------------------------------------------------------
    def add_residual(self, block: ResidualBlock, weight: float | np.ndarray = 1.0) -> ResidualBlock:
        """Add a residual block; `weight` multiplies its rows (scalar, or one per row)."""
        names = {v.name for v in self._variables}
        missing = [v for v in block.variables if v not in names]
        if missing:
            raise ValueError(f"{type(block).__name__} reads unknown variables {missing}")
        if len(set(block.variables)) != len(block.variables):
            raise ValueError(f"{type(block).__name__} lists a variable twice: {block.variables}")
        w = np.asarray(weight, float)
        if w.ndim and w.shape != (block.size,):
            raise ValueError(f"weight must be a scalar or have {block.size} entries, got shape {w.shape}")
        if w.ndim and isinstance(block, StructuredBlock):
            raise ValueError("a StructuredBlock accepts only a scalar weight")
        if w.ndim and block.jacobian_rows is not None:
            raise ValueError("a block with shared Jacobian rows (`jacobian_rows`) accepts only a scalar weight")
        self._blocks.append((block, float(w) if not w.ndim else w))
        self._invalidate()
        return block

    def _invalidate(self) -> None:
        self._layout = None
        self._index_cache.clear()
        self.structure_cache.clear()
        self._offsets = None
        self._jacobian_offsets = None
        self._row_map = None
        self._jac_assembler = None
        self._jact_assembler = None
        self._hess_assembler = None
        self._nonzero = NonzeroPattern()
        self._nonzero_gather = NonzeroGather()

    @property
    def layout(self) -> VariableLayout:
        if self._layout is None:
            self._layout = VariableLayout(self._variables)
            sizes = [b.size for b, _ in self._blocks]
            self._offsets = np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)])
            rows = [b.size if b.jacobian_rows is None else int(np.max(b.jacobian_rows, initial=-1)) + 1
                    for b, _ in self._blocks]
            self._jacobian_offsets = np.concatenate([[0], np.cumsum(rows, dtype=np.int64)])
            if any(b.jacobian_rows is not None for b, _ in self._blocks):
                jrow = [np.arange(lo, hi) if b.jacobian_rows is None else lo + np.asarray(b.jacobian_rows, np.int64)
                        for (b, _), lo, hi in zip(self._blocks, self._jacobian_offsets[:-1], self._jacobian_offsets[1:])]
                sign = [np.ones(b.size) if b.jacobian_sign is None else np.asarray(b.jacobian_sign, float)
                        for b, _ in self._blocks]
                self._row_map = (np.concatenate(jrow), np.concatenate(sign))
            m = int(self._jacobian_offsets[-1])
            self._jac_assembler = CooAssembler((m, self._layout.n))
            self._jact_assembler = CooAssembler((self._layout.n, m))
            self._hess_assembler = CooAssembler((self._layout.n, self._layout.n))
            self._diagonal = np.arange(self._layout.n)  # one object: the assembler sees a cached index piece
        return self._layout

    def row_map(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(jrow, sign): residual row i's derivative is sign_i times row jrow_i of the stacked J of
        `jacobian` and `nonzero_jacobian`, which hold each shared Jacobian row once (blocks'
        `jacobian_rows`); None when every residual row is its own Jacobian row."""
        _ = self.layout
        return self._row_map

    @property
    def blocks(self) -> list[ResidualBlock]:
        return [b for b, _ in self._blocks]

    def hinge_mask(self) -> np.ndarray:
        """Rows of h whose residual is max(0, value) (blocks with a boolean `hinged` attribute, for
        `solve_hinged_lm`); the other rows are used as they are."""
        parts = [np.broadcast_to(np.asarray(getattr(b, "hinged", False), bool), (b.size,)) for b, _ in self._blocks]
        return np.concatenate(parts) if parts else np.zeros(0, bool)

    # --- evaluation -----------------------------------------------------------------------------
    def _block_values(self, values: dict[str, np.ndarray], block: ResidualBlock) -> list[np.ndarray]:
        return [values[name] for name in block.variables]

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """h(θ): weighted residuals of all blocks, stacked in the order they were added (eq. (12))."""
        values = self.layout.values(theta)
        parts = [w * self._checked(b, b.evaluate(self._block_values(values, b), False)[0]) for b, w in self._blocks]
        return np.concatenate(parts) if parts else np.zeros(0)

    def residual_rows(self, theta: np.ndarray, needed: np.ndarray) -> np.ndarray:
        """h(θ) on the rows where `needed` (bool, one per row) holds, zero elsewhere: a block without
        a needed row is not evaluated, one with some gives those (`ResidualBlock.residual_rows`)."""
        values = self.layout.values(theta)
        out = np.zeros(int(self._offsets[-1]))
        for (block, w), lo, hi in zip(self._blocks, self._offsets[:-1], self._offsets[1:]):
            rows = np.flatnonzero(needed[lo:hi])
            if not rows.size:
                continue
            args = self._block_values(values, block)
            if rows.size == hi - lo:
                out[lo:hi] = w * self._checked(block, block.evaluate(args, False)[0])
            else:
                out[lo + rows] = (w if np.ndim(w) == 0 else w[rows]) * block.residual_rows(args, rows)
        return out

    def trial_norm(self, theta: np.ndarray, bound: float) -> float:
        """‖h(θ)‖ if it is below `bound`; otherwise some value ≥ `bound` (or NaN if h is not finite).

        Sums the squares of the blocks' `residual_chunks` and stops as soon as the partial sum
        reaches bound², so a trial point of LM that is worse than the current one (a rejected step,
        Algorithm 1 line 9) is usually judged from part of the residual; the accept/reject
        decision is the same as with the full ‖h(θ)‖.
        """
        values = self.layout.values(theta)
        limit = bound * bound
        total = 0.0
        for block, w in self._blocks:
            args = self._block_values(values, block)
            chunks = block.residual_chunks(args) if np.ndim(w) == 0 else iter([w * block.evaluate(args, False)[0]])
            scale = w * w if np.ndim(w) == 0 else 1.0
            for chunk in chunks:
                total += scale * float(np.dot(chunk, chunk))
                if not total < limit:  # also stops on NaN
                    return float(np.sqrt(total))
        return float(np.sqrt(total))

    @staticmethod
    def _checked(block: ResidualBlock, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, float).reshape(-1)
        if r.size != block.size:
            raise ValueError(f"{type(block).__name__} returned {r.size} residuals, declared size {block.size}")
        return r

    def _coo(self, key: tuple, term: Matrix | BlockDiagonal, rowmap: np.ndarray | int, colmap: np.ndarray):
        """COO triplets of `term` in θ coordinates (rows via `rowmap`, or from the first row `rowmap` on
        when it is an integer; cols via `colmap`; -1 = drop)."""
        if isinstance(term, BlockDiagonal):
            cached = self._index_cache.get(key + ("bd", term.blocks.shape))
            if cached is None:
                count, m, _ = term.blocks.shape
                base = np.arange(count)[:, None, None] * m
                r = np.broadcast_to(base + np.arange(m)[None, :, None], term.blocks.shape).reshape(-1)
                c = np.broadcast_to(base + np.arange(m)[None, None, :], term.blocks.shape).reshape(-1)
                cached = self._index_cache[key + ("bd", term.blocks.shape)] = self._mapped(r, c, rowmap, colmap)
            rows, cols, keep = cached
            return rows, cols, term.blocks.reshape(-1)[keep]
        if sp.issparse(term):
            # CSR/CSC: compared by their compressed index arrays, values taken in storage order
            term = term if term.format in ("csr", "csc") else sp.coo_matrix(term)
            pattern = (term.indptr, term.indices) if term.format != "coo" else (term.row, term.col)
            cached = self._index_cache.get(key + ("sparse",))
            if cached is None or not (cached[0] == term.format and same_indices(cached[1], pattern)):
                if term.format == "csr":  # the entries' rows and columns in storage order, as tocoo gives them
                    r, c = np.repeat(np.arange(term.shape[0]), np.diff(term.indptr)), term.indices
                else:
                    coo = term.tocoo()
                    r, c = coo.row, coo.col
                cached = self._index_cache[key + ("sparse",)] = (term.format, kept_indices(pattern),
                                                                  self._mapped(r, c, rowmap, colmap))
            rows, cols, keep = cached[2]
            return rows, cols, term.data[keep]
        term = np.asarray(term, float)
        cached = self._index_cache.get(key + ("dense", term.shape))
        if cached is None:
            r, c = np.indices(term.shape)
            cached = self._index_cache[key + ("dense", term.shape)] = self._mapped(r.ravel(), c.ravel(), rowmap, colmap)
        rows, cols, keep = cached
        return rows, cols, term.reshape(-1)[keep]

    @staticmethod
    def _mapped(r, c, rowmap, colmap):
        """`rowmap` an index array (-1 = drop), or an integer: the block's first row, every row kept."""
        if isinstance(rowmap, np.ndarray):
            rows, cols = rowmap[r], colmap[c]
            keep = (rows >= 0) & (cols >= 0)
        else:
            rows, cols = np.asarray(r, np.int64) + rowmap, colmap[c]
            keep = cols >= 0
        if keep.all():  # no fixed entry: a slice takes the values without copying them
            return rows, cols, slice(None)
        return rows[keep], cols[keep], np.flatnonzero(keep)

    def _weighted_linearization(self, values, index):
        block, w = self._blocks[index]
        r, jacs = block.evaluate(self._block_values(values, block), True)
        r = self._checked(block, r)
        if np.ndim(w) == 0:
            return (r, list(jacs)) if w == 1.0 else (w * r, [w * j for j in jacs])
        scaled = []
        for j in jacs:
            if sp.issparse(j):
                j = sp.coo_matrix(j, copy=True)
                j.data *= w[j.row]  # keeps explicit zeros (a product with diags(w) would drop them)
            else:
                j = w[:, None] * np.asarray(j, float)
            scaled.append(j)
        return w * r, scaled

    def _structural_product(self, key: tuple, a: Matrix, b: Matrix) -> Matrix:
        """aᵀb; for sparse a, b as COO on the structural pattern of |a|ᵀ|b| in column-major order.

        scipy computes bᵀa (CSR, i.e. aᵀb in CSC) with its entries in an order that depends on the
        input patterns only, dropping entries that cancel to exact zero. Cached per pattern of a, b:
        the sorted pattern (from the product of the patterns, its entry numbers sorted along) and
        the slot of every entry of that order, so a refresh is one product and one scatter. A
        product with cancelled entries is placed by a search instead.
        """
        if not (sp.issparse(a) and sp.issparse(b)):
            return a.T @ b
        bt, a = sp.csc_matrix(b).T, sp.csr_matrix(a)  # CSR bᵀ and CSR a: one conversion at most
        signature = (bt.indptr, bt.indices, a.indptr, a.indices)
        cached = self._index_cache.get(key)
        if cached is None or not all(np.array_equal(x, y) for x, y in zip(cached[0], signature)):
            ones = lambda m: sp.csr_matrix((np.ones(m.nnz), m.indices, m.indptr), shape=m.shape)
            struct = ones(bt) @ ones(a)  # bᵀa in scipy's entry order
            order = (struct.indptr.copy(), struct.indices.copy())
            struct.data = np.arange(struct.nnz, dtype=float)
            struct.sort_indices()  # column-major aᵀb; data: where each entry was
            slots = np.empty(struct.nnz, np.intp)
            slots[struct.data.astype(np.intp)] = np.arange(struct.nnz)
            cols = np.repeat(np.arange(struct.shape[0]), np.diff(struct.indptr))
            template = sp.coo_matrix((np.zeros(struct.nnz), (struct.indices, cols)), shape=struct.shape[::-1])
            cached = self._index_cache[key] = [tuple(x.copy() for x in signature), template, (*order, slots)]
        _, template, (indptr, indices, slots) = cached
        prod = bt @ a
        if not (np.array_equal(indptr, prod.indptr) and np.array_equal(indices, prod.indices)):
            keys = template.col.astype(np.int64) * template.shape[0] + template.row  # increasing
            pcols = np.repeat(np.arange(prod.shape[0], dtype=np.int64), np.diff(prod.indptr))
            slots = np.searchsorted(keys, pcols * template.shape[0] + prod.indices)
            cached[2] = (prod.indptr.copy(), prod.indices.copy(), slots)
        data = np.empty(template.nnz) if prod.nnz == template.nnz else np.zeros(template.nnz)
        data[slots] = prod.data
        return sp.coo_matrix((data, (template.row, template.col)), shape=template.shape)

    def jacobian(self, theta: np.ndarray) -> tuple[np.ndarray, sp.csc_matrix]:
        """h(θ) and the stacked weighted Jacobian J (CSC, pattern cached across calls; its rows per
        `row_map`)."""
        h, rows, cols, vals = self._jacobian_triplets(theta)
        return h, self._jac_assembler.assemble_parts(rows, cols, vals)

    def nonzero_jacobian(self, theta: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """h(θ) and the stacked weighted J as CSR on the entries that were ever nonzero in this
        problem's evaluations (`assembly.NonzeroPattern`): the values of `jacobian`, without the
        entries that are zero by construction. Its pattern changes only when an entry becomes
        nonzero for the first time (`nonzero_version`), so a factorization analysed on it holds."""
        layout = self.layout
        h, rows, cols, vals = self._jacobian_triplets(theta)
        J = self._nonzero_gather.reduced(self._jact_assembler, self._nonzero, cols, rows, vals)
        if J is None:  # a new pattern or a new nonzero: assembled in full, then reduced
            Jt = self._jact_assembler.assemble_parts(cols, rows, vals)  # Jᵀ in CSC: J in CSR
            J = sp.csr_matrix((Jt.data, Jt.indices, Jt.indptr), shape=(int(self._jacobian_offsets[-1]), layout.n))
            J = self._nonzero.reduced(J, self._jact_assembler.version)
            self._nonzero_gather.follow(self._jact_assembler, self._nonzero)
        return h, J

    @property
    def nonzero_version(self) -> int:
        """Changes whenever the pattern of `nonzero_jacobian` changes."""
        return self._nonzero.version

    def _jacobian_triplets(self, theta: np.ndarray):
        """h(θ) and the COO pieces (rows, cols, values) of the stacked weighted J."""
        layout = self.layout
        values = layout.values(theta)
        residuals, rows, cols, vals = [], [], [], []
        for k, (block, _) in enumerate(self._blocks):
            r, jacs = self._weighted_linearization(values, k)
            residuals.append(r)
            first = int(self._jacobian_offsets[k])  # the block's rows: first, first + 1, ...
            for i, (name, jac) in enumerate(zip(block.variables, jacs)):
                rr, cc, vv = self._coo(("J", k, i), jac, first, layout.columns[name])
                rows.append(rr), cols.append(cc), vals.append(vv)
        return _cat(residuals, float), rows, cols, vals

    def normal_equations(self, theta: np.ndarray, assembly: str = "blocks",
                         schur: tuple[np.ndarray, int] | None = None) -> NormalEquations:
        """h, H = JᵀJ and g = Jᵀh at θ for eq. (13), by the chosen assembly path (J instead of H for
        ``"jacobian"``).

        `schur` (the eliminated columns and their block size, `VariableLayout.schur_columns`) asks for H
        as the dense pieces of the Schur elimination (`SchurParts`, H itself None) where the problem is one
        structured block over a kept and an eliminated variable (`schur_parts_plan`): its dense normal
        terms go to the solver without a sparse H being assembled and gathered back."""
        if assembly not in ASSEMBLY_MODES:
            raise ValueError(f"assembly must be one of {ASSEMBLY_MODES}, got {assembly!r}")
        if self.row_map() is not None:
            raise ValueError("normal equations of blocks with shared Jacobian rows: use nonzero_jacobian")
        layout = self.layout
        n = layout.n
        diag = self._diagonal
        if assembly == "jacobian":  # Jᵀ assembled as CSC, i.e. J as CSR; no JᵀJ
            t0 = time.perf_counter()
            h, rows, cols, vals = self._jacobian_triplets(theta)
            Jt = self._jact_assembler.assemble_parts(cols, rows, vals)
            t1 = time.perf_counter()
            g = Jt @ h
            return NormalEquations(h, None, g, self._jact_assembler.version, t1 - t0, time.perf_counter() - t1,
                                   jacobian=Jt.T)
        if assembly == "stacked":
            t0 = time.perf_counter()
            h, J = self.jacobian(theta)
            t1 = time.perf_counter()
            product = self._structural_product(("JtJ",), J, J)
            rows, cols, vals = [product.row, diag], [product.col, diag], [product.data, None]
            return self._finish(h, rows, cols, vals, J.T @ h, t1 - t0, t1)
        t0 = time.perf_counter()
        values = layout.values(theta)
        plan = self.schur_parts_plan(*schur) if schur is not None and assembly == "blocks" else None
        if plan is not None:
            direct = self._schur_equations(values, plan, t0)
            if direct is not None:
                return direct
        terms = []
        for k, (block, w) in enumerate(self._blocks):
            if isinstance(block, StructuredBlock):
                nt = block.normal_terms(self._block_values(values, block))
                nt.residual = w * self._checked(block, nt.residual)
                if w != 1.0:
                    nt.hessian = {ij: _scaled(t, w * w) for ij, t in nt.hessian.items()}
                    nt.gradient = [w * w * gi for gi in nt.gradient]
            else:
                nt = default_normal_terms(*self._weighted_linearization(values, k),
                                          product=lambda i, j, a, b, k=k: self._structural_product(("JtJ", k, i, j), a, b))
            terms.append(nt)
        t1 = time.perf_counter()
        g = np.zeros(n)
        rows, cols, vals = [diag], [diag], [None]  # structural diagonal
        for k, ((block, _), nt) in enumerate(zip(self._blocks, terms)):
            maps = [layout.columns[name] for name in block.variables]
            for i, gi in enumerate(nt.gradient):
                keep = maps[i] >= 0
                g[maps[i][keep]] += np.asarray(gi).reshape(-1)[keep]  # columns within one variable are distinct
            for (i, j), term in nt.hessian.items():
                rr, cc, vv = self._coo(("H", k, i, j), term, maps[i], maps[j])
                rows.append(rr), cols.append(cc), vals.append(vv)
                if i != j:
                    rows.append(cc), cols.append(rr), vals.append(vv)
        h = _cat([nt.residual for nt in terms], float)
        return self._finish(h, rows, cols, vals, g, t1 - t0, t1)

    def schur_parts_plan(self, eliminate: np.ndarray, block: int):
        """(block, weight, free) if H can be handed over as `SchurParts`: one `StructuredBlock` over two
        variables, the second exactly the eliminated columns (none fixed, `block` per diagonal block), the
        first the kept ones (its free entries `free`, in θ's order); else None. Cached per structure."""
        key = ("schur_parts", int(block), eliminate.tobytes())
        if key not in self.structure_cache:
            self.structure_cache[key] = self._schur_parts_plan(np.asarray(eliminate), int(block))
        return self.structure_cache[key]

    def _schur_parts_plan(self, eliminate: np.ndarray, block: int):
        layout = self.layout
        if len(self._blocks) != 1 or not isinstance(self._blocks[0][0], StructuredBlock):
            return None
        structured, w = self._blocks[0]
        if len(structured.variables) != 2 or len(layout.blocks) != 2:
            return None
        kept, eliminated = (layout.columns[name] for name in structured.variables)
        free = np.flatnonzero(kept >= 0)
        if not (np.array_equal(eliminated, eliminate) and np.array_equal(kept[free], np.arange(free.size))
                and np.array_equal(eliminate, free.size + np.arange(eliminate.size)) and eliminate.size % block == 0):
            return None
        return structured, w, free

    def _schur_equations(self, values, plan, t0) -> NormalEquations | None:
        """`normal_equations` with H as `SchurParts`; None if the block's terms are not dense (0, 0) and
        (0, 1) terms and a `BlockDiagonal` (1, 1) term (then H is assembled from them as usual)."""
        block, w, free = plan
        nt = block.normal_terms(self._block_values(values, block))
        nt.residual = w * self._checked(block, nt.residual)
        if w != 1.0:
            nt.hessian = {ij: _scaled(t, w * w) for ij, t in nt.hessian.items()}
            nt.gradient = [w * w * gi for gi in nt.gradient]
        t1 = time.perf_counter()
        h00, h01, h11 = (nt.hessian.get(ij) for ij in ((0, 0), (0, 1), (1, 1)))
        if not (len(nt.hessian) == 3 and isinstance(h00, np.ndarray) and isinstance(h01, np.ndarray)
                and isinstance(h11, BlockDiagonal)):
            return None
        n = self.layout.n
        g = np.zeros(n)
        g[:free.size] += np.asarray(nt.gradient[0]).reshape(-1)[free]
        g[free.size:] += np.asarray(nt.gradient[1]).reshape(-1)
        # 0 + value, as the sparse sum of the assembled H holds every entry (a −0 becomes +0)
        parts = SchurParts(h00[np.ix_(free, free)] + 0.0, h01[free] + 0.0, h11.blocks + 0.0)
        return NormalEquations(nt.residual, None, g, -1, t1 - t0, time.perf_counter() - t1, schur_parts=parts)

    def _finish(self, h, rows, cols, vals, g, evaluate_seconds, t_start) -> NormalEquations:
        H = self._hess_assembler.assemble_parts(rows, cols, vals)
        return NormalEquations(h, H, g, self._hess_assembler.version, evaluate_seconds,
                               time.perf_counter() - t_start)


def _cat(parts: list[np.ndarray], dtype) -> np.ndarray:
    return np.concatenate(parts).astype(dtype, copy=False) if parts else np.zeros(0, dtype)


def _scaled(term, factor: float):
    return BlockDiagonal(term.blocks * factor) if isinstance(term, BlockDiagonal) else term * factor
