"""`legplan.geometry.sparse.wrapped`: a CSR/CSC matrix without scipy's index checks behaves as the one
scipy's constructor builds from the same arrays, under every operation the solver applies."""

import numpy as np
import pytest
import scipy.sparse as sp

from legplan.geometry.sparse import wrapped


@pytest.mark.parametrize("kind", [sp.csr_matrix, sp.csc_matrix])
@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_wrapped_equals_the_checked_construction(kind, index):
    rng = np.random.default_rng(2)
    base = kind(sp.random(40, 25, density=0.2, random_state=3))
    indices, indptr = base.indices.astype(index), base.indptr.astype(index)
    data = rng.standard_normal(base.nnz)
    checked = kind((data, indices, indptr), shape=base.shape)
    fast = wrapped(kind, data, indices, indptr, base.shape)
    assert type(fast) is kind and fast.shape == checked.shape and fast.format == checked.format
    assert fast.data is data and fast.indices is indices  # shared, not copied
    x, y = rng.standard_normal(25), rng.standard_normal(40)
    np.testing.assert_array_equal(fast.toarray(), checked.toarray())
    np.testing.assert_array_equal(fast @ x, checked @ x)
    np.testing.assert_array_equal(fast.T @ y, checked.T @ y)
    np.testing.assert_array_equal(sp.csr_matrix(fast)[[3, 1, 7]].toarray(), sp.csr_matrix(checked)[[3, 1, 7]].toarray())
    np.testing.assert_array_equal((fast.T @ fast).toarray(), (checked.T @ checked).toarray())
    np.testing.assert_array_equal(fast.tocoo().toarray(), checked.toarray())
    assert fast.has_sorted_indices == checked.has_sorted_indices


def test_wrapped_falls_back_to_scipy_for_arrays_that_do_not_fit():
    """Mixed index dtypes, or data of another length than the indices, go through scipy's constructor
    (which converts, or refuses)."""
    indices, indptr = np.array([0, 2, 1], np.int64), np.array([0, 2, 3], np.int32)
    m = wrapped(sp.csr_matrix, np.array([1.0, 2.0, 3.0]), indices, indptr, (2, 3))
    np.testing.assert_array_equal(m.toarray(), [[1, 0, 2], [0, 3, 0]])
    with pytest.raises(ValueError):
        wrapped(sp.csr_matrix, np.array([1.0, 2.0]), indices.astype(np.int32), indptr, (2, 3))


def test_times_is_scipys_product_bit_for_bit_and_leaves_other_cases_to_it():
    """`times(M, x)` equals `M @ x` exactly (same kernels, same sums) for a CSR M and float64 x: a
    vector, one column, several columns, a non-contiguous view; other cases (CSC, complex x, int x)
    take scipy's product and still agree."""
    import scipy.sparse as sp

    from legplan.geometry.sparse import times

    rng = np.random.default_rng(3)
    m = sp.csr_matrix(sp.random(40, 25, density=0.2, random_state=4))
    assert type(m) is sp.csr_matrix  # the fast path's case
    cases = [rng.normal(size=25), rng.normal(size=(25, 1)), rng.normal(size=(25, 3)), rng.normal(size=(25, 6))[:, ::2],
             np.asfortranarray(rng.normal(size=(25, 3)))]
    for x in cases:
        got, expected = times(m, x), m @ x
        assert got.shape == expected.shape and got.dtype == expected.dtype
        assert np.array_equal(got, expected)
    for matrix, x in ((m.tocsc(), cases[2]), (m, cases[0] * (1 + 2j)), (m, np.arange(25))):
        np.testing.assert_array_equal(times(matrix, x), matrix @ x)
