"""Linear solvers for the damped normal equations (JᵀJ + βI) x = b of eq. (13).

Each solver has `factorize(H, beta)` then `solve(rhs)`; a matrix that is not positive definite
raises `NotPositiveDefiniteError` (LM then raises λ; Algorithm 1 counts it as a failed step).
`factorize` is `set_matrix(H)` (work that depends on H only: conversion, symbolic analysis, the
Schur pieces of `SchurSolver`) followed by `refactor(beta)` (the numeric factorisation of H + βI).
LM calls `set_matrix` once per linearisation and `refactor(λ)` once per iteration, so a rejected
step (same H, larger λ) repeats only the λ-dependent work. `set_jacobian(J)` takes J instead of
H = JᵀJ (``assembly="jacobian"``): CHOLMOD factorises JᵀJ + βI from J in its AAᵀ mode (A = Jᵀ)
without JᵀJ being formed in Python; the other solvers form JᵀJ.

* ``cholmod`` (default): CHOLMOD via scikit-sparse. The fill-reducing ordering and symbolic
  factorisation are computed once per sparsity pattern (`cholmod.analyze`); every λ change is a
  numeric refactorisation `Factor.cholesky_inplace(H, beta=λ)`. Simplicial mode computes LDLᵀ and
  does not complain about indefinite matrices, so the sign of D is checked here. Simplicial wins on
  the step-planner-shaped matrices measured in bench/solve_lm.py; supernodal wins on matrices with
  large dense fronts (3D meshes). Only the lower triangle of H is read. The default ordering
  ``"auto"`` keeps the natural order when its fill is provably within `NATURAL_FILL_SLACK` of the
  least any order can give (banded or nearly dense H: no reordering can help, and AMD's analysis
  of a 100k-unknown band costs more than a numeric factorisation), else CHOLMOD's default.
* ``scipy``: SuperLU (`scipy.sparse.linalg.splu`) in symmetric mode on H + βI. The fallback when
  scikit-sparse is missing; refactors from scratch every time.
* ``dense``: LAPACK Cholesky (`scipy.linalg.cho_factor`). Wins below roughly a thousand unknowns,
  or whenever H is nearly dense (e.g. the reduced system after Schur elimination of slacks).
"""

from __future__ import annotations

import functools
import warnings
from abc import ABC, abstractmethod

import numpy as np
import scipy.sparse as sp

from legplan.solve.assembly import kept_indices, same_indices

try:
    from sksparse import cholmod
except ImportError as exc:  # pragma: no cover - depends on the environment
    cholmod = None
    _CHOLMOD_IMPORT_ERROR = exc

_fallback_warned = False

SOLVER_NAMES = ("cholmod", "scipy", "dense")
UPDATE_ROWS = 64  # `CholmodSolver.refactor_rows`: rank updates up to this many rows (break-even ≈ 128)
NATURAL_FILL_SLACK = 1.25  # "auto" ordering: natural when its fill bound ≤ this × the least fill possible


class NotPositiveDefiniteError(ArithmeticError):
    """H + βI could not be factorised as a positive-definite matrix."""


class LinearSolver(ABC):
    """Factorise H + βI once, then solve for any right-hand side."""

    name: str

    def factorize(self, H: sp.spmatrix | np.ndarray, beta: float) -> None:
        """Factorise H + βI; raise NotPositiveDefiniteError if it is not positive definite."""
        self.set_matrix(H)
        self.refactor(beta)

    @abstractmethod
    def set_matrix(self, H: sp.spmatrix | np.ndarray) -> None:
        """Take H for the following `refactor` calls (H must not be modified while in use)."""

    def set_jacobian(self, J: sp.spmatrix, rows: np.ndarray | None = None) -> None:
        """Take H = JᵀJ given J (m × n), or the product of its `rows` only, for the following
        `refactor` calls (same contract as `set_matrix`). This default forms the product;
        `CholmodSolver` factorises from J itself."""
        J = sp.csr_matrix(J)
        if rows is not None:
            J = J[rows]
        self.set_matrix(sp.csc_matrix(J.T @ J))

    @abstractmethod
    def refactor(self, beta: float) -> None:
        """Factorise H + βI for the H of the last `set_matrix`."""

    @abstractmethod
    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """x with (H + βI) x = rhs for the last factorised H, β."""


