"""CooAssembler: pieces summed into a fixed CSC pattern, consecutive pieces added as slices."""

import numpy as np
import scipy.sparse as sp

from legplan.solve.assembly import CooAssembler


def _reference(shape, rows, cols, values):
    pieces = [v if v is not None else np.zeros(r.size) for r, v in zip(rows, values)]
    return sp.coo_matrix((np.concatenate(pieces), (np.concatenate(rows), np.concatenate(cols))), shape=shape).toarray()


def test_pieces_in_csc_order_scattered_duplicates_and_structural_zeros():
    shape = (4, 3)
    full_r, full_c = np.array([0, 1, 3, 0, 1, 2, 1, 2, 3]), np.array([0, 0, 0, 1, 1, 1, 2, 2, 2])  # CSC order
    rows = [np.arange(3), full_r, np.array([3, 3, 1])]
    cols = [np.arange(3), full_c, np.array([0, 0, 2])]
    assembler = CooAssembler(shape)
    rng = np.random.default_rng(0)
    for _ in range(3):  # same index objects: the cached plan is reused with new values
        values = [None, rng.standard_normal(9), rng.standard_normal(3)]
        H = assembler.assemble_parts(rows, cols, values)
        np.testing.assert_allclose(H.toarray(), _reference(shape, rows, cols, values), rtol=1e-15)
        assert H.nnz == 9
    assert assembler.version == 1
    assert [k for k, _, _ in assembler._plan[0]] == [1]  # the CSC-ordered piece took the slice path
    values = [rng.standard_normal(3), rng.standard_normal(9), None]
    H = assembler.assemble_parts(rows, cols, values)
    np.testing.assert_allclose(H.toarray(), _reference(shape, rows, cols, values), rtol=1e-15)
    new_rows = [r.copy() for r in rows]  # equal contents, new objects: compared, not re-analysed
    assembler.assemble_parts(new_rows, cols, values)
    assert assembler.version == 1


def test_one_piece_in_csc_order_is_copied_not_aliased():
    rows, cols = np.array([0, 2, 1, 0]), np.array([0, 0, 1, 2])
    values = np.array([1.0, 2.0, 3.0, 4.0])
    H = CooAssembler((3, 3)).assemble_parts([rows], [cols], [values])
    values[:] = 0.0
    np.testing.assert_array_equal(H.toarray(), [[1, 0, 4], [0, 3, 0], [2, 0, 0]])


def test_nonzero_pattern_keeps_every_entry_ever_nonzero_and_grows_only():
    from legplan.solve.assembly import NonzeroPattern

    structure = sp.csr_matrix(np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]]))
    pattern = NonzeroPattern()

    def with_values(values):
        m = structure.copy()
        m.data = np.asarray(values, float)
        return m

    first = with_values([2.0, 0.0, 0.0, 3.0, -0.0, 4.0])  # explicit zeros (one negative) dropped
    reduced = pattern.reduced(first, structure=1)
    np.testing.assert_array_equal(reduced.toarray(), first.toarray())
    assert reduced.nnz == 3 and pattern.version == 1
    again = pattern.reduced(with_values([5.0, 0.0, 0.0, 6.0, 0.0, 7.0]), structure=1)
    assert again.nnz == 3 and pattern.version == 1  # same pattern: a factorization analysed on it holds
    grown = with_values([5.0, 1.0, 0.0, 0.0, 0.0, np.nan])  # an entry nonzero for the first time
    reduced = pattern.reduced(grown, structure=1)
    assert pattern.version == 2 and reduced.nnz == 4  # the earlier nonzero entries stay, as zeros now
    np.testing.assert_array_equal(reduced.toarray(), grown.toarray())  # NaN kept: the caller sees it
    later = pattern.reduced(with_values([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]), structure=1)
    assert later.nnz == 4 and pattern.version == 2
    fresh = pattern.reduced(with_values([0.0, 0.0, 9.0, 0.0, 0.0, 0.0]), structure=2)  # a new structure
    assert fresh.nnz == 1 and pattern.version == 3
    assert not (fresh.indices.flags.writeable or fresh.indptr.flags.writeable)  # shared: trusted by identity
    np.testing.assert_array_equal(fresh.toarray(), with_values([0, 0, 9.0, 0, 0, 0]).toarray())


def test_same_indices_trusts_only_a_read_only_array_by_identity():
    from legplan.solve.assembly import kept_indices, same_indices

    frozen, mutable = np.arange(5), np.arange(5)
    frozen.flags.writeable = False
    kept = kept_indices((frozen, mutable))
    assert same_indices(kept, (frozen, mutable))
    mutable[0] = 7  # changed in place: the same object, other contents
    assert not same_indices(kept, (frozen, mutable))
    assert same_indices(kept_indices((frozen, mutable)), (frozen.copy(), mutable.copy()))  # equal copies
    assert not same_indices(kept, (frozen,))


def test_same_indices_recognises_a_view_of_the_same_read_only_memory():
    from legplan.solve.assembly import kept_indices, same_indices

    frozen = np.arange(6)
    frozen.flags.writeable = False
    kept = kept_indices((frozen,))
    assert same_indices(kept, (frozen[:],))  # scipy's matrices hold views such as this one
    assert not same_indices(kept, (frozen[:5],)) and not same_indices(kept, (frozen[::2],))


