"""The stacked path constraint F̃_ε,N(P, ξ) of eq. (12) as one structured residual block.

Per sample t_k (eq. (10)) the configuration is x_k = Σ_i B_i^d(t_k) p_i (eq. (6)) with the end
points p_0 = x(q_start), p_d = x(q_end) fixed entries of variable "P" (row-major (d+1) × nx), so only
the d − 1 inner control points are unknown, together with the slacks ξ_k of the stance feet
(variable "xi", 3·(stance legs) per sample, eq. (11)).

`SampleConstraints` returns per-sample residuals r_k (m,) and Jacobians G_k = ∂r_k/∂x (m × nx),
S_k = ∂r_k/∂ξ_k (m × s). By the chain rule ∂r_k/∂p_i = B_i^d(t_k) G_k, so

    JᵀJ restricted to P = Σ_k kron(b_k b_kᵀ, G_kᵀ G_k)      (dense, every sample touches every p_i)
    P–ξ coupling           = [b_k ⊗ G_kᵀ S_k]_k
    ξ–ξ                    = blockdiag(S_kᵀ S_k)              (eliminated by the solver's Schur path)

which `legplan.solve.SampledCurveBlock.normal_terms` forms without a sparse JᵀJ product; the
solver's Schur path eliminates ξ and factorises only the (d−1)·nx control-point unknowns.
"""

from __future__ import annotations

import numpy as np

from legplan.contact.terms import ContactMode, nearest_end, sphere_margins, swing_foot_margin
from legplan.geometry.bezier import bernstein_matrix
from legplan.solve.curve import SampledCurveBlock
from legplan.stepplan.kinematics import planner_kinematics


