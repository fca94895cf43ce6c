"""COO → CSC assembly that sorts the index arrays once per sparsity pattern.

The Jacobian J and the normal matrix JᵀJ of eq. (13) keep their sparsity pattern across LM
iterations; only values change. `CooAssembler` remembers the (row, col) triplet order of the last
pattern and the CSC slot of every triplet, so a refresh is one `np.bincount` (duplicates summed).
Explicit zeros stay in the pattern, so a factorisation analysed once stays valid. `assemble_parts`
takes the triplets in pieces and skips even the index comparison when the pieces are the same
cached arrays as last time.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from legplan.geometry.sparse import wrapped


class CooAssembler:
    """Sum COO triplets into a CSC matrix of fixed `shape`; re-analyse only when indices change."""

    def __init__(self, shape: tuple[int, int]):
        self.shape = shape
        self.version = 0  # incremented whenever the pattern changes
        self._rows: np.ndarray | None = None
        self._cols: np.ndarray | None = None
        self._pieces: tuple[list[np.ndarray], list[np.ndarray]] | None = None

    def _analyze(self, rows: np.ndarray, cols: np.ndarray, copy: bool = True) -> None:
        """Pattern and CSC slot of every triplet; keeps (a copy of, unless `copy` is False) the indices."""
        nrows, ncols = self.shape
        key = np.multiply(cols, nrows, dtype=np.int64)
        key += rows
        if np.all(key[1:] > key[:-1]):  # already in CSC order without duplicates (e.g. one CSR block of Jᵀ)
            self._slot = np.arange(key.size)
            self._in_order = True
            unique_rows, unique_cols = rows, cols
        else:
            # np.unique with a stable sort: triplets from cached patterns arrive as a few sorted
            # runs, which a stable (merging) sort handles in about linear time.
            order = np.argsort(key, kind="stable")
            ordered = key[order]
            first = np.empty(ordered.size, bool)
            first[:1] = True
            np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
            self._slot = np.empty(key.size, np.intp)
            if first.all():  # no duplicates (a Jacobian's triplets): each triplet its own slot
                self._slot[order] = np.arange(key.size)
                taken = order
            else:
                self._slot[order] = np.cumsum(first) - 1
                taken = order[first]
            self._in_order = False
            unique_rows, unique_cols = rows[taken], cols[taken]  # each key's first triplet
        self._indices = unique_rows.astype(np.int32)
        self._indptr = np.zeros(ncols + 1, dtype=np.int32)
        np.cumsum(np.bincount(unique_cols, minlength=ncols), out=self._indptr[1:])
        self._rows, self._cols = (rows.copy(), cols.copy()) if copy else (rows, cols)
        self.version += 1

    def assemble(self, rows: np.ndarray, cols: np.ndarray, values: np.ndarray) -> sp.csc_matrix:
        if not (self._rows is not None and self._rows.size == rows.size
                and np.array_equal(self._rows, rows) and np.array_equal(self._cols, cols)):
            self._analyze(rows, cols)
        data = np.bincount(self._slot, weights=values, minlength=self._indices.size)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=self.shape)

    def assemble_parts(self, rows: list[np.ndarray], cols: list[np.ndarray], values: list[np.ndarray | None]
                       ) -> sp.csc_matrix:
        """`assemble` of triplets given in pieces; a `None` values piece is structural (zeros).

        When every index piece is the same array object as in the previous call (cached index
        arrays, never modified), the indices are neither concatenated nor compared again; only the
        values are summed into their slots. A piece whose slots are consecutive (e.g. a product
        already in CSC order) is added as a slice, the others by one `np.bincount`.
        """
        if not self.holds(rows, cols):
            index = [np.concatenate(p).astype(np.int64, copy=False) if p else np.zeros(0, np.int64)
                     for p in (rows, cols)]
            if not (self._rows is not None and self._rows.size == index[0].size
                    and np.array_equal(self._rows, index[0]) and np.array_equal(self._cols, index[1])):
                self._analyze(*index, copy=False)  # concatenated: already our own arrays
            self._pieces = (list(rows), list(cols))  # holding them keeps the identity test sound
            self._plan = self._piece_plan([r.size for r in rows])
        ranges, scattered, scattered_slots = self._plan
        parts = [values[k] for k in scattered if values[k] is not None]
        if not parts and len(ranges) == 1 and ranges[0][1:] == (0, self._indices.size) \
                and values[ranges[0][0]] is not None:  # one piece fills the pattern in order: a copy
            return sp.csc_matrix((np.array(values[ranges[0][0]], float), self._indices, self._indptr),
                                 shape=self.shape)
        if parts:
            slots = scattered_slots if len(parts) == len(scattered) else np.concatenate(
                [self._piece_slots[k] for k in scattered if values[k] is not None])
            data = np.bincount(slots, weights=np.concatenate(parts), minlength=self._indices.size)
            data = data.astype(float, copy=False)  # bincount of no weights counts (integers)
        else:
            data = np.zeros(self._indices.size)
        for k, start, stop in ranges:
            if values[k] is not None:
                data[start:stop] += values[k]
        return sp.csc_matrix((data, self._indices, self._indptr), shape=self.shape)

    def holds(self, rows: list[np.ndarray], cols: list[np.ndarray]) -> bool:
        """Whether the index pieces are the very arrays of the last `assemble_parts` (its plan holds)."""
        pieces = self._pieces
        return (pieces is not None and len(pieces[0]) == len(rows) and len(pieces[1]) == len(cols)
                and all(a is b for a, b in zip(pieces[0], rows)) and all(a is b for a, b in zip(pieces[1], cols)))

    def _piece_plan(self, sizes: list[int]):
        """Per piece: a slice of the CSC data if its slots are consecutive, else bincount slots."""
        bounds = np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)])
        self._piece_slots = [self._slot[bounds[k]:bounds[k + 1]] for k in range(len(sizes))]
        ranges, scattered = [], []
        for k, slots in enumerate(self._piece_slots):
            if slots.size and (self._in_order or (slots[-1] - slots[0] == slots.size - 1
                                                  and np.all(np.diff(slots) == 1))):
                ranges.append((k, int(slots[0]), int(slots[-1]) + 1))
            else:
                scattered.append(k)
        scattered_slots = (np.concatenate([self._piece_slots[k] for k in scattered]) if scattered
                           else np.zeros(0, np.intp))
        return ranges, scattered, scattered_slots


class NonzeroPattern:
    """The entries of a compressed (CSR/CSC) matrix that have ever been nonzero, for a matrix whose
    structural pattern is fixed but holds many entries that are zero by construction (a zero block
    of a per-sample Jacobian, a force fixed at zero in swing, a sampling weight of zero).

    `reduced` returns the matrix restricted to those entries: the same values (a dropped entry is
    exactly zero), fewer of them, so that products, factorizations and matrix-vector products skip
    them. The kept set only grows (an entry nonzero once stays in the pattern), so it settles after
    a few evaluations and a factorization analysed on it is reused; `version` counts its changes.
    A new structural pattern (`structure`, e.g. an assembler's version) starts it afresh.
    """

    def __init__(self):
        self.version = 0
        self._structure = None
        self._kept: np.ndarray | None = None

    def reduced(self, matrix: sp.csr_matrix | sp.csc_matrix, structure) -> sp.csr_matrix | sp.csc_matrix:
        nonzero = matrix.data != 0.0  # NaN counts as nonzero: it stays visible to the caller
        if self._structure != structure or self._kept is None or self._kept.size != nonzero.size:
            self._structure = structure
            self._update(matrix, nonzero)
        elif np.any(nonzero & ~self._kept):
            self._update(matrix, nonzero | self._kept)
        return type(matrix)((matrix.data[self._take], self._indices, self._indptr), shape=matrix.shape)

    def _update(self, matrix, kept: np.ndarray) -> None:
        self.grow(kept, matrix.indptr, matrix.indices)

    def grow(self, kept: np.ndarray, indptr: np.ndarray, indices: np.ndarray) -> None:
        """Keep the entries `kept` (a superset of the kept ones) of the pattern (indptr, indices) it
        follows: `reduced`'s update, for a caller that knows the new nonzeros without the matrix."""
        self._kept = kept
        self._take = np.flatnonzero(kept)
        before = np.concatenate([[0], np.cumsum(kept, dtype=np.int64)])
        self._indptr = before[indptr].astype(indptr.dtype)
        self._indices = indices[self._take]
        self._indptr.flags.writeable = self._indices.flags.writeable = False  # shared by every reduced matrix
        self.version += 1


class NonzeroGather:
    """`NonzeroPattern.reduced` of what `CooAssembler.assemble_parts` would assemble, taken straight
    from the triplet pieces: while the pieces are the assembler's last ones (`CooAssembler.holds`)
    and no two triplets share an entry (the slots are a permutation of the pattern), the reduced
    matrix's data is one gather of the concatenated values (the same numbers; a −0 becomes 0, as the
    sum into zeros makes it), with no scatter into the whole pattern. Triplets nonzero outside the
    kept set (or NaN) grow the pattern from the triplets themselves (`NonzeroPattern.grow`: the kept
    set and the arrays the assembled matrix would give it). `reduced` returns None otherwise: the
    caller assembles and reduces, then calls `follow`."""

    def __init__(self):
        self._key = None

    def follow(self, assembler: CooAssembler, pattern: NonzeroPattern) -> None:
        """Take the gather of the assembler's current pieces and the pattern's kept entries."""
        slot = assembler._slot
        self._key = None
        if slot.size != assembler._indices.size or pattern._kept is None or pattern._kept.size != slot.size:
            return  # duplicates (summed): the assembler's scatter is needed
        position = np.empty(slot.size, np.intp)
        position[slot] = np.arange(slot.size)
        self._slot = slot
        self._position = position
        self._gather = position[pattern._take]
        self._outside = ~pattern._kept[slot]  # per triplet: not (yet) in the kept set
        self._key = (assembler, assembler.version, pattern, pattern.version)

    def reduced(self, assembler: CooAssembler, pattern: NonzeroPattern, rows, cols, values, fmt=sp.csr_matrix):
        if self._key != (assembler, assembler.version, pattern, pattern.version) or not assembler.holds(rows, cols) \
                or any(v is None for v in values):
            return None
        data = np.concatenate(values) if len(values) != 1 else np.asarray(values[0], float)
        new = (data != 0.0) & self._outside
        if np.any(new):  # a new nonzero (or NaN): the pattern grows by those entries
            kept = pattern._kept.copy()
            kept[self._slot[new]] = True
            pattern.grow(kept, assembler._indptr, assembler._indices)
            self._gather = self._position[pattern._take]
            self._outside = ~kept[self._slot]
            self._key = (assembler, assembler.version, pattern, pattern.version)
        return wrapped(fmt, data[self._gather] + 0.0, pattern._indices, pattern._indptr, assembler.shape[::-1])


def kept_indices(arrays) -> tuple:
    """What `same_indices` compares later: each index array with a copy of its contents."""
    return tuple((a, a.copy()) for a in arrays)


def same_indices(kept: tuple, arrays) -> bool:
    """Whether index arrays hold what they held when `kept_indices` took them: the memory of the
    same read-only array (a cached pattern nobody can change; scipy hands out a new view of it with
    every matrix) without a look at its contents, else by comparing the contents with the copy."""
    return len(kept) == len(arrays) and all(
        _same_memory(original, a) or np.array_equal(copy, a) for (original, copy), a in zip(kept, arrays))


def _same_memory(original: np.ndarray, a: np.ndarray) -> bool:
    if original.flags.writeable:
        return False
    if a is original:  # the very array (a block handing out its cached pattern): no look at its memory
        return True
    return (a.dtype == original.dtype and a.shape == original.shape and a.strides == original.strides
            and a.ctypes.data == original.ctypes.data)
