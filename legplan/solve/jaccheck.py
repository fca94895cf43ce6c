"""Finite-difference checks of analytic Jacobians and of structured normal-equation terms.

Every residual block's tests should call `check_jacobian(block, values)`:

    report = check_jacobian(block, {"P": P, "xi": xi})
    assert report.max_abs_error < 1e-6, report
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.solve.blocks import BlockDiagonal, ResidualBlock, StructuredBlock, default_normal_terms


@dataclass(frozen=True)
class JacobianCheck:
    """Largest disagreement between analytic and central-difference Jacobians.

    The relative error of an entry is |a − n| / max(|a|, |n|, scale) where `scale` is the largest
    magnitude in the Jacobian times 1e-6 (so entries that are zero up to noise do not dominate).
    `worst` is (variable, row, column) of the largest absolute error.
    """

    max_abs_error: float
    max_rel_error: float
    worst: tuple[str, int, int]

    def ok(self, atol: float = 1e-6, rtol: float = 1e-4) -> bool:
        return self.max_abs_error <= atol or self.max_rel_error <= rtol


def _dense(m) -> np.ndarray:
    return m.toarray() if sp.issparse(m) else np.asarray(m, float)


def _as_values(block: ResidualBlock, values) -> list[np.ndarray]:
    if isinstance(values, Mapping):
        return [np.asarray(values[name], float).reshape(-1) for name in block.variables]
    return [np.asarray(v, float).reshape(-1) for v in values]


def column_groups(pattern) -> list[np.ndarray]:
    """Columns of a Jacobian's sparsity `pattern` (m × n, dense or sparse) in groups of which no two
    share a row, so one perturbation per group finds every column's derivatives (Curtis, Powell and
    Reid's finite-difference grouping). Greedy, in column order."""
    pattern = sp.csc_matrix(pattern, dtype=bool)
    groups: list[list[int]] = []
    rows_used: list[np.ndarray] = []
    for j in range(pattern.shape[1]):
        rows = pattern.indices[pattern.indptr[j]:pattern.indptr[j + 1]]
        for g, used in enumerate(rows_used):
            if not used[rows].any():
                groups[g].append(j)
                used[rows] = True
                break
        else:
            used = np.zeros(pattern.shape[0], bool)
            used[rows] = True
            groups.append([j])
            rows_used.append(used)
    return [np.asarray(g) for g in groups]


def numeric_jacobian(fn: Callable[[np.ndarray], np.ndarray], x: np.ndarray, step: float | None = None,
                     pattern=None) -> np.ndarray:
    """Central-difference Jacobian of `fn` at `x` (step ≈ ε^(1/3)·max(1, |x_j|) unless given).

    With a sparsity `pattern` (the analytic Jacobian's), columns that share no row are perturbed
    together (`column_groups`) and each row's difference goes to the column the pattern gives it; a
    row no column of the group claims keeps its difference in the group's first column, so a
    derivative missing from the pattern still shows as an error.
    """
    x = np.asarray(x, float)
    f0 = np.asarray(fn(x), float)
    out = np.zeros((f0.size, x.size))
    if pattern is None:
        groups = [np.array([j]) for j in range(x.size)]
    else:
        pattern = sp.csc_matrix(pattern, dtype=bool)
        groups = column_groups(pattern)
    for group in groups:
        h = step if step is not None else np.cbrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x[group]))
        xp, xm = x.copy(), x.copy()
        xp[group] += h
        xm[group] -= h
        diff = np.asarray(fn(xp), float) - np.asarray(fn(xm), float)
        if pattern is None:
            out[:, group[0]] = diff / (2 * h)
            continue
        owner = np.full(f0.size, group[0])
        for j in group:
            owner[pattern.indices[pattern.indptr[j]:pattern.indptr[j + 1]]] = j
        width = np.broadcast_to(h, group.shape)[np.searchsorted(group, owner)]
        out[np.arange(f0.size), owner] = diff / (2 * width)
    return out


def check_jacobian(block_or_fn: ResidualBlock | Callable, x, step: float | None = None) -> JacobianCheck:
    """Compare analytic and finite-difference Jacobians.

    `block_or_fn` is a `ResidualBlock` with `x` its variable values (a sequence in the order of
    `block.variables`, or a mapping name → value), or a function `fn(x) -> (r, J)` of one vector.
    """
    if isinstance(block_or_fn, ResidualBlock):
        block = block_or_fn
        values = _as_values(block, x)
        _, jacs = block.evaluate(values, True)
        pairs = []
        for i, name in enumerate(block.variables):
            def fi(v, i=i):
                vals = list(values)
                vals[i] = v
                return block.evaluate(vals, False)[0]
            analytic = _dense(jacs[i])
            pairs.append((name, analytic, numeric_jacobian(fi, values[i], step, analytic != 0)))
    else:
        fn = block_or_fn
        x = np.asarray(x, float)
        pairs = [("x", _dense(fn(x)[1]), numeric_jacobian(lambda v: fn(v)[0], x, step))]
    scale = 1e-6 * max((float(np.abs(a).max(initial=0.0)) for _, a, _ in pairs), default=0.0)
    best_abs, best_rel, worst = 0.0, 0.0, ("", -1, -1)
    for name, analytic, numeric in pairs:
        if analytic.shape != numeric.shape:
            raise ValueError(f"Jacobian for {name!r} has shape {analytic.shape}, expected {numeric.shape}")
        err = np.abs(analytic - numeric)
        if err.size == 0:
            continue
        rel = err / np.maximum(np.maximum(np.abs(analytic), np.abs(numeric)), max(scale, 1e-300))
        best_rel = max(best_rel, float(rel.max()))
        k = np.unravel_index(np.argmax(err), err.shape)
        if err[k] >= best_abs:
            best_abs, worst = float(err[k]), (name, int(k[0]), int(k[1]))
    return JacobianCheck(best_abs, best_rel, worst)


def check_normal_terms(block: StructuredBlock, x: Sequence[np.ndarray] | Mapping[str, np.ndarray]) -> float:
    """Largest absolute difference between `block.normal_terms` and JᵀJ, Jᵀh from `block.evaluate`."""
    values = _as_values(block, x)
    expected = default_normal_terms(*block.evaluate(values, True))
    got = block.normal_terms(values)
    err = float(np.abs(got.residual - expected.residual).max(initial=0.0))
    for gi, ei in zip(got.gradient, expected.gradient, strict=True):
        err = max(err, float(np.abs(gi - ei).max(initial=0.0)))
    for key, term in expected.hessian.items():
        mine = got.hessian.get(key)
        mine = np.zeros(term.shape) if mine is None else mine
        mine = sp.block_diag(list(mine.blocks)).toarray() if isinstance(mine, BlockDiagonal) else _dense(mine)
        err = max(err, float(np.abs(mine - _dense(term)).max(initial=0.0)))
    return err
