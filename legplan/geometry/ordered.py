"""Sorted sets and medians of numbers held in arrays: numpy's routines without the masked-array package.

`sorted_unique`, `sorted_union`, `sorted_difference` and `median` return what `np.unique`,
`np.union1d`, `np.setdiff1d` and `np.median` return for the values the planners, the check and the
artefacts' summaries merge (sample times, node indices, per-task figures). numpy's own ask
`np.ma.is_masked` or `np.ma.isMaskedArray` on the path these take, and that first use imports the
whole `numpy.ma` package, which no planning command otherwise needs.
"""

from __future__ import annotations

import numpy as np


def sorted_unique(values) -> np.ndarray:
    """The distinct entries of `values` (any shape, finite), sorted ascending, as a 1-D array of
    their dtype: `np.unique(values)` (two NaN would be kept apart, not merged)."""
    flat = np.sort(np.asarray(values).ravel())
    keep = np.empty(flat.shape, bool)
    keep[:1] = True
    np.not_equal(flat[1:], flat[:-1], out=keep[1:])
    return flat[keep]


def sorted_union(a, b) -> np.ndarray:
    """The distinct entries of `a` and `b` together, sorted: `np.union1d(a, b)`."""
    return sorted_unique(np.concatenate((a, b), axis=None))


def sorted_difference(a, b) -> np.ndarray:
    """The distinct entries of `a` that are not in `b`, sorted: `np.setdiff1d(a, b)`."""
    ours, theirs = sorted_unique(a), sorted_unique(b)
    if not theirs.size:
        return ours
    at = np.minimum(np.searchsorted(theirs, ours), theirs.size - 1)
    return ours[theirs[at] != ours]


def median(values) -> float:
    """`np.median` of a non-empty collection of numbers: the middle one of the sorted values, or the
    mean of the two middle ones, (a + b) / 2; NaN when any value is NaN."""
    flat = np.sort(np.asarray(values, float).ravel())
    if np.isnan(flat[-1]):
        return float("nan")
    middle = flat.size // 2
    return float(flat[middle]) if flat.size % 2 else float((flat[middle - 1] + flat[middle]) / 2.0)