class SampleConstraints:
    """Residual rows of one step at a batch of configurations X (n, nx) with slacks Xi (n, s).

    Rows per configuration, in order: stance-foot equality f − ξ (eq. (11a), 3 per stance leg);
    slack bound max(‖ξ_l‖ − ε, 0) per stance leg (eq. (11b)); CoM inside the support polygon, one
    hinge per edge; sphere clearance vs the terrain distance, one hinge per checked sphere; joint
    limits, two hinges per joint. The inequalities g ≤ 0 are those of `legplan.contact.terms`
    (`com_terms`, `collision_terms` with `sphere_margins`, `joint_limit_terms`), turned into rows
    max(g, 0) by eq. (8b); the collision rows of swing-foot spheres get a margin relaxed near the
    swing footholds, which ramps up to `mode.clearance` + `headroom`.

    The rows are formed here from the planner's batch kinematics (`legplan.stepplan.kinematics`:
    every sample at once, Jacobians in x directly): an inactive hinge row has a zero Jacobian, so
    sphere Jacobians are formed only for the (sample, sphere) pairs whose row is active.
    """

    def __init__(self, robot, sdf, mode: ContactMode, epsilon: float, *, swing_ends=None,
                 relax_radius: float = 0.05, headroom: float = 0.0):
        self.robot = robot
        self.kinematics = planner_kinematics(robot)
        self.headroom = float(headroom)
        self.sdf = sdf
        self.mode = mode
        self.epsilon = float(epsilon)
        self.legs = np.flatnonzero(mode.stance)
        self.slack_size = 3 * len(self.legs)
        self.nx = robot.nv
        self._footholds = np.asarray(mode.footholds, float)[self.legs]
        margins = sphere_margins(robot, mode)
        self.checked = np.flatnonzero(~np.isnan(margins))
        self._margins = margins[self.checked]
        self._radii = np.asarray(robot.spheres.radii, float)[self.checked]
        # a terrain distance at or above margin + radius leaves a collision row at 0; with 1 nm to spare, a
        # value known only to be above this bound gives the same 0 after rounding (`ColumnDistance.values`)
        self._threshold = self._margins + self._radii + 1e-9
        self._relaxation(swing_ends, relax_radius)
        self._relaxed_index = np.full(len(self.checked), -1, np.intp)  # position among the relaxed rows, or −1
        self._relaxed_index[self.relaxed_rows] = np.arange(len(self.relaxed_rows))
        self._sphere_points = len(robot.legs) + self.checked  # their points in `kinematics.jacobians`
        nj = robot.n_joints
        self._joint_rows = np.concatenate([np.arange(nj), np.arange(nj)])
        self._joint_sign = np.concatenate([np.ones(nj), -np.ones(nj)])
        self._limits = np.concatenate([-np.asarray(robot.upper, float), np.asarray(robot.lower, float)])
        self.size = 4 * len(self.legs) + len(mode.polygon.b) + len(self.checked) + 2 * nj

    def _relaxation(self, swing_ends, radius: float) -> None:
        """Collision rows of swing-foot spheres whose margin is relaxed near the swing footholds.

        `swing_ends` (2, n_spheres, 3): sphere centres at q_start and q_end. The required clearance
        of a swing-foot sphere follows `legplan.contact.terms.swing_foot_margin` with ε the sample
        slack bound: the tip may touch at either end, `mode.clearance` + `headroom` from
        `relax_radius` on.
        """
        spheres = self.robot.spheres
        legs = np.asarray(spheres.leg_index)
        swing_foot = np.asarray(spheres.is_foot, bool) & (legs >= 0)
        swing_foot &= ~np.where(legs >= 0, self.mode.stance[np.maximum(legs, 0)], False)
        self.relaxed_spheres = np.flatnonzero(swing_foot) if swing_ends is not None else np.zeros(0, int)
        self.relaxed_rows = np.searchsorted(self.checked, self.relaxed_spheres)
        self.relax_radius = float(radius)
        if self.relaxed_spheres.size:
            self.relax_ends = np.asarray(swing_ends, float)[:, self.relaxed_spheres]
            self.relax_radii = np.asarray(spheres.radii, float)[self.relaxed_spheres]

    def residuals(self, X: np.ndarray, Xi: np.ndarray, points=None) -> np.ndarray:
        """r (n, m) at configurations X (n, nx) with slacks Xi (n, s); `points`: the planner kinematics'
        points of X if already at hand (`kinematics.points(X)`)."""
        return self._rows(np.atleast_2d(np.asarray(X, float)), Xi, False, points)[0]

    def linearize(self, X: np.ndarray, Xi: np.ndarray, points=None, r=None):
        """r (n, m) and the rows with a nonzero Jacobian in compact form (r_c, G_c, S_c) (n, m_c, ·): the
        stance-foot and slack rows, the CoM rows, then per sample its active collision and joint-limit rows
        packed (zero-padded to the largest count). Every row left out has zero G and S, so the products
        GᵀG, Gᵀr, GᵀS, SᵀS and Sᵀr of the compact rows are those of all rows. `points` as in `residuals`;
        `r`: the rows at X, Xi if already at hand (`residuals`), then only the Jacobians are formed."""
        X = np.atleast_2d(np.asarray(X, float))
        r, parts = self._rows(X, Xi, True, points, r)
        jf, jcom, samples, rows, vectors, direction = parts
        n, nx, k = len(X), self.nx, len(self.legs)
        counts = np.bincount(samples, minlength=n)
        width = int(counts.max(initial=0))
        rank = np.arange(len(samples)) - np.repeat(np.cumsum(counts) - counts, counts)
        order = np.argsort(samples, kind="stable")
        live_g = np.zeros((n, width, nx))
        live_r = np.zeros((n, width))
        live_g[samples[order], rank] = vectors[order]
        live_r[samples[order], rank] = r[samples[order], rows[order]]
        head = 4 * k + jcom.shape[1]
        G = np.concatenate([jf, np.zeros((n, k, nx)), jcom, live_g], axis=1)
        S = np.zeros((n, head + width, self.slack_size))
        self._slack_jacobian(S, direction)
        return r, (np.concatenate([r[:, :head], live_r], axis=1), G, S)

    def evaluate(self, X: np.ndarray, Xi: np.ndarray, jacobians: bool):
        """r (n, m) and, with `jacobians`, G (n, m, nx) and S (n, m, s)."""
        X = np.atleast_2d(np.asarray(X, float))
        r, parts = self._rows(X, Xi, jacobians)
        if not jacobians:
            return r, None, None
        jf, jcom, samples, rows, vectors, direction = parts
        n, m = r.shape
        k = len(self.legs)
        G = np.zeros((n, m, self.nx))
        G[:, :3 * k] = jf
        G[:, 4 * k:4 * k + jcom.shape[1]] = jcom
        G[samples, rows] = vectors
        S = np.zeros((n, m, self.slack_size))
        self._slack_jacobian(S, direction)
        return r, G, S

    def _slack_jacobian(self, S: np.ndarray, direction: np.ndarray) -> None:
        """∂r/∂ξ into the first 4k rows of S: −I on the stance-foot rows, the unit ξ_l of an active slack row."""
        k = len(self.legs)
        S[:, np.arange(3 * k), np.arange(3 * k)] = -1.0
        for leg in range(k):
            S[:, 3 * k + leg, 3 * leg:3 * leg + 3] = direction[:, leg]

    def _rows(self, X: np.ndarray, Xi: np.ndarray, jacobians: bool, points=None, r=None):
        """r (n, m) and, with `jacobians`, its nonzero Jacobian parts: stance-foot rows (n, 3k, nx), CoM rows
        (n, h, nx), the active collision and joint-limit rows as (samples, rows, vectors (K, nx)), and the
        unit directions (n, k, 3) of the active slack rows. `r`: the rows at X, Xi if already at hand."""
        if points is None:
            points = self.kinematics.points(X)
        if r is None:
            r = self._values(X, Xi, points)
        return r, (self._jacobian_parts(X, Xi, points, r) if jacobians else None)

    def _values(self, X: np.ndarray, Xi: np.ndarray, points) -> np.ndarray:
        """The rows r (n, m) at X, Xi from the kinematics' `points` of X."""
        n, nx = X.shape
        k = len(self.legs)
        f = (points.feet[:, self.legs] - self._footholds).reshape(n, 3 * k) - Xi
        xi = Xi.reshape(n, k, 3)
        norms = np.sqrt(np.einsum("nki,nki->nk", xi, xi))
        slack = np.maximum(norms - self.epsilon, 0.0)
        polygon = self.mode.polygon
        com = self.mode.com_margin - polygon.margins(points.com[:, :2])
        centres = points.spheres[:, self.checked]
        threshold = self._threshold  # distance from which a collision row is inactive (+ a margin for rounding)
        if self.relaxed_spheres.size:
            d = nearest_end(centres[:, self.relaxed_rows], self.relax_ends)
            margin, _ = swing_foot_margin(d, self.relax_radii, self.mode.clearance + self.headroom, self.epsilon,
                                          self.relax_radius)
            relaxed = margin - self.mode.foot_clearance
            threshold = np.broadcast_to(threshold, (n, len(self.checked))).copy()
            threshold[:, self.relaxed_rows] += relaxed
        bound = np.broadcast_to(threshold, (n, len(self.checked))).reshape(-1)
        dist = self.sdf.values(centres.reshape(-1, 3), bound=bound)
        collision = self._margins - (dist.reshape(n, -1) - self._radii)
        if self.relaxed_spheres.size:
            collision[:, self.relaxed_rows] += relaxed
        joints = X[:, nx - self.robot.n_joints:]
        limits = np.concatenate([joints, -joints], axis=1) + self._limits
        return np.concatenate([f, slack, np.maximum(com, 0.0), np.maximum(collision, 0.0), np.maximum(limits, 0.0)],
                              axis=1)

    def _jacobian_parts(self, X: np.ndarray, Xi: np.ndarray, points, r: np.ndarray):
        """The nonzero Jacobian parts of `_rows` at X, Xi given its rows r there: a hinge row max(g, 0) has a
        derivative where r > 0 (g > 0), so the terrain gradient and the swing-foot ramp are formed only for the
        active collision rows, which are few (the terrain distance of an active row is exact whatever the bound
        its value was found with, so its gradient is that of the full evaluation)."""
        n, nx = X.shape
        k = len(self.legs)
        kin = self.kinematics
        polygon = self.mode.polygon
        h, c = len(polygon.b), len(self.checked)
        row = 4 * k + h
        jf = kin.jacobians(points, np.repeat(np.arange(n), k), np.tile(self.legs, n)).reshape(n, 3 * k, nx)
        # g = margin − (b − A·com): rows A·J_com where active
        jcom = np.einsum("hk,nkx->nhx", polygon.A, kin.com_jacobian(points)[:, :2]) * (r[:, 4 * k:row] > 0)[..., None]
        active, sphere = np.nonzero(r[:, row:row + c] > 0)
        if active.size:  # most linearisation points have no active collision row
            centres = points.spheres[active, self.checked[sphere]]
            # d g / d centre = −∇dist, plus the ramp's slope along the unit vector from the nearer end (relaxed rows)
            direction = -self.sdf.value_and_gradient(centres)[1]
            which = self._relaxed_index[sphere] if self.relaxed_spheres.size else np.zeros(0, np.intp)
            on = np.flatnonzero(which >= 0)
            if on.size:
                w = which[on]
                d, unit = nearest_end(centres[on][None], self.relax_ends[:, w], True)
                _, ramp = swing_foot_margin(d[0], self.relax_radii[w], self.mode.clearance + self.headroom,
                                            self.epsilon, self.relax_radius)
                direction[on] += ramp[:, None] * unit[0]
            vectors = np.einsum("ka,kax->kx", direction, kin.jacobians(points, active, self._sphere_points[sphere]))
        else:
            vectors = np.zeros((0, nx))
        on_limit, limit = np.nonzero(r[:, row + c:] > 0)
        unit_rows = np.zeros((len(on_limit), nx))
        unit_rows[np.arange(len(on_limit)), nx - self.robot.n_joints + self._joint_rows[limit]] = self._joint_sign[limit]
        xi = Xi.reshape(n, k, 3)
        norms = np.sqrt(np.einsum("nki,nki->nk", xi, xi))
        slack_direction = np.where(norms[..., None] > 0, xi / np.maximum(norms, 1e-300)[..., None], 0.0)
        slack_direction *= (r[:, 3 * k:4 * k] > 0)[..., None]
        return (jf, jcom, np.concatenate([active, on_limit]), np.concatenate([row + sphere, row + c + limit]),
                np.concatenate([vectors, unit_rows]), slack_direction)


