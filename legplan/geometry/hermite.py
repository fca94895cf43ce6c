"""Cubic Hermite node splines, the trajectory representation of TOWR (TOWR-costs paper, Sec. III-A).

A spline is a list of segments over a node array. Node j holds a value p_j and a time derivative
v_j (one column each per dimension); a *Hermite* segment on [t0, t1] with h = t1 − t0 and s = (t − t0)/h is

    x(t) = h00(s) p_a + h10(s) h v_a + h01(s) p_b + h11(s) h v_b,
    h00 = 2s³ − 3s² + 1,  h10 = s³ − 2s² + s,  h01 = −2s³ + 3s²,  h11 = s³ − s²,

and a *constant* segment holds x(t) = p_a (a stance foot, or a zero force in swing). Everything is
linear in the node array N (2·nodes × dim, rows p_0, v_0, p_1, v_1, ...): sampling at times t is
`spline.matrix(t, derivative) @ N`, a sparse (len(t) × 2·nodes) matrix, so a sampled constraint
has the Jacobian `matrix ⊗ (∂r/∂x)` with respect to the nodes.

`hermite_gram(h, d)` gives the 4 × 4 matrix Q with ∫_0^h (x^(d)(t))² dt = cᵀQc for c = (p_a, v_a,
p_b, v_b): the closed form behind the analytic integral costs of eq. (1).
"""

from __future__ import annotations

import functools

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.geometry.sparse import wrapped

# x(s) = Σ_k s^k (_MONOMIAL[k] · (p_a, h v_a, p_b, h v_b)): monomial coefficients of the basis
_MONOMIAL = np.array([[1, 0, 0, 0],
                      [0, 1, 0, 0],
                      [-3, -2, 3, -1],
                      [2, 1, -2, 1]], dtype=float)


_FALLING = [[float(np.prod(np.arange(k - d + 1, k + 1))) if d else 1.0 for k in range(4)] for d in range(4)]
"""k!/(k−d)! by [d][k]: the factor of d^d/ds^d s^k."""


def hermite_weights(s: np.ndarray, h: np.ndarray, derivative: int = 0) -> np.ndarray:
    """(n, 4) weights of (p_a, v_a, p_b, v_b) for the `derivative`-th time derivative at s ∈ [0, 1]
    on segments of duration h (scalar or (n,))."""
    s = np.asarray(s, float).reshape(-1)
    h = np.broadcast_to(np.asarray(h, float), s.shape)
    powers = np.zeros((s.size, 4))
    for k in range(derivative, 4):  # d^d/ds^d s^k = k!/(k-d)! s^(k-d)
        powers[:, k] = _FALLING[derivative][k] * s ** (k - derivative)
    w = powers @ _MONOMIAL / h[:, None] ** derivative
    w[:, 1] *= h
    w[:, 3] *= h
    return w


def hermite_time_partials(s: np.ndarray, h: np.ndarray, derivative: int = 0, moving: bool = False
                          ) -> tuple[np.ndarray, np.ndarray]:
    """(n, 4) weights of (p_a, v_a, p_b, v_b) in ∂x^(r)/∂t0 and ∂x^(r)/∂t1, the derivatives of a sample
    of the segment [t0, t1] with respect to its ends (r = `derivative`): at a fixed time t when not
    `moving`, at a fixed fraction s = (t − t0)/h when `moving` (the sample moves with the segment).

    With x^(r) = h^(−r) Σ_k P_k^(r)(s) (M_k · (p_a, h v_a, p_b, h v_b)): ∂x^(r)/∂s = h x^(r+1) and
    ∂x^(r)/∂h at fixed s = −(r/h) x^(r) + (the v terms)/h; at a fixed time ∂s/∂t0 = (s − 1)/h,
    ∂s/∂t1 = −s/h, and ∂h/∂t0 = −1, ∂h/∂t1 = 1 either way."""
    s = np.asarray(s, float).reshape(-1)
    h = np.broadcast_to(np.asarray(h, float), s.shape)
    w = hermite_weights(s, h, derivative)
    w_h = -derivative / h[:, None] * w
    w_h[:, 1::2] += w[:, 1::2] / h[:, None]
    if moving:
        return -w_h, w_h
    rate = hermite_weights(s, h, derivative + 1)
    return rate * (s - 1.0)[:, None] - w_h, -rate * s[:, None] + w_h