class CholmodSolver(LinearSolver):
    """CHOLMOD: analyse once per sparsity pattern, refactor numerically with beta = λ."""

    name = "cholmod"

    def __init__(self, mode: str = "simplicial", ordering_method: str = "auto"):
        if cholmod is None:
            raise ImportError("scikit-sparse is not importable") from _CHOLMOD_IMPORT_ERROR
        self.mode = mode
        self.ordering_method = ordering_method
        self._factor = None
        self._pattern: tuple | None = None
        self._pending: tuple | None = None  # (J, rows) whose J[rows]ᵀ the next refactorisation takes
        self.analyses = 0  # how many patterns it took (one analysis each, or a copy from `ANALYSES`)
        self.updates = 0  # how many `refactor_rows` calls were rank updates

    def set_matrix(self, H):
        self._set(sp.csc_matrix(H), transposed_jacobian=False)

    def set_jacobian(self, J, rows=None, keys=None):
        """CHOLMOD's AAᵀ factorisation with A = Jᵀ: JᵀJ + βI is factorised from J (its CSR arrays are
        those of Jᵀ in CSC), never formed here; the ordering is analysed on the pattern of JᵀJ. With
        `rows`, A holds those rows only, in that order, on the analysis of the whole J's pattern: the
        product of any subset of J's rows has a subset of its pattern, which CHOLMOD's numeric
        factorisation takes (checked against dense solves in the tests), so the hinged LM's active
        sets share one analysis. `keys` (distinct, increasing, one per entry of `rows`) name the
        residual rows that `rows` stand for when residual rows share a row of J (`Problem.row_map`;
        a row of J may then be given twice); `refactor_rows` follows the set by them."""
        J = sp.csr_matrix(J)
        self._set(_transposed(J), transposed_jacobian=True)
        self._rows = self._keys = None
        if rows is not None:
            self._rows = np.asarray(rows)
            self._keys = self._rows if keys is None else np.asarray(keys)
            self._pending = (J, self._rows)  # J[rows], taken when a factorization needs it

    def refactor_rows(self, J, rows: np.ndarray, keys: np.ndarray | None = None) -> None:
        """The factorisation of J_RᵀJ_R + βI for the rows R (sorted, or in the order of their `keys`
        as `set_jacobian`) of the same J as the last `set_jacobian(J, rows)`, at the last β: when at
        most `UPDATE_ROWS` rows join or leave, by CHOLMOD's rank updates of the current factor
        (cholmod_updown, simplicial LDLᵀ; the joining rows first, in the order of their keys, so the
        matrix grows before it shrinks), else, or when an update leaves a pivot ≤ 0, a
        refactorisation. Measured on a 1069-variable pallet problem: 0.03 ms a row against 3.5 ms a
        refactorisation, the solutions equal to 1e-12 (relative)."""
        J, rows = sp.csr_matrix(J), np.asarray(rows)
        keys = rows if keys is None else np.asarray(keys)
        before_rows, before_keys = self._rows, self._keys
        self._rows, self._keys, self._pending = rows, keys, (J, rows)  # J[rows] only if it comes to a refactorisation
        if _repeats(keys) or _repeats(before_keys):  # a row of J taken twice under one key: refactorized
            self.refactor(self._beta)
            return
        member = np.zeros(int(max(keys.max(initial=-1), before_keys.max(initial=-1))) + 1, np.int8)
        member[before_keys] -= 1
        member[keys] += 1  # 1: joins, −1: leaves
        added, removed = np.flatnonzero(member > 0), np.flatnonzero(member < 0)
        if self.mode == "simplicial" and added.size + removed.size <= UPDATE_ROWS:
            if added.size:
                self._factor.update_inplace(_transposed(J[rows[np.searchsorted(keys, added)]]))
            if removed.size:
                self._factor.update_inplace(_transposed(J[before_rows[np.searchsorted(before_keys, removed)]]),
                                            subtract=True)
            if np.all(self._factor.D() > 0):
                self.updates += 1
                return
        self.refactor(self._beta)

    def _set(self, A: sp.csc_matrix, transposed_jacobian: bool) -> None:
        """Take the analysis of A's pattern (H, or Jᵀ when `transposed_jacobian`) when it changes, then
        keep A (its indices sorted in place, as CHOLMOD would). The analysis is that of the pattern's
        canonical form (`_canonical`), from `ANALYSES` or new: the same whatever the cache holds, and
        shared by the Jacobians that differ only by rows repeating another row's pattern (the tasks
        of a task space, and their extra range-of-motion samples, on the pallet tasks)."""
        kept = self._pattern
        same = lambda: (kept is not None and kept[0] == transposed_jacobian and A.shape == kept[1]
                        and same_indices(kept[2], (A.indptr, A.indices)))
        known = same()  # the pattern kept after sorting (the same read-only arrays, or equal ones): sorted
        if known:
            A.has_sorted_indices = True
        else:
            A.sort_indices()
        if not (known or same()):
            self._pattern = (transposed_jacobian, A.shape, kept_indices((A.indptr, A.indices)))
            canonical = _canonical(A) if transposed_jacobian else A
            key = (self.mode, self.ordering_method, transposed_jacobian, canonical.shape,
                   canonical.indptr.copy(), canonical.indices.copy())
            self._factor = ANALYSES.copy_of(key)
            if self._factor is None:
                self._factor = self._analyze(canonical, transposed_jacobian)
                ANALYSES.add(key, self._factor.copy())
            self.analyses += 1
        self._matrix, self._pending = A, None
        self._transposed_jacobian = transposed_jacobian

    def _analyze(self, A: sp.csc_matrix, transposed_jacobian: bool):
        """CHOLMOD's symbolic analysis of A's pattern in the solver's ordering ("auto": module docstring)."""
        ordering = self.ordering_method
        if ordering == "auto":
            pattern = A
            if transposed_jacobian:  # structural JᵀJ (no entry cancelled)
                ones = sp.csc_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
                pattern = sp.csc_matrix(ones @ ones.T)
            ordering = "natural" if natural_order_suffices(pattern) else "default"
        analyze = cholmod.analyze_AAt if transposed_jacobian else cholmod.analyze
        return analyze(A, mode=self.mode, ordering_method=ordering)

    def refactor(self, beta):
        self._beta = beta
        if self._pending is not None:
            J, rows = self._pending
            self._matrix, self._pending = _transposed(J[rows]), None
        try:
            if self._transposed_jacobian:
                self._factor.cholesky_AAt_inplace(self._matrix, beta=beta)
            else:
                self._factor.cholesky_inplace(self._matrix, beta=beta)
        except cholmod.CholmodNotPositiveDefiniteError as exc:
            raise NotPositiveDefiniteError(str(exc)) from exc
        if self.mode == "simplicial":
            d = self._factor.D()
            if not np.all(d > 0):
                raise NotPositiveDefiniteError(f"LDLᵀ pivot {d.min():.3g} ≤ 0 at beta={beta:.3g}")

    def solve(self, rhs):
        return self._factor.solve_A(rhs)


