"""The whole TEB objective of eq. (24) as one structured residual block with a fixed JᵀJ pattern.

`TebObjective` stacks weighted terms (`residuals.py`). A term with bounds goes through the TEB
interval penalty r = max(0, x − (upper − ε)) + max(0, (lower + ε) − x) (built from
`legplan.solve.inequality.hinge`); its Jacobian rows are scaled by the penalty's slope, which
keeps inactive rows in the pattern with zero values.

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

from legplan.nav.teb.residuals import BAND, Term, split_vector
from legplan.solve import NormalTerms, StructuredBlock
from legplan.solve.inequality import hinge


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

    def penalty(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interval penalty of x and its slope (identity when the term has no bounds)."""
        if not self.bounded:
            return x, np.ones_like(x)
        above, s_above = hinge(x - (self.upper - self.epsilon))
        below, s_below = hinge((self.lower + self.epsilon) - x)
        return above + below, s_above - s_below


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
        self.entries = [e for e in entries if e.term.size]
        self.size = sum(e.term.size for e in self.entries)
        self.columns = 4 * n - 1
        offsets = np.concatenate([[0], np.cumsum([e.term.size for e in self.entries])]).astype(np.int64)
        self._offsets = offsets
        self.rows = np.concatenate([e.term.rows + o for e, o in zip(self.entries, offsets)]) if self.entries \
            else np.zeros(0, np.int64)
        self.cols = np.concatenate([e.term.cols for e in self.entries]) if self.entries else np.zeros(0, np.int64)
        self._pairs()

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
        poses, dt = split_vector(np.asarray(z, float), self.n)
        cache: dict[int, tuple] = {}
        residuals, values = [], []
        for e in self.entries:
            key = id(e.term)
            if key not in cache:
                cache[key] = e.term.linearize(poses, dt, jacobian)
            x, vals = cache[key]
            r, slope = e.penalty(x)
            residuals.append(e.weight * r)
            if jacobian:
                values.append((e.weight * slope)[e.term.rows] * vals)
        h = np.concatenate(residuals) if residuals else np.zeros(0)
        return h, ((np.concatenate(values) if values else np.zeros(0)) if jacobian else None)

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
