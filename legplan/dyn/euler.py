"""Base orientation as Euler angles e = (roll φ, pitch θ, yaw ψ), R = Rz(ψ) Ry(θ) Rx(φ), as TOWR.

The single-rigid-body dynamics need the body angular velocity and acceleration from the Euler-angle
spline (Winkler et al. 2018, Sec. III): ω_B = E_B(e) ė with

    E_B = [[1, 0, −sθ], [0, cφ, sφ cθ], [0, −sφ, cφ cθ]],    ω̇_B = E_B ë + Ė_B ė,

and the world angular velocity ω = R ω_B. Every function is batched over rows (n, 3) and written with
holomorphic operations only, so `complex_step` differentiates it exactly (to round-off), where a
block still uses it; `rotation_derivatives` and `body_rate_derivatives` give ∂R/∂e and the body
rates' Jacobians in closed form.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

COMPLEX_STEP = 1e-30


def rotation(e: np.ndarray) -> np.ndarray:
    """R(e) (n, 3, 3), base to world, for Euler angles e (n, 3) = (roll, pitch, yaw)."""
    cr, sr = np.cos(e[:, 0]), np.sin(e[:, 0])
    cp, sp = np.cos(e[:, 1]), np.sin(e[:, 1])
    cy, sy = np.cos(e[:, 2]), np.sin(e[:, 2])
    r = np.empty(e.shape[:1] + (3, 3), dtype=np.result_type(e, float))
    r[:, 0, 0], r[:, 0, 1], r[:, 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    r[:, 1, 0], r[:, 1, 1], r[:, 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    r[:, 2, 0], r[:, 2, 1], r[:, 2, 2] = -sp, cp * sr, cp * cr
    return r


def rotation_derivatives(e: np.ndarray) -> np.ndarray:
    """∂R/∂e_k (n, 3, 3, 3), [:, k] the derivative of `rotation`'s R(e) w.r.t. e_k (roll, pitch, yaw):
    the product rule on R = Rz(ψ) Ry(θ) Rx(φ), entry by entry (real e only)."""
    cr, sr = np.cos(e[:, 0]), np.sin(e[:, 0])
    cp, sp = np.cos(e[:, 1]), np.sin(e[:, 1])
    cy, sy = np.cos(e[:, 2]), np.sin(e[:, 2])
    d = np.zeros(e.shape[:1] + (3, 3, 3))
    roll, pitch, yaw = d[:, 0], d[:, 1], d[:, 2]
    roll[:, 0, 1], roll[:, 0, 2] = cy * sp * cr + sy * sr, -cy * sp * sr + sy * cr
    roll[:, 1, 1], roll[:, 1, 2] = sy * sp * cr - cy * sr, -sy * sp * sr - cy * cr
    roll[:, 2, 1], roll[:, 2, 2] = cp * cr, -cp * sr
    pitch[:, 0, 0], pitch[:, 0, 1], pitch[:, 0, 2] = -cy * sp, cy * cp * sr, cy * cp * cr
    pitch[:, 1, 0], pitch[:, 1, 1], pitch[:, 1, 2] = -sy * sp, sy * cp * sr, sy * cp * cr
    pitch[:, 2, 0], pitch[:, 2, 1], pitch[:, 2, 2] = -cp, -sp * sr, -sp * cr
    yaw[:, 0, 0], yaw[:, 0, 1], yaw[:, 0, 2] = -sy * cp, -sy * sp * sr - cy * cr, -sy * sp * cr + cy * sr
    yaw[:, 1, 0], yaw[:, 1, 1], yaw[:, 1, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    return d


def body_rates(e: np.ndarray, ed: np.ndarray, edd: np.ndarray | None = None):
    """ω_B (n, 3) and, given ë, ω̇_B (n, 3) from Euler angles, rates and accelerations."""
    cr, sr = np.cos(e[:, 0]), np.sin(e[:, 0])
    cp, sp = np.cos(e[:, 1]), np.sin(e[:, 1])
    rd, pd, yd = ed[:, 0], ed[:, 1], ed[:, 2]
    w = np.stack([rd - sp * yd, cr * pd + sr * cp * yd, -sr * pd + cr * cp * yd], axis=1)
    if edd is None:
        return w
    rdd, pdd, ydd = edd[:, 0], edd[:, 1], edd[:, 2]
    # E_B ë + Ė_B ė
    wd = np.stack([rdd - sp * ydd - cp * pd * yd,
                   cr * pdd + sr * cp * ydd - sr * rd * pd + (cr * cp * rd - sr * sp * pd) * yd,
                   -sr * pdd + cr * cp * ydd - cr * rd * pd + (-sr * cp * rd - cr * sp * pd) * yd], axis=1)
    return w, wd


def body_rate_derivatives(e: np.ndarray, ed: np.ndarray, edd: np.ndarray):
    """`body_rates`' ω_B, ω̇_B (n, 3) with their Jacobians (n, 3, 3): ∂ω_B/∂e, ∂ω_B/∂ė (= E_B),
    ∂ω̇_B/∂e, ∂ω̇_B/∂ė and ∂ω̇_B/∂ë (= E_B), differentiated entry by entry (no yaw appears: its
    column of ∂/∂e is zero; a roll turns (ω_y, ω_z) and (ω̇_y, ω̇_z) by 90°)."""
    cr, sr = np.cos(e[:, 0]), np.sin(e[:, 0])
    cp, sp = np.cos(e[:, 1]), np.sin(e[:, 1])
    rd, pd, yd = ed[:, 0], ed[:, 1], ed[:, 2]
    w, wd = body_rates(e, ed, edd)
    rdd, pdd, ydd = edd[:, 0], edd[:, 1], edd[:, 2]
    n = e.shape[0]
    E = np.zeros((n, 3, 3))  # E_B
    E[:, 0, 0], E[:, 0, 2] = 1.0, -sp
    E[:, 1, 1], E[:, 1, 2] = cr, sr * cp
    E[:, 2, 1], E[:, 2, 2] = -sr, cr * cp
    dw_de = np.zeros((n, 3, 3))
    dw_de[:, 0, 1] = -cp * yd
    dw_de[:, 1, 0], dw_de[:, 1, 1] = w[:, 2], -sr * sp * yd
    dw_de[:, 2, 0], dw_de[:, 2, 1] = -w[:, 1], -cr * sp * yd
    dwd_de = np.zeros((n, 3, 3))
    dwd_de[:, 0, 1] = -cp * ydd + sp * pd * yd
    dwd_de[:, 1, 0], dwd_de[:, 1, 1] = wd[:, 2], -sr * sp * ydd - (cr * sp * rd + sr * cp * pd) * yd
    dwd_de[:, 2, 0], dwd_de[:, 2, 1] = -wd[:, 1], -cr * sp * ydd + (sr * sp * rd - cr * cp * pd) * yd
    dwd_ded = np.zeros((n, 3, 3))
    dwd_ded[:, 0, 1], dwd_ded[:, 0, 2] = -cp * yd, -cp * pd
    dwd_ded[:, 1, 0], dwd_ded[:, 1, 1], dwd_ded[:, 1, 2] = dw_de[:, 1, 0], -sr * rd - sr * sp * yd, cr * cp * rd - sr * sp * pd
    dwd_ded[:, 2, 0], dwd_ded[:, 2, 1], dwd_ded[:, 2, 2] = dw_de[:, 2, 0], -cr * rd - cr * sp * yd, -sr * cp * rd - cr * sp * pd
    return w, wd, dw_de, E, dwd_de, dwd_ded, E


def world_rates(e: np.ndarray, ed: np.ndarray, edd: np.ndarray | None = None):
    """World-frame ω (n, 3) and, given ë, ω̇ (n, 3) (ω̇ = R ω̇_B, since ω × ω = 0)."""
    r = rotation(e)
    if edd is None:
        return np.einsum("nij,nj->ni", r, body_rates(e, ed))
    wb, wdb = body_rates(e, ed, edd)
    return np.einsum("nij,nj->ni", r, wb), np.einsum("nij,nj->ni", r, wdb)


def complex_step(fn: Callable[..., np.ndarray], args: Sequence[np.ndarray], wrt: Sequence[int]
                 ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Value fn(*args) (n, r) and its row-wise Jacobians (n, r, 3) w.r.t. the (n, 3) arguments `wrt`.

    All perturbations are evaluated in one batched call: each of the 3·len(wrt) directions gets its
    own copy of the n rows, imaginary part `COMPLEX_STEP` in one coordinate.
    """
    n = args[0].shape[0]
    k = 3 * len(wrt)
    stacked = [np.tile(np.asarray(a, complex), (k + 1, 1)) for a in args]
    for m, arg in enumerate(wrt):
        for c in range(3):
            d = 3 * m + c
            stacked[arg][(d + 1) * n:(d + 2) * n, c] += 1j * COMPLEX_STEP
    out = fn(*stacked)
    value = out[:n].real
    jac = out[n:].imag.reshape(k, n, -1) / COMPLEX_STEP  # (k, n, r)
    return value, [np.moveaxis(jac[3 * m:3 * m + 3], 0, 2) for m in range(len(wrt))]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis, broadcast, by its components (numpy's `cross` moves and copies axes,
    several times the arithmetic for a few hundred vectors); the same floating-point operations."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    x = a1 * b2 - a2 * b1
    out = np.empty(x.shape + (3,), np.result_type(a, b))  # as np.stack's, without its checks
    out[..., 0], out[..., 1], out[..., 2] = x, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    return out