def hermite_gram(h: float, derivative: int = 0) -> np.ndarray:
    """Q (4 × 4) with ∫_0^h x^(d)(t)² dt = cᵀQc, c = (p_a, v_a, p_b, v_b), exact (rational integrals
    of the monomial basis, then scaled by h)."""
    d = derivative
    coeff = np.zeros((4, 4))
    for k in range(d, 4):
        coeff[k - d] = np.prod(np.arange(k - d + 1, k + 1)) * _MONOMIAL[k] if d else _MONOMIAL[k]
    m = np.array([[1.0 / (i + j + 1) for j in range(4)] for i in range(4)])  # ∫ s^(i+j) ds, correctly rounded
    q = coeff.T @ m @ coeff * h / h ** (2 * d)  # dt = h ds, d/dt = (1/h) d/ds
    scale = np.array([1.0, h, 1.0, h])
    return q * np.outer(scale, scale)


@dataclass(frozen=True)
class Segment:
    """[t0, t1] of a spline: Hermite from node `a` to node `b`, or constant at node `a` (b = -1)."""

    t0: float
    t1: float
    a: int
    b: int = -1

    @property
    def constant(self) -> bool:
        return self.b < 0


class NodeSpline:
    """A piecewise cubic Hermite / constant curve over `nodes` nodes (see module docstring)."""

    def __init__(self, segments: list[Segment], nodes: int):
        if not segments:
            raise ValueError("a spline needs at least one segment")
        starts = np.array([s.t0 for s in segments])
        ends = np.array([s.t1 for s in segments])
        if np.any(ends <= starts) or np.any(np.abs(starts[1:] - ends[:-1]) > 1e-9):
            raise ValueError("segments must have positive durations and follow each other without gaps")
        self.segments = list(segments)
        self.nodes = int(nodes)
        self.starts, self.ends = starts, ends
        self.node_a = np.array([s.a for s in self.segments])  # per segment: its nodes (b = -1: constant)
        self.node_b = np.array([s.b for s in self.segments])
        self.duration = float(ends[-1])

    def segment_index(self, times) -> np.ndarray:
        """Segment of each time; a time on a boundary belongs to the segment that ends there
        (as TOWR's spline), times before 0 / after the end to the first / last segment."""
        t = np.asarray(times, float).reshape(-1)
        return np.clip(np.searchsorted(self.ends, t - 1e-12, side="left"), 0, len(self.segments) - 1)

    def matrix(self, times, derivative: int = 0) -> sp.csr_matrix:
        """Sparse (len(times) × 2·nodes) M with x^(derivative)(t_i) = Σ_j M[i, j] N[j] (N as in the
        module docstring: column 2j is p_j, 2j+1 is v_j). A copy of a cached matrix: every task of
        a task space samples splines of the same segments at the same times (in profiles of learned
        pallet solves, building them again was 7-9 % of the time)."""
        t = np.ascontiguousarray(times, float).reshape(-1)
        key = self.__dict__.get("_key")
        if key is None:
            key = self._key = _SplineKey(self)
        m = _sampling_matrix(key, t.tobytes(), derivative)
        return wrapped(sp.csr_matrix, m.data.copy(), m.indices.copy(), m.indptr.copy(), m.shape)  # valid: a copy

    def _matrix(self, t: np.ndarray, derivative: int) -> sp.csr_matrix:
        seg = self.segment_index(t)
        return self.matrix_at(seg, np.clip((t - self.starts[seg]) / (self.ends[seg] - self.starts[seg]), 0.0, 1.0),
                              derivative)

    def matrix_at(self, seg: np.ndarray, fraction: np.ndarray, derivative: int = 0) -> sp.csr_matrix:
        """`matrix` of samples given by their segment and the fraction s ∈ [0, 1] of it."""
        seg = np.asarray(seg, int).reshape(-1)
        frac = np.asarray(fraction, float).reshape(-1)
        a, b = self.node_a[seg], self.node_b[seg]
        hermite = b >= 0
        idx = np.flatnonzero(hermite)
        w = hermite_weights(frac[idx], (self.ends - self.starts)[seg[idx]], derivative)
        cols = np.stack([2 * a[idx], 2 * a[idx] + 1, 2 * b[idx], 2 * b[idx] + 1], axis=1)
        if np.all(a[idx] < b[idx]) and max(frac.size, 2 * self.nodes) < np.iinfo(np.int32).max:
            # every row's columns distinct and increasing: the canonical CSR at once, as scipy's
            # COO conversion would give it (its int32 indices, rows in order), without the sort
            if idx.size == frac.size:  # Hermite segments only: 4 entries a row, the weights in order
                indptr = np.arange(0, 4 * frac.size + 1, 4, dtype=np.int32)
                return wrapped(sp.csr_matrix, w.reshape(-1), cols.reshape(-1).astype(np.int32), indptr,
                               (frac.size, 2 * self.nodes))
            count = np.where(hermite, 4, 1 if derivative == 0 else 0)
            indptr = np.zeros(frac.size + 1, np.int32)
            np.cumsum(count, out=indptr[1:])
            indices, data = np.empty(indptr[-1], np.int32), np.empty(indptr[-1])
            slots = indptr[idx][:, None] + np.arange(4)
            indices[slots], data[slots] = cols, w
            const = np.flatnonzero(~hermite) if derivative == 0 else np.zeros(0, int)
            indices[indptr[const]], data[indptr[const]] = 2 * a[const], 1.0
            return wrapped(sp.csr_matrix, data, indices, indptr, (frac.size, 2 * self.nodes))
        rows, vals = [np.repeat(idx, 4)], [w.reshape(-1)]
        cols = [cols.reshape(-1)]
        if derivative == 0:  # a constant segment holds its node's value; its derivatives vanish
            const = np.flatnonzero(~hermite)
            rows.append(const), cols.append(2 * a[const]), vals.append(np.ones(const.size))
        m = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(frac.size, 2 * self.nodes))
        return m.tocsr()


