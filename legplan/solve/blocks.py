"""Residual blocks: small pieces of h(θ) of eq. (12), each with its own Jacobian block.

A block reads a few named variable blocks and returns its residual values and, on request, one
Jacobian block per variable it reads (dense ndarray when small, scipy.sparse otherwise). A block
that knows the structure of its JᵀJ (e.g. Bézier weights: H = Σ_k kron(b_k b_kᵀ, G_kᵀG_k)) derives
from `StructuredBlock` and returns that contribution to the normal equations of eq. (13) directly.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from legplan.geometry.sparse import times

Matrix = np.ndarray | sp.sparray | sp.spmatrix


@dataclass(frozen=True)
class BlockDiagonal:
    """A block-diagonal matrix given by its dense diagonal blocks, shape (count, m, m)."""

    blocks: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        count, m, _ = self.blocks.shape
        return count * m, count * m


@dataclass
class NormalTerms:
    """A block's contribution to the normal equations of eq. (13): JᵀJ, Jᵀh and h itself.

    `hessian[(i, j)]` with i ≤ j indexes the block's `variables`; it is dense, sparse, or (i == j
    only) `BlockDiagonal`. The (j, i) term is implied by symmetry. `gradient[i]` is J_iᵀh.
    Sizes are those of the full variable vectors; the problem drops fixed entries.
    """

    residual: np.ndarray
    hessian: dict[tuple[int, int], Matrix | BlockDiagonal] = field(default_factory=dict)
    gradient: list[np.ndarray] = field(default_factory=list)


class ResidualBlock(ABC):
    """A residual block over the variable blocks named in `variables` with `size` rows."""

    variables: tuple[str, ...]
    size: int
    jacobian_rows: np.ndarray | None = None
    """Optional (size,) ints: the row of the block's Jacobians that holds each residual row's
    derivative, times `jacobian_sign` (±1 per residual row). Rows whose derivatives are equal up to
    sign (the two bounds of one constraint row) then share one Jacobian row, which the solver
    evaluates, stores and multiplies once (`Problem.row_map`). None: row i is Jacobian row i."""
    jacobian_sign: np.ndarray | None = None

    @abstractmethod
    def evaluate(self, values: Sequence[np.ndarray], jacobians: bool) -> tuple[np.ndarray, list[Matrix] | None]:
        """Residual (size,) and, if `jacobians`, one Jacobian per variable: (size × len(values[i])),
        or with `jacobian_rows` (max(jacobian_rows) + 1 rows × len(values[i]))."""

    def residual_rows(self, values: Sequence[np.ndarray], rows: np.ndarray) -> np.ndarray:
        """The residual's rows `rows` (increasing indices) alone, as `evaluate` gives them, for a
        caller that reads no other row (the hinged LM's curvature probe reads the plain and active
        rows). Default: the whole residual, picked; a block whose rows are cheaper one by one (a
        leg's IK per sample) evaluates only what they need."""
        return np.asarray(self.evaluate(values, False)[0], float).reshape(-1)[rows]

    def residual_chunks(self, values: Sequence[np.ndarray]) -> Iterator[np.ndarray]:
        """The residual in pieces whose squared norms add up to ‖r‖² (any partition, any order).

        LM judges a trial point only by ‖h‖ against the current one (Algorithm 1, line 5); pieces
        let it stop evaluating once the partial sum already exceeds it (`Problem.trial_norm`).
        Default: one piece, the whole residual.
        """
        yield self.evaluate(values, False)[0]


class StructuredBlock(ResidualBlock):
    """A block that also contributes JᵀJ and Jᵀh directly (the "structured" assembly path)."""

    @abstractmethod
    def normal_terms(self, values: Sequence[np.ndarray]) -> NormalTerms:
        """Residual, JᵀJ blocks and Jᵀh blocks at `values`; must equal those of `evaluate`."""


def default_normal_terms(residual: np.ndarray, jacobians: Sequence[Matrix],
                         product: Callable[[int, int, Matrix, Matrix], Matrix] | None = None) -> NormalTerms:
    """JᵀJ and Jᵀh of one block from its Jacobian blocks (dense products go to BLAS).

    `product(i, j, J_i, J_j)` computes J_iᵀJ_j; the default is the plain `J_i.T @ J_j`.
    """
    terms = NormalTerms(residual)
    for i, ji in enumerate(jacobians):
        terms.gradient.append(np.asarray(ji.T @ residual).reshape(-1))
        for j in range(i, len(jacobians)):
            terms.hessian[(i, j)] = ji.T @ jacobians[j] if product is None else product(i, j, ji, jacobians[j])
    return terms


class FunctionBlock(ResidualBlock):
    """A residual block from a function `fn(*values) -> (r, [J_0, J_1, ...])`.

    `residual_fn(*values) -> r` is optional; give it when the residual is much cheaper than the
    Jacobians, since LM evaluates trial points without Jacobians (Algorithm 1, line 5).
    """

    def __init__(self, variables: Sequence[str], size: int,
                 fn: Callable[..., tuple[np.ndarray, list[Matrix]]],
                 residual_fn: Callable[..., np.ndarray] | None = None):
        self.variables = tuple(variables)
        self.size = int(size)
        self._fn = fn
        self._residual_fn = residual_fn

    def evaluate(self, values, jacobians):
        if not jacobians and self._residual_fn is not None:
            return np.asarray(self._residual_fn(*values), float), None
        r, jac = self._fn(*values)
        return np.asarray(r, float), (list(jac) if jacobians else None)


class LinearBlock(ResidualBlock):
    """r = Σ_i A_i x_i − b over the named variables, with constant Jacobians A_i.

    Serves the linear pieces of a problem: the closed-form integral costs of a spline (eq. (1) of the
    TOWR-costs paper, r = L c with LᵀL the Gram matrix), continuity and bound rows on node values.
    """

    def __init__(self, variables: Sequence[str], matrices: Sequence[Matrix], offset: np.ndarray | float = 0.0):
        if len(variables) != len(matrices):
            raise ValueError("one matrix per variable")
        self.variables = tuple(variables)
        self.matrices = [sp.csr_matrix(m) for m in matrices]
        self.size = self.matrices[0].shape[0]
        if any(m.shape[0] != self.size for m in self.matrices):
            raise ValueError("all matrices need the same number of rows")
        self.offset = np.broadcast_to(np.asarray(offset, float), (self.size,))

    def evaluate(self, values, jacobians):
        r = sum(times(m, np.asarray(v, float)) for m, v in zip(self.matrices, values)) - self.offset
        return r, (list(self.matrices) if jacobians else None)
