"""Phase durations as optimization variables (Winkler et al. 2018; TOWR-costs paper, Sec. III-A: "if
the timing of steps is optimized, the duration of the stance and swing phases of each step are
included, adding 2S variables").

Variable ``phases``: per foot, foot after foot, the durations of all its phases but the last (the
last takes what is left of T, so every foot ends at T): a foot with S_i swings has 2·S_i of them,
2S in all. Each is bounded below by `PhaseTiming.minimum` (a box bound of the variable), the last
one by a linear constraint T − Σ d ≥ minimum (`last_phase_block`).

Every end of a segment of a foot's motion and force spline is affine in its foot's durations: phase
boundaries are partial sums, a swing's apex node sits at the middle of the swing, the force knots
split a stance in thirds (`legplan.dyn.formulation`). So a sample x = M(d) N of a spline moves with
d through the ends (t0, t1) of its segment: ∂x/∂d = ∂x/∂t0 ∂t0/∂d + ∂x/∂t1 ∂t1/∂d
(`hermite_time_partials`), at a fixed time (dynamics, range of motion) or at a fixed fraction of the
segment (swing samples, which move with the swing). A block reading such samples adds ``phases`` to
its variables; its Jacobian there is Σ_terms G_i ∂x_i/∂d, with G_i = ∂r_i/∂x_i the same per-sample
blocks its node Jacobian is built from (`phase_jacobian`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import scipy.sparse as sp

from legplan.dyn.formulation import FORCE_POLYNOMIALS, Formulation
from legplan.dyn.gait import Gait
from legplan.geometry.hermite import NodeSpline, Segment, hermite_time_partials
from legplan.geometry.ordered import sorted_unique
from legplan.solve import VariableBlock
from legplan.solve.blocks import LinearBlock

PHASES = "phases"


class PhaseTiming:
    """The ``phases`` variable of a `Formulation` (module docstring) and the affine maps from it to the
    ends of every segment of every foot's motion and force spline."""

    def __init__(self, form: Formulation, minimum: float):
        self.form, self.duration, self.minimum = form, form.duration, float(minimum)
        self.counts = [len(foot.phases) - 1 for foot in form.feet]
        self.offsets = np.concatenate([[0], np.cumsum(self.counts)]).astype(int)
        self.size = int(self.offsets[-1])
        self.ends = {"motion": [], "force": []}  # per leg: (c0, A0, c1, A1), t0 = c0 + A0 d_leg
        for foot, count in zip(form.feet, self.counts):
            # boundary j of the foot's phases: Σ_{i<j} d_i, and T for the last one
            const = np.zeros(count + 2)
            const[-1] = self.duration
            coef = np.tril(np.ones((count + 2, count)), -1)
            coef[-1] = 0.0
            motion, force = [], []
            for j, phase in enumerate(foot.phases):
                a, b = (const[j], coef[j]), (const[j + 1], coef[j + 1])
                if phase.stance:
                    motion.append((a, b))
                    force += [(_between(a, b, k / FORCE_POLYNOMIALS), _between(a, b, (k + 1) / FORCE_POLYNOMIALS))
                              for k in range(FORCE_POLYNOMIALS)]
                else:
                    mid = _between(a, b, 0.5)
                    motion += [(a, mid), (mid, b)]
                    force.append((a, b))
            for name, pairs in (("motion", motion), ("force", force)):
                self.ends[name].append((np.array([p[0][0] for p in pairs]), np.array([p[0][1] for p in pairs]),
                                        np.array([p[1][0] for p in pairs]), np.array([p[1][1] for p in pairs])))

    def leg_durations(self, d: np.ndarray, leg: int) -> np.ndarray:
        return np.asarray(d, float)[self.offsets[leg]:self.offsets[leg + 1]]

    def initial(self) -> np.ndarray:
        """The durations of the formulation's own phases (the gait's, or those it was retimed to)."""
        return foot_durations(self.form)

    def admissible(self, d: np.ndarray) -> np.ndarray:
        """d with every phase at least `minimum` long, each foot's last one included (of a foot whose
        durations leave less, the parts above the minimum are scaled down, so that the start is
        inside the variable's bounds and the last phase's row): a network's prediction, or a gait
        whose phases are shorter than the minimum, made a timing. A foot with more phases than
        the minimum leaves room for gets them equal."""
        d = np.maximum(np.asarray(d, float), self.minimum)
        for leg in range(len(self.counts)):
            part = d[self.offsets[leg]:self.offsets[leg + 1]]
            room = self.duration - self.minimum
            if part.sum() > room:
                excess, spare = part - self.minimum, room - self.minimum * part.size
                part[:] = self.minimum + excess * (spare / excess.sum()) if spare > 0 else room / part.size
        return d

    def variable(self, value: np.ndarray | None = None) -> VariableBlock:
        return VariableBlock(PHASES, self.initial() if value is None else value, lower=self.minimum)

    def last_phase_block(self) -> LinearBlock:
        """T − Σ d per foot: the duration of each foot's last phase (one row per foot)."""
        rows = np.repeat(np.arange(len(self.counts)), self.counts)
        m = sp.csr_matrix((-np.ones(self.size), (rows, np.arange(self.size))), shape=(len(self.counts), self.size))
        return LinearBlock((PHASES,), [m], -self.duration)

    def segment_ends(self, kind: str, leg: int, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c0, a0, c1, a1 = self.ends[kind][leg]
        dl = self.leg_durations(d, leg)
        return c0 + a0 @ dl, c1 + a1 @ dl

    def formulation(self, d: np.ndarray) -> Formulation:
        """The formulation of the same gait and nodes with the foot durations d (the base knots
        stay where they were)."""
        return Formulation(self.gait(d), self.form.dt, self.form.knots)

    def gait(self, d: np.ndarray) -> Gait:
        """The whole-body phase schedule of the foot durations d: a phase between every two
        consecutive foot events (what `Formulation` and the artefact's contact flags read)."""
        bounds = [np.concatenate([[0.0], np.cumsum(self.leg_durations(d, leg)), [self.duration]])
                  for leg in range(len(self.counts))]
        events = sorted_unique(np.concatenate(bounds))
        events = events[np.concatenate([[True], np.diff(events) > 1e-9])]
        events[-1] = self.duration
        mids = 0.5 * (events[:-1] + events[1:])
        stance = np.column_stack([
            np.array([p.stance for p in foot.phases])[np.clip(np.searchsorted(b, mids, side="right") - 1, 0,
                                                                 len(foot.phases) - 1)]
            for foot, b in zip(self.form.feet, bounds)])
        return Gait(self.form.gait.name, np.diff(events), stance)


def foot_durations(form: Formulation) -> np.ndarray:
    """The ``phases`` values of a formulation's own timing: per foot, the durations of all its
    phases but the last."""
    return np.concatenate([[p.duration for p in foot.phases[:-1]] for foot in form.feet])


def _between(a, b, s: float):
    """The affine map (1 − s)·a + s·b of two affine maps (constant, coefficients)."""
    return (1 - s) * a[0] + s * b[0], (1 - s) * a[1] + s * b[1]


class _FootSamples(ABC):
    """What the timed samplers of one foot share: `refresh` moves them to new durations."""

    timing: PhaseTiming
    kind: str
    leg: int
    key: np.ndarray | None = None

    def refresh(self, d: np.ndarray) -> bool:
        """Move the samples to the durations d; True if they changed. `valid` says whether d leaves
        every segment time; only then is `matrix` that of d."""
        dl = self.timing.leg_durations(d, self.leg)
        if self.key is not None and np.array_equal(dl, self.key):
            return False
        self.key = dl.copy()
        t0, t1 = self.timing.segment_ends(self.kind, self.leg, d)
        self.valid = bool(np.all(t1 - t0 > 1e-6))
        if self.valid:
            self._resample(t0, t1)
        return True

    @abstractmethod
    def _resample(self, t0: np.ndarray, t1: np.ndarray) -> None:
        """Set `matrix` for the segment ends (t0, t1) of the foot's spline."""


class TimedSamples(_FootSamples):
    """Samples of one foot's motion or force spline (`kind`) as the phase durations change: at fixed
    `times`, or moving with their segments (`moving`: the segment and fraction of each sample fixed
    at construction). `matrix` is M(d) over the all-feet node array (as `Formulation.foot_matrix`),
    `refresh(d)` moves it to the durations d, `time_jacobian(nodes)` gives ∂x/∂d_leg (n, 3, count)."""

    def __init__(self, timing: PhaseTiming, kind: str, leg: int, times, derivative: int = 0, moving: bool = False):
        self.timing, self.kind, self.leg, self.derivative, self.moving = timing, kind, leg, derivative, moving
        foot = timing.form.feet[leg]
        self.spline = foot.motion if kind == "motion" else foot.force
        self.offset = foot.motion_offset if kind == "motion" else foot.force_offset
        self.total = timing.form.motion_nodes if kind == "motion" else timing.form.force_nodes
        self.times = np.asarray(times, float).reshape(-1)
        self.segment = self.spline.segment_index(self.times)
        starts, ends = self.spline.starts[self.segment], self.spline.ends[self.segment]
        self.fraction = (self.times - starts) / (ends - starts)
        self.columns = slice(timing.offsets[leg], timing.offsets[leg + 1])
        self.refresh(timing.initial())

    def _resample(self, t0: np.ndarray, t1: np.ndarray) -> None:
        spline = NodeSpline([Segment(a, b, s.a, s.b) for a, b, s in zip(t0, t1, self.spline.segments)],
                            self.spline.nodes)
        self.t0, self.t1 = t0, t1
        if self.moving:  # a sample stays at its fraction of its segment
            self.local = self.fraction
        else:
            self.segment = spline.segment_index(self.times)
            self.local = np.clip((self.times - t0[self.segment]) / (t1 - t0)[self.segment], 0.0, 1.0)
        m = spline.matrix_at(self.segment, self.local, self.derivative)
        self.matrix = sp.csr_matrix((m.data, m.indices + 2 * self.offset, m.indptr), shape=(m.shape[0], 2 * self.total))

    def time_jacobian(self, nodes: np.ndarray) -> np.ndarray:
        """∂x/∂d of the samples (n, 3, count) at the flattened all-feet `nodes` of the last refresh."""
        n3 = np.asarray(nodes).reshape(-1, 2, 3)[self.offset:self.offset + self.spline.nodes]
        c0, a0, c1, a1 = self.timing.ends[self.kind][self.leg]
        out = np.zeros((self.times.size, 3, a0.shape[1]))
        idx = np.flatnonzero(self.spline.node_b[self.segment] >= 0)  # samples on Hermite segments
        if not idx.size:
            return out
        k = self.segment[idx]
        h = (self.t1 - self.t0)[k]
        w0, w1 = hermite_time_partials(self.local[idx], h, self.derivative, self.moving)
        a, b = self.spline.node_a[k], self.spline.node_b[k]
        c = np.stack([n3[a, 0], n3[a, 1], n3[b, 0], n3[b, 1]], axis=1)  # (n, 4, 3)
        x0, x1 = np.einsum("nj,nja->na", w0, c), np.einsum("nj,nja->na", w1, c)
        out[idx] = x0[:, :, None] * a0[k][:, None, :] + x1[:, :, None] * a1[k][:, None, :]
        return out


class TimedControlPoints(_FootSamples):
    """The Bézier control points p_a, p_a + h v_a/3, p_b − h v_b/3, p_b of every stance force polynomial
    of foot `leg` (`Formulation.force_control_points`) as the durations change: rows over the
    all-feet ``forces`` node array; only the inner points move with h."""

    kind = "force"

    def __init__(self, timing: PhaseTiming, leg: int):
        self.timing, self.leg = timing, leg
        form = timing.form
        foot = form.feet[leg]
        self.offset, self.total = foot.force_offset, form.force_nodes
        self.columns = slice(timing.offsets[leg], timing.offsets[leg + 1])
        base, self.stance_of_row = form.force_control_points(leg)
        self.base = sp.csr_matrix(base)
        # per row: the segment whose h scales it (−1: none) and the sign and node of the v term
        hermite = [k for k, s in enumerate(foot.force.segments) if not s.constant]
        self.row_segment, self.row_node, self.row_sign = [], [], []
        for i, k in enumerate(hermite):
            seg = foot.force.segments[k]
            rows = ([(-1, 0, 0.0)] if i == 0 or foot.force.segments[k - 1].constant else []) + \
                   [(k, seg.a, 1.0), (k, seg.b, -1.0), (-1, 0, 0.0)]
            for r in rows:
                self.row_segment.append(r[0]), self.row_node.append(r[1]), self.row_sign.append(r[2])
        self.row_segment, self.row_node = np.array(self.row_segment), np.array(self.row_node)
        self.row_sign = np.array(self.row_sign)
        if self.row_segment.size != self.base.shape[0]:
            raise AssertionError("control point rows out of step with Formulation.force_control_points")
        self.refresh(timing.initial())

    def _resample(self, t0: np.ndarray, t1: np.ndarray) -> None:
        self.h = t1 - t0
        m = self.base.tocoo()
        moving = self.row_segment[m.row] >= 0
        odd = (m.col % 2 == 1) & moving  # the v entry of an inner point: ±h/3
        data = m.data.copy()
        data[odd] = self.row_sign[m.row[odd]] * self.h[self.row_segment[m.row[odd]]] / 3.0
        self.matrix = sp.csr_matrix((data, (m.row, m.col)), shape=m.shape)

    def time_jacobian(self, nodes: np.ndarray) -> np.ndarray:
        n3 = np.asarray(nodes).reshape(-1, 2, 3)
        c0, a0, c1, a1 = self.timing.ends["force"][self.leg]
        out = np.zeros((self.row_segment.size, 3, a0.shape[1]))
        rows = np.flatnonzero(self.row_segment >= 0)
        k = self.row_segment[rows]
        v = n3[self.offset + self.row_node[rows], 1] * (self.row_sign[rows] / 3.0)[:, None]
        out[rows] = v[:, :, None] * (a1[k] - a0[k])[:, None, :]
        return out


def refresh(samples, d: np.ndarray) -> tuple[bool, bool]:
    """Move every sampler to the durations d: (any changed, all valid)."""
    changed = [s.refresh(d) for s in samples]
    return any(changed), all(s.valid for s in samples)


def invalid_timing(block, jacobians: bool):
    """The (residual, Jacobians) of a block at phase durations that leave a segment without time: NaN
    rows (a trial step of the solver, which rejects it); Jacobians there are an error."""
    if jacobians:
        raise ValueError(f"{type(block).__name__}: Jacobians requested at phase durations that are no timing")
    return np.full(block.size, np.nan), None


def phase_jacobian(terms, rows: int, size: int) -> sp.csr_matrix:
    """Σ_terms G ∂x/∂d: the Jacobian of a block's `rows` rows with respect to ``phases`` (`size`
    durations). `terms` are (G (n, r, 3) with n·r = rows, samples: a `TimedSamples` or
    `TimedControlPoints`, the nodes it samples). Every row gets an entry in every column of each
    foot it reads (explicit zeros kept), so the pattern stays put while the durations change."""
    dense = np.zeros((rows, size))
    used = np.zeros(size, bool)
    for g, samples, nodes in terms:
        d = samples.time_jacobian(nodes)
        dense[:, samples.columns] += np.einsum("nra,nap->nrp", g, d).reshape(rows, -1)
        used[samples.columns] = True
    cols = np.flatnonzero(used)
    return sp.csr_matrix((dense[:, cols].reshape(-1), np.tile(cols, rows), np.arange(rows + 1) * cols.size),
                         shape=(rows, size))
