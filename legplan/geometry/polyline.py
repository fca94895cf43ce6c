"""Polylines: cumulative arc length and resampling uniform in arc length (any dimension)."""

from __future__ import annotations

import numpy as np


def arc_length(points) -> np.ndarray:
    """Cumulative Euclidean length (k,) along the polyline through `points` (k, n), from 0."""
    points = np.asarray(points, float)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def resample_by_arc_length(points, lengths, *values) -> list[np.ndarray]:
    """The polyline through `points` (k, n), and per-point `values` (k,) each, linearly
    interpolated at the arc lengths `lengths` (m,) (0 ≤ length ≤ total; zero-length steps — a
    stop — are skipped so arc length increases strictly); returns [points (m, n), *values (m,)].
    The polyline must have a positive length."""
    points = np.asarray(points, float)
    s = arc_length(points)
    keep = np.concatenate([[True], np.diff(s) > 0])
    s = s[keep]
    columns = [np.interp(lengths, s, points[keep, j]) for j in range(points.shape[1])]
    return [np.stack(columns, axis=1), *(np.interp(lengths, s, np.asarray(v, float)[keep]) for v in values)]
