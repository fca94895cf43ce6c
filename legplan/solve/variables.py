"""Named variable blocks and the map from their entries to the columns of the Jacobian.

The optimisation vector θ of eq. (13) is the concatenation of the *free* entries of all variable
blocks, in the order the blocks were added. Fixed entries keep their value and own no column.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class VariableBlock:
    """One named vector of unknowns (e.g. the Bézier control points P, or the slacks ξ of eq. (11)).

    `fixed` is a boolean mask of entries that the solver must not change. `lower`/`upper` are box
    bounds (scalars or arrays, ±inf for none); the solver projects each step onto them.
    `schur_block` set to m declares that JᵀJ restricted to this variable is block-diagonal with
    m×m blocks (e.g. per-sample slacks ξ_i of eq. (11)); the solver then eliminates the variable by a
    Schur complement before factorising (`LMParams.schur`).
    """

    name: str
    value: np.ndarray
    fixed: np.ndarray | None = None
    lower: np.ndarray | float = -np.inf
    upper: np.ndarray | float = np.inf
    schur_block: int | None = None

    def __post_init__(self) -> None:
        self.value = np.array(self.value, dtype=float).reshape(-1)
        n = self.value.size
        self.fixed = np.zeros(n, bool) if self.fixed is None else np.asarray(self.fixed, bool).reshape(-1)
        self.lower = np.broadcast_to(np.asarray(self.lower, float), (n,)).copy()
        self.upper = np.broadcast_to(np.asarray(self.upper, float), (n,)).copy()
        if self.fixed.size != n:
            raise ValueError(f"variable {self.name!r}: fixed mask has {self.fixed.size} entries, value has {n}")
        if np.any(self.lower > self.upper):
            raise ValueError(f"variable {self.name!r}: lower bound above upper bound")
        if self.schur_block is not None:
            if self.schur_block <= 0 or n % self.schur_block:
                raise ValueError(f"variable {self.name!r}: size {n} is not a multiple of schur_block={self.schur_block}")
            if self.fixed.any():
                raise ValueError(f"variable {self.name!r}: a Schur-eliminated variable cannot have fixed entries")

    @property
    def size(self) -> int:
        return self.value.size


class VariableLayout:
    """Column map of a set of variable blocks: θ ↔ {name: full value vector}."""

    def __init__(self, blocks: list[VariableBlock]):
        self.blocks = {b.name: b for b in blocks}
        if len(self.blocks) != len(blocks):
            raise ValueError("variable names must be unique")
        self.columns: dict[str, np.ndarray] = {}
        offset = 0
        for b in blocks:
            col = np.full(b.size, -1, dtype=np.int64)
            free = ~b.fixed
            col[free] = offset + np.arange(free.sum())
            self.columns[b.name] = col
            offset += int(free.sum())
        self.n = offset
        self.lower = self._gather(lambda b: b.lower)
        self.upper = self._gather(lambda b: b.upper)
        self.bounded = bool(np.isfinite(self.lower).any() or np.isfinite(self.upper).any())
        # blocks without fixed entries own a contiguous range of θ: read as a slice, not a gather; the others
        # by their free entries and those entries' columns
        self._ranges = {b.name: slice(int(self.columns[b.name][0]), int(self.columns[b.name][-1]) + 1)
                        for b in blocks if b.size and not b.fixed.any()}
        self._free = {name: (np.flatnonzero(col >= 0), col[col >= 0]) for name, col in self.columns.items()
                      if name not in self._ranges}

    def _gather(self, attr) -> np.ndarray:
        out = np.empty(self.n)
        for b in self.blocks.values():
            col = self.columns[b.name]
            out[col[col >= 0]] = attr(b)[~b.fixed]
        return out

    def initial(self) -> np.ndarray:
        """θ of the current block values, projected onto the bounds."""
        return self.project(self._gather(lambda b: b.value))

    def project(self, theta: np.ndarray) -> np.ndarray:
        """θ clipped to the box bounds (θ itself when no entry has a finite bound)."""
        return np.clip(theta, self.lower, self.upper) if self.bounded else theta

    def values(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Full value vector of every block for θ (fixed entries from the block's stored value)."""
        out = {}
        for name, b in self.blocks.items():
            if name in self._ranges:
                out[name] = theta[self._ranges[name]].copy()
                continue
            v = b.value.copy()
            free, columns = self._free[name]
            v[free] = theta[columns]
            out[name] = v
        return out

    def store(self, theta: np.ndarray) -> None:
        """Write θ back into the blocks' `value` arrays."""
        for name, v in self.values(theta).items():
            self.blocks[name].value = v

    def schur_columns(self) -> tuple[np.ndarray, int] | None:
        """Columns to eliminate by Schur complement and their diagonal block size (one size for all)."""
        elim = [b for b in self.blocks.values() if b.schur_block is not None]
        if not elim:
            return None
        sizes = {b.schur_block for b in elim}
        if len(sizes) != 1:
            raise ValueError(f"Schur-eliminated variables must share one schur_block size, got {sorted(sizes)}")
        cols = np.concatenate([self.columns[b.name] for b in elim])
        return cols, sizes.pop()
