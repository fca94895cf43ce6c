"""The whole TEB objective of eq. (24) as one structured residual block with a fixed JᵀJ pattern.

`TebObjective` stacks weighted terms (`residuals.py`). A term with bounds goes through the TEB
interval penalty r = max(0, x − (upper − ε)) + max(0, (lower + ε) − x) (built from
`legplan.solve.inequality.interval_penalty`); its Jacobian rows are scaled by the penalty's slope, which
keeps inactive rows in the pattern with zero values. The penalty is applied once to the stacked
values of all terms (unbounded rows have bounds ∓∞ and pass through unchanged), and a term that
appears in several entries (clearance: obstacle and inflation bounds) is evaluated once.

The pattern of the stacked Jacobian J (rows R, cols C) is fixed for a given band size and term
set, so the constructor precomputes every pair (p, q) of Jacobian entries sharing a row and the
slot of (C_p, C_q) in JᵀJ: per iteration JᵀJ = bincount(slot, V_p·V_q) and Jᵀh = bincount(C, V·h[R])
are pure numpy, and the solver core receives a single COO matrix with an unchanged pattern (its
CHOLMOD analysis is reused across the round).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.nav.teb.residuals import BAND, BandState, Term
from legplan.solve import NormalTerms, StructuredBlock
from legplan.solve.inequality import interval_penalty


@dataclass(frozen=True)
class Weighted:
    """A term in the objective: per-row √weight, and optional bounds (lower, upper, ε) of the penalty."""

    term: Term
    weight: np.ndarray
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    epsilon: float = 0.0

    @property
    def bounded(self) -> bool:
        return self.lower is not None


def objective_key(n: int, entries: list[Weighted]) -> tuple:
    """Identifies the Jacobian pattern of `TebObjective(n, entries)`: equal keys, equal patterns."""
    return n, tuple(e.term.key for e in entries if e.term.size)


def weighted(term: Term, weight, lower=None, upper=None, epsilon: float = 0.0) -> Weighted:
    """`Weighted` with weight and bounds broadcast to the term's rows."""
    size = (term.size,)
    bounds = (None, None) if lower is None else (np.broadcast_to(np.asarray(lower, float), size).copy(),
                                                 np.broadcast_to(np.asarray(upper, float), size).copy())
    if bounds[0] is not None and (epsilon < 0 or np.any(bounds[1] - bounds[0] < 2 * epsilon)):
        raise ValueError("need epsilon ≥ 0 and upper − lower ≥ 2·epsilon")
    return Weighted(term, np.broadcast_to(np.asarray(weight, float), size).copy(), *bounds, float(epsilon))


class TebObjective(StructuredBlock):
    """Σ of weighted (penalized) terms over the band vector z; see module docstring."""

    variables = (BAND,)

    def __init__(self, n: int, entries: list[Weighted]):
        self.n = n
        self.key = objective_key(n, entries)
        self.entries = [e for e in entries if e.term.size]
        self.size = sum(e.term.size for e in self.entries)
        self.columns = 4 * n - 1
        offsets = np.concatenate([[0], np.cumsum([e.term.size for e in self.entries])]).astype(np.int64)
        self._offsets = offsets
        self.rows = np.concatenate([e.term.rows + o for e, o in zip(self.entries, offsets)]) if self.entries \
            else np.zeros(0, np.int64)
        self.cols = np.concatenate([e.term.cols for e in self.entries]) if self.entries else np.zeros(0, np.int64)
        self._stack_bounds()
        self._pairs()

    def refresh(self, entries: list[Weighted]) -> None:
        """Replace the entries by ones with the same pattern (equal `objective_key`): new data,
        weights and bounds, and the precomputed JᵀJ slots stay valid."""
        if objective_key(self.n, entries) != self.key:
            raise ValueError("TebObjective.refresh: the entries have a different Jacobian pattern")
        self.entries = [e for e in entries if e.term.size]
        self._stack_bounds()

    def _stack_bounds(self) -> None:
        """Row weights, penalty thresholds (lower + ε, upper − ε; ∓∞ for unbounded rows) and the
        unbounded-row indicator, stacked over all entries."""
        def stacked(part):
            return np.concatenate([part(e) for e in self.entries]) if self.entries else np.zeros(0)
        self._weight = stacked(lambda e: e.weight)
        self._low = stacked(lambda e: e.lower + e.epsilon if e.bounded else np.full(e.term.size, -np.inf))
        self._high = stacked(lambda e: e.upper - e.epsilon if e.bounded else np.full(e.term.size, np.inf))
        self._free = stacked(lambda e: np.full(e.term.size, float(not e.bounded)))

    def _pairs(self) -> None:
        """Entry pairs (p, q) sharing a Jacobian row and the JᵀJ slot of each (see module docstring)."""
        R, C = self.rows, self.cols
        order = np.argsort(R, kind="stable")
        counts = np.bincount(R, minlength=self.size)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        per = counts[R[order]]
        first = np.repeat(np.arange(R.size), per)
        within = np.arange(first.size) - np.repeat(np.cumsum(per) - per, per)
        second = starts[R[order][first]] + within
        self._p, self._q = order[first], order[second]
        key = C[self._p] * self.columns + C[self._q]
        unique, self._slot = np.unique(key, return_inverse=True)
        self._h_rows, self._h_cols = unique // self.columns, unique % self.columns

    def _linearize(self, z: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        state = BandState(z, self.n, jacobian)
        cache: dict[int, tuple] = {}
        for e in self.entries:
            if id(e.term) not in cache:
                cache[id(e.term)] = e.term.linearize(state)
        parts = [cache[id(e.term)] for e in self.entries]
        x = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0)
        penalty, slope = interval_penalty(x, self._low, self._high)
        h = self._weight * (penalty + self._free * x)
        if not jacobian:
            return h, None
        row_scale = self._weight * (slope + self._free)
        vals = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0)
        return h, row_scale[self.rows] * vals

    def evaluate(self, values, jacobians):
        h, vals = self._linearize(values[0], jacobians)
        if not jacobians:
            return h, None
        return h, [sp.coo_matrix((vals, (self.rows, self.cols)), shape=(self.size, self.columns))]

    def normal_terms(self, values) -> NormalTerms:
        h, vals = self._linearize(values[0], True)
        products = np.bincount(self._slot, weights=vals[self._p] * vals[self._q], minlength=self._h_rows.size)
        hessian = sp.coo_matrix((products, (self._h_rows, self._h_cols)), shape=(self.columns, self.columns))
        gradient = np.bincount(self.cols, weights=vals * h[self.rows], minlength=self.columns)
        return NormalTerms(h, {(0, 0): hessian}, [gradient])
