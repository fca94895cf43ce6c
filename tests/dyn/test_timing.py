"""Phase durations as variables (`legplan.dyn.timing`): the time partials of a Hermite sample, the
map from durations to a retimed gait, and the samplers that move with the durations, each against
the fixed-timing formulation of the same durations and against central finite differences."""

from dataclasses import replace

import numpy as np
import pytest

from legplan.dyn.formulation import Formulation
from legplan.dyn.gait import make_gait
from legplan.dyn.init import heuristic
from legplan.dyn.problem import PAPER_COSTS, DynParams, DynTask, build_problem
from legplan.dyn.timing import PHASES, PhaseTiming, TimedControlPoints, TimedSamples
from legplan.geometry.hermite import hermite_time_partials, hermite_weights
from legplan.solve.blocks import LinearBlock

EPS = 1e-6
GAITS = {"walk": ("walk", 2, 3.0), "trot": ("trot", 4, 2.4)}


def _sample(c, t0, t1, t, derivative):
    """x^(r)(t) of the Hermite segment [t0, t1] with node values c (4 × 3: p_a, v_a, p_b, v_b)."""
    h = t1 - t0
    return (hermite_weights(np.array([(t - t0) / h]), h, derivative) @ c)[0]


@pytest.mark.parametrize("derivative", [0, 1, 2])
def test_hermite_time_partials_at_a_fixed_time_match_finite_differences(derivative):
    """∂x^(r)(t)/∂t0 and ∂x^(r)(t)/∂t1 at a fixed t: the segment rebuilt with t0 ± ε, t1 ± ε."""
    rng = np.random.default_rng(derivative)
    c = rng.normal(size=(4, 3))
    t0, t1 = 0.3, 0.75
    for t in (0.31, 0.42, 0.6, 0.74):
        w0, w1 = hermite_time_partials(np.array([(t - t0) / (t1 - t0)]), t1 - t0, derivative)
        fd0 = (_sample(c, t0 + EPS, t1, t, derivative) - _sample(c, t0 - EPS, t1, t, derivative)) / (2 * EPS)
        fd1 = (_sample(c, t0, t1 + EPS, t, derivative) - _sample(c, t0, t1 - EPS, t, derivative)) / (2 * EPS)
        scale = 1.0 + np.abs(fd0).max() + np.abs(fd1).max()
        assert (w0 @ c)[0] == pytest.approx(fd0, abs=1e-6 * scale)
        assert (w1 @ c)[0] == pytest.approx(fd1, abs=1e-6 * scale)
        assert np.abs(fd0).max() + np.abs(fd1).max() > 1e-3  # the sample does depend on the ends


@pytest.mark.parametrize("derivative", [0, 1, 2])
def test_hermite_time_partials_of_a_moving_sample_match_finite_differences(derivative):
    """moving=True: the sample at a fixed fraction s of the segment follows its ends."""
    rng = np.random.default_rng(10 + derivative)
    c = rng.normal(size=(4, 3))
    t0, t1 = 0.3, 0.75
    for s in (0.0, 0.2, 0.5, 0.9, 1.0):
        w0, w1 = hermite_time_partials(np.array([s]), t1 - t0, derivative, moving=True)
        at = lambda a, b: (hermite_weights(np.array([s]), b - a, derivative) @ c)[0]
        fd0 = (at(t0 + EPS, t1) - at(t0 - EPS, t1)) / (2 * EPS)
        fd1 = (at(t0, t1 + EPS) - at(t0, t1 - EPS)) / (2 * EPS)
        scale = 1.0 + np.abs(fd0).max() + np.abs(fd1).max()
        assert (w0 @ c)[0] == pytest.approx(fd0, abs=1e-6 * scale)
        assert (w1 @ c)[0] == pytest.approx(fd1, abs=1e-6 * scale)
        fixed0, _ = hermite_time_partials(np.array([s]), t1 - t0, derivative)
        if 0.0 < s < 1.0:  # a moving sample differs from one at a fixed time
            assert not np.allclose(w0, fixed0)


def _timing(name):
    gait = make_gait(*GAITS[name])
    return gait, PhaseTiming(Formulation(gait, dt=0.1), minimum=0.2)


