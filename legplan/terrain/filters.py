"""Gaussian and maximum filters of a 2D grid, border cells repeated ("nearest"), in numpy.

They give what `scipy.ndimage.gaussian_filter(..., mode="nearest")` and
`scipy.ndimage.maximum_filter(..., mode="nearest")` give, value for value (tests/terrain/test_filters.py
compares them bit for bit), for the planners and checks that filter a heightmap on every run:
importing `scipy.ndimage` builds its array-API wrappers, which costs a command more CPU than these
filters do on a map. Map building (`legplan.terrain.layers`, `legplan.terrain.sdf`) still uses
`scipy.ndimage` itself.

The Gaussian is scipy's: per axis (rows, then columns) a correlation with the kernel
exp(−x²/2σ²) normalized to sum 1 over |x| ≤ ⌊4σ + 0.5⌋ cells, accumulated as scipy does for a symmetric
kernel (centre first, then the pairs of cells at the same distance, farthest first), so every
rounding is the same.
"""

from __future__ import annotations

import numpy as np

TRUNCATE = 4.0  # kernel radius in σ (scipy's default)


def _gaussian_kernel(sigma: float, radius: int) -> np.ndarray:
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (sigma * sigma) * x ** 2)
    return phi / phi.sum()


def _gaussian_axis(a: np.ndarray, sigma: float, axis: int) -> np.ndarray:
    radius = int(TRUNCATE * float(sigma) + 0.5)
    w = _gaussian_kernel(float(sigma), radius)[::-1]
    a = np.moveaxis(a, axis, -1)
    n = a.shape[-1]
    padded = np.pad(a, [(0, 0)] * (a.ndim - 1) + [(radius, radius)], mode="edge")
    out = padded[..., radius:radius + n] * w[radius]
    for j in range(radius, 0, -1):  # farthest pair first, as scipy's symmetric correlation
        out += (padded[..., radius - j:radius - j + n] + padded[..., radius + j:radius + j + n]) * w[radius - j]
    return np.moveaxis(out, -1, axis)


def gaussian_filter(a, sigma: float) -> np.ndarray:
    """Gaussian smoothing of the float grid `a` with standard deviation `sigma` (cells) on every axis,
    border cells repeated: `scipy.ndimage.gaussian_filter(a, sigma, mode="nearest")`."""
    out = np.asarray(a, dtype=float)
    if sigma > 1e-15:
        for axis in range(out.ndim):
            out = _gaussian_axis(out, sigma, axis)
    return np.array(out, dtype=float)


def maximum_filter(a, footprint) -> np.ndarray:
    """Maximum of the 2D grid `a` over the cells of the boolean `footprint` (odd sizes, centred on
    each cell), border cells repeated: `scipy.ndimage.maximum_filter(a, footprint=footprint,
    mode="nearest")`."""
    a = np.asarray(a)
    footprint = np.asarray(footprint, bool)
    ry, rx = (s // 2 for s in footprint.shape)
    if footprint.shape != (2 * ry + 1, 2 * rx + 1):
        raise ValueError(f"footprint must have odd sizes, got shape {footprint.shape}")
    padded = np.pad(a, [(ry, ry), (rx, rx)], mode="edge")
    ny, nx = a.shape
    out = None
    for dy, dx in zip(*np.nonzero(footprint)):
        window = padded[dy:dy + ny, dx:dx + nx]
        out = window.copy() if out is None else np.maximum(out, window, out=out)
    if out is None:
        raise ValueError("footprint has no cell")
    return out


def square_maximum_filter(a, size: int) -> np.ndarray:
    """Maximum of `a` over the size × size square (odd size) around each cell, border cells repeated:
    `scipy.ndimage.maximum_filter(a, size=size, mode="nearest")`, as a row then a column filter."""
    line = np.ones((1, size), bool)
    return maximum_filter(maximum_filter(a, line), line.T)