def test_nonzero_gather_gives_the_assembled_and_reduced_matrix():
    """`NonzeroGather` against `CooAssembler.assemble_parts` + `NonzeroPattern.reduced` on pieces of
    distinct triplets with entries zero by construction: equal arrays (data, indices, indptr) on every
    call it answers, also where a new nonzero or a NaN grows the pattern (grown from the triplets, the
    pattern's version moving as the full path's); None (the full path then) for other pieces and
    duplicates."""
    from legplan.solve.assembly import CooAssembler, NonzeroGather, NonzeroPattern

    rng = np.random.default_rng(4)
    shape = (30, 40)  # the assembler's (Jᵀ) shape
    keys = rng.choice(shape[0] * shape[1], 300, replace=False)
    rows, cols = [np.array(x) for x in np.array_split(keys // shape[1], 5)], \
        [np.array(x) for x in np.array_split(keys % shape[1], 5)]
    zero = rng.random(300) < 0.3  # zero until the growth below
    split = lambda v: list(np.array_split(v, 5))
    assembler, pattern, gather = CooAssembler(shape), NonzeroPattern(), NonzeroGather()

    def full(values):
        m = assembler.assemble_parts(rows, cols, split(values))
        return pattern.reduced(sp.csr_matrix((m.data, m.indices, m.indptr), shape=shape[::-1]), assembler.version)

    values = np.where(zero, 0.0, rng.standard_normal(300))
    assert gather.reduced(assembler, pattern, rows, cols, split(values)) is None  # nothing followed yet
    full(values)
    gather.follow(assembler, pattern)
    for k in range(4):
        values = np.where(zero, 0.0, rng.standard_normal(300))
        values[zero & (rng.random(300) < 0.5)] = -0.0
        got = gather.reduced(assembler, pattern, rows, cols, split(values))
        expected = full(values)
        for a in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(got, a), getattr(expected, a))
        assert not np.any(np.signbit(got.data) & (got.data == 0))
    # growth: the same arrays as the full path's on a twin that follows the full path alone
    twin_assembler, twin = CooAssembler(shape), NonzeroPattern()

    def twin_full(values):
        m = twin_assembler.assemble_parts(rows, cols, split(values))
        return twin.reduced(sp.csr_matrix((m.data, m.indices, m.indptr), shape=shape[::-1]), twin_assembler.version)

    twin_full(np.where(zero, 0.0, 1.0))
    nan = np.where(zero, 0.0, 1.0)
    nan[np.flatnonzero(zero)[0]] = np.nan  # NaN outside: kept, so the caller sees it
    some = np.where(zero & (rng.random(300) < 0.5), rng.standard_normal(300), np.where(zero, 0.0, 1.0))
    grown = rng.standard_normal(300)
    for values in (nan, some, grown):
        version = pattern.version
        got = gather.reduced(assembler, pattern, rows, cols, split(values))
        expected = twin_full(values)
        assert pattern.version == version + 1 and twin.version == pattern.version
        for a in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(got, a), getattr(expected, a))
    assert got.nnz == 300
    again = gather.reduced(assembler, pattern, rows, cols, split(grown))
    assert again is not None and pattern.version == version + 1  # settled: no growth
    assert gather.reduced(assembler, pattern, [r.copy() for r in rows], cols, split(grown)) is None  # other pieces
    twice = [np.concatenate([rows[0], rows[0][:1]])] + rows[1:], [np.concatenate([cols[0], cols[0][:1]])] + cols[1:]
    doubled = CooAssembler(shape)
    m = doubled.assemble_parts(*twice, [np.ones(r.size) for r in twice[0]])
    other = NonzeroPattern()
    other.reduced(sp.csr_matrix((m.data, m.indices, m.indptr), shape=shape[::-1]), doubled.version)
    gather.follow(doubled, other)
    assert gather.reduced(doubled, other, *twice, [np.ones(r.size) for r in twice[0]]) is None  # summed duplicates


def test_analysis_without_duplicates_and_with_them_is_the_unique_sort():
    """The pattern and slots of `CooAssembler` (its analysis) are those of `np.unique` of the keys
    (col, row), whether every triplet has its own entry (a Jacobian) or some share one (summed)."""
    rng = np.random.default_rng(4)
    for duplicates in (False, True):
        for _ in range(50):
            shape = (int(rng.integers(1, 30)), int(rng.integers(1, 30)))
            count = int(rng.integers(1, shape[0] * shape[1] + 1))
            keys = rng.choice(shape[0] * shape[1], count, replace=duplicates)
            rows, cols = (keys % shape[0]).astype(np.int64), (keys // shape[0]).astype(np.int64)
            values = rng.normal(size=count)
            assembler = CooAssembler(shape)
            H = assembler.assemble_parts([rows], [cols], [values])
            unique, slot = np.unique(cols * shape[0] + rows, return_inverse=True)
            assert np.array_equal(assembler._slot, slot.reshape(-1))
            assert np.array_equal(H.indices, unique % shape[0]) and H.indices.dtype == np.int32
            np.testing.assert_allclose(H.toarray(), _reference(shape, [rows], [cols], [values]), rtol=1e-15)
