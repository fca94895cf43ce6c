"""Cubic Hermite node splines: interpolation of nodes, derivatives, Gram matrices, sampling matrices."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import quad

from legplan.geometry.hermite import NodeSpline, SampledJacobian, Segment, hermite_gram, hermite_weights


def _poly(c, h, t, d=0):
    return (hermite_weights(np.atleast_1d(t) / h, h, d) @ c)[0]


@pytest.mark.parametrize("h", [0.1, 0.37, 2.0])
def test_weights_interpolate_values_and_derivatives(h):
    c = np.array([0.3, -1.2, 0.8, 2.5])  # p_a, v_a, p_b, v_b
    assert _poly(c, h, 0.0) == pytest.approx(c[0])
    assert _poly(c, h, h) == pytest.approx(c[2])
    assert _poly(c, h, 0.0, 1) == pytest.approx(c[1])
    assert _poly(c, h, h, 1) == pytest.approx(c[3])
    t, eps = 0.4 * h, 1e-6
    assert _poly(c, h, t, 1) == pytest.approx((_poly(c, h, t + eps) - _poly(c, h, t - eps)) / (2 * eps), rel=1e-6)
    assert _poly(c, h, t, 2) == pytest.approx((_poly(c, h, t + eps, 1) - _poly(c, h, t - eps, 1)) / (2 * eps), rel=1e-5)


@pytest.mark.parametrize("d", [0, 1, 2])
@pytest.mark.parametrize("h", [0.15, 1.3])
def test_gram_matrix_equals_numerical_quadrature(d, h):
    rng = np.random.default_rng(d)
    for _ in range(3):
        c = rng.normal(size=4)
        exact = c @ hermite_gram(h, d) @ c
        numeric = quad(lambda t: _poly(c, h, t, d) ** 2, 0, h, epsabs=1e-12)[0]
        assert exact == pytest.approx(numeric, rel=1e-9, abs=1e-12)


def test_spline_with_constant_and_hermite_segments():
    # stance at node 0, swing through apex node 1, stance at node 2
    spline = NodeSpline([Segment(0, 1, 0), Segment(1, 1.5, 0, 1), Segment(1.5, 2, 1, 2), Segment(2, 3, 2)], 3)
    nodes = np.array([[0.0], [0.0], [1.0], [2.0], [2.0], [0.0]])  # p0, v0, p1, v1, p2, v2
    t = np.array([0.5, 1.0, 1.5, 2.0, 2.7])
    assert (spline.matrix(t) @ nodes).ravel() == pytest.approx([0.0, 0.0, 1.0, 2.0, 2.0])
    assert (spline.matrix(t, 1) @ nodes).ravel() == pytest.approx([0.0, 0.0, 2.0, 0.0, 0.0])
    with pytest.raises(ValueError):
        NodeSpline([Segment(0, 1, 0), Segment(1.2, 2, 0, 1)], 2)


def test_sampled_jacobian_matches_dense_kron():
    rng = np.random.default_rng(1)
    spline = NodeSpline([Segment(0, 1, 0, 1), Segment(1, 2, 1, 2)], 3)
    m, m1 = spline.matrix(np.array([0.2, 1.0, 1.7]), 1), spline.matrix(np.array([0.2, 1.0, 1.7]))
    jacobian = SampledJacobian([m, m1], 2, 3, 18)  # two terms over one variable: overlapping entries sum
    for _ in range(2):  # the structure is reused by every call
        g, g1 = rng.normal(size=(3, 2, 3)), rng.normal(size=(3, 2, 3))
        j = jacobian([g, g1])
        expect = np.zeros((6, 18))
        for i in range(3):  # ∂r_i/∂x_i · ∂x_i/∂N, summed over the terms
            expect[2 * i:2 * i + 2] = (g[i] @ np.kron(m.toarray()[i][None], np.eye(3))
                                       + g1[i] @ np.kron(m1.toarray()[i][None], np.eye(3)))
        assert j.toarray() == pytest.approx(expect)
        pattern = sum(sp.csr_matrix((np.ones(a.nnz), a.indices, a.indptr), shape=a.shape) for a in (m, m1))
        assert j.has_sorted_indices and j.nnz == pattern.nnz * 6  # canonical CSR, explicit zeros kept
    complex_j = jacobian([g * (1 + 2j), g1 * (1 + 2j)])
    assert complex_j.toarray() == pytest.approx(expect * (1 + 2j))


def test_sampling_matrix_is_scipys_canonical_csr_of_the_weights():
    """`NodeSpline.matrix_at` (built in CSR directly) equals scipy's COO → CSR conversion of the
    Hermite weights and constant entries, array by array (int32 indices, row pointers, values), for
    every derivative, with samples on segment boundaries and in constant segments."""
    from legplan.geometry.hermite import NodeSpline, Segment, hermite_weights

    rng = np.random.default_rng(6)
    spline = NodeSpline([Segment(0, 0.3, 0, 1), Segment(0.3, 0.5, 1), Segment(0.5, 0.9, 1, 2),
                         Segment(0.9, 1.4, 2, 3), Segment(1.4, 2.0, 3)], 4)
    t = np.sort(np.concatenate([rng.uniform(0, 2.0, 40), [0.0, 0.3, 0.5, 0.9, 2.0]]))
    seg = spline.segment_index(t)
    frac = np.clip((t - spline.starts[seg]) / (spline.ends - spline.starts)[seg], 0, 1)
    for derivative in range(3):
        m = spline.matrix_at(seg, frac, derivative)
        rows, cols, vals = [], [], []
        for i, (k, s) in enumerate(zip(seg, frac)):
            a, b = spline.node_a[k], spline.node_b[k]
            if b >= 0:
                w = hermite_weights(np.array([s]), spline.ends[k] - spline.starts[k], derivative)[0]
                rows += [i] * 4
                cols += [2 * a, 2 * a + 1, 2 * b, 2 * b + 1]
                vals += list(w)
            elif derivative == 0:
                rows.append(i), cols.append(2 * a), vals.append(1.0)
        expected = sp.coo_matrix((vals, (rows, cols)), shape=(t.size, 8)).tocsr()
        np.testing.assert_allclose(m.data, expected.data, rtol=1e-13, atol=1e-15)  # one sample at a time here
        for name in ("indices", "indptr"):
            np.testing.assert_array_equal(getattr(m, name), getattr(expected, name))
        assert m.indices.dtype == expected.indices.dtype and m.indptr.dtype == expected.indptr.dtype


def test_sampled_jacobian_structure_of_one_pattern_is_the_sorted_one():
    """The structure written down for matrices of one pattern (`_one_pattern_structure`) is, array by
    array and dtype by dtype, the one sorted from every entry's key (`_sorted_structure`): empty
    rows, empty matrices, one to three terms; a row whose columns do not increase is refused."""
    from legplan.geometry.hermite import _one_pattern_structure, _sorted_structure

    rng = np.random.default_rng(3)
    for _ in range(200):
        samples, nodes = int(rng.integers(1, 25)), int(rng.integers(1, 15))
        m = sp.random(samples, nodes, density=rng.uniform(0.0, 0.6), format="csr",
                      random_state=int(rng.integers(1 << 30)))
        m.sort_indices()
        rows, terms = int(rng.integers(1, 7)), int(rng.integers(1, 4))
        pattern = (m.indptr.dtype.str, m.indptr.tobytes(), m.indices.dtype.str, m.indices.tobytes())
        direct = _one_pattern_structure(rows, samples, 3 * nodes, *pattern, terms)
        sorted_ = _sorted_structure(rows, samples, 3 * nodes, (pattern,) * terms)
        assert len(direct[0]) == terms and all(np.array_equal(a, b) for a, b in zip(direct[0], sorted_[0]))
        for a, b in zip(direct[1:], sorted_[1:]):
            assert a.dtype == b.dtype and np.array_equal(a, b)
        long_rows = np.flatnonzero(np.diff(m.indptr) > 1)
        if long_rows.size:
            swapped = m.indices.copy()
            k = m.indptr[long_rows[0]]
            swapped[[k, k + 1]] = swapped[[k + 1, k]]
            assert _one_pattern_structure(rows, samples, 3 * nodes, pattern[0], pattern[1], pattern[2],
                                          swapped.tobytes(), 1) is None


def test_sampling_matrix_is_a_valid_copy_of_the_cached_one():
    """`NodeSpline.matrix` hands out a copy of its cached matrix (built without scipy's checks): it
    passes scipy's format check, equals the matrix of `matrix_at`, and changing it leaves the next
    call's matrix as it was."""
    from legplan.geometry.hermite import NodeSpline, Segment

    spline = NodeSpline([Segment(0, 0.3, 0, 1), Segment(0.3, 0.5, 1), Segment(0.5, 0.9, 1, 2)], 3)
    t = np.array([0.0, 0.1, 0.3, 0.4, 0.7, 0.9])
    for derivative in range(3):
        m = spline.matrix(t, derivative)
        m.check_format(full_check=True)
        seg = spline.segment_index(t)
        expected = spline.matrix_at(seg, np.clip((t - spline.starts[seg]) / (spline.ends - spline.starts)[seg], 0, 1),
                                    derivative)
        for name in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(m, name), getattr(expected, name))
        m.data[:] = 7.0
        m.indices[:] = 0
        again = spline.matrix(t, derivative)
        np.testing.assert_array_equal(again.data, expected.data)
        np.testing.assert_array_equal(again.indices, expected.indices)


