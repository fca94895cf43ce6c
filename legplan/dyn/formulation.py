"""Variables of the centroidal trajectory optimization and the splines they define (Sec. III-A).

Phase-based parametrization of Winkler et al. (2018), as summarized in the TOWR-costs paper:

* base linear position and Euler angles: cubic Hermite node splines, the duration split into equal
  polynomials of at most ``dt`` (TOWR's), or with `aligned`, or for a gait whose feet make or break
  contact in pairs (`pair_switches`), every whole-body phase of the gait so (`phase_knots`); a gait
  with `unloaded_phases` (a trot's support pairs, whose summed force rises from zero and falls back
  to it) gets phase-aligned knots and at least `unloaded_polynomials` equal
  polynomials in each of those phases: the base acceleration, linear on a polynomial, then follows
  the summed force between the knots, where the dynamics are sampled (the single-rigid-body
  dynamics of Winkler et al. 2018, eq. (1), on the TOWR-costs paper's collocation, Sec. III-A, with
  more base polynomials where one every 0.1 s cannot follow the force);
  variables ``base_lin`` and ``base_ang``,
  each (nodes, value|derivative, xyz) flattened. The first node (start pose, zero velocity) is fixed;
  of the last node the goal fixes x, y, all three angles and every derivative, the height stays free.
* per foot, one node per stance phase (the foot is constant in stance: derivative fixed to 0) and one
  mid-swing node per swing phase (value free, z-derivative fixed to 0: the swing node is the apex),
  joined by two Hermite polynomials per swing. The first stance node's x, y are fixed to the start.
  Variable ``feet``: the nodes of all feet, foot after foot.
* per foot, forces as three Hermite polynomials per stance phase (4 nodes) and zero in swing (one
  fixed zero node); stance nodes next to a swing are fixed to zero value (the force vanishes at
  touchdown and lift-off) with the rate free, where TOWR fixes the rate to zero too: the force then
  can rise linearly after a touchdown, as m(p̈ + g) does on a base polynomial, where a zero rate
  makes it rise quadratically and leaves the Newton–Euler residual between the knots no way to
  vanish (`DynParams.dynamics_points`). Variable ``forces``.

Free variables: 12·K + 26·S + c (K base polynomials, T/dt with TOWR's knots; S footsteps: 3 rates at
each touchdown and lift-off more than TOWR's), against the paper's N = 12T/dt + 20S + 120
(`Formulation.paper_variable_count`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.dyn.gait import FootPhase, Gait
from legplan.geometry.hermite import NodeSpline, Segment
from legplan.geometry.sparse import wrapped
from legplan.solve import VariableBlock

FORCE_POLYNOMIALS = 3  # per stance phase (TOWR default)


@dataclass(frozen=True)
class Pose:
    """A base pose: position (x, y, z) and Euler angles (roll, pitch, yaw)."""

    position: np.ndarray
    euler: np.ndarray


@dataclass
class FootNodes:
    """Node bookkeeping of one foot: where its stance and swing nodes sit in the ``feet`` / ``forces``
    node arrays, and its phases."""

    phases: list[FootPhase]
    motion_offset: int           # first node of this foot in the feet node array
    stance_nodes: list[int]      # global feet-node index of each stance phase (in phase order)
    swing_nodes: list[int]       # global feet-node index of each swing's apex node
    force_offset: int
    force_nodes: list[list[int]]  # per stance phase: its 4 global force-node indices
    motion: NodeSpline
    force: NodeSpline


class Formulation:
    """Splines and variable blocks of one problem: a gait over `duration`, `legs` feet."""

    def __init__(self, gait: Gait, dt: float = 0.1, knots: np.ndarray | None = None, aligned: bool = False,
                 unloaded_polynomials: int | None = None, unloaded_dt: float | None = None):
        self.gait, self.dt = gait, dt
        self.duration = gait.duration
        self.legs = gait.stance.shape[1]
        if knots is None:
            count = max(1, int(np.ceil(self.duration / dt - 1e-9)))
            if unloaded_polynomials is not None and unloaded_phases(gait).any():
                knots = phase_knots(gait, dt, unloaded_polynomials, unloaded_dt)
            else:
                aligned = aligned or (unloaded_polynomials is not None and bool(pair_switches(gait).any()))
                knots = phase_knots(gait, dt) if aligned else np.linspace(0.0, self.duration, count + 1)
        self.knots = np.asarray(knots, float)
        count = self.knots.size - 1
        self.base = NodeSpline([Segment(a, b, k, k + 1) for k, (a, b) in
                                enumerate(zip(self.knots[:-1], self.knots[1:]))], count + 1)
        self.feet: list[FootNodes] = []
        motion_total = force_total = 0
        for leg in range(self.legs):
            foot = _foot_nodes(gait.foot_phases(leg), motion_total, force_total)
            motion_total += foot.motion.nodes
            force_total += foot.force.nodes
            self.feet.append(foot)
        self.motion_nodes, self.force_nodes = motion_total, force_total

    # --- sampling matrices (sparse, acting on (2·nodes, 3) node arrays) ---------------------------
    def base_matrix(self, times, derivative: int = 0) -> sp.csr_matrix:
        return self.base.matrix(times, derivative)

    def foot_matrix(self, leg: int, times, derivative: int = 0) -> sp.csr_matrix:
        """Samples of foot `leg` from the whole ``feet`` node array."""
        foot = self.feet[leg]
        return _embed(foot.motion.matrix(times, derivative), foot.motion_offset, self.motion_nodes)

    def force_matrix(self, leg: int, times, derivative: int = 0) -> sp.csr_matrix:
        foot = self.feet[leg]
        return _embed(foot.force.matrix(times, derivative), foot.force_offset, self.force_nodes)

    def force_control_points(self, leg: int) -> tuple[sp.csr_matrix, list[int]]:
        """Bézier control points of every stance force polynomial of foot `leg` (rows over the whole
        ``forces`` node array) and the stance node of each row.

        A cubic Hermite piece on [t_a, t_b] is the Bézier curve with control points p_a, p_a + h v_a/3,
        p_b − h v_b/3, p_b (h = t_b − t_a); by the convex-hull property a linear constraint that holds
        at these four points holds along the whole piece. Shared end points appear once.
        """
        foot = self.feet[leg]
        rows, cols, vals, stance_of_row = [], [], [], []
        stance_phases = [p for p in foot.phases if p.stance]
        for phase, ids, node in zip(stance_phases, foot.force_nodes, foot.stance_nodes):
            knots = np.linspace(phase.t0, phase.t1, FORCE_POLYNOMIALS + 1)
            entries = [[(2 * ids[0], 1.0)]]
            for k in range(FORCE_POLYNOMIALS):
                h = knots[k + 1] - knots[k]
                a, b = 2 * ids[k], 2 * ids[k + 1]
                entries += [[(a, 1.0), (a + 1, h / 3)], [(b, 1.0), (b + 1, -h / 3)], [(b, 1.0)]]
            for row in entries:
                for col, val in row:
                    rows.append(len(stance_of_row)), cols.append(col), vals.append(val)
                stance_of_row.append(node)
        m = sp.csr_matrix((vals, (rows, cols)), shape=(len(stance_of_row), 2 * self.force_nodes))
        return m, stance_of_row

    @staticmethod
    def node_selector(nodes: list[int], total: int, derivative: int = 0) -> sp.csr_matrix:
        """(len(nodes) × 2·total) rows picking node values (derivative 0) or node derivatives."""
        cols = 2 * np.asarray(nodes, int) + derivative
        if cols.size and not 0 <= cols.min() <= cols.max() < 2 * total:
            raise ValueError(f"node selector: nodes outside 0..{total - 1}")
        index = np.int32 if 2 * total < np.iinfo(np.int32).max else np.int64  # scipy's choice
        # one entry per row: the canonical CSR at once, as scipy's COO conversion gives it
        return wrapped(sp.csr_matrix, np.ones(cols.size), cols.astype(index), np.arange(cols.size + 1, dtype=index),
                       (cols.size, 2 * total))

    # --- variables ----------------------------------------------------------------------------------
    def variables(self, start: Pose, goal: Pose, start_feet: np.ndarray, guess: dict[str, np.ndarray]
                  ) -> list[VariableBlock]:
        """Variable blocks with the fixed entries set from start/goal and the rest from `guess`
        (full value vectors for ``base_lin``, ``base_ang``, ``feet``, ``forces``)."""
        nb = self.base.nodes
        lin = np.array(guess["base_lin"], float).reshape(nb, 2, 3)
        ang = np.array(guess["base_ang"], float).reshape(nb, 2, 3)
        fix_lin = np.zeros((nb, 2, 3), bool)
        fix_ang = np.zeros((nb, 2, 3), bool)
        lin[0, 0], lin[0, 1], ang[0, 0], ang[0, 1] = start.position, 0.0, start.euler, 0.0
        fix_lin[0] = fix_ang[0] = True
        lin[-1, 0, :2], lin[-1, 1], ang[-1, 0], ang[-1, 1] = goal.position[:2], 0.0, goal.euler, 0.0
        fix_lin[-1, 0, :2] = fix_lin[-1, 1] = fix_ang[-1] = True
        feet = np.array(guess["feet"], float).reshape(self.motion_nodes, 2, 3)
        fix_feet = np.zeros_like(feet, bool)
        forces = np.array(guess["forces"], float).reshape(self.force_nodes, 2, 3)
        fix_forces = np.zeros_like(forces, bool)
        for leg, foot in enumerate(self.feet):
            fix_feet[foot.stance_nodes, 1] = True
            feet[foot.stance_nodes, 1] = 0.0
            fix_feet[foot.swing_nodes, 1, 2] = True
            feet[foot.swing_nodes, 1, 2] = 0.0
            fix_feet[foot.stance_nodes[0], 0, :2] = True
            feet[foot.stance_nodes[0], 0, :2] = start_feet[leg, :2]
            zero = [foot.force_offset]  # the swing node
            for k, phase in enumerate(p for p in foot.phases if p.stance):
                nodes = foot.force_nodes[k]
                if phase.t0 > 0:
                    zero.append(nodes[0])
                if phase.t1 < self.duration - 1e-9:
                    zero.append(nodes[-1])
            fix_forces[zero, 0] = True  # touchdown and lift-off: zero force, its rate free
            forces[zero, 0] = 0.0
            fix_forces[foot.force_offset] = True  # the swing node: no rate either
            forces[foot.force_offset] = 0.0
        return [VariableBlock("base_lin", lin.reshape(-1), fix_lin.reshape(-1)),
                VariableBlock("base_ang", ang.reshape(-1), fix_ang.reshape(-1)),
                VariableBlock("feet", feet.reshape(-1), fix_feet.reshape(-1)),
                VariableBlock("forces", forces.reshape(-1), fix_forces.reshape(-1))]

    @property
    def footsteps(self) -> int:
        return sum(len(f.swing_nodes) for f in self.feet)

    def paper_variable_count(self, dt: float = 0.1) -> int:
        """N = 12T/dt + 20S + 120 of the TOWR-costs paper (Sec. III-A), for comparison."""
        return int(round(12 * self.duration / dt + 20 * self.footsteps + 120))


def phase_knots(gait: Gait, dt: float, unloaded_polynomials: int | None = None,
                unloaded_dt: float | None = None) -> np.ndarray:
    """The base knots: every whole-body phase of the gait split into equal polynomials of at most
    `dt`, the `unloaded_phases` into `unloaded_polynomials` at least and of at most `unloaded_dt`
    (a slow trot's long pairs: its count alone left their polynomials too long for the solver to
    converge; a fixed count keeps a fast trot's base as smooth as it executes). The contact set is then
    constant on every base polynomial, whose acceleration is linear: the summed forces can follow it
    between the knots (`DynParams.dynamics_points`), where knots spaced evenly over the motion put
    touchdowns, lift-offs and flights inside a polynomial."""
    least = np.ones(gait.durations.size, int)
    longest = np.full(gait.durations.size, dt)
    if unloaded_polynomials is not None:
        least[unloaded_phases(gait)] = unloaded_polynomials
        if unloaded_dt is not None:
            longest[unloaded_phases(gait)] = min(dt, unloaded_dt)
    knots, t = [0.0], 0.0
    for d, fewest, h in zip(gait.durations, least, longest):
        count = max(fewest, int(np.ceil(d / h - 1e-9)))
        knots += list(t + d * np.arange(1, count + 1) / count)
        t += d
    knots[-1] = gait.duration
    return np.array(knots)


def dense_knots(gait: Gait, dt: float, unloaded_polynomials: int, unloaded_dt: float | None = None) -> np.ndarray:
    """Evenly spaced base knots as dense as `phase_knots` makes them in the shortest unloaded phase
    (its duration / `unloaded_polynomials`, at most `dt` and `unloaded_dt`): for phase durations that the optimizer moves
    (`DynParams.optimize_phases`), where knots fixed at the initial phase boundaries would end up
    inside the moved phases, short polynomials everywhere follow the summed force wherever its phases
    go (a foot's force leaves and reaches zero at a free rate, so the summed force has a corner at a
    boundary; the Newton–Euler rows between the knots bound how far a short polynomial's linear
    acceleration may miss it, `DynParams.dynamics_band`)."""
    unloaded = unloaded_phases(gait)
    spacing = min(dt, float(gait.durations[unloaded].min()) / unloaded_polynomials) if unloaded.any() else dt
    if unloaded.any() and unloaded_dt is not None:
        spacing = min(spacing, unloaded_dt)
    count = max(1, int(np.ceil(gait.duration / spacing - 1e-9)))
    return np.linspace(0.0, gait.duration, count + 1)


def pair_switches(gait: Gait) -> np.ndarray:
    """Per interior phase boundary: whether two or more feet make or break contact at it together (a
    trot's diagonal pairs, which a slow trot hands over through four-leg support, `gait.make_gait`'s
    `line_support`). There the summed contact force's slope jumps by two feet's free rates at once
    (each foot's force leaves and reaches zero at a free rate, module docstring), which the linear
    acceleration of a base polynomial spanning the boundary cannot follow while the Newton–Euler rows
    hold exactly at its knots (Winkler et al. 2018, eq. (1)): such a gait gets knots at every phase
    boundary (`phase_knots`), as a gait with `unloaded_phases` does (both only in the planner's
    formulation: `unloaded_polynomials` None keeps TOWR's even knots). A walk changes one foot at a
    time and keeps even knots."""
    stance = np.asarray(gait.stance, bool)
    return (stance[1:] != stance[:-1]).sum(axis=1) >= 2


def unloaded_phases(gait: Gait) -> np.ndarray:
    """Per whole-body phase: whether feet carry it and it begins or ends at a boundary where no foot
    stays in contact (every contact there is made or broken: a trot's support pairs), i.e. where the
    summed contact force vanishes, each foot's force being zero at its touchdown and lift-off (module
    docstring). The summed force over such a phase is a bump to or from zero that carries the weight
    over the phase and the flight next to it; the base's acceleration, linear on each polynomial of
    the cubic base spline (the dynamics of Winkler et al. 2018, eq. (1), m p̈ = Σf − m g),
    follows a bump of curvature f'' within about f''h²/8 on polynomials of length h. For a parabolic
    bump of duration T carrying m·g over T + T_flight, f'' = 12 m g (T + T_flight)/T³, so with
    n = T/h polynomials the gap is about 1.5 (1 + T_flight/T) m·g / n²: a count of polynomials per
    phase, not a spacing, bounds it whatever the gait's tempo. A flight needs none: no force, the
    acceleration is −g, linear."""
    stance = np.asarray(gait.stance, bool)
    kept = (stance[:-1] & stance[1:]).any(axis=1)  # per interior boundary: some foot stays down
    vanishing = np.concatenate([[False], ~kept, [False]])
    return (vanishing[:-1] | vanishing[1:]) & stance.any(axis=1)


def _foot_nodes(phases: list[FootPhase], motion_offset: int, force_offset: int) -> FootNodes:
    """Nodes and segments of one foot's motion and force splines (see module docstring)."""
    if not (phases[0].stance and phases[-1].stance):
        raise ValueError("every foot must start and end in stance")
    motion_segments, force_segments = [], []
    stance_nodes, swing_nodes, force_nodes = [], [], []
    node = 0
    force_node = 1  # local force node 0 is the fixed zero node of the swing phases
    for k, phase in enumerate(phases):
        if phase.stance:
            stance_nodes.append(node)
            motion_segments.append(Segment(phase.t0, phase.t1, node))
            node += 1
            ids = list(range(force_node, force_node + FORCE_POLYNOMIALS + 1))
            force_nodes.append(ids)
            knots = np.linspace(phase.t0, phase.t1, FORCE_POLYNOMIALS + 1)
            force_segments += [Segment(a, b, i, i + 1) for a, b, i in zip(knots[:-1], knots[1:], ids)]
            force_node += FORCE_POLYNOMIALS + 1
        else:
            mid = 0.5 * (phase.t0 + phase.t1)
            swing_nodes.append(node)
            motion_segments += [Segment(phase.t0, mid, node - 1, node), Segment(mid, phase.t1, node, node + 1)]
            node += 1
            force_segments.append(Segment(phase.t0, phase.t1, 0))
    return FootNodes(phases, motion_offset, [motion_offset + n for n in stance_nodes],
                     [motion_offset + n for n in swing_nodes], force_offset,
                     [[force_offset + n for n in ids] for ids in force_nodes],
                     NodeSpline(motion_segments, node), NodeSpline(force_segments, force_node))


def _embed(m: sp.csr_matrix, offset: int, total: int) -> sp.csr_matrix:
    """Shift the columns of a per-foot matrix into the all-feet node array (2 columns per node): the
    same valid index arrays, shifted (`wrapped`: no check of them again)."""
    m = m if type(m) is sp.csr_matrix else sp.csr_matrix(m)
    return wrapped(sp.csr_matrix, m.data, m.indices + 2 * offset, m.indptr, (m.shape[0], 2 * total))
