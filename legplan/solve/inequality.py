"""Inequality constraints as residual blocks wrapping any block that returns g(θ).

* `HingeInequality`: g(θ) ≤ 0 becomes r = max(g, 0) — eq. (8b) of the Bézier step-planning paper,
  which writes the same thing as min(g, 0) for constraints g ≥ 0. The residual is zero exactly on
  the feasible set, so a root of h (eq. (12)) satisfies the inequality.
* `IntervalPenalty`: lower ≤ x(θ) ≤ upper as in timed elastic band / g2o,
  r = max(0, x − (upper − ε)) + max(0, (lower + ε) − x). The margin ε makes the penalty active
  slightly inside the interval, so a root lies ε inside the bounds, not on them. The penalty is
  continuous and piecewise linear in x.

Inactive rows keep their place in the Jacobian pattern with zero values, so the sparsity pattern
(and the CHOLMOD analysis built on it) does not change as constraints switch on and off.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np
import scipy.sparse as sp

from legplan.solve.blocks import Matrix, ResidualBlock


def _scale_rows(jac: Matrix, factor: np.ndarray) -> Matrix:
    """diag(factor) @ jac without dropping the sparsity pattern of `jac`."""
    if sp.issparse(jac):
        out = sp.csr_matrix(jac, copy=True)
        out.data *= np.repeat(factor, np.diff(out.indptr))
        return out
    return factor[:, None] * np.asarray(jac, float)


class _ElementwiseWrapper(ResidualBlock):
    """r = φ(inner(θ)) applied elementwise, Jacobian diag(φ') @ J_inner."""

    def __init__(self, inner: ResidualBlock):
        self.inner = inner
        self.variables = inner.variables
        self.size = inner.size

    @abstractmethod
    def _map(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Elementwise residual φ(x) and slope φ'(x)."""

    def evaluate(self, values, jacobians):
        x, jacs = self.inner.evaluate(values, jacobians)
        r, slope = self._map(np.asarray(x, float))
        return r, ([_scale_rows(j, slope) for j in jacs] if jacobians else None)


def hinge(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """max(g, 0) and its slope (1 where active, 0 elsewhere): eq. (8b) for g ≤ 0 constraints."""
    active = g > 0
    return np.where(active, g, 0.0), active.astype(float)


def interval_penalty(x: np.ndarray, low, high) -> tuple[np.ndarray, np.ndarray]:
    """max(0, x − high) + max(0, low − x) and its slope (+1 above, −1 below, 0 between): the
    penalty of `IntervalPenalty` with the margin already in `low`, `high` (∓∞ for no bound)."""
    above, slope_above = hinge(x - high)
    below, slope_below = hinge(low - x)
    return above + below, slope_above - slope_below


class HingeInequality(_ElementwiseWrapper):
    """g(θ) ≤ 0 as the residual max(g, 0) (eq. (8b))."""

    def _map(self, x):
        return hinge(x)


class IntervalPenalty(_ElementwiseWrapper):
    """lower ≤ x(θ) ≤ upper as the TEB-style penalty with margin `epsilon` (see module docstring)."""

    def __init__(self, inner: ResidualBlock, lower: float | np.ndarray = -np.inf,
                 upper: float | np.ndarray = np.inf, epsilon: float = 0.0):
        super().__init__(inner)
        self.lower = np.broadcast_to(np.asarray(lower, float), (self.size,))
        self.upper = np.broadcast_to(np.asarray(upper, float), (self.size,))
        self.epsilon = float(epsilon)
        if self.epsilon < 0 or np.any(self.upper - self.lower < 2 * self.epsilon):
            raise ValueError("need epsilon ≥ 0 and upper − lower ≥ 2·epsilon")

    def _map(self, x):
        return interval_penalty(x, self.lower + self.epsilon, self.upper - self.epsilon)