class _SplineKey:
    """A spline as a cache key: equal for equal segments and node counts (any spline object), its
    hash computed once (a tuple of segments hashes every segment at every look-up); it carries the
    first spline it was made for, whose `_matrix` fills the cache (equal splines sample alike)."""

    __slots__ = ("segments", "nodes", "spline", "_hash")

    def __init__(self, spline: NodeSpline):
        self.segments, self.nodes, self.spline = tuple(spline.segments), spline.nodes, spline
        self._hash = hash((self.segments, self.nodes))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return self is other or (isinstance(other, _SplineKey) and self._hash == other._hash
                                 and self.nodes == other.nodes and self.segments == other.segments)


@functools.lru_cache(maxsize=256)  # a learned pallet plan samples 48 (spline, times) pairs
def _sampling_matrix(key: _SplineKey, times: bytes, derivative: int) -> sp.csr_matrix:
    """`NodeSpline.matrix` of the spline `key` at the float64 times given as bytes."""
    return key.spline._matrix(np.frombuffer(times, float), derivative)


def kron_dim(m: sp.spmatrix, dim: int = 3) -> sp.csr_matrix:
    """M ⊗ I_dim: the sampling matrix acting on the flattened node array (node, p|v, dimension)."""
    return sp.kron(sp.csr_matrix(m), sp.identity(dim, format="csr"), format="csr")


def kron_axis(m: sp.spmatrix, axis: int, dim: int = 3) -> sp.csr_matrix:
    """The rows of one `axis` of M ⊗ I_dim (`kron_dim(m)[axis::dim]`): M's entries, in its order, at the
    columns dim·j + axis; written down from M's CSR arrays instead of the product and a row slice."""
    m = m if type(m) is sp.csr_matrix else sp.csr_matrix(m)
    index = np.result_type(m.indices.dtype, np.int32)
    indices = (dim * m.indices.astype(np.int64) + axis).astype(index)
    return sp.csr_matrix((m.data.copy(), indices, m.indptr.astype(index)), shape=(m.shape[0], dim * m.shape[1]))


