"""Constraint blocks of the centroidal problem (Winkler et al. 2018; TOWR-costs paper Sec. III-A).

Each block samples the splines of a `Formulation` at fixed times (sparse sampling matrices built
once) and returns its values and one sparse Jacobian per variable it reads; bounds are attached by
`legplan.solve.Constraint`. The rotation of a vector, R(e)ᵀd and R(e)v, is differentiated by the
closed-form ∂R/∂e (`euler.rotation_derivatives`), the inertial torque through the body rates'
closed-form Jacobians (`euler.body_rate_derivatives`), the terrain heights and slopes by their
bilinear gradients; the terrain normals (friction) by complex step (`euler.complex_step`, exact to
round-off); the rest analytically.

* `DynamicsBlock` — single-rigid-body Newton-Euler at every dynamics time (6 rows, N and N·m):
  m·p̈ + m·g·e_z − Σ f_i = 0 and I_W ω̇ + ω × I_W ω − Σ (p_i − p) × f_i = 0, I_W = R I_B Rᵀ.
* `RangeOfMotionBlock` — Rᵀ(p_i − p) − p̄_i, bounded by the range-of-motion box.
* `LegClearanceBlock` — the height of the legs' collision spheres above the terrain's envelope.
* `JointTorqueBlock` — a leg's joint torques Jᵀ(q) Rᵀ f for its foot's force, q by the leg's IK,
  bounded by the robot's torque limits: the force polytope the joints allow.
* `TerrainHeightBlock` — z − h(x, y) of foot samples: = 0 for stance nodes, ≥ 0 along swings against
  the terrain's column envelope (ours, between nodes too: TOWR constrains the swing apex only).
* `ForceBlock` — f·n ∈ [0, f_max] and a friction pyramid inscribed in the Coulomb cone in stance, on
  the Bézier control points of the force polynomials (so along the whole of them).
* linear rows (`LinearBlock`): base acceleration continuity at the spline junctions, TOWR's swing
  constraint (apex x, y halfway, apex velocity = step / swing time), the paper's swing-height rows;
  `BaseAboveFeetBlock`, the paper's base-above-feet rows.
* With a `PhaseTiming` (`legplan.dyn.timing`) the blocks that sample feet or forces in time also
  read the ``phases`` variable: their samples move with the phase durations.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import scipy.sparse as sp

from legplan.dyn.euler import body_rate_derivatives, body_rates, complex_step, cross, rotation, rotation_derivatives
from legplan.dyn.formulation import Formulation
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import (PHASES, PhaseTiming, TimedControlPoints, TimedSamples, invalid_timing, phase_jacobian,
                                refresh)
from legplan.geometry.hermite import SampledJacobian, hermite_weights, kron_axis, kron_dim
from legplan.geometry.sparse import times, wrapped
from legplan.robots.so3 import skew
from legplan.solve import ResidualBlock
from legplan.solve.blocks import LinearBlock

GRAVITY = 9.81
COLUMN_REACH = 0.1  # m beyond a leg sphere's radius up to which its distance to the terrain is resolved


def _nodes(v: np.ndarray) -> np.ndarray:
    return np.asarray(v).reshape(-1, 3)


def _in_base_jacobian(turns: np.ndarray, d: np.ndarray) -> np.ndarray:
    """∂(R(e)ᵀ d)/∂e (n, 3, 3), [:, i, k] the derivative of entry i w.r.t. e_k, for the rotation's
    derivatives `turns` = `euler.rotation_derivatives(e)` and vectors d (n, 3)."""
    return np.einsum("nkji,nj->nik", turns, d)


class DynamicsBlock(ResidualBlock):
    """Newton-Euler residual of the single rigid body at `times` (see module docstring)."""

    variables = ("base_lin", "base_ang", "feet", "forces")

    def __init__(self, form: Formulation, mass: float, inertia: np.ndarray, times: np.ndarray,
                 timing: PhaseTiming | None = None):
        self.mass, self.inertia = float(mass), np.asarray(inertia, float)
        self.times = np.asarray(times, float)
        self.n = self.times.size
        self.size = 6 * self.n
        self.base = [form.base_matrix(self.times, d) for d in range(3)]
        self.timing = timing
        if timing is None:
            self.feet = [form.foot_matrix(leg, self.times) for leg in range(form.legs)]
            self.forces = [form.force_matrix(leg, self.times) for leg in range(form.legs)]
        else:  # feet and forces move with the phase durations (`legplan.dyn.timing`)
            self.variables = DynamicsBlock.variables + (PHASES,)
            self.samples = [TimedSamples(timing, kind, leg, self.times) for kind in ("motion", "force")
                            for leg in range(form.legs)]
            self.feet = [s.matrix for s in self.samples[:form.legs]]
            self.forces = [s.matrix for s in self.samples[form.legs:]]
        self.columns = [3 * m.shape[1] for m in (self.base[0], self.base[0], self.feet[0], self.forces[0])]
        n, c = self.n, self.columns
        self.jacobians = [SampledJacobian([self.base[2], self.base[0]], 6, n, c[0]),
                          SampledJacobian(self.base, 3, n, c[1]),  # the angular rows only (`_angular_rows`)
                          SampledJacobian(self.feet, 3, n, c[2]),  # the angular rows only
                          SampledJacobian(self.forces, 6, n, c[3])]
        self._lifted: dict[int, tuple] = {}  # `_angular_rows`' row pointers by the pattern's

    def _retime(self, d: np.ndarray) -> bool:
        """Move the feet and force samples to the durations d; False if d is no valid timing."""
        changed, valid = refresh(self.samples, d)
        if changed and valid:
            legs = len(self.feet)
            self.feet = [s.matrix for s in self.samples[:legs]]
            self.forces = [s.matrix for s in self.samples[legs:]]
            self.jacobians[2] = self.jacobians[2].with_matrices(self.feet)
            self.jacobians[3] = self.jacobians[3].with_matrices(self.forces)
        return valid

    def _angular_rows(self, jac: sp.csr_matrix) -> sp.csr_matrix:
        """The Jacobian of the angular rows (3 per time) as that of all 6 rows of each time: the
        orientation and the feet enter the torque rows alone, so their linear rows hold no entry
        (none is computed). Same data and indices; the row pointers of the interleaved rows are
        derived once per pattern (kept while `jac.indptr` is the same read-only array)."""
        ptr = jac.indptr
        lifted = self._lifted.get(id(ptr))
        if lifted is None or lifted[0] is not ptr or ptr.flags.writeable:
            starts = ptr[:-1].reshape(self.n, 3)
            rows = np.empty((self.n, 6), ptr.dtype)
            rows[:, :3], rows[:, 3:] = starts[:, :1], starts  # the linear rows: empty, where the angular start
            indptr = np.append(rows.reshape(-1), ptr[-1])
            indptr.flags.writeable = False
            self._lifted[id(ptr)] = lifted = (ptr, indptr)
        return wrapped(sp.csr_matrix, jac.data, jac.indices, lifted[1], (self.size, jac.shape[1]))

    def inertial_torque(self, e, ed, edd):
        """I_W ω̇ + ω × I_W ω = R (I_B ω̇_B + ω_B × I_B ω_B), rows (n, 3)."""
        wb, wdb = body_rates(e, ed, edd)
        iw = wb @ self.inertia.T
        u = wdb @ self.inertia.T + cross(wb, iw)
        return np.einsum("nij,nj->ni", rotation(e), u)

    def inertial_torque_jacobians(self, e, ed, edd):
        """`inertial_torque` τ = R u, u = I ω̇_B + ω_B × I ω_B, with ∂τ/∂e, ∂τ/∂ė, ∂τ/∂ë (n, 3, 3):
        ∂u/∂x = I ∂ω̇_B/∂x + ([ω_B]× I − [I ω_B]×) ∂ω_B/∂x by the chain rule through the body rates'
        Jacobians (`euler.body_rate_derivatives`), and ∂τ/∂e_k = R ∂u/∂e_k + ∂R/∂e_k u."""
        wb, wdb, dw_de, dw_ded, dwd_de, dwd_ded, dwd_dedd = body_rate_derivatives(e, ed, edd)
        inertia = self.inertia
        iw = wb @ inertia.T
        u = wdb @ inertia.T + cross(wb, iw)
        gyro = skew(wb) @ inertia - skew(iw)  # ∂(ω × I ω)/∂ω
        rot = rotation(e)
        torque = np.einsum("nij,nj->ni", rot, u)
        d_e = rot @ (inertia @ dwd_de + gyro @ dw_de) + np.einsum("nkij,nj->nik", rotation_derivatives(e), u)
        d_ed = rot @ (inertia @ dwd_ded + gyro @ dw_ded)
        d_edd = rot @ (inertia @ dwd_dedd)
        return torque, (d_e, d_ed, d_edd)

    def evaluate(self, values, jacobians):
        if self.timing is not None and not self._retime(values[4]):
            return invalid_timing(self, jacobians)
        lin, ang, feet, forces = (_nodes(v) for v in values[:4])
        p0, p1, p2 = (times(m, lin) for m in self.base)
        e, ed, edd = (times(m, ang) for m in self.base)
        pf = [times(m, feet) for m in self.feet]
        f = [times(m, forces) for m in self.forces]
        linear = self.mass * p2 - sum(f)
        linear[:, 2] += self.mass * GRAVITY
        if jacobians:
            torque, (j_e, j_ed, j_edd) = self.inertial_torque_jacobians(e, ed, edd)
        else:
            torque = self.inertial_torque(e, ed, edd)
        angular = torque - sum(cross(q - p0, fi) for q, fi in zip(pf, f))
        r = np.hstack([linear, angular]).reshape(-1)
        if not jacobians:
            return r, None
        zero, eye = np.zeros((self.n, 3, 3)), np.broadcast_to(np.eye(3), (self.n, 3, 3))
        stack = lambda top, bottom: np.concatenate([top, bottom], axis=1)  # (n, 6, 3)
        f_skew = [skew(fi) for fi in f]
        lin_j, ang_j, feet_j, forces_j = self.jacobians
        g_forces = [stack(-eye, -skew(q - p0)) for q in pf]
        out = [lin_j([stack(self.mass * eye, zero), stack(zero, -sum(f_skew))]),
               self._angular_rows(ang_j([j_e, j_ed, j_edd])), self._angular_rows(feet_j(f_skew)), forces_j(g_forces)]
        if self.timing is not None:
            g_feet = [stack(zero, fs) for fs in f_skew]
            legs = len(self.feet)
            terms = [(g, s, values[2]) for g, s in zip(g_feet, self.samples[:legs])]
            terms += [(g, s, values[3]) for g, s in zip(g_forces, self.samples[legs:])]
            out.append(phase_jacobian(terms, self.size, self.timing.size))
        return r, out


class RangeOfMotionBlock(ResidualBlock):
    """Foot `leg` in the base frame minus its nominal position, Rᵀ(p_i − p) − p̄_i, at `times`."""

    variables = ("base_lin", "base_ang", "feet")

    def __init__(self, form: Formulation, leg: int, nominal: np.ndarray, times: np.ndarray,
                 timing: PhaseTiming | None = None):
        self.times = np.asarray(times, float)
        self.n = self.times.size
        self.size = 3 * self.n
        self.nominal = np.asarray(nominal, float)
        self.base = form.base_matrix(self.times)
        self.timing = timing
        if timing is None:
            self.foot = form.foot_matrix(leg, self.times)
        else:
            self.variables = RangeOfMotionBlock.variables + (PHASES,)
            self.samples = TimedSamples(timing, "motion", leg, self.times)
            self.foot = self.samples.matrix
        self.columns = (3 * self.base.shape[1], 3 * self.base.shape[1], 3 * self.foot.shape[1])
        self.base_jacobian = SampledJacobian([self.base], 3, self.n, self.columns[0])  # base_lin and base_ang
        self.foot_jacobian = SampledJacobian([self.foot], 3, self.n, self.columns[2])

    def _retime(self, d: np.ndarray) -> bool:
        changed, valid = refresh([self.samples], d)
        if changed and valid:
            self.foot = self.samples.matrix
            self.foot_jacobian = self.foot_jacobian.with_matrices([self.foot])
        return valid

    @staticmethod
    def _in_base(e, d, rot=None):
        """Rᵀd per sample for Euler angles e (or their rotations `rot`, computed once by the caller)."""
        return np.einsum("nji,nj->ni", rotation(e) if rot is None else rot, d)

    def _sampled(self, values):
        """Base position p, Euler angles e and foot q at the samples (n, 3) each; None for an
        invalid timing."""
        if self.timing is not None and not self._retime(values[3]):
            return None
        lin, ang, feet = (_nodes(v) for v in values[:3])
        return times(self.base, lin), times(self.base, ang), times(self.foot, feet)

    def _jacobians(self, j_p, j_e, j_q, values) -> list:
        """The block's Jacobians from the per-sample ones (n, rows, 3) w.r.t. p, e and q."""
        out = [self.base_jacobian([j_p]), self.base_jacobian([j_e]), self.foot_jacobian([j_q])]
        if self.timing is not None:
            out.append(phase_jacobian([(j_q, self.samples, values[2])], self.size, self.timing.size))
        return out

    def evaluate(self, values, jacobians):
        sampled = self._sampled(values)
        if sampled is None:
            return invalid_timing(self, jacobians)
        p, e, q = sampled
        if not jacobians:
            return (self._in_base(e, q - p) - self.nominal).reshape(-1), None
        rot = rotation(e)
        x = np.einsum("nji,nj->ni", rot, q - p)  # `_in_base`
        j_e = _in_base_jacobian(rotation_derivatives(e), q - p)
        rt = np.transpose(rot, (0, 2, 1))
        return (x - self.nominal).reshape(-1), self._jacobians(-rt, j_e, rt, values)

    def residual_rows(self, values, rows):
        """The rows `rows` from the samples that hold them alone (each computed as in `evaluate`): the
        hinged LM's curvature probe reads the active rows of the box; with phases as variables, the
        whole evaluation."""
        if self.timing is not None:
            return ResidualBlock.residual_rows(self, values, rows)
        samples, at = np.unique(rows // 3, return_inverse=True)
        lin, ang, feet = (_nodes(v) for v in values[:3])
        base = self.base[samples]
        p, e, q = times(base, lin), times(base, ang), times(self.foot[samples], feet)
        return (self._in_base(e, q - p) - self.nominal)[at, rows % 3]


class LegClearanceBlock(RangeOfMotionBlock):
    """Per sample time, per collision sphere of leg `leg` (all but its foot): the distance of its
    surface from the terrain, d(c) − r with d the exact distance to the heightmap's column solid
    (`legplan.terrain.columns.ColumnDistance`, the true edges, as the independent check measures
    it; exact up to the sphere's radius plus `COLUMN_REACH`, beyond which the row is satisfied and
    flat), with the centre
    c = p + R (s(b) − o), b = Rᵀ(p_i − p) + o the foot in the base frame (p the CoM, o its offset
    in the base frame, `Centroidal.com_offset`), s the sphere's centre in the base frame given the
    foot — by the robot's own kinematics (`legplan.dyn.legs.ChainLegs`: forward kinematics and leg
    IK from the chain's joints) or by the closed form of planar legs
    (`legplan.robots.planar_legs.PlanarLegs`). Bounded below by the clearance, it keeps the legs,
    not only the feet, off the terrain, the sides of steps included (ours: the paper keeps the legs
    clear through the swing height only, Sec. III-A2). The exact distance, rather than a bound of
    the columns near the sphere, lets a shank pass beside an edge it clears. The Jacobian is the
    chain rule through ∂s/∂b (the legs' own), the rotation's derivative ∂R/∂e and the
    distance's gradient (the unit vector from the nearest terrain point)."""

    def __init__(self, form: Formulation, leg: int, legs, terrain: TerrainModel, times: np.ndarray,
                 timing: PhaseTiming | None = None, com_offset=(0.0, 0.0, 0.0), batch: LegClearanceBatch | None = None):
        super().__init__(form, leg, np.zeros(3), times, timing)
        self.leg, self.legs = leg, legs
        self.offset = np.asarray(com_offset, float)
        self.radius = legs.sphere_radius[legs.spheres_of(leg)]
        self.distance = terrain.column_distance(float(self.radius.max(initial=0.0)) + COLUMN_REACH)
        self.rows = self.radius.size
        self.size = self.rows * self.n
        self.joints = legs.workspace(leg, self.n) if hasattr(legs, "workspace") else None  # IK warm start
        self.base_jacobian = SampledJacobian([self.base], self.rows, self.n, self.columns[0])
        self.foot_jacobian = SampledJacobian([self.foot], self.rows, self.n, self.columns[2])
        self.batch = batch if batch is not None and batch.join(self) else None

    def _spheres(self, legs, b, derivatives: bool = True):
        """Sphere centres s (n, k, 3) and ∂s/∂b (n, k, 3, 3) in the base frame for feet b (n, 3) of the
        leg(s) `legs` (this block's, or one per row) (None without `derivatives`); planar legs give
        both in closed form (`PlanarLegs.sphere_centres_and_jacobian`)."""
        if self.joints is not None:
            centres, jac, _ = self.legs.sphere_centres(self.leg, b, self.joints)
            return centres, jac
        if not derivatives:
            return self.legs.sphere_centres(legs, b), None
        return self.legs.sphere_centres_and_jacobian(legs, b)

    def _clearance(self, c, radius, gradient: bool = True):
        """d(c) − r for centres c (n, k, 3) and its gradient (n, k, 3; None without `gradient`): the
        exact distance to the terrain's columns (`TerrainModel.column_distance`) less the radius. The
        distance saturates at its reach (value the reach, gradient 0), so the search among
        neighbouring columns is skipped wherever a lower bound of their distance already reaches it
        (`bound`): the same values and gradients."""
        points = c.reshape(-1, 3)
        bound = np.full(len(points), self.distance.reach)
        if not gradient:
            return self.distance.values(points, bound).reshape(c.shape[:2]) - radius, None
        d, grad = self.distance.value_and_gradient(points, bound)
        return (d.reshape(c.shape[:2]) - radius), grad.reshape(c.shape)

    def rows_at(self, legs, p, e, q, radius, jacobians):
        """The rows (n, k) at samples (p, e, q) (n, 3) each, of the leg(s) `legs` with sphere radii
        `radius`, and with `jacobians` the per-sample gradients (n, k, 3) w.r.t. p, e and q."""
        rot = rotation(e)
        b = self._in_base(e, q - p, rot) + self.offset
        s, ds = self._spheres(legs, b, jacobians)
        lever = s - self.offset
        c = p[:, None] + np.einsum("nij,nkj->nki", rot, lever)
        value, dh = self._clearance(c, radius, jacobians)  # and ∂row/∂c
        if not jacobians:
            return value, None
        turns = rotation_derivatives(e)
        db_de = _in_base_jacobian(turns, q - p)  # (n, 3, 3)
        # the chain rule vector first (no (n, k, 3, 3) matrix products): g = dh·R·∂s/∂b per sphere, then
        # ∂row/∂p_i = g Rᵀ, ∂row/∂p = dh − g Rᵀ, ∂row/∂e = dh·(∂R/∂e) v + g ∂b/∂e
        g_b = (dh @ rot)[:, :, None] @ ds  # (n, k, 1, 3)
        d_q = (g_b @ np.transpose(rot, (0, 2, 1))[:, None])[:, :, 0]
        d_e = np.einsum("nki,nlij,nkj->nkl", dh, turns, lever) + (g_b @ db_de[:, None])[:, :, 0]  # v = s − o
        return value, (dh - d_q, d_e, d_q)

    def evaluate(self, values, jacobians):
        if self.batch is not None:
            return self.batch.part(self, values, jacobians)
        sampled = self._sampled(values)
        if sampled is None:
            return invalid_timing(self, jacobians)
        value, gradients = self.rows_at(self.leg, *sampled, self.radius, jacobians)
        if not jacobians:
            return value.reshape(-1), None
        return value.reshape(-1), self._jacobians(*gradients, values)

    def residual_rows(self, values, rows):
        """The rows `rows` from the samples that hold them alone (`rows_at` of those samples, each
        row computed as in `evaluate`): the hinged LM's curvature probe reads the active rows of a
        bound, a few samples of the leg's; with phases as variables or chain legs (an IK warm-started
        from the last evaluation), the whole evaluation."""
        if self.timing is not None or self.joints is not None:
            return ResidualBlock.residual_rows(self, values, rows)
        samples, at = np.unique(rows // self.rows, return_inverse=True)
        lin, ang, feet = (_nodes(v) for v in values[:3])
        base, foot = self.base[samples], self.foot[samples]
        value, _ = self.rows_at(self.leg, times(base, lin), times(base, ang), times(foot, feet), self.radius, False)
        return value[at, rows % self.rows]


class _LegBatch(ABC):
    """What the per-leg batches share: members evaluated together at the same variable values. The
    first member evaluated at some values computes every member's part (`_evaluate`) and keeps it;
    the other members take their part while the values are the same, compared entry by entry (a
    caller may change its arrays in place)."""

    def __init__(self):
        self.members: list = []
        self._kept: dict[bool, tuple] = {}

    @abstractmethod
    def _admits(self, block) -> bool:
        """Whether `block` can be evaluated in one pass with the members (fixed phases, and the same
        models and settings as theirs)."""

    def join(self, block) -> bool:
        """Take `block` as a member if it can be evaluated with the others (else False)."""
        if not self._admits(block):
            return False
        block.batch_index = len(self.members)
        self.members.append(block)
        self._kept.clear()
        return True

    def part(self, block, values, jacobians: bool):
        """`block.evaluate(values, jacobians)`, from the members' evaluation at these values."""
        jacobians = bool(jacobians)
        kept = self._kept.get(jacobians)
        if kept is None or len(kept[0]) != len(values) or not all(
                np.array_equal(a, b) for a, b in zip(kept[0], values)):
            kept = self._kept[jacobians] = ([np.array(v, float) for v in values], self._evaluate(values, jacobians))
        return kept[1][block.batch_index]

    @abstractmethod
    def _evaluate(self, values, jacobians: bool) -> list:
        """Every member's `evaluate` result at these values, in member order."""


class LegClearanceBatch(_LegBatch):
    """The leg-clearance rows of every leg in one pass: the per-leg `LegClearanceBlock`s of one
    problem share it (closed-form legs with as many spheres each, fixed phases, one column
    distance). The first member evaluated at some variable values computes the rows, and with
    Jacobians their per-sample gradients, of every member at once on the members' samples stacked
    (each numpy call over the four legs instead of one call per leg; the same operations row by
    row), and keeps them; the other members take their part while the values are the same, compared
    entry by entry (a caller may change its arrays in place). The blocks, their rows and their
    Jacobians' patterns stay those of the legs alone."""

    def _admits(self, block: LegClearanceBlock) -> bool:
        if block.timing is not None or block.joints is not None or getattr(block.legs, "sphere_slots", None) is None \
                or block.legs.sphere_slots() is None:
            return False
        if self.members:
            first = self.members[0]
            if not (block.legs is first.legs and block.distance is first.distance
                    and np.array_equal(block.offset, first.offset) and block.rows == first.rows):
                return False
        return True

    def _evaluate(self, values, jacobians: bool) -> list:
        members = self.members
        sampled = [m._sampled(values) for m in members]
        count = [m.n for m in members]
        legs = np.repeat([m.leg for m in members], count)
        radius = np.concatenate([np.broadcast_to(m.radius, (m.n, m.rows)) for m in members])
        p, e, q = (np.concatenate([x[k] for x in sampled]) for k in range(3))
        value, gradients = members[0].rows_at(legs, p, e, q, radius, jacobians)
        bounds = np.concatenate([[0], np.cumsum(count)])
        out = []
        for m, lo, hi in zip(members, bounds[:-1], bounds[1:]):
            r = value[lo:hi].reshape(-1)
            out.append((r, m._jacobians(*(g[lo:hi] for g in gradients), values)) if jacobians else (r, None))
        return out


class JointTorqueBlock(RangeOfMotionBlock):
    """Per sample time, the torques of leg `leg`'s joints that hold its foot's force:
    τ = J_f(q)ᵀ Rᵀ f, with q the joints that put the foot at b = Rᵀ(p_i − p) + o in the base frame (p
    the CoM, o its offset in the base frame) by the leg's own kinematics (`legplan.dyn.legs.ChainLegs`:
    IK started from the planar closed form `PlanarLegs.joints` on HAA/HFE/KFE legs, else warm-started
    from the last evaluation) and J_f the foot's point Jacobian there (statics of
    massless legs, the torques the joints give for the contact force). Bounded by the joints' torque
    limits (`Centroidal.torque_limits`) it keeps every force inside the polytope |J_fᵀ g| ≤ τ_max of
    the leg's configuration at that time, not one bound on the normal force for every stance and
    direction (ours: TOWR bounds f·n alone). The Jacobian: ∂τ/∂b (`ChainLegs.foot_torques`, through
    the IK) by the chain rule with ∂b/∂(p, e, p_i), ∂τ/∂g = J_fᵀ with g = Rᵀ f, the rotation's
    derivative ∂R/∂e."""

    variables = ("base_lin", "base_ang", "feet", "forces")

    def __init__(self, form: Formulation, leg: int, legs, times: np.ndarray, timing: PhaseTiming | None = None,
                 com_offset=(0.0, 0.0, 0.0)):
        super().__init__(form, leg, np.zeros(3), times, timing)
        self.leg, self.legs = leg, legs
        self.offset = np.asarray(com_offset, float)
        self.joints = legs.workspace(leg, self.n)  # the IK's warm start
        self.rows = self.joints.q.shape[1]
        self.size = self.rows * self.n
        if timing is None:
            self.variables = JointTorqueBlock.variables
            self.force = form.force_matrix(leg, self.times)
        else:
            self.variables = JointTorqueBlock.variables + (PHASES,)
            self.force_samples = TimedSamples(timing, "force", leg, self.times)
            self.force = self.force_samples.matrix
        self.base_jacobian = SampledJacobian([self.base], self.rows, self.n, self.columns[0])
        self.foot_jacobian = SampledJacobian([self.foot], self.rows, self.n, self.columns[2])
        self.force_jacobian = SampledJacobian([self.force], self.rows, self.n, 3 * self.force.shape[1])

    def _retime(self, d: np.ndarray) -> bool:
        if not super()._retime(d):
            return False
        changed, valid = refresh([self.force_samples], d)
        if changed and valid:
            self.force = self.force_samples.matrix
            self.force_jacobian = self.force_jacobian.with_matrices([self.force])
        return valid

    def evaluate(self, values, jacobians):
        if self.timing is not None and not self._retime(values[4]):
            return invalid_timing(self, jacobians)
        lin, ang, feet, forces = (_nodes(v) for v in values[:4])
        p, e, q = times(self.base, lin), times(self.base, ang), times(self.foot, feet)
        f = times(self.force, forces)
        rot = rotation(e)
        b = self._in_base(e, q - p, rot) + self.offset
        g = self._in_base(e, f, rot)
        tau, d_b, d_g, _ = self.legs.foot_torques(self.leg, b, g, self.joints, derivatives=jacobians)
        if not jacobians:
            return tau.reshape(-1), None
        turns = rotation_derivatives(e)
        db_de, dg_de = _in_base_jacobian(turns, q - p), _in_base_jacobian(turns, f)
        rt = np.transpose(rot, (0, 2, 1))
        d_q = d_b @ rt
        d_f = d_g @ rt
        out = [self.base_jacobian([-d_q]), self.base_jacobian([d_b @ db_de + d_g @ dg_de]), self.foot_jacobian([d_q]),
               self.force_jacobian([d_f])]
        if self.timing is not None:
            out.append(phase_jacobian([(d_q, self.samples, values[2]), (d_f, self.force_samples, values[3])],
                                      self.size, self.timing.size))
        return tau.reshape(-1), out

    def residual_rows(self, values, rows):
        """The torques of the samples that hold `rows` alone, by an IK of those samples from the
        workspace's joints (the workspace itself left as it is: the next whole evaluation starts
        where the last one ended)."""
        if self.timing is not None:
            return super().residual_rows(values, rows)
        samples, at = np.unique(rows // self.rows, return_inverse=True)
        lin, ang, feet, forces = (_nodes(v) for v in values[:4])
        base, foot = self.base[samples], self.foot[samples]
        p, e, q, f = base @ lin, base @ ang, foot @ feet, self.force[samples] @ forces
        rot = rotation(e)
        b = self._in_base(e, q - p, rot) + self.offset
        g = self._in_base(e, f, rot)
        tau = self.legs.foot_torques(self.leg, b, g, self.joints.q[samples], derivatives=False)[0]
        return tau[at, rows % self.rows]


class FootTerrainBlock(ResidualBlock):
    """One row per foot position sampled by `matrix` (rows of the ``feet`` node array): a terrain
    function of the position, `_row(q)` for q (n, 3), differentiated by `_row_jacobian` (complex
    step unless a block gives its gradient)."""

    variables = ("feet",)
    batch = None  # a `FootTerrainBatch` the block joined (`join`)

    def __init__(self, terrain: TerrainModel, matrix: sp.csr_matrix | TimedSamples):
        self.terrain = terrain
        self.samples = matrix if isinstance(matrix, TimedSamples) else None
        if self.samples is not None:  # samples moving with the phase durations
            self.variables = FootTerrainBlock.variables + (PHASES,)
            matrix = self.samples.matrix
        self.matrix = sp.csr_matrix(matrix)
        self.size = self.matrix.shape[0]
        self.jacobian = SampledJacobian([self.matrix], 1, self.size, 3 * self.matrix.shape[1])

    def join(self, batch: FootTerrainBatch | None) -> FootTerrainBlock:
        """This block, evaluated with the other members of `batch` where it can be (itself)."""
        self.batch = batch if batch is not None and batch.join(self) else None
        return self

    def _retime(self, d: np.ndarray) -> bool:
        changed, valid = refresh([self.samples], d)
        if changed and valid:
            self.matrix = self.samples.matrix
            self.jacobian = self.jacobian.with_matrices([self.matrix])
        return valid

    @abstractmethod
    def _row(self, q):
        """The row value at foot positions q (n, 3), real or complex."""

    def _column(self, q):
        return self._row(q)[:, None]

    def _row_jacobian(self, q):
        """The row values (n,) and their Jacobians (n, 1, 3) at foot positions q: by complex step
        here, in closed form where a block knows its function's gradient."""
        r, (j,) = complex_step(self._column, (q,), (0,))
        return r[:, 0], j

    def evaluate(self, values, jacobians):
        if self.batch is not None:
            return self.batch.part(self, values, jacobians)
        if self.samples is not None and not self._retime(values[1]):
            return invalid_timing(self, jacobians)
        q = times(self.matrix, _nodes(values[0]))
        if not jacobians:
            return self._row(q), None
        r, j = self._row_jacobian(q)
        out = [self.jacobian([j])]
        if self.samples is not None:
            out.append(phase_jacobian([(j, self.samples, values[0])], self.size, self.samples.timing.size))
        return r, out


class TerrainHeightBlock(FootTerrainBlock):
    """z − h(x, y) of the sampled foot positions; h is the terrain surface, or with `envelope` its
    upper bound over the column terrain (for swing feet)."""

    def __init__(self, terrain: TerrainModel, matrix: sp.csr_matrix, envelope: bool = False):
        super().__init__(terrain, matrix)
        self.height = terrain.envelope if envelope else terrain.height
        self.height_gradient = terrain.envelope_gradient if envelope else terrain.height_gradient

    def _row(self, q):
        return q[:, 2] - self.height(q[:, 0], q[:, 1])

    def _row_jacobian(self, q):
        """z − h and (−∂h/∂x, −∂h/∂y, 1): the bilinear surface's exact gradient."""
        h, hx, hy = self.height_gradient(q[:, 0], q[:, 1])
        return q[:, 2] - h, np.stack([-hx, -hy, np.ones_like(hx)], axis=-1)[:, None]


class StanceSlopeBlock(FootTerrainBlock):
    """`TerrainModel.stance_slope` at the sampled (stance) foot positions: bounded above, it keeps
    footholds off step edges (`DynParams.stance_slope_max`)."""

    def _row(self, q):
        return self.terrain.stance_slope(q[:, 0], q[:, 1])

    def _row_jacobian(self, q):
        value, gx, gy = self.terrain.stance_slope_gradient(q[:, 0], q[:, 1])
        return value, np.stack([gx, gy, np.zeros_like(gx)], axis=-1)[:, None]


class FootTerrainBatch(_LegBatch):
    """The rows of one terrain constraint (`FootTerrainBlock`: stance on the terrain, swing above it,
    stance off edges) of every leg in one pass: the per-leg blocks of one problem with fixed phases,
    of one kind over one terrain function, evaluated on their feet samples stacked (one terrain
    interpolation for the four legs; every row the same operations as alone). The blocks, their
    rows and their Jacobians' patterns stay those of the legs alone."""

    def _admits(self, block: FootTerrainBlock) -> bool:
        if block.samples is not None:
            return False
        if not self.members:
            return True
        first = self.members[0]
        return (type(block) is type(first) and block.terrain is first.terrain
                and getattr(block, "height", None) == getattr(first, "height", None))

    def _evaluate(self, values, jacobians: bool) -> list:
        members = self.members
        feet = _nodes(values[0])
        q = np.concatenate([times(m.matrix, feet) for m in members])
        bounds = np.concatenate([[0], np.cumsum([m.size for m in members])])
        if not jacobians:
            r = members[0]._row(q)
            return [(r[lo:hi], None) for lo, hi in zip(bounds[:-1], bounds[1:])]
        r, j = members[0]._row_jacobian(q)
        return [(r[lo:hi], [m.jacobian([j[lo:hi]])]) for m, lo, hi in zip(members, bounds[:-1], bounds[1:])]


FRICTION_FACES = 8
"""Faces of the friction pyramid `ForceBlock` keeps forces in: the pyramid inscribed in the Coulomb
cone |f_t| ≤ μ f·n (the simulator's elliptic cone) with this many faces."""


class ForceBlock(ResidualBlock):
    """Per force point of one foot (rows of `force`, e.g. Bézier control points): f·n, then for each
    of the `FRICTION_FACES` faces d_k·f − μ cos(π/K) f·n with d_k = cos θ_k t1 + sin θ_k t2, θ_k = 2πk/K
    (1 + K rows), with the terrain basis at the foot's stance position (`foot` selects the stance
    node of each point). Bounded above by 0, these keep f inside the pyramid inscribed in the
    Coulomb cone, where TOWR's four rows ±f·t_j − μ f·n ≤ 0 admit tangential forces up to √2 μ f·n
    along the diagonals, outside the cone the simulator's contact obeys. Eight faces keep cos(π/8)
    of the cone's friction in every direction (the four-face inscribed pyramid, μ/√2, gives up 29 %
    along the axes, where the walking forces lie). The rows are linear in f for a fixed foothold;
    the cone is convex, so rows that hold at the control points hold along the polynomials."""

    variables = ("feet", "forces")
    ROWS = 1 + FRICTION_FACES
    ANGLES = 2 * np.pi * np.arange(FRICTION_FACES) / FRICTION_FACES

    def __init__(self, terrain: TerrainModel, friction: float, force: sp.csr_matrix | TimedControlPoints,
                 foot: sp.csr_matrix, batch: ForceBatch | None = None):
        self.terrain, self.mu = terrain, float(friction)
        self.samples = force if isinstance(force, TimedControlPoints) else None
        if self.samples is not None:  # control points moving with the phase durations
            self.variables = ForceBlock.variables + (PHASES,)
            force = self.samples.matrix
        self.force, self.foot = sp.csr_matrix(force), sp.csr_matrix(foot)
        self.n = self.force.shape[0]
        self.size = self.ROWS * self.n
        self.foot_jacobian = SampledJacobian([self.foot], self.ROWS, self.n, 3 * self.foot.shape[1])
        self.force_jacobian = SampledJacobian([self.force], self.ROWS, self.n, 3 * self.force.shape[1])
        self.batch = batch if batch is not None and batch.join(self) else None

    def _retime(self, d: np.ndarray) -> bool:
        changed, valid = refresh([self.samples], d)
        if changed and valid:
            self.force = self.samples.matrix
            self.force_jacobian = self.force_jacobian.with_matrices([self.force])
        return valid

    def _rows(self, f, q):
        n, t1, t2 = self.terrain.basis(q[:, 0], q[:, 1])
        fn = np.sum(f * n, axis=1)
        a, b = np.sum(f * t1, axis=1), np.sum(f * t2, axis=1)
        faces = (np.cos(self.ANGLES) * a[:, None] + np.sin(self.ANGLES) * b[:, None]
                 - self.mu * np.cos(np.pi / FRICTION_FACES) * fn[:, None])
        return np.hstack([fn[:, None], faces])

    def evaluate(self, values, jacobians):
        if self.batch is not None:
            return self.batch.part(self, values, jacobians)
        if self.samples is not None and not self._retime(values[2]):
            return invalid_timing(self, jacobians)
        q, f = times(self.foot, _nodes(values[0])), times(self.force, _nodes(values[1]))
        if not jacobians:
            return self._rows(f, q).reshape(-1), None
        r, (j_f, j_q) = complex_step(self._rows, (f, q), (0, 1))
        out = [self.foot_jacobian([j_q]), self.force_jacobian([j_f])]
        if self.samples is not None:
            out.append(phase_jacobian([(j_f, self.samples, values[1])], self.size, self.samples.timing.size))
        return r.reshape(-1), out

    def residual_rows(self, values, rows):
        """The rows `rows` from the force points that hold them alone (each computed as in
        `evaluate`); with control points that move with the phases, the whole evaluation."""
        if self.samples is not None:
            return super().residual_rows(values, rows)
        points, at = np.unique(rows // self.ROWS, return_inverse=True)
        q = times(self.foot[points], _nodes(values[0]))
        f = times(self.force[points], _nodes(values[1]))
        return self._rows(f, q)[at, rows % self.ROWS]

    @staticmethod
    def bounds(n: int, max_normal_force: float) -> tuple[np.ndarray, np.ndarray]:
        faces = FRICTION_FACES
        lower = np.tile([0.0] + [-np.inf] * faces, n)
        upper = np.tile([max_normal_force] + [0.0] * faces, n)
        return lower, upper


class ForceBatch(_LegBatch):
    """The friction-pyramid rows of every leg in one pass: the per-leg `ForceBlock`s of one problem
    share it (fixed phases, one terrain and friction), evaluated on the members' force points stacked
    (the terrain basis, the complex step and each numpy call over the four legs instead of one call
    per leg; every row the same operations as alone). The blocks, their rows and their Jacobians'
    patterns stay those of the legs alone (as `LegClearanceBatch` for the leg clearance)."""

    def _admits(self, block: ForceBlock) -> bool:
        if block.samples is not None:
            return False
        return not self.members or (block.terrain is self.members[0].terrain and block.mu == self.members[0].mu)

    def _evaluate(self, values, jacobians: bool) -> list:
        members = self.members
        feet, forces = _nodes(values[0]), _nodes(values[1])
        q = np.concatenate([times(m.foot, feet) for m in members])
        f = np.concatenate([times(m.force, forces) for m in members])
        bounds = np.concatenate([[0], np.cumsum([m.n for m in members])])
        if not jacobians:
            rows = members[0]._rows(f, q)
            return [(rows[lo:hi].reshape(-1), None) for lo, hi in zip(bounds[:-1], bounds[1:])]
        r, (j_f, j_q) = complex_step(members[0]._rows, (f, q), (0, 1))
        return [(r[lo:hi].reshape(-1), [m.foot_jacobian([j_q[lo:hi]]), m.force_jacobian([j_f[lo:hi]])])
                for m, lo, hi in zip(members, bounds[:-1], bounds[1:])]


def acceleration_continuity(form: Formulation, variable: str) -> LinearBlock:
    """p̈ from the left polynomial minus p̈ from the right one at every interior base knot (3 rows each)."""
    knots = form.knots
    inner = knots.size - 2
    left = hermite_weights(np.ones(inner), np.diff(knots)[:-1], 2)  # end of segment j − 1
    right = hermite_weights(np.zeros(inner), np.diff(knots)[1:], 2)  # start of segment j
    first = 2 * np.arange(inner)[:, None]  # (p, v) of node j − 1, then of j and j + 1
    cols = np.hstack([first + np.arange(4), first + 2 + np.arange(4)])
    m = sp.csr_matrix((np.hstack([left, -right]).reshape(-1), (np.repeat(np.arange(inner), 8), cols.reshape(-1))),
                      shape=(inner, 2 * form.base.nodes))
    return LinearBlock((variable,), [kron_dim(m)])


def _foot_rows(form: Formulation, entries: list[list[tuple[int, int, int, float]]]) -> sp.csr_matrix:
    """A matrix over the flattened ``feet`` array from rows of (node, derivative, axis, coefficient)."""
    rows, cols, vals = [], [], []
    for i, row in enumerate(entries):
        for node, deriv, axis, coef in row:
            rows.append(i), cols.append(6 * node + 3 * deriv + axis), vals.append(coef)
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(entries), 6 * form.motion_nodes))


def _swings(form: Formulation):
    """(previous stance node, apex node, next stance node, swing duration) of every swing."""
    for foot in form.feet:
        swings = [p for p in foot.phases if not p.stance]
        for k, (apex, phase) in enumerate(zip(foot.swing_nodes, swings)):
            yield foot.stance_nodes[k], apex, foot.stance_nodes[k + 1], phase.duration


def swing_constraint(form: Formulation) -> LinearBlock:
    """TOWR's swing constraint: apex x, y halfway between the stance nodes, apex x, y velocity equal
    to the step over the swing duration (4 rows per swing)."""
    entries = []
    for prev, apex, nxt, duration in _swings(form):
        for axis in (0, 1):
            entries.append([(apex, 0, axis, 1.0), (prev, 0, axis, -0.5), (nxt, 0, axis, -0.5)])
            entries.append([(apex, 1, axis, 1.0), (prev, 0, axis, 1.0 / duration), (nxt, 0, axis, -1.0 / duration)])
    return LinearBlock(("feet",), [_foot_rows(form, entries)])


def swing_height(form: Formulation) -> LinearBlock:
    """Apex z minus the z of the previous and of the next stance node (2 rows per swing): the paper's
    swing-height constraint (≥ clearance) and cost."""
    entries = []
    for prev, apex, nxt, _ in _swings(form):
        entries.append([(apex, 0, 2, 1.0), (prev, 0, 2, -1.0)])
        entries.append([(apex, 0, 2, 1.0), (nxt, 0, 2, -1.0)])
    return LinearBlock(("feet",), [_foot_rows(form, entries)])


class BaseAboveFeetBlock(ResidualBlock):
    """Base z minus foot `leg`'s z at `times` (one row a time): the paper's base clearance, held
    leg by leg at that leg's own samples (its swings move fastest). The base is the base frame's
    origin, where the independent check measures it: p = c − R(e) o (c the planner's CoM spline, o
    the CoM in the base frame, `Centroidal.com_offset`), so the row is c_z − (R o)_z − p_i,z, linear
    in the nodes when o = 0 and otherwise through ∂R/∂e. With a `timing` the foot moves with the
    phase durations."""

    def __init__(self, form: Formulation, leg: int, times: np.ndarray, timing: PhaseTiming | None = None,
                 com_offset=(0.0, 0.0, 0.0)):
        self.size = self.n = np.asarray(times).size
        self.offset = np.asarray(com_offset, float)
        self.turning = bool(self.offset.any())
        self.variables = ("base_lin",) + (("base_ang",) if self.turning else ()) + ("feet",)
        base = form.base_matrix(times)
        self.base = kron_axis(base, 2)
        self.angles = kron_dim(base) if self.turning else None
        self.timing = timing
        if timing is None:
            self.sample = None
            self.feet = kron_axis(form.foot_matrix(leg, times), 2)
        else:
            self.variables = self.variables + (PHASES,)
            self.sample = TimedSamples(timing, "motion", leg, times)
            self.feet = kron_axis(self.sample.matrix, 2)

    def evaluate(self, values, jacobians):
        base, feet = values[0], values[2 if self.turning else 1]
        if self.timing is not None:
            changed, valid = refresh([self.sample], values[-1])
            if not valid:
                return invalid_timing(self, jacobians)
            if changed:
                self.feet = kron_axis(self.sample.matrix, 2)
        r = times(self.base, base) - times(self.feet, feet)
        if self.turning:
            e = times(self.angles, values[1]).reshape(-1, 3)
            r = r - rotation(e)[:, 2] @ self.offset
        if not jacobians:
            return r, None
        out = [self.base]
        if self.turning:
            dz_de = -np.einsum("nlj,j->nl", rotation_derivatives(e)[:, :, 2], self.offset)  # −∂(R o)_z/∂e
            rows = sp.csr_matrix((dz_de.reshape(-1), np.arange(3 * self.n), np.arange(0, 3 * self.n + 1, 3)),
                                 shape=(self.n, 3 * self.n))  # row k: ∂row_k/∂e_k
            out.append((rows @ self.angles).tocsr())
        out.append(-self.feet)
        if self.timing is not None:
            e_z = np.zeros((self.n, 1, 3))
            e_z[:, 0, 2] = -1.0
            out.append(phase_jacobian([(e_z, self.sample, feet)], self.n, self.timing.size).tocsr())
        return r, out