def _perturbed(timing, seed):
    """Durations scaled by factors in [0.8, 1.2], every foot's drawn again until its phases leave
    more than 0.2 s of the motion to its last phase."""
    rng = np.random.default_rng(seed)
    d0 = timing.initial()
    d = d0.copy()
    for leg in range(len(timing.counts)):
        part = slice(timing.offsets[leg], timing.offsets[leg + 1])
        while True:
            d[part] = d0[part] * rng.uniform(0.8, 1.2, size=d0[part].size)
            if d[part].sum() < timing.duration - 0.2:
                break
    return d


def _away_from_ends(timing, d, times, margin=1e-3):
    """The times farther than `margin` from every segment end of every spline at durations d (a
    fixed sample is only differentiable in d between them)."""
    ends = np.concatenate([np.concatenate(timing.segment_ends(kind, leg, d))
                           for kind in ("motion", "force") for leg in range(len(timing.counts))])
    return times[np.abs(times[:, None] - ends[None, :]).min(axis=1) > margin]


@pytest.mark.parametrize("name", sorted(GAITS))
def test_phase_timing_has_two_variables_per_footstep_and_the_feet_durations(name):
    """2S durations: per foot its phases but the last, which `initial` reads off the gait."""
    gait, timing = _timing(name)
    assert timing.size == 2 * gait.footsteps == 2 * timing.form.footsteps
    expected = np.concatenate([[p.t1 - p.t0 for p in gait.foot_phases(leg)[:-1]] for leg in range(4)])
    np.testing.assert_allclose(timing.initial(), expected, atol=1e-12)
    assert timing.variable().lower == pytest.approx(np.full(timing.size, 0.2))


@pytest.mark.parametrize("name", sorted(GAITS))
def test_gait_of_the_initial_durations_is_the_original_gait(name):
    """`gait(initial)` has every foot's phases and the contact flags of the gait it came from."""
    gait, timing = _timing(name)
    again = timing.gait(timing.initial())
    assert again.duration == pytest.approx(gait.duration, abs=1e-12)
    for leg in range(4):
        a, b = gait.foot_phases(leg), again.foot_phases(leg)
        assert [p.stance for p in a] == [p.stance for p in b]
        np.testing.assert_allclose([p.t0 for p in b], [p.t0 for p in a], atol=1e-9)
        np.testing.assert_allclose([p.t1 for p in b], [p.t1 for p in a], atol=1e-9)
    t = np.arange(0.0, gait.duration, 5e-4)
    events = np.cumsum(gait.durations)
    t = t[np.abs(t[:, None] - events[None, :]).min(axis=1) > 1e-6]  # off the phase boundaries
    np.testing.assert_array_equal(again.contact(t), gait.contact(t))


@pytest.mark.parametrize("name", sorted(GAITS))
def test_formulation_of_perturbed_durations_has_them_and_ends_at_t(name):
    """Retimed: each foot's phases have the durations d, the last one T − Σ d (`last_phase_block`),
    and every foot ends at T; the contact flags follow the new phases."""
    gait, timing = _timing(name)
    d = _perturbed(timing, seed=len(name))
    assert not np.allclose(d, timing.initial())
    form = timing.formulation(d)
    block = timing.last_phase_block()
    assert isinstance(block, LinearBlock) and block.variables == (PHASES,)
    last = block.evaluate([d], False)[0]
    assert last.shape == (4,)
    for leg in range(4):
        phases = form.feet[leg].phases
        durations = [p.t1 - p.t0 for p in phases]
        np.testing.assert_allclose(durations[:-1], timing.leg_durations(d, leg), atol=1e-9)
        assert phases[-1].t1 == pytest.approx(gait.duration, abs=1e-9)
        assert durations[-1] == pytest.approx(last[leg], abs=1e-9)
        assert last[leg] == pytest.approx(gait.duration - timing.leg_durations(d, leg).sum(), abs=1e-12)
        assert [p.stance for p in phases] == [p.stance for p in gait.foot_phases(leg)]
        mids = np.array([0.5 * (p.t0 + p.t1) for p in phases])
        np.testing.assert_array_equal(form.gait.contact(mids)[:, leg], [p.stance for p in phases])
    assert form.gait.duration == pytest.approx(gait.duration, abs=1e-9)


