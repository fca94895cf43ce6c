"""Compressed sparse matrices on index arrays that were computed once and are valid by construction.

The blocks of the solver core build their Jacobians on cached patterns (`hermite.SampledJacobian`,
the augmented Lagrangian's row pickers, the reduced J of the hinged LM): only the values change from
evaluation to evaluation. scipy's constructor checks the index arrays each time (dtype range,
contents, format); `wrapped` skips that for arrays known valid. `times` is scipy's product of such
a matrix with a dense array without scipy's dispatch around its kernel.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import _sparsetools


def wrapped(kind, data: np.ndarray, indices: np.ndarray, indptr: np.ndarray, shape: tuple[int, int]):
    """`kind((data, indices, indptr), shape=shape)` (sp.csr_matrix or sp.csc_matrix) without scipy's
    checks of the index arrays (dtype range, contents, format), which would otherwise be paid for
    every per-block Jacobian of every evaluation: for index arrays computed once per pattern (a
    cached structure, read-only) and valid by construction. The arrays are shared, not copied. Index
    arrays of different dtypes, or data not matching them, take scipy's constructor."""
    if not (indices.dtype == indptr.dtype and indices.dtype in (np.int32, np.int64) and data.ndim == 1
            and data.shape == indices.shape and indptr.size == (shape[0] if kind is sp.csr_matrix else shape[1]) + 1):
        return kind((data, indices, indptr), shape=shape)
    matrix = kind.__new__(kind)  # the attributes scipy's constructor sets (scipy==1.17.1, pinned)
    matrix._shape, matrix.maxprint = (int(shape[0]), int(shape[1])), 50
    matrix.data, matrix.indices, matrix.indptr = data, indices, indptr
    return matrix


def times(matrix, x):
    """`matrix @ x` for a CSR matrix and a float64 array x (a vector, or columns of vectors): scipy's
    own kernels (`csr_matvec`, `csr_matvecs`) called as its product calls them, the same sums in the
    same order, without its per-call dispatch, which costs more than the product of a block's small
    sampling matrix (scipy==1.17.1, pinned). Anything else (another format or dtype, a sparse x) is
    left to scipy's `@`."""
    if not (type(matrix) is sp.csr_matrix and type(x) is np.ndarray and x.dtype == np.float64
            and matrix.data.dtype == np.float64 and matrix.indices.dtype == matrix.indptr.dtype):
        return matrix @ x
    m, n = matrix.shape
    if x.shape == (n,):
        out = np.zeros(m)
        _sparsetools.csr_matvec(m, n, matrix.indptr, matrix.indices, matrix.data, x, out)
        return out
    if x.ndim == 2 and x.shape[0] == n and x.shape[1] != 1:
        out = np.zeros((m, x.shape[1]))
        _sparsetools.csr_matvecs(m, n, x.shape[1], matrix.indptr, matrix.indices, matrix.data, x.ravel(), out.ravel())
        return out
    return matrix @ x