@functools.lru_cache(maxsize=512)
def _jacobian_structure(rows: int, samples: int, columns: int, patterns: tuple) -> tuple:
    """`SampledJacobian`'s structure for its sizes and the (indptr, indices) patterns of its matrices
    (dtype and bytes each): the sample row of every matrix entry, the CSR slot of every product entry,
    the CSR indices and indptr (read-only, shared). Cached by content: every problem built for a task
    space samples its splines alike, and a stage's problem repeats the last one's, so most blocks of a
    new problem find their structure here (it was a third of a problem's first Jacobian). When every
    matrix has one and the same pattern with increasing columns in each row (a spline sampled once,
    or its derivatives), that structure is written down directly (`_one_pattern_structure`)."""
    if len(set(patterns)) == 1:
        direct = _one_pattern_structure(rows, samples, columns, *patterns[0], len(patterns))
        if direct is not None:
            return direct
    else:
        merged = _merged_structure(rows, samples, columns, patterns)
        if merged is not None:
            return merged
    return _sorted_structure(rows, samples, columns, patterns)


def _merged_structure(rows: int, samples: int, columns: int, patterns: tuple) -> tuple | None:
    """`_jacobian_structure` of matrices of several patterns whose entries, taken term after term,
    have increasing columns in every row (None otherwise), without a sort: the terms share no entry
    (the feet or forces of the legs, each on its own nodes), so each term's entries sit in the row of
    their union at the term's offset there, and the union is one pattern (`_one_pattern_structure`),
    whose slots the terms' entries take."""
    arrays = [(np.frombuffer(ptr, ptr_dtype).astype(np.int64), np.frombuffer(idx, idx_dtype))
              for ptr_dtype, ptr, idx_dtype, idx in patterns]
    if any(indptr.size != samples + 1 for indptr, _ in arrays):
        return None
    counts = np.array([np.diff(indptr) for indptr, _ in arrays])  # (terms, samples)
    before = np.cumsum(counts, axis=0) - counts  # each term's offset within the union's row
    union_ptr = np.zeros(samples + 1, np.int64)
    np.cumsum(counts.sum(axis=0), out=union_ptr[1:])
    union_indices = np.empty(int(union_ptr[-1]), np.int64)
    entry_rows, places = [], []
    for (indptr, indices), offset in zip(arrays, before):
        entry_row = np.repeat(np.arange(samples), np.diff(indptr))
        place = union_ptr[entry_row] + offset[entry_row] + (np.arange(indices.size) - indptr[entry_row])
        union_indices[place] = indices
        entry_rows.append(entry_row)
        places.append(place)
    index = np.int32 if max(union_indices.size, samples) <= np.iinfo(np.int32).max else np.int64
    union = _one_pattern_structure(rows, samples, columns, np.dtype(index).str, union_ptr.astype(index).tobytes(),
                                   np.dtype(index).str, union_indices.astype(index).tobytes(), 1)
    if union is None:
        return None
    _, union_slot, out_indices, out_indptr = union
    by_entry = union_slot.reshape(union_indices.size, 3 * rows)
    slot = np.concatenate([by_entry[place].reshape(-1) for place in places])
    slot.flags.writeable = False
    for entry_row in entry_rows:
        entry_row.flags.writeable = False
    return entry_rows, slot, out_indices, out_indptr


