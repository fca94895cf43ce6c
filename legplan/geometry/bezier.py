"""Bézier curves in a vector space: Bernstein basis, derivatives, degree elevation, quality integrals.

A Bézier curve of degree d with control points P = (p_0, ..., p_d) (rows of a (d+1, n) array) is
π_d(P, t) = Σ_i B_i^d(t) p_i (Bézier paper eq. (6)), with the Bernstein polynomials
B_i^d(t) = C(d, i) t^i (1 − t)^(d−i). Everything here is linear in P, so sampling a curve at N
parameters is one matrix product `bernstein_matrix(d, t) @ P`; the same (N, d+1) matrix holds the
Bernstein weights b_k that scale per-sample Jacobians in the planner (chain rule dπ(t_k)/dp_i = B_i^d(t_k) I).

The k-th derivative is again a Bézier curve, of degree d − k, whose control points are the scaled
k-th forward differences d!/(d−k)! Δ^k p_i (`derivative_matrix`). Degree elevation, eq. (7), gives
the same curve with one more control point (`elevate`, `elevation_matrix`).
"""

from __future__ import annotations

from math import comb, factorial

import numpy as np


def bernstein_matrix(degree: int, t, derivative: int = 0) -> np.ndarray:
    """(len(t), degree+1) matrix M with π^(derivative)(t_j) = Σ_i M[j, i] p_i (eq. (6) and its derivatives).

    For derivative ≥ degree+1 the matrix is zero (eq. (15): π^(i) = 0 for i > d).
    """
    if degree < 0 or derivative < 0:
        raise ValueError(f"degree and derivative must be >= 0, got {degree}, {derivative}")
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if derivative > degree:
        return np.zeros((t.size, degree + 1))
    lower = degree - derivative
    basis = _bernstein(lower, t)
    if derivative == 0:
        return basis
    return basis @ difference_matrix(degree, derivative)


def _bernstein(degree: int, t: np.ndarray) -> np.ndarray:
    """B_i^degree(t) for i = 0..degree, shape (len(t), degree+1)."""
    i = np.arange(degree + 1)
    coeff = np.array([comb(degree, k) for k in i], dtype=float)
    # t**0 and (1-t)**0 are 1 even at t = 0 or 1 (numpy: 0.0**0 == 1.0).
    return coeff * t[:, None] ** i * (1.0 - t[:, None]) ** (degree - i)


def difference_matrix(degree: int, derivative: int) -> np.ndarray:
    """(degree−derivative+1, degree+1) matrix D: control points of π^(derivative) are D @ P.

    D = d!/(d−k)! × (k-th forward difference), i.e. row i holds d!/(d−k)! Σ_j (−1)^(k−j) C(k, j) at column i+j.
    """
    if derivative > degree:
        raise ValueError(f"derivative {derivative} exceeds degree {degree}")
    rows = degree - derivative + 1
    scale = factorial(degree) / factorial(degree - derivative)
    stencil = np.array([(-1) ** (derivative - j) * comb(derivative, j) for j in range(derivative + 1)], float)
    out = np.zeros((rows, degree + 1))
    for i in range(rows):
        out[i, i:i + derivative + 1] = scale * stencil
    return out


def evaluate(control_points, t, derivative: int = 0) -> np.ndarray:
    """π^(derivative)(t) for control points (d+1, n) at parameters t: shape (len(t), n)."""
    P = np.asarray(control_points, dtype=float)
    return bernstein_matrix(len(P) - 1, t, derivative) @ P


def elevation_matrix(degree: int) -> np.ndarray:
    """(degree+2, degree+1) matrix E with P_{d+1} = E @ P_d, eq. (7): the same curve, one degree higher.

    p̃_0 = p_0, p̃_{d+1} = p_d and p̃_i = i/(d+1) p_{i−1} + (1 − i/(d+1)) p_i for i = 1..d (eq. (7c)).
    """
    d = degree
    out = np.zeros((d + 2, d + 1))
    out[0, 0] = 1.0
    out[d + 1, d] = 1.0
    for i in range(1, d + 1):
        a = i / (d + 1)
        out[i, i - 1] = a
        out[i, i] = 1.0 - a
    return out


def elevate(control_points, times: int = 1) -> np.ndarray:
    """Control points of the equivalent curve of degree d + `times` (eq. (7) applied `times` times)."""
    P = np.asarray(control_points, dtype=float)
    for _ in range(times):
        P = elevation_matrix(len(P) - 1) @ P
    return P


def uniform_parameters(count: int) -> np.ndarray:
    """The uniform partition t_i = i / N, i = 0..N of eq. (10) (count = N + 1 points)."""
    if count < 2:
        raise ValueError(f"need at least 2 parameters, got {count}")
    return np.linspace(0.0, 1.0, count)


def derivative_norm_integrals(control_points, orders=(1, 2, 3), quadrature: int = 64) -> np.ndarray:
    """∫_0^1 ||π^(k)(t)|| dt for each k in `orders` — the path-quality terms of eq. (5).

    Computed from the control points with Gauss-Legendre quadrature of `quadrature` nodes (the
    integrand is the norm of a polynomial; it is smooth except where π^(k) vanishes).
    """
    P = np.asarray(control_points, dtype=float)
    nodes, weights = np.polynomial.legendre.leggauss(quadrature)
    t = 0.5 * (nodes + 1.0)
    w = 0.5 * weights
    return np.array([w @ np.linalg.norm(evaluate(P, t, k), axis=1) for k in orders])