def _check_time_jacobian(sampler, timing, d, nodes):
    """time_jacobian at d against central differences of refresh(d ± ε e_j); matrix @ nodes."""
    sampler.refresh(d)
    analytic = sampler.time_jacobian(nodes)
    n3 = nodes.reshape(-1, 3)
    columns = range(timing.offsets[sampler.leg], timing.offsets[sampler.leg + 1])
    assert analytic.shape == (sampler.matrix.shape[0], 3, len(columns))
    for k, j in enumerate(columns):
        e = np.zeros(timing.size)
        e[j] = EPS
        assert sampler.refresh(d + e)
        plus = sampler.matrix @ n3
        assert sampler.refresh(d - e)
        minus = sampler.matrix @ n3
        fd = (plus - minus) / (2 * EPS)
        assert analytic[:, :, k] == pytest.approx(fd, abs=1e-5 * (1.0 + np.abs(fd).max()))
    sampler.refresh(d)
    return analytic


def _retimed_nodes(name: str, kind: str, seed_durations: int, seed_nodes: int):
    """The gait, its timing, perturbed durations, the formulation retimed to them and random node
    values of the `kind` spline of all feet."""
    gait, timing = _timing(name)
    d = _perturbed(timing, seed=seed_durations)
    form = timing.formulation(d)
    total = form.motion_nodes if kind == "motion" else form.force_nodes
    return gait, timing, d, form, np.random.default_rng(seed_nodes).normal(size=2 * total * 3)


@pytest.mark.parametrize("name", sorted(GAITS))
@pytest.mark.parametrize("kind", ["motion", "force"])
@pytest.mark.parametrize("derivative", [0, 1])
def test_timed_samples_at_fixed_times(name, kind, derivative):
    """Fixed times: the matrix is the retimed formulation's `foot_matrix` / `force_matrix`, and
    `time_jacobian` matches central differences in every duration of the foot."""
    gait, timing, d, form, nodes = _retimed_nodes(name, kind, 7, 3)
    grid = np.linspace(0.0, gait.duration, 97)
    moved = 0.0
    for leg in range(4):
        sampler = TimedSamples(timing, kind, leg, grid, derivative)
        assert sampler.refresh(d) and not sampler.refresh(d)  # a second refresh at d changes nothing
        expected = (form.foot_matrix if kind == "motion" else form.force_matrix)(leg, grid, derivative)
        np.testing.assert_allclose(sampler.matrix.toarray(), expected.toarray(), atol=1e-12)
        times = _away_from_ends(timing, d, grid)
        analytic = _check_time_jacobian(TimedSamples(timing, kind, leg, times, derivative), timing, d, nodes)
        moved = max(moved, np.abs(analytic).max())
    assert moved > 1e-2  # the samples do move with the durations


@pytest.mark.parametrize("name", sorted(GAITS))
@pytest.mark.parametrize("kind", ["motion", "force"])
@pytest.mark.parametrize("derivative", [0, 1])
def test_timed_samples_moving_with_their_segments(name, kind, derivative):
    """moving=True: a sample stays at its fraction of its segment, so at durations d it is the
    retimed formulation's sample at the moved time; `time_jacobian` matches central differences."""
    gait, timing, d, form, nodes = _retimed_nodes(name, kind, 11, 4)
    moved = 0.0
    for leg in range(4):
        swings = [p for p in gait.foot_phases(leg) if not p.stance]
        times = np.array([p.t0 + s * (p.t1 - p.t0) for p in swings for s in (0.1, 0.3, 0.45, 0.7, 0.9)])
        if kind == "force":  # forces are Hermite in stance: sample the stances
            stances = [p for p in gait.foot_phases(leg) if p.stance]
            times = np.array([p.t0 + s * (p.t1 - p.t0) for p in stances for s in (0.1, 0.25, 0.5, 0.8, 0.95)])
        sampler = TimedSamples(timing, kind, leg, times, derivative, moving=True)
        seg, fraction = sampler.segment.copy(), sampler.fraction.copy()
        sampler.refresh(d)
        t0, t1 = timing.segment_ends(kind, leg, d)
        moved_times = t0[seg] + fraction * (t1 - t0)[seg]
        expected = (form.foot_matrix if kind == "motion" else form.force_matrix)(leg, moved_times, derivative)
        np.testing.assert_allclose(sampler.matrix.toarray(), expected.toarray(), atol=1e-9)
        analytic = _check_time_jacobian(sampler, timing, d, nodes)
        moved = max(moved, np.abs(analytic).max())
    assert moved > 1e-2