class AnalysisCache:
    """The last `size` symbolic analyses of the process by (mode, ordering, pattern): a CHOLMOD
    analysis depends on the pattern only, and successive problems often share one (the planner's
    stages before and after its costs, every task of a task space sampled alike), while it costs
    more than a numeric factorization (14 ms against 3 ms on a 1069-variable pallet problem). A
    solver gets a copy of the cached factor, so no two solvers share one."""

    def __init__(self, size: int = 16):
        self.size = size
        self._entries: list[tuple[tuple, object]] = []  # most recent first

    def copy_of(self, key: tuple):
        """A copy of the analysis of `key` (mode, ordering, transposed, shape, indptr, indices), or None."""
        for k, (entry, factor) in enumerate(self._entries):
            if entry[:4] == key[:4] and np.array_equal(entry[4], key[4]) and np.array_equal(entry[5], key[5]):
                self._entries.insert(0, self._entries.pop(k))
                return factor.copy()
        return None

    def add(self, key: tuple, factor) -> None:
        self._entries.insert(0, (key, factor))
        del self._entries[self.size:]


ANALYSES = AnalysisCache()


def _repeats(rows: np.ndarray) -> bool:
    """Whether sorted row indices hold one twice."""
    return rows.size > 1 and bool(np.any(rows[1:] == rows[:-1]))


def _canonical(A: sp.csc_matrix) -> sp.csc_matrix:
    """Jᵀ (A, CSC) reduced to J's distinct row patterns, one row each, ordered by a hash of the pattern
    (a fixed random weight per column, summed): JᵀJ has the same pattern, so CHOLMOD's AAᵀ analysis
    of it holds for A. Every row is checked against its representative; if two patterns share a hash,
    A itself."""
    n, m = A.shape
    hashes = np.zeros(m, np.uint64)
    nonempty = np.diff(A.indptr) > 0
    if A.nnz:
        hashes[nonempty] = np.add.reduceat(_column_weights(n)[A.indices], A.indptr[:-1][nonempty])
    _, first, inverse = np.unique(hashes, return_index=True, return_inverse=True)
    J = sp.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=(m, n))
    representative = J[first]
    again = representative[inverse]
    if not (np.array_equal(again.indptr, J.indptr) and np.array_equal(again.indices, J.indices)):
        return A
    return _transposed(representative)


@functools.lru_cache(maxsize=16)
def _column_weights(n: int) -> np.ndarray:
    """Fixed random 64-bit weights of n columns for `_canonical`'s row hash (read-only)."""
    weights = np.random.default_rng(n).integers(1, np.iinfo(np.int64).max, size=n, dtype=np.uint64)
    weights.flags.writeable = False
    return weights


def _transposed(J: sp.csr_matrix) -> sp.csc_matrix:
    """Jᵀ in CSC from J in CSR, sharing its arrays."""
    return sp.csc_matrix((J.data, J.indices, J.indptr), shape=J.shape[::-1])