def test_kron_axis_is_one_axis_of_kron_dim_entry_for_entry():
    """`kron_axis(m, a)` holds the very arrays (indptr, indices, data, their dtypes) of
    `kron_dim(m)[a::3]`, explicit zeros included, for sampling matrices and a hand-made one."""
    from legplan.geometry.hermite import kron_axis, kron_dim

    spline = NodeSpline([Segment(0.0, 0.4, 0, 1), Segment(0.4, 1.0, 1, 2), Segment(1.0, 1.5, 2)], 3)
    t = np.linspace(0.0, 1.5, 41)
    zeros = sp.csr_matrix((np.array([0.0, 2.0, -1.0]), np.array([0, 3, 1]), np.array([0, 2, 2, 3])), shape=(3, 5))
    for m in (spline.matrix(t), spline.matrix(t, 1), spline.matrix(t, 2), zeros):
        for axis in range(3):
            a, b = kron_dim(m)[axis::3], kron_axis(m, axis)
            assert a.shape == b.shape and a.indptr.dtype == b.indptr.dtype and a.indices.dtype == b.indices.dtype
            assert np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
            assert np.array_equal(a.data, b.data)


def _placed(jacobian: SampledJacobian, blocks) -> sp.csr_matrix:
    """`jacobian`'s J by the placed path (`_jacobian_structure`, a sum into zeros), whatever its rows."""
    jacobian._structure()
    values = np.concatenate([(m.data[:, None, None] * g[rows]).reshape(-1)
                             for m, g, rows in zip(jacobian.matrices, blocks, jacobian.entry_rows)])
    data = np.bincount(jacobian.slot, weights=values, minlength=jacobian.indices.size)
    return sp.csr_matrix((data, jacobian.indices, jacobian.indptr), shape=jacobian.shape)