@pytest.mark.parametrize("name", sorted(GAITS))
def test_timed_control_points_follow_the_retimed_force_polynomials(name):
    """The Bézier control points at durations d are `force_control_points` of the retimed
    formulation, and their `time_jacobian` matches central differences."""
    _, timing = _timing(name)
    d = _perturbed(timing, seed=5)
    form = timing.formulation(d)
    nodes = np.random.default_rng(6).normal(size=2 * form.force_nodes * 3)
    moved = 0.0
    for leg in range(4):
        points = TimedControlPoints(timing, leg)
        before = points.matrix.toarray()
        assert points.refresh(d) and points.valid
        expected, stance_of_row = form.force_control_points(leg)
        assert points.stance_of_row == stance_of_row
        np.testing.assert_allclose(points.matrix.toarray(), expected.toarray(), atol=1e-12)
        assert not np.allclose(points.matrix.toarray(), before)  # the inner points moved
        analytic = _check_time_jacobian(points, timing, d, nodes)
        moved = max(moved, np.abs(analytic).max())
    assert moved > 1e-2


@pytest.fixture(scope="module")
def timed_problem(anymal, flat):
    params = replace(DynParams(), costs=PAPER_COSTS, base_clearance=0.3, optimize_phases=True)
    return build_problem(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0), anymal, flat, params, heuristic)


def test_an_invalid_timing_gives_nan_residuals_and_refuses_jacobians(timed_problem):
    """Durations running past T (a trial step of the solver): every timed constraint and cost block
    returns NaN rows without Jacobians and raises ValueError with them; at a valid timing again the
    residuals are those of before."""
    values = {b.name: b.value.copy() for b in timed_problem.variables}
    timing = timed_problem.timing
    bad = values[PHASES].copy()
    bad[timing.offsets[:-1]] += timing.duration  # every foot's first phase longer than the motion
    timed = [k for k in timed_problem.constraints
             if PHASES in k.block.variables and not isinstance(k.block, LinearBlock)]
    assert {"dynamics", "range_of_motion", "swing_above_terrain", "force", "base_clearance"} <= {k.name for k in timed}
    for k in timed:
        at = lambda d: [d if v == PHASES else values[v] for v in k.block.variables]
        good = k.block.evaluate(at(values[PHASES]), False)[0]
        assert np.all(np.isfinite(good)), k.name
        r, jac = k.block.evaluate(at(bad), False)
        assert r.shape == good.shape and np.all(np.isnan(r)) and jac is None, k.name
        with pytest.raises(ValueError, match="phase durations"):
            k.block.evaluate(at(bad), True)
        np.testing.assert_array_equal(k.block.evaluate(at(values[PHASES]), False)[0], good)
    for term in timed_problem.costs:
        name, block = term.name, term.block
        if PHASES in block.variables:
            at = [bad if v == PHASES else values[v] for v in block.variables]
            r = block.evaluate(at, False)[0]
            assert np.all(np.isnan(r)), name
            with pytest.raises(ValueError, match="phase durations"):
                block.evaluate(at, True)