def natural_order_suffices(H: sp.csc_matrix) -> bool:
    """Whether Cholesky of the structurally symmetric H in its natural order has at most
    `NATURAL_FILL_SLACK` times the fill of the best order.

    In the natural order row i of L lies within the envelope, columns f_i..i with f_i the first
    nonzero column of row i of H, so nnz(L) ≤ Σ_i (i − f_i + 1); in any order nnz(L) ≥ n + (the
    strictly lower entries of H) ≥ (nnz(H) + n)/2. f_i is the first row of column i (symmetry).
    A one-triangle H (no entry above the diagonal) is not judged: False.
    """
    n = H.shape[0]
    index = np.arange(n)
    first = index.copy()
    nonempty = np.diff(H.indptr) > 0
    if H.nnz:  # smallest row index per nonempty column (unsorted: empty columns are empty segments)
        starts = H.indptr[:-1][nonempty]
        least = H.indices[starts] if H.has_sorted_indices else np.minimum.reduceat(H.indices, starts)
        first[nonempty] = np.minimum(least, index[nonempty])
    if H.nnz > n and np.array_equal(first, index):  # off-diagonal entries, none above the diagonal
        return False
    return float(np.sum(index - first)) + n <= NATURAL_FILL_SLACK * (H.nnz + n) / 2


class ScipySolver(LinearSolver):
    """SuperLU on H + βI with symmetric-mode options (no pattern reuse)."""

    name = "scipy"

    def set_matrix(self, H):
        self._matrix = sp.csc_matrix(H)

    def refactor(self, beta):
        import scipy.sparse.linalg  # this fallback only: not imported with the default solver

        n = self._matrix.shape[0]
        A = sp.csc_matrix(self._matrix + beta * sp.identity(n, format="csc"))
        try:
            self._lu = scipy.sparse.linalg.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                                options={"SymmetricMode": True})
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise NotPositiveDefiniteError(str(exc)) from exc
        if not np.all(self._lu.U.diagonal() > 0):  # no pivoting: U's diagonal holds the LDLᵀ pivots
            raise NotPositiveDefiniteError(f"LU pivot ≤ 0 at beta={beta:.3g}")

    def solve(self, rhs):
        return self._lu.solve(rhs)


class DenseSolver(LinearSolver):
    """LAPACK Cholesky of the dense H + βI."""

    name = "dense"

    def set_matrix(self, H):
        self._matrix = H.toarray() if sp.issparse(H) else np.asarray(H, float)

    def refactor(self, beta):
        potrf, _ = _lapack_cholesky()
        A = np.array(self._matrix, float, order="F")  # LAPACK's order: factorised in place, no further copy
        A.flat[::A.shape[0] + 1] += beta
        if not A.size:
            self._factor = A
            return
        self._factor, info = potrf(A, lower=1, overwrite_a=1, clean=0)
        if info > 0:
            raise NotPositiveDefiniteError(f"{info}-th leading minor of the array is not positive definite")
        if info < 0:
            raise ValueError(f"LAPACK potrf: illegal value in argument {-info}")

    def solve(self, rhs):
        """x of (H + βI) x = rhs from the Cholesky factor (LAPACK potrs, as `scipy.linalg.cho_solve`)."""
        _, potrs = _lapack_cholesky()
        rhs = np.asarray(rhs, float)
        if not rhs.size:
            return rhs.copy()
        x, info = potrs(self._factor, rhs, lower=1, overwrite_b=0)
        if info != 0:
            raise ValueError(f"LAPACK potrs: illegal value in argument {-info}")
        return x


@functools.cache
def _lapack_cholesky():
    """LAPACK's double Cholesky factorisation and solve (dpotrf, dpotrs), the routines `scipy.linalg.cho_factor`
    and `cho_solve` call, without their per-call argument handling (the dense solver calls them once per λ)."""
    from scipy.linalg import lapack  # the dense solver only: not imported with the default solver

    return lapack.dpotrf, lapack.dpotrs


def make_solver(name: str = "cholmod", cholmod_mode: str = "simplicial") -> LinearSolver:
    """A fresh solver by name; ``cholmod`` falls back to ``scipy`` (one warning) without sksparse."""
    global _fallback_warned
    if name == "cholmod":
        if cholmod is None:
            if not _fallback_warned:
                _fallback_warned = True
                warnings.warn(f"scikit-sparse unavailable ({_CHOLMOD_IMPORT_ERROR}); using the scipy SuperLU solver",
                              RuntimeWarning, stacklevel=2)
            return ScipySolver()
        return CholmodSolver(mode=cholmod_mode)
    if name == "scipy":
        return ScipySolver()
    if name == "dense":
        return DenseSolver()
    raise ValueError(f"linear solver must be one of {SOLVER_NAMES}, got {name!r}")