def test_sampled_jacobian_of_uniform_rows_is_the_placed_one_bit_for_bit():
    """Matrices of one pattern with c entries in every row (Hermite segments only: 4; constant ones
    only: 1) give J straight from the products (`_uniform_structure`): array by array, dtype by
    dtype and bit by bit (a −0 product a 0, as the sum into zeros gives it) the placed J, for one to
    three terms; a ragged pattern, an empty one and complex blocks (complex steps) take the placed
    path."""
    from legplan.geometry.hermite import _uniform_structure

    rng = np.random.default_rng(11)
    spline = NodeSpline([Segment(0, 0.4, 0, 1), Segment(0.4, 1.0, 1, 2), Segment(1.0, 1.3, 2, 3)], 4)
    stance = NodeSpline([Segment(0, 0.5, 0), Segment(0.5, 1.0, 1), Segment(1.0, 1.3, 2)], 3)
    for trial in range(40):
        samples = int(rng.integers(1, 30))
        t = np.sort(rng.uniform(0.0, 1.3, samples))
        if trial % 3 == 2:
            matrices = [stance.matrix(t)]
        else:
            matrices = [spline.matrix(t, d) for d in range(int(rng.integers(1, 4)))]
        rows = int(rng.integers(1, 10))
        blocks = [rng.normal(size=(samples, rows, 3)) for _ in matrices]
        blocks[0][0, 0, 0] = -0.0 if trial % 2 else blocks[0][0, 0, 0]  # a −0 product
        jacobian = SampledJacobian(matrices, rows, samples, 3 * matrices[0].shape[1])
        direct = jacobian(blocks)
        assert jacobian.uniform == (1 if trial % 3 == 2 else 4)
        placed = _placed(SampledJacobian(matrices, rows, samples, jacobian.columns), blocks)
        for name in ("data", "indices", "indptr"):
            a, b = getattr(direct, name), getattr(placed, name)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
        again = jacobian([b + 1.0 for b in blocks])  # the structure reused
        assert np.array_equal(again.toarray(), _placed(jacobian, [b + 1.0 for b in blocks]).toarray())
        complex_j = jacobian([b * (1 + 1j) for b in blocks])  # complex: the placed path
        assert np.allclose(complex_j.toarray(), direct.toarray() * (1 + 1j))
    mixed = NodeSpline([Segment(0, 0.5, 0), Segment(0.5, 1.0, 0, 1)], 2).matrix(np.array([0.2, 0.7, 0.9]))
    assert _uniform_structure(2, 3, 6, [mixed]) is None  # rows of 1 and 4 entries
    assert SampledJacobian([mixed], 2, 3, 6)._direct() is False
    assert _uniform_structure(2, 0, 6, [sp.csr_matrix((0, 2))]) is None


