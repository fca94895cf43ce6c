"""Standard nonlinear least-squares problems as `Problem`s, for the solver tests and bench/solve_lm.py.

Rosenbrock, Powell singular, Brown almost-linear and Broyden tridiagonal are from Moré, Garbow &
Hillstrom, "Testing unconstrained optimization software" (1981), with their standard start points.
`bundle_adjustment_like` is a planar pose/landmark problem with the block-sparse structure of bundle
adjustment (landmarks eliminable by Schur complement). `step_planner_like` has the shape of the
Bézier step planner's eq. (12) with a known root. A problem's `residual` and `jacobian` are
what a reference solver (scipy.optimize.least_squares) gets, so both solve the same function.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from scipy.special import comb

from legplan.solve.blocks import FunctionBlock
from legplan.solve.curve import SampledCurveBlock
from legplan.solve.inequality import IntervalPenalty, hinge
from legplan.solve.problem import Problem
from legplan.solve.variables import VariableBlock


def rosenbrock() -> Problem:
    """r = (10(x₂ − x₁²), 1 − x₁); root (1, 1); start (−1.2, 1)."""
    def fn(x):
        return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]), [np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])]
    problem = Problem([VariableBlock("x", [-1.2, 1.0])])
    problem.add_residual(FunctionBlock(["x"], 2, fn))
    return problem


def powell_singular() -> Problem:
    """Root 0 with a singular Jacobian there; start (3, −1, 0, 1)."""
    s5, s10 = np.sqrt(5.0), np.sqrt(10.0)

    def fn(x):
        r = np.array([x[0] + 10 * x[1], s5 * (x[2] - x[3]), (x[1] - 2 * x[2]) ** 2, s10 * (x[0] - x[3]) ** 2])
        a, b = 2 * (x[1] - 2 * x[2]), 2 * s10 * (x[0] - x[3])
        J = np.array([[1, 10, 0, 0], [0, 0, s5, -s5], [0, a, -2 * a, 0], [b, 0, 0, -b]], float)
        return r, [J]
    problem = Problem([VariableBlock("x", [3.0, -1.0, 0.0, 1.0])])
    problem.add_residual(FunctionBlock(["x"], 4, fn))
    return problem


def brown_almost_linear(n: int = 10) -> Problem:
    """r_i = x_i + Σx − (n+1) for i < n, r_n = Πx − 1; root x = 1; start 0.5 (dense Jacobian)."""
    def fn(x):
        r = np.empty(n)
        r[:-1] = x[:-1] + x.sum() - (n + 1)
        r[-1] = np.prod(x) - 1
        J = np.ones((n, n)) + np.eye(n)
        J[-1] = [np.prod(np.delete(x, j)) for j in range(n)]
        return r, [J]
    problem = Problem([VariableBlock("x", np.full(n, 0.5))])
    problem.add_residual(FunctionBlock(["x"], n, fn))
    return problem


def broyden_tridiagonal(n: int = 10_000) -> Problem:
    """r_i = (3 − 2x_i)x_i − x_{i−1} − 2x_{i+1} + 1 (x₀ = x_{n+1} = 0); start −1; sparse Jacobian.

    The tridiagonal Jacobian keeps one CSR pattern; each evaluation only writes its diagonal
    3 − 4x into a copy of the constant values (no per-call sparse construction).
    """
    def residual(x):
        r = (3 - 2 * x) * x + 1
        r[1:] -= x[:-1]
        r[:-1] -= 2 * x[1:]
        return r

    pattern = sp.diags([np.full(n - 1, -1.0), np.ones(n), np.full(n - 1, -2.0)], [-1, 0, 1], format="csr")
    pattern.sort_indices()
    rows = np.repeat(np.arange(n), np.diff(pattern.indptr))
    diagonal = np.flatnonzero(pattern.indices == rows)

    def fn(x):
        data = pattern.data.copy()
        data[diagonal] = 3 - 4 * x
        return residual(x), [sp.csr_matrix((data, pattern.indices, pattern.indptr), shape=(n, n))]
    problem = Problem([VariableBlock("x", np.full(n, -1.0))])
    problem.add_residual(FunctionBlock(["x"], n, fn, residual_fn=residual))
    return problem


def bundle_adjustment_like(num_poses: int = 8, num_landmarks: int = 60, noise: float = 0.01,
                           rng: np.random.Generator | None = None) -> Problem:
    """Planar poses (angle, x, y) observe landmarks (x, y) in their own frame: r = R(φ)ᵀ(p − t) − z.

    Pose 0 is fixed (gauge). Landmarks declare `schur_block=2` (each observation touches one).
    Observations are exact measurements plus Gaussian `noise`, so the minimum has ‖h‖ > 0.
    Variables start from the truth perturbed by 0.1.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    poses = np.column_stack([rng.uniform(-0.5, 0.5, num_poses), rng.uniform(-2, 2, (num_poses, 2))])
    landmarks = rng.uniform(-5, 5, (num_landmarks, 2))
    obs_pose = np.repeat(np.arange(num_poses), num_landmarks)
    obs_landmark = np.tile(np.arange(num_landmarks), num_poses)
    m = obs_pose.size

    def predict(pose_vec, lm_vec):
        ps, ls = pose_vec.reshape(-1, 3)[obs_pose], lm_vec.reshape(-1, 2)[obs_landmark]
        c, s = np.cos(ps[:, 0]), np.sin(ps[:, 0])
        d = ls - ps[:, 1:]
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]]), c, s, d

    z = predict(poses.ravel(), landmarks.ravel())[0] + noise * rng.standard_normal((m, 2))
    rows = np.arange(2 * m).reshape(m, 2)

    def residual(pose_vec, lm_vec):
        return (predict(pose_vec, lm_vec)[0] - z).ravel()

    def fn(pose_vec, lm_vec):
        pred, c, s, d = predict(pose_vec, lm_vec)
        dphi = np.column_stack([-s * d[:, 0] + c * d[:, 1], -c * d[:, 0] - s * d[:, 1]])
        rot = np.stack([np.column_stack([c, s]), np.column_stack([-s, c])], axis=1)  # (m, 2, 2) = R(φ)ᵀ
        pose_vals = np.concatenate([dphi[:, :, None], -rot], axis=2)  # (m, 2, 3)
        pose_cols = 3 * obs_pose[:, None, None] + np.arange(3)[None, None, :]
        lm_cols = 2 * obs_landmark[:, None, None] + np.arange(2)[None, None, :]
        Jp = sp.csr_matrix((pose_vals.ravel(), (np.repeat(rows, 3), np.broadcast_to(pose_cols, (m, 2, 3)).ravel())),
                           shape=(2 * m, 3 * num_poses))
        Jl = sp.csr_matrix((rot.ravel(), (np.repeat(rows, 2), np.broadcast_to(lm_cols, (m, 2, 2)).ravel())),
                           shape=(2 * m, 2 * num_landmarks))
        return (pred - z).ravel(), [Jp, Jl]

    fixed = np.zeros(3 * num_poses, bool)
    fixed[:3] = True
    start_poses = poses.ravel() + 0.1 * rng.standard_normal(3 * num_poses) * ~fixed
    start_landmarks = landmarks.ravel() + 0.1 * rng.standard_normal(2 * num_landmarks)
    problem = Problem([VariableBlock("poses", start_poses, fixed=fixed),
                       VariableBlock("landmarks", start_landmarks, schur_block=2)])
    problem.add_residual(FunctionBlock(["poses", "landmarks"], 2 * m, fn, residual_fn=residual))
    return problem