def _sorted_structure(rows: int, samples: int, columns: int, patterns: tuple) -> tuple:
    """`_jacobian_structure` for any patterns: every product entry's key (row, column), sorted and
    merged (`np.unique`)."""
    entry_rows, keys = [], []
    for ptr_dtype, ptr, idx_dtype, idx in patterns:
        indptr, indices = np.frombuffer(ptr, ptr_dtype), np.frombuffer(idx, idx_dtype)
        entry_row = np.repeat(np.arange(samples), np.diff(indptr))
        shape = (entry_row.size, rows, 3)
        r = np.broadcast_to((rows * entry_row)[:, None, None] + np.arange(rows)[None, :, None], shape)
        c = np.broadcast_to((3 * indices)[:, None, None] + np.arange(3)[None, None, :], shape)
        keys.append((r.astype(np.int64) * columns + c).reshape(-1))
        entry_rows.append(entry_row)
    unique, slot = np.unique(np.concatenate(keys), return_inverse=True)
    index = np.int32 if max(unique.size, columns, samples * rows) < np.iinfo(np.int32).max else np.int64
    # in scipy's index dtype already: the CSR matrices share these (read-only) arrays, call after call
    out = (entry_rows, slot, (unique % columns).astype(index),
           np.searchsorted(unique // columns, np.arange(samples * rows + 1)).astype(index))
    for a in [*entry_rows, *out[1:]]:
        a.flags.writeable = False
    return out


def _one_pattern_structure(rows: int, samples: int, columns: int, ptr_dtype, ptr, idx_dtype, idx,
                           terms: int) -> tuple | None:
    """`_jacobian_structure` of `terms` matrices of one CSR pattern whose columns increase within each
    row (None otherwise), without a sort: no two entries coincide within a term, so the product's
    row (i, a) (sample i, residual row a) holds, in order, the 3 columns 3j + b of each entry j of
    sample i, entry e of that sample at slot 3·rows·p_i + 3·a·n_i + 3·(e − p_i) + b (p_i its first
    entry, n_i its count); the terms' entries share these slots."""
    indptr, indices = np.frombuffer(ptr, ptr_dtype), np.frombuffer(idx, idx_dtype)
    if indices.size > 1:
        increasing = indices[1:] > indices[:-1]
        starts = indptr[1:-1]
        increasing[starts[(starts > 0) & (starts < indices.size)] - 1] = True  # pairs across rows
        if not increasing.all():
            return None
    count = np.diff(indptr).astype(np.int64)
    first = indptr[:-1].astype(np.int64)
    entry_row = np.repeat(np.arange(samples), count)
    size = 3 * rows * indices.size
    index = np.int32 if max(size, columns, samples * rows) < np.iinfo(np.int32).max else np.int64
    start = 3 * rows * first[entry_row] + 3 * (np.arange(indices.size) - first[entry_row])
    slot = (start[:, None, None] + (3 * count[entry_row])[:, None, None] * np.arange(rows)[None, :, None]
            + np.arange(3)[None, None, :]).reshape(-1).astype(np.intp)
    out_indices = np.empty(size, index)
    out_indices[slot] = np.broadcast_to((3 * indices.astype(np.int64))[:, None, None] + np.arange(3),
                                        (indices.size, rows, 3)).reshape(-1)
    out_indptr = np.append((3 * rows * first[:, None] + 3 * count[:, None] * np.arange(rows)).reshape(-1),
                           size).astype(index)
    out = ([entry_row] * terms, np.tile(slot, terms), out_indices, out_indptr)
    for a in [entry_row, *out[1:]]:
        a.flags.writeable = False
    return out


def _uniform_structure(rows: int, samples: int, columns: int, matrices) -> tuple | None:
    """(c, CSR indices, CSR indptr) of `SampledJacobian`'s J when its matrices share one pattern (equal
    arrays) holding c ≥ 1 entries in every one of its `samples` rows, their columns increasing: row
    (i, a) of J holds, in order, the 3 columns 3j + b of each entry j of sample i, so the product
    M[i, j]·G_i[a, b] in the order (i, a, entry, b) is J's data (c·3 entries a row). The arrays are
    those `_jacobian_structure` gives (read-only, shared by every call). None otherwise."""
    first = matrices[0]
    indptr, indices = first.indptr, first.indices
    if samples < 1 or indptr.size != samples + 1 or indices.size % samples or not indices.size:
        return None
    c = indices.size // samples
    if first.data.dtype != np.float64 or first.data.size != indices.size or not all(
            m.data.dtype == np.float64 and np.array_equal(m.indptr, indptr) and np.array_equal(m.indices, indices)
            for m in matrices[1:]):
        return None
    if not np.array_equal(indptr, c * np.arange(samples + 1)):
        return None
    by_row = indices.reshape(samples, c)
    if c > 1 and not np.all(by_row[:, 1:] > by_row[:, :-1]):
        return None
    size = 3 * rows * indices.size
    index = np.int32 if max(size, columns, samples * rows) < np.iinfo(np.int32).max else np.int64
    out_indices = np.empty((samples, rows, c, 3), index)
    out_indices[...] = (3 * by_row.astype(np.int64))[:, None, :, None] + np.arange(3)
    out_indices = out_indices.reshape(-1)
    out_indptr = (3 * c * np.arange(samples * rows + 1, dtype=np.int64)).astype(index)
    out_indices.flags.writeable = out_indptr.flags.writeable = False
    return c, out_indices, out_indptr


class SampledJacobian:
    """Jacobian of `rows` residuals per sample, J[(i, a), (j, b)] = Σ_terms M[i, j] · G_i[a, b].

    Each term has a fixed sparse M (samples × columns/3): the sampled 3-vector x_i = (M ⊗ I₃) N; at
    each evaluation the call gives per-sample blocks G (samples, rows, 3) = ∂r_i/∂x_i, one per term.
    Terms over the same variable are summed. The pattern depends on the M's only (explicit zeros
    kept), so the entries' places, the merge of coinciding ones and the CSR order are worked out
    once per pattern, at the first call (`_jacobian_structure`; a block evaluated without Jacobians
    never pays for them); a call multiplies, sums into those places and wraps the CSR arrays. Where
    every term has one pattern with the same number c of increasing columns in every row (a spline
    sampled in Hermite segments only, or in constant ones only), the CSR order is the products'
    own order (sample, row, entry, axis) and nothing is placed (`_uniform_structure`): the products
    are the CSR data, with the sums of the terms in their order from 0, as the placed sums.
    """

    def __init__(self, matrices, rows: int, samples: int, columns: int):
        self.matrices = [m if type(m) is sp.csr_matrix else sp.csr_matrix(m) for m in matrices]
        self.rows, self.samples, self.columns = rows, samples, columns
        self.slot = None
        self.uniform = None  # the entries per row of `_uniform_structure`, once known; 0: placed instead

    def _structure(self) -> None:
        patterns = tuple((m.indptr.dtype.str, m.indptr.tobytes(), m.indices.dtype.str, m.indices.tobytes())
                         for m in self.matrices)
        self.entry_rows, self.slot, self.indices, self.indptr = _jacobian_structure(
            self.rows, self.samples, self.columns, patterns)
        self.shape = (self.samples * self.rows, self.columns)

    def _direct(self) -> bool:
        """Whether the products are the CSR data in their own order (`_uniform_structure`), its
        arrays taken at the first call."""
        if self.uniform is None:
            structure = _uniform_structure(self.rows, self.samples, self.columns, self.matrices)
            self.uniform = 0
            if structure is not None:
                self.uniform, self.indices, self.indptr = structure
                self.shape = (self.samples * self.rows, self.columns)
        return self.uniform > 0

    def with_matrices(self, matrices) -> SampledJacobian:
        """This Jacobian for new matrices of the same sizes: itself, with their values, when every
        pattern is the same (the entries' places stay: samples that moved within their segments);
        a new one otherwise."""
        new = [sp.csr_matrix(m) for m in matrices]
        if all(np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
               for a, b in zip(self.matrices, new)):
            self.matrices = new
            return self
        return SampledJacobian(new, self.rows, self.samples, self.columns)

    def __call__(self, blocks) -> sp.csr_matrix:
        """J for the per-sample blocks G of every term, in the order of the matrices."""
        if self._direct() and not any(np.iscomplexobj(g) for g in blocks):
            c = self.uniform
            data = None
            for m, g in zip(self.matrices, blocks):
                product = m.data.reshape(self.samples, 1, c, 1) * np.asarray(g)[:, :, None, :]
                if data is None:  # 0 + the first term, as a sum into zeros gives it (a −0 becomes 0)
                    data = np.add(product, 0.0, out=product)
                else:
                    data += product
            return wrapped(sp.csr_matrix, data.reshape(-1), self.indices, self.indptr, self.shape)
        if self.slot is None:
            self._structure()
        values = np.concatenate([(m.data[:, None, None] * g[entry_row]).reshape(-1)
                                 for m, g, entry_row in zip(self.matrices, blocks, self.entry_rows)])
        size = self.indices.size
        data = np.bincount(self.slot, weights=values.real, minlength=size)
        if np.iscomplexobj(values):
            data = data + 1j * np.bincount(self.slot, weights=values.imag, minlength=size)
        return wrapped(sp.csr_matrix, data, self.indices, self.indptr, self.shape)