def test_sampled_jacobian_structure_of_disjoint_patterns_is_the_sorted_one():
    """Matrices of several patterns whose entries, term after term, increase in every row (the legs'
    feet or forces in one block) get their structure without a sort (`_merged_structure`): array by
    array and dtype by dtype the sorted one; patterns that share a column in a row are refused."""
    from legplan.geometry.hermite import _merged_structure, _sorted_structure

    rng = np.random.default_rng(12)
    for _ in range(200):
        samples, terms = int(rng.integers(1, 20)), int(rng.integers(2, 5))
        widths = rng.integers(1, 6, terms)
        matrices, start = [], 0
        for w in widths:  # each term on its own columns, after the last one's
            m = sp.random(samples, int(w), density=rng.uniform(0.0, 0.8), format="csr",
                          random_state=int(rng.integers(1 << 30)))
            m.sort_indices()
            matrices.append(sp.csr_matrix((m.data, m.indices + start, m.indptr), shape=(samples, int(widths.sum()))))
            start += int(w)
        rows, columns = int(rng.integers(1, 7)), 3 * int(widths.sum())
        patterns = tuple((m.indptr.dtype.str, m.indptr.tobytes(), m.indices.dtype.str, m.indices.tobytes())
                         for m in matrices)
        merged = _merged_structure(rows, samples, columns, patterns)
        sorted_ = _sorted_structure(rows, samples, columns, patterns)
        assert len(merged[0]) == terms and all(np.array_equal(a, b) for a, b in zip(merged[0], sorted_[0]))
        for a, b in zip(merged[1:], sorted_[1:]):
            assert a.dtype == b.dtype and np.array_equal(a, b)
    one = sp.csr_matrix(np.array([[1.0, 0.0, 2.0], [0.0, 3.0, 0.0]]))
    two = sp.csr_matrix(np.array([[0.0, 4.0, 0.0], [0.0, 0.0, 5.0]]))  # row 0: column 1 after the first's 2
    patterns = tuple((m.indptr.dtype.str, m.indptr.tobytes(), m.indices.dtype.str, m.indices.tobytes())
                     for m in (one, two))
    assert _merged_structure(2, 2, 9, patterns) is None
    assert _merged_structure(2, 2, 9, patterns[:1] * 2) is None  # the same entries twice
    assert SampledJacobian([one, two], 2, 2, 9)([np.ones((2, 2, 3))] * 2).toarray() == pytest.approx(
        np.kron((one + two).toarray(), np.ones((2, 3))).reshape(2, 2, 9).reshape(4, 9))


def test_sampling_matrix_cache_tells_splines_apart_by_their_segments():
    """The cached sampling matrix is keyed by the spline's segments and node count (`_SplineKey`):
    another spline object with equal segments gets the same matrix, a spline whose segments differ
    (another knot, another node) gets its own, equal to one computed afresh (`matrix_at`)."""
    t = np.array([0.1, 0.45, 0.8, 1.2])
    base = [Segment(0, 0.5, 0, 1), Segment(0.5, 1.0, 1, 2), Segment(1.0, 1.5, 2, 3)]
    first = NodeSpline(base, 4)
    m = first.matrix(t, 1)
    same = NodeSpline(list(base), 4)
    assert np.array_equal(same.matrix(t, 1).toarray(), m.toarray())
    for segments, nodes in (([Segment(0, 0.6, 0, 1), Segment(0.6, 1.0, 1, 2), Segment(1.0, 1.5, 2, 3)], 4),
                            ([Segment(0, 0.5, 0, 1), Segment(0.5, 1.0, 1), Segment(1.0, 1.5, 1, 2)], 3),
                            (base, 5)):
        other = NodeSpline(segments, nodes)
        got = other.matrix(t, 1)
        seg = other.segment_index(t)
        fresh = other.matrix_at(seg, np.clip((t - other.starts[seg]) / (other.ends - other.starts)[seg], 0, 1), 1)
        assert got.shape == (4, 2 * nodes) and np.array_equal(got.toarray(), fresh.toarray())
        assert not (got.shape == m.shape and np.array_equal(got.toarray(), m.toarray()))