class _SlackedMap(SampledCurveBlock):
    """r_i = f(q_i) − f(q*_i) − ξ_i with f(q) = sin(Aq): eq. (11a) with a synthetic "kinematics" f."""

    def __init__(self, basis, A, target):
        super().__init__(("P", "xi"), basis, A.shape[1], A.shape[0], slack_dim=A.shape[0])
        self.A, self.f_target = A, np.sin(target @ A.T)

    def sample(self, q, xi, jacobians, index):
        u = q @ self.A.T
        r = np.sin(u) - self.f_target[index] - xi
        if not jacobians:
            return r, None, None
        S = np.broadcast_to(-np.eye(self.rows), (q.shape[0], self.rows, self.rows))
        return r, np.cos(u)[:, :, None] * self.A, S


class _Clearance(SampledCurveBlock):
    """max(g, 0) for g_ij = sin(c_jᵀ(q_i − q*_i)) − ½ ≤ 0: synthetic "collision" rows of eq. (8)."""

    def __init__(self, basis, C, target):
        super().__init__(("P",), basis, C.shape[1], C.shape[0])
        self.C, self.target = C, target

    def sample(self, q, xi, jacobians, index):
        u = (q - self.target[index]) @ self.C.T
        r, slope = hinge(np.sin(u) - 0.5)
        return r, ((slope * np.cos(u))[:, :, None] * self.C if jacobians else None), None


def step_planner_like(num_samples: int = 100, degree: int = 10, dim: int = 24, slack_dim: int = 18,
                      num_clearance: int = 20, epsilon: float = 1e-3,
                      rng: np.random.Generator | None = None) -> Problem:
    """Synthetic problem shaped like eq. (12): a degree-`degree` Bézier curve in R^dim, end points fixed.

    Per sample: `slack_dim` equations f(q_i) − f(q*_i) − ξ_i = 0 (eq. (11a)), |ξ_i| ≤ ε as an
    interval penalty (eq. (11b)), and `num_clearance` hinge inequalities. The curve with control
    points P* and ξ = 0 is a root. Start: straight line between the end points (as Algorithm 1),
    ξ = 0. Columns: (degree − 1)·dim control-point entries plus num_samples·slack_dim slacks.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    t = np.linspace(0.0, 1.0, num_samples)
    k = np.arange(degree + 1)
    basis = comb(degree, k) * t[:, None] ** k * (1 - t[:, None]) ** (degree - k)
    q_start, q_end = rng.uniform(-1, 1, dim), rng.uniform(-1, 1, dim)
    line = q_start + (k / degree)[:, None] * (q_end - q_start)
    truth = line + 0.3 * rng.standard_normal(line.shape) * ((k > 0) & (k < degree))[:, None]
    target = basis @ truth
    A = rng.standard_normal((slack_dim, dim)) / np.sqrt(dim)
    C = rng.standard_normal((num_clearance, dim)) / np.sqrt(dim)
    fixed = np.zeros(line.shape, bool)
    fixed[[0, -1]] = True
    problem = Problem([VariableBlock("P", line.ravel(), fixed=fixed.ravel()),
                       VariableBlock("xi", np.zeros(num_samples * slack_dim), schur_block=slack_dim)])
    problem.add_residual(_SlackedMap(basis, A, target))
    n_xi = num_samples * slack_dim
    slack = FunctionBlock(["xi"], n_xi, lambda xi: (xi, [sp.identity(n_xi, format="csr")]), residual_fn=lambda xi: xi)
    problem.add_residual(IntervalPenalty(slack, -epsilon, epsilon))
    problem.add_residual(_Clearance(basis, C, target))
    return problem