class BezierConstraintBlock(SampledCurveBlock):
    """F̃_ε,N of eq. (12) for a Bézier curve of `degree` sampled at `t`.

    Variables: "P", all d + 1 control points (row-major (d+1) × nx; give p_0 and p_d as fixed
    entries of the `VariableBlock`), and "xi", the per-sample slacks. The structured normal terms
    (Σ_k kron(b_k b_kᵀ, G_kᵀG_k), …) come from `legplan.solve.SampledCurveBlock`.

    A trial point of LM is evaluated at every sample in one call of the rows (`residual_chunks`) and
    its kinematics and rows kept: an accepted trial is the next linearisation point (`normal_terms`),
    which then forms only the Jacobians and the terrain gradients of the active rows.
    """

    def __init__(self, constraints: SampleConstraints, degree: int, t):
        self.constraints = constraints
        self.degree = int(degree)
        self.t = np.asarray(t, float)
        self.samples = len(self.t)
        super().__init__(("P", "xi"), bernstein_matrix(self.degree, self.t), constraints.nx,
                         constraints.size, constraints.slack_size)
        self._trial: tuple | None = None  # control points and slacks of the last trial, their points and rows

    def residual_chunks(self, values):
        """The residuals of `sample_groups`, in their order, from one evaluation of every sample.

        The rows cost a fixed number of array operations per call whatever the number of samples, so one
        call over all samples costs less than the groups' calls even when a rejected trial would stop
        after the first group; the groups' partial sums, and so LM's accept/reject decision and ‖h‖, are
        those of `SampledCurveBlock.residual_chunks` (the rows of a sample do not depend on the others)."""
        q = self.basis @ values[0].reshape(-1, self.dim)
        points = self.constraints.kinematics.points(q)
        r = self.constraints.residuals(q, values[1].reshape(self.samples, self.slack_dim), points)
        self._trial = (np.array(values[0], float), np.array(values[1], float), points, r)
        for idx in self.sample_groups():
            yield r[idx].reshape(-1)

    def _kept(self, P: np.ndarray, xi: np.ndarray):
        """The kinematics and the rows of the last trial (then forgotten): (points, r) if it was at control
        points `P`, (points, None) if at `P` with other slacks, (None, None) otherwise."""
        trial, self._trial = self._trial, None
        if trial is None or not np.array_equal(trial[0], P):
            return None, None
        return trial[2], (trial[3] if np.array_equal(trial[1], xi) else None)

    def sample(self, q, xi, jacobians, index):
        if not jacobians:
            return self.constraints.residuals(q, xi), None, None
        return self.constraints.evaluate(q, xi, jacobians)  # no per-sample data: rows depend on q_k, ξ_k only

    def normal_terms(self, values):
        """The structured normal terms of `SampledCurveBlock` from the rows with a nonzero Jacobian only
        (`SampleConstraints.linearize`)."""
        q = self.basis @ values[0].reshape(-1, self.dim)
        r, compact = self.constraints.linearize(q, values[1].reshape(self.samples, self.slack_dim),
                                                *self._kept(values[0], values[1]))
        terms = self.curve_terms(*compact)
        terms.residual = r.reshape(-1)
        return terms