def test_admissible_durations_respect_the_minimum_and_end_within_the_motion():
    """A network's predicted durations made a timing: short phases raised to the minimum, a foot whose
    phases leave less than the minimum for its last one has their parts above the minimum scaled
    down (every phase stays at the minimum or above), valid ones left as they are."""
    _, timing = _timing("walk")
    d = timing.initial()
    assert np.array_equal(timing.admissible(d), d)
    bad = d.copy()
    bad[0] = -0.3  # a negative prediction
    bad[timing.offsets[1]:timing.offsets[2]] *= 3.0  # the second foot overruns T
    fixed = timing.admissible(bad)
    assert fixed.min() >= timing.minimum - 1e-12 and fixed[0] == timing.minimum
    for leg in range(4):
        part = fixed[timing.offsets[leg]:timing.offsets[leg + 1]]
        assert timing.duration - part.sum() >= timing.minimum - 1e-9
    second, before = fixed[timing.offsets[1]:timing.offsets[2]], 3.0 * d[timing.offsets[1]:timing.offsets[2]]
    assert timing.duration - second.sum() == pytest.approx(timing.minimum)
    assert np.allclose((second - timing.minimum) / (second - timing.minimum).sum(),
                       (before - timing.minimum) / (before - timing.minimum).sum())
    timing.formulation(fixed)  # a valid formulation (positive segments)
    tight = d.copy()  # a phase just under the minimum and a foot that overruns: none ends under it
    part = slice(timing.offsets[1], timing.offsets[2])
    first, rest = timing.offsets[1], slice(timing.offsets[1] + 1, timing.offsets[2])
    tight[first] = 0.95 * timing.minimum
    tight[rest] *= (1.05 * (timing.duration - timing.minimum) - tight[first]) / tight[rest].sum()
    fixed = timing.admissible(tight)
    assert fixed[part].min() >= timing.minimum - 1e-12
    assert timing.duration - fixed[part].sum() == pytest.approx(timing.minimum)


def test_a_guess_with_durations_sets_the_timing_optimized_or_fixed(anymal, flat):
    """The paper's Fig. 8 curves: a guess that carries durations (a network's that predicts them) sets
    the problem's timing; without optimize_phases it stays fixed there (no ``phases`` variable),
    with it they are the variable's start."""
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0)
    _, timing = _timing("walk")
    d = _perturbed(timing, seed=5)

    def with_durations(form, *args):
        return {**heuristic(form, *args), PHASES: d}

    fixed = build_problem(task, anymal, flat, DynParams(), with_durations)
    assert fixed.timing is None and PHASES not in {v.name for v in fixed.variables}
    np.testing.assert_allclose(PhaseTiming(fixed.form, 0.2).initial(), d, atol=1e-9)
    timed = build_problem(task, anymal, flat, DynParams(optimize_phases=True), with_durations)
    start = next(v.value for v in timed.variables if v.name == PHASES)
    np.testing.assert_allclose(start, d, atol=1e-12)
    np.testing.assert_allclose(timed.timing.initial(), d, atol=1e-9)
    plain = build_problem(task, anymal, flat, DynParams(), heuristic)  # no durations: the gait's timing
    np.testing.assert_array_equal(plain.form.gait.durations, make_gait("walk", 2, 3.0).durations)


def test_a_torque_limited_trot_with_its_phase_durations_optimized_converges(flat):
    """Issue 34: the learn tests' tiny trot (2 strides in 1.2 s) inside the URDF's joint efforts
    with the durations optimized. Its gait has phases at the shortest duration allowed
    (`DynParams.phase_min`) and the solution keeps one there: the solver holds that duration on its
    bound and steps the others (`legplan.solve.hinged.held_at_bounds`), where a step clipped to the
    bound afterwards stalled on the dynamics rows."""
    from legplan.dyn.planner import plan
    from legplan.dyn.tasks import centroidal_model
    from legplan.robots import load_robot

    model = centroidal_model(load_robot("anymal"))
    assert model.torque_limits is not None
    params = replace(DynParams(optimize_phases=True), iteration_budget=60)
    result = plan(DynTask((-0.35, -0.03, 0.02), (0.0, 0.0, 0.0), "trot", 2, 1.2), model, flat, params)
    assert result.success, result.reason
    durations = result.solve.values[PHASES]
    assert durations.min() == pytest.approx(params.phase_min, abs=1e-9)  # a duration on its bound
    assert result.solve.violations["joint_torque"] <= params.solver.violation_tolerance
