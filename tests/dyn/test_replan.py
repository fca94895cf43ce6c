"""legplan.dyn.replan: the rest of a plan from a measured state (issue 39 item 3)."""

import numpy as np
import pytest

from legplan.dyn.euler import world_rates
from legplan.dyn.gait import make_gait
from legplan.dyn.planner import plan
from legplan.dyn.problem import DynParams, DynTask
from dataclasses import replace

from legplan.dyn.replan import MeasuredState, Previous, ReplanParams, euler_rates, frozen_tail, replan
from legplan.dyn.rest_gait import AIRBORNE_HOLD, remaining_gait
from legplan.dyn.shifted_init import ShiftedInit

TASK = DynTask((0.0, 0.0, 0.0), (0.5, 0.1, 0.1), "walk", 2, 3.0)


@pytest.fixture(scope="module")
def planned(anymal, flat):
    result = plan(TASK, anymal, flat, DynParams())
    assert result.success
    return result


def _previous_at(planned, replanned, t):
    """The previous plan's samples at the replan's sample times, shifted by t."""
    k = np.rint((replanned.samples["t"] + t) / 0.01).astype(int)
    return {name: value[np.clip(k, 0, len(value) - 1)] for name, value in planned.samples.items()}


def test_remaining_gait_keeps_the_phases_after_t():
    gait = make_gait("walk", 2, 3.0)
    ends = np.cumsum(gait.durations)
    t = 0.5 * (ends[2] + ends[3])  # inside phase 3, where a foot swings
    rest, airborne = remaining_gait(gait, t, hold=0.02)
    assert rest.duration == pytest.approx(gait.duration - t)
    assert np.array_equal(airborne, ~gait.stance[3])
    assert airborne.any()
    assert rest.stance[0].all() and np.array_equal(rest.stance[1:], gait.stance[3:])
    assert rest.durations[0] == pytest.approx(0.02)
    assert np.allclose(rest.durations[2:], gait.durations[4:])
    with pytest.raises(ValueError, match="outside"):
        remaining_gait(gait, gait.duration)


def test_euler_rates_invert_world_rates():
    rng = np.random.default_rng(0)
    for _ in range(5):
        e, ed = rng.uniform(-0.5, 0.5, 3), rng.normal(size=3)
        assert np.allclose(euler_rates(e, world_rates(e[None], ed[None])[0]), ed)


def test_shifted_guess_is_the_previous_spline(planned, anymal, flat):
    """Every node of the shifted guess lies on the previous splines at its own time t + τ."""
    previous = Previous.from_plan(planned)
    t = 1.0
    rest, _ = remaining_gait(previous.form.gait, t)
    from legplan.dyn.formulation import Formulation
    form = Formulation(rest, 0.1)
    guess = ShiftedInit(previous, t)(form, anymal, flat, None, None, None)
    lin = guess["base_lin"].reshape(-1, 2, 3)
    old = previous.values["base_lin"].reshape(-1, 3)
    assert np.allclose(lin[:, 0], previous.form.base_matrix(form.knots + t) @ old)
    assert np.allclose(lin[:, 1], previous.form.base_matrix(form.knots + t, 1) @ old)


@pytest.mark.parametrize("phase", [2, 5])
def test_unperturbed_replan_reproduces_the_rest(planned, anymal, flat, phase):
    """From the plan's own state inside a phase with a foot in the air."""
    gait = planned.problem.form.gait
    ends = np.cumsum(gait.durations)
    state = MeasuredState.from_samples(planned.samples, 0.5 * (ends[phase - 1] + ends[phase]))
    assert remaining_gait(gait, state.t)[1].any()
    out = replan(planned, state, anymal, flat, DynParams())
    assert out.success, out.plan.reason
    assert out.iterations < planned.solve.iterations
    before = _previous_at(planned, out.plan, state.t)
    assert np.abs(out.plan.samples["base_pos"] - before["base_pos"]).max() < 0.02
    stance = out.plan.samples["contact"] & before["contact"]
    assert np.abs(out.plan.samples["feet_pos"] - before["feet_pos"])[stance].max() < 0.02


def test_perturbed_replan_converges_from_the_measured_state(planned, anymal, flat):
    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos + [0.0, 0.02, 0.0], state.base_euler,
                           state.base_vel + [0.0, 0.3, 0.0], state.base_ang_vel, state.feet_pos)
    out = replan(planned, pushed, anymal, flat, DynParams())
    assert out.success, out.plan.reason
    s = out.plan.samples
    assert np.allclose(s["base_pos"][0], pushed.base_pos, atol=1e-9)
    assert np.allclose(s["base_vel"][0], pushed.base_vel, atol=1e-9)
    stance = s["contact"][0]
    assert np.allclose(s["feet_pos"][0][stance][:, :2], pushed.feet_pos[stance][:, :2], atol=1e-9)
    assert s["t"][-1] == pytest.approx(TASK.duration - pushed.t)
    assert np.allclose(s["base_pos"][-1, :2], planned.samples["base_pos"][-1, :2], atol=1e-6)
    record = out.record()
    assert record["success"] and record["cpu_seconds"] > 0 and record["iterations"] == out.iterations


def test_a_flying_trot_replans_on_its_short_polynomials(anymal, flat):
    """A flying trot (short base polynomials in its support pairs) replanned from its own state in
    the middle of a pair: the replan keeps the previous plan's knots after t, converges, and the
    independent check finds its Newton–Euler residual within 5 % at every 10 ms sample."""
    from legplan.robots import load_robot
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate.trajectory import check_trajectory

    trot = plan(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "trot", 2, 2.4), anymal, flat, DynParams())
    assert trot.success, trot.reason
    gait = trot.problem.form.gait
    ends = np.cumsum(gait.durations)
    state = MeasuredState.from_samples(trot.samples, 0.5 * (ends[2] + ends[3]))
    out = replan(trot, state, anymal, flat, DynParams())
    assert out.success, out.plan.reason
    later = trot.problem.form.knots[trot.problem.form.knots > state.t + 0.05] - state.t
    assert np.abs(out.plan.problem.form.knots[:, None] - later[None, :-1]).min(axis=0).max() < 1e-9
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))  # the `flat` fixture's map
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    check = check_trajectory(out.plan.samples, anymal, terrain_map, load_robot("anymal"),
                             node_times=out.plan.problem.form.knots)
    assert check.passed["newton_euler_force"] and check.passed["newton_euler_torque"], check.failures()


@pytest.fixture(scope="module")
def trot4(anymal, flat):
    """A flying trot, four strides in 2.4 s: pairs short enough to keep their flights
    (`DynParams.line_support`); its base knots include every contact change."""
    trot = plan(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "trot", 4, 2.4), anymal, flat, DynParams())
    assert trot.success, trot.reason
    return trot


def test_a_replan_just_before_a_flight_keeps_a_knot_at_the_lift_off(trot4, anymal, flat):
    """A replan 20 ms before a trot's support pair lifts off into a flight: the short first base
    polynomial is not merged into the next (one cubic cannot follow the pair's forces and then −g
    through the flight), and the replan from the plan's own state converges."""
    trot = trot4
    gait = trot.problem.form.gait
    ends = np.cumsum(gait.durations)
    lift_off = next(ends[k] for k in range(1, len(ends) - 1) if not gait.stance[k + 1].any())
    state = MeasuredState.from_samples(trot.samples, lift_off - 0.02)
    out = replan(trot, state, anymal, flat, DynParams())
    assert out.success, out.plan.reason
    assert np.isclose(out.plan.problem.form.knots, lift_off - state.t, rtol=0.0, atol=1e-9).any()


@pytest.mark.parametrize("before", [1e-15, 5e-4])
def test_a_replan_a_hair_before_a_contact_change_has_no_sliver_polynomial(trot4, anymal, flat, before):
    """A replan measured a hair before a knot at a contact change (a clock's rounding: a tube-triggered
    replan lands on the previous replan's phase boundary; or within `PHASE_END` of it): the rest of
    the motion takes that phase as over, so its first base polynomial does not end there — one of
    1e-15 s asks accelerations of 1e29 of its dynamics rows and no replan from there converges. The
    replan from the plan's own state converges with no polynomial shorter than `PHASE_END`."""
    from legplan.dyn.rest_gait import PHASE_END

    form = trot4.problem.form
    ends = np.cumsum(form.gait.durations)
    knot = next(k for k in form.knots[1:-1] if np.isclose(k, ends, rtol=0.0, atol=1e-12).any() and k > 0.5)
    own = MeasuredState.from_samples(trot4.samples, knot)
    state = MeasuredState(knot - before, own.base_pos, own.base_euler, own.base_vel, own.base_ang_vel, own.feet_pos)
    assert state.t < knot
    out = replan(trot4, state, anymal, flat, DynParams())
    assert np.diff(out.plan.problem.form.knots).min() >= PHASE_END
    assert out.success, out.plan.reason

def _state_in_swing(planned, share):
    """The plan's own state `share` of the way through the first phase after the start with a foot in
    the air."""
    gait = planned.problem.form.gait
    ends = np.concatenate([[0.0], np.cumsum(gait.durations)])
    phase = next(k for k in range(1, len(gait.durations)) if not gait.stance[k].all())
    return MeasuredState.from_samples(planned.samples, ends[phase] + share * gait.durations[phase])


def test_frozen_tail_is_the_previous_plan(planned, anymal, flat):
    """With a horizon, every node after it keeps the previous plan's value: the replanned samples
    after `Tail.until` are the previous plan's, and the free part starts from the measured state."""
    state = MeasuredState.from_samples(planned.samples, 0.6)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.2, 0.0],
                           state.base_ang_vel, state.feet_pos)
    out = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(horizon=0.4))
    assert out.success, out.plan.reason
    tail = out.plan.problem.task.tail
    assert tail.until is not None and 0.4 <= tail.until < TASK.duration - state.t
    assert tail.base.any() and tail.feet.any() and not tail.base[0]
    s = out.plan.samples
    before = _previous_at(planned, out.plan, state.t)
    after = s["t"] > tail.until + 0.01
    assert after.sum() > 10
    assert np.abs(s["base_pos"][after] - before["base_pos"][after]).max() < 1e-3
    assert np.abs(s["feet_pos"][after] - before["feet_pos"][after]).max() < 1e-3
    assert np.allclose(s["base_vel"][0], pushed.base_vel, atol=1e-9)
    moved = (s["t"] > 0.05) & (s["t"] < tail.until)
    assert np.abs(s["base_pos"][moved] - before["base_pos"][moved]).max() > 1e-3  # the push changed it
    rows = {c.name: c.block.times for c in out.plan.problem.constraints if c.name == "range_of_motion"}
    assert rows["range_of_motion"].max() <= tail.until + 1e-9  # no samples read frozen nodes alone


def test_frozen_tail_without_horizon_is_empty(planned):
    form = planned.problem.form
    assert frozen_tail(form, None).until is None
    assert frozen_tail(form, 10 * form.duration).until is None
    tail = frozen_tail(form, 0.5)
    knot = form.knots[np.argmax(tail.base)]
    assert tail.until == pytest.approx(knot) and tail.base[form.knots >= knot - 1e-9].all()
    assert not tail.base[form.knots < knot - 1e-9].any()


@pytest.fixture(scope="module")
def planned_apex(anymal, flat):
    """The walk with swing apexes 5 cm above both footholds (`DynParams.swing_height_min`)."""
    result = plan(TASK, anymal, flat, replace(DynParams(), swing_height_min=0.05))
    assert result.success
    return result


def test_late_in_a_swing_the_rest_need_not_rise(planned_apex, anymal, flat):
    """A foot near the end of its swing: what is left of it cannot rise 5 cm above both footholds, so
    the replan drops that swing's height rows (and keeps the others)."""
    params = replace(DynParams(), swing_height_min=0.05)
    state = _state_in_swing(planned_apex, 0.85)
    out = replan(planned_apex, state, anymal, flat, params)
    assert out.success, out.plan.reason
    heights = next(c for c in out.plan.problem.constraints if c.name == "swing_height")
    dropped = ~np.isfinite(heights.lower)
    assert 0 < dropped.sum() == 2 * int(remaining_gait(planned_apex.problem.form.gait, state.t)[1].sum())
    assert np.all(heights.lower[~dropped] == 0.05)


def test_a_measured_foot_outside_its_box_settles_back(planned, anymal, flat):
    """The base measured 6 cm sideways of the plan puts the stance feet outside their range-of-motion
    boxes: the replan's boxes at time 0 widen by that excess, shrinking to none at `settle`, and the
    plan brings the feet back inside by then."""
    state = MeasuredState.from_samples(planned.samples, 0.9)
    moved = MeasuredState(state.t, state.base_pos + [0.0, 0.06, 0.0], state.base_euler, state.base_vel,
                          state.base_ang_vel, state.feet_pos)
    out = replan(planned, moved, anymal, flat, DynParams(), settings=ReplanParams(settle=0.25))
    assert out.success, out.plan.reason
    boxes = [c for c in out.plan.problem.constraints if c.name == "range_of_motion"]
    widened = [c for c in boxes if c.upper[0] > c.upper[-1] + 1e-9]
    assert widened  # some foot was outside at time 0
    for c in widened:
        late = c.block.times >= 0.25
        assert np.allclose(c.upper.reshape(-1, 3)[late], c.upper[-3:])  # the plain box after `settle`
        assert np.all(np.diff(c.upper.reshape(-1, 3)[~late], axis=0) <= 1e-12)  # shrinking


def test_measured_state_keeps_its_values_when_the_simulator_moves_on():
    """A simulator hands views of its live state; the state (and what a replan records of it) is
    the one at the replan, not whatever the buffers hold later."""
    qvel, feet = np.array([0.4, 0.0, 0.0, 0.1, 0.2, 0.3]), np.zeros((4, 3))
    state = MeasuredState(1.0, qvel[:3], np.zeros(3), qvel[:3], qvel[3:], feet)
    qvel[:] = 0.0
    feet[:] = 1.0
    assert state.base_vel[0] == 0.4 and state.base_ang_vel[2] == 0.3 and np.all(state.feet_pos == 0.0)
    assert state.record()["base_vel"][0] == 0.4


SLIP = 0.14  # m: farther than the walk's last stance leaves the left front foot inside its box at the goal


def test_a_foot_standing_to_the_end_off_its_planned_foothold_still_replans(planned, anymal, flat):
    """After the last swing the goal pins the base's end while a foot that slipped `SLIP` stays where
    it is: the replan widens that foot's box by the displacement it cannot undo (and no other) and
    converges; without the widening the last samples' boxes are infeasible (the solve stalls)."""
    gait = planned.problem.form.gait
    ends = np.cumsum(gait.durations)
    last_swing_end = ends[np.flatnonzero(~gait.stance.all(axis=1)).max()]
    state = MeasuredState.from_samples(planned.samples, 0.5 * (last_swing_end + gait.duration))
    feet = state.feet_pos.copy()
    feet[0, 0] += SLIP
    slipped = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel, state.base_ang_vel, feet)
    out = replan(planned, slipped, anymal, flat, DynParams())
    assert out.success, out.plan.reason
    boxes = [c for c in out.plan.problem.constraints if c.name == "range_of_motion"]
    nominal = next(c for c in planned.problem.constraints if c.name == "range_of_motion").upper[:3]
    assert boxes[0].upper[-3] == pytest.approx(nominal[0] + SLIP, abs=0.01)
    assert all(np.allclose(c.upper[-3:], nominal) for c in boxes[1:])


def _standing(planned, t):
    """The plan's state at t and the legs in stance there (none in the air)."""
    state = MeasuredState.from_samples(planned.samples, t)
    _, airborne = remaining_gait(planned.problem.form.gait, state.t)
    return state, np.flatnonzero(~airborne)


def test_a_leg_standing_by_a_wall_keeps_its_clearance_deficit_through_its_stance(planned, anymal):
    """A pillar measured 1 cm beside a standing foot (outside it): the shank's spheres cannot clear it
    while the foot stands, so the leg's clearance rows keep the deficit the measured state has at t
    through that stance (the spheres where they were measured meet them) and the plain bound after its
    lift-off; the other legs' rows are the plain ones."""
    from legplan.dyn.terrain import TerrainModel
    from legplan.terrain import Grid2D, terrain_from_heightmap

    state, standing = _standing(planned, 1.0)
    leg = int(standing[-1])  # a hind leg: its shank leans out over the pillar
    foot = state.feet_pos[leg]
    side = np.sign(anymal.nominal_feet[leg, 1])
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.01, shape=(201, 351))
    x, y = grid.centres()
    pillar = (np.abs(x - foot[0]) < 0.05) & (side * (y - foot[1]) > 0.01) & (side * (y - foot[1]) < 0.08)
    wall = TerrainModel(terrain_from_heightmap(np.where(pillar, 0.3, 0.0), grid, name="pillar"))
    out = replan(planned, state, anymal, wall, DynParams())
    rows = [c for c in out.plan.problem.constraints if c.name == "leg_clearance"]
    assert len(rows) == 4
    bound = DynParams().leg_clearance
    c = rows[leg]
    times = c.block.times
    lower = np.asarray(c.lower, float).reshape(times.size, -1)
    lift_off = out.plan.problem.form.feet[leg].phases[0].t1
    assert lower[0].min() < bound - 0.005  # a deficit at t
    assert np.all(lower[times <= lift_off + 1e-9] == lower[0])  # kept through the stance
    assert np.all(lower[times > lift_off + 1e-9] == bound)
    assert all(np.all(np.asarray(k.lower) == bound) for i, k in enumerate(rows) if i != leg)


class _Rows:
    """A residual block c(x) = x on one variable, for the scaled violation."""

    def __init__(self, name, size):
        self.variables, self.size = [name], size

    def evaluate(self, values, jacobians):
        return np.asarray(values[0], float), None


def test_scaled_violation_weighs_every_row_by_its_scale():
    """Rows of different units on one scale: 3 N over a bound scaled per 300 N weighs 0.01, 2 mm
    over a bound scaled per 0.1 m weighs 0.02; rows within their bounds weigh nothing."""
    from legplan.dyn.replan import scaled_violation
    from legplan.solve.auglag import Constraint

    force = Constraint(_Rows("f", 2), -np.inf, 100.0, "force", scale=1.0 / 300.0)
    length = Constraint(_Rows("p", 3), [-0.1, -0.1, 0.0], 0.1, "range", scale=1.0 / 0.1)
    values = {"f": np.array([103.0, 50.0]), "p": np.array([0.0, -0.102, 0.05])}
    assert scaled_violation([force, length], values) == pytest.approx(0.02)
    values["p"][1] = 0.0
    assert scaled_violation([force, length], values) == pytest.approx(0.01)
    values["f"][0] = 99.0
    assert scaled_violation([force, length], values) == 0.0


def test_capture_step_is_the_pendulum_offset_within_the_box():
    from legplan.dyn.capture import capture_step

    tau = np.sqrt(0.42 / 9.81)
    limit = np.array([0.15, 0.10, 0.0])
    shift = capture_step([0.2, -0.3, 0.5], tau, limit)
    assert np.allclose(shift, [0.2 * tau, -0.3 * tau, 0.0])
    assert np.allclose(capture_step([2.0, -3.0, 0.0], tau, limit, gain=0.5), [0.15, -0.10, 0.0])
    assert not capture_step([0.0, 0.0, 1.0], tau, limit).any()


def test_step_adaptation_moves_each_next_foothold_onto_the_terrain(planned, anymal, step):
    """The guess's second stance of every foot moves by the step (z the terrain's height there),
    the apex before it by half; the first stance and the later nodes stay the previous plan's."""
    from legplan.dyn.formulation import Formulation

    previous = Previous.from_plan(planned)
    t = 1.0
    rest, _ = remaining_gait(previous.form.gait, t)
    form = Formulation(rest, 0.1)
    shift = np.array([0.6, -0.05])  # onto the 10 cm step for the feet that land at x >= 0.5 - 0.6
    kept = ShiftedInit(previous, t)(form, anymal, step, None, None, None)["feet"].reshape(-1, 2, 3)
    moved = ShiftedInit(previous, t, shift)(form, anymal, step, None, None, None)["feet"].reshape(-1, 2, 3)
    changed = np.zeros(len(kept), bool)
    for foot in form.feet:
        node, apex = foot.stance_nodes[1], foot.swing_nodes[0]
        xy = kept[node, 0, :2] + shift
        assert np.allclose(moved[node, 0, :2], xy)
        assert moved[node, 0, 2] == pytest.approx(float(step.height(xy[:1], xy[1:])[0]))
        assert np.allclose(moved[apex, 0, :2], kept[apex, 0, :2] + 0.5 * shift)
        changed[[node, apex]] = True
    assert np.array_equal(moved[~changed], kept[~changed])
    assert np.array_equal(moved[:, 1], kept[:, 1])


def test_a_pushed_replan_with_step_adaptation_starts_from_the_measured_state(planned, anymal, flat):
    """With `step_adaptation` the replan still starts where the robot is and ends at the goal."""
    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos + [0.0, 0.02, 0.0], state.base_euler,
                           state.base_vel + [0.0, 0.3, 0.0], state.base_ang_vel, state.feet_pos)
    out = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(step_adaptation=1.0))
    assert out.success, out.plan.reason
    assert 0.0 <= out.scaled_violation <= 1e-3 * 10.0  # converged: rows within 1e-3 in their units, scales ≤ 10
    s = out.plan.samples
    assert np.allclose(s["base_vel"][0], pushed.base_vel, atol=1e-9)
    assert np.allclose(s["base_pos"][-1, :2], planned.samples["base_pos"][-1, :2], atol=1e-6)


def test_a_window_samples_its_rows_within_it_and_keeps_the_rest(planned, anymal, flat):
    """`ReplanParams.window`: no constraint row sampled after the window, nothing frozen; after the
    window's last knot the plan stays the previous one but for what the knots' continuity rows
    carry over (fading), before it the plan starts from the pushed state."""
    state = MeasuredState.from_samples(planned.samples, 0.6)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.2, 0.0],
                           state.base_ang_vel, state.feet_pos)
    window = 0.8
    out = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(window=window))
    assert out.success, out.plan.reason
    problem = out.plan.problem
    assert problem.task.sample_until == window and problem.task.tail.until is None
    times = [c.block.times for c in problem.constraints if getattr(c.block, "times", None) is not None]
    assert times and max(t.max(initial=0.0) for t in times) <= window + 1e-9
    whole = replan(planned, pushed, anymal, flat, DynParams())
    assert sum(c.block.size for c in problem.constraints) < 0.6 * sum(c.block.size for c in whole.plan.problem.constraints)
    knots = problem.form.knots
    last = knots[np.searchsorted(knots, window - 1e-9) + 1]  # the end of the last polynomial a row reads
    s = out.plan.samples
    before = _previous_at(planned, out.plan, state.t)
    after = s["t"] > last + 1e-9
    assert after.sum() > 10
    moved = (s["t"] > 0.05) & (s["t"] < window)
    change = np.abs(s["base_pos"] - before["base_pos"]).max(axis=1)
    assert change[moved].max() > 0.01
    assert change[after].max() < 0.2 * change[moved].max()
    assert change[s["t"] > s["t"][-1] - 0.5].max() < 1e-4
    assert np.allclose(s["base_vel"][0], pushed.base_vel, atol=1e-9)
    both = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(window=window, horizon=0.4))
    assert both.plan.problem.task.sample_until == min(window, both.plan.problem.task.tail.until)


def test_a_capped_replan_linearizes_once_per_iteration(planned, anymal, flat, monkeypatch):
    """A replan capped at k LM iterations evaluates k Jacobians (none at the point it stops at) and,
    with geodesic acceleration off, one residual per step; with the solver's, one more per step."""
    from legplan.solve.problem import Problem

    calls = {"jacobian": 0, "residual": 0}
    # the curvature probe evaluates only the rows it reads (`Problem.residual_rows`): a residual too
    for name, key in (("nonzero_jacobian", "jacobian"), ("residual", "residual"), ("residual_rows", "residual")):
        original = getattr(Problem, name)

        def counted(self, theta, *rest, _original=original, _key=key):
            calls[_key] += 1
            return _original(self, theta, *rest)
        monkeypatch.setattr(Problem, name, counted)
    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.3, 0.0],
                           state.base_ang_vel, state.feet_pos)
    for k in (1, 2):
        calls.update(jacobian=0, residual=0)
        out = replan(planned, pushed, anymal, flat, DynParams(),
                     settings=ReplanParams(max_iterations=k, geodesic_acceleration=0.0))
        assert out.iterations == k and out.status.name == "MAX_ITERATIONS"
        assert calls == {"jacobian": k, "residual": k}
    calls.update(jacobian=0, residual=0)
    replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(max_iterations=1))  # the solver's α > 0
    assert DynParams().projection_solver.inner.geodesic_acceleration > 0
    assert calls == {"jacobian": 1, "residual": 2}


def test_the_solvers_scaled_violation_is_the_replans(planned, anymal, flat):
    """`ReplanResult.scaled_violation` (the solver's, from its last evaluation) equals the rows
    evaluated again at the replan's values."""
    from legplan.dyn.replan import scaled_violation

    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.3, 0.0],
                           state.base_ang_vel, state.feet_pos)
    out = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(max_iterations=1))
    again = scaled_violation(out.plan.problem.constraints, out.plan.solve.values)
    assert again > 1e-4  # one iteration from a push leaves rows off
    assert out.scaled_violation == pytest.approx(again, rel=1e-12)


def test_a_replan_stops_once_every_row_is_within_its_scaled_tolerance(planned, anymal, flat):
    """`ReplanParams.scaled_tolerance`: a pushed replan converges in fewer iterations than with the
    solver's 1e-3 in every row's own units (N for the forces), every row within its own tolerance."""
    from legplan.solve.auglag import row_tolerances

    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.3, 0.0],
                           state.base_ang_vel, state.feet_pos)
    strict = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(scaled_tolerance=0.0))
    loose = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(scaled_tolerance=1e-3))
    assert strict.success and loose.success, (strict.reason, loose.reason)
    assert loose.iterations < strict.iterations
    assert strict.violation <= 1e-3 < loose.violation  # a force row keeps more than 1e-3 N
    constraints, values = loose.plan.problem.constraints, loose.plan.solve.values
    tolerances = row_tolerances(constraints, replace(DynParams().projection_solver, scaled_tolerance=1e-3))
    for k, tolerance in zip(constraints, tolerances):
        if k.block.size:
            c = k.block.evaluate([values[v] for v in k.block.variables], False)[0]
            assert np.all(k.violation(np.asarray(c)) <= tolerance), k.name


def test_a_replan_out_of_cpu_time_ends_where_its_solve_is(planned, anymal, flat):
    """`ReplanParams.cpu_budget` spent before the first LM step (building took it): the replan stops
    with `Status.TIME_LIMIT` and no iteration, its plan the shifted guess from the measured state; a
    budget of 0 or less is refused."""
    from legplan.errors import LegplanError
    from legplan.solve.lm import Status

    state = MeasuredState.from_samples(planned.samples, 1.0)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 0.3, 0.0],
                           state.base_ang_vel, state.feet_pos)
    out = replan(planned, pushed, anymal, flat, DynParams(), settings=ReplanParams(cpu_budget=1e-9))
    assert out.status is Status.TIME_LIMIT and out.iterations == 0 and not out.success
    assert out.record()["status"] == "time_limit" and "CPU time" in out.reason
    assert np.allclose(out.plan.samples["base_vel"][0], pushed.base_vel, atol=1e-9)
    assert np.allclose(out.plan.samples["base_pos"][0], pushed.base_pos, atol=1e-9)
    with pytest.raises(LegplanError, match="cpu_budget"):
        ReplanParams(cpu_budget=0.0)


def test_early_touchdown_lands_the_feet_in_the_air_and_keeps_the_rest():
    """A foot in the air at t lands at `swing` and stands to its planned touchdown: the phase holding
    `swing` is split there, every other flag, the total duration and every later lift-off unchanged;
    a foot that lands sooner as planned, or none in the air, leaves the gait as it is."""
    from legplan.dyn.rest_gait import early_touchdown

    gait = make_gait("walk", 2, 3.0)
    ends = np.cumsum(gait.durations)
    k = next(k for k in range(1, len(ends)) if not gait.stance[k].all())
    rest, airborne = remaining_gait(gait, ends[k - 1] + 0.01)  # just after a lift-off
    (leg,) = np.flatnonzero(airborne)
    landed = early_touchdown(rest, airborne, 0.12)
    assert landed.duration == pytest.approx(rest.duration)
    assert len(landed.durations) == len(rest.durations) + 1
    assert landed.contact(np.array([0.119]))[0, leg] == False  # noqa: E712 (numpy bool)
    hold, swing, stance = rest.foot_phases(leg)[:3]
    assert hold.stance and not swing.stance and stance.stance
    planned_touchdown = stance.t0
    assert landed.contact(np.array([0.121, 0.5 * (0.12 + planned_touchdown)]))[:, leg].all()
    later = np.linspace(planned_touchdown + 1e-3, rest.duration - 1e-3, 200)
    assert np.array_equal(landed.contact(later), rest.contact(later))
    others = np.ones(len(airborne), bool)
    others[leg] = False
    every = np.linspace(1e-3, rest.duration - 1e-3, 400)
    assert np.array_equal(landed.contact(every)[:, others], rest.contact(every)[:, others])
    late_in_swing, in_air = remaining_gait(gait, ends[k - 1] + 0.01 + planned_touchdown - 0.05)  # lands in 0.05 s
    assert in_air[leg]
    times = np.linspace(1e-3, late_in_swing.duration - 1e-3, 400)
    kept = early_touchdown(late_in_swing, in_air, 0.12).contact(times)[:, leg]
    assert np.array_equal(kept, late_in_swing.contact(times)[:, leg])
    standing, none = remaining_gait(gait, 0.5 * ends[0])
    assert not none.any() and early_touchdown(standing, none, 0.12) is standing


def test_a_pushed_replan_recovers_and_an_unpushed_one_does_not(planned, anymal, flat):
    """`ReplanParams.recovery_velocity`: a measured CoM velocity that far from the plan's lands the foot
    in the air within `recovery_swing` (its plan in stance from there); just below it, or with the
    recovery off, the foot keeps its planned swing. Either way the replan ends at the goal."""
    from legplan.dyn.replan import recovering, velocity_error

    state = _state_in_swing(planned, 0.1)
    previous = Previous.from_plan(planned)
    assert np.abs(velocity_error(previous, state)).max() < 0.05  # the plan's own state
    push = np.array([0.0, 0.3, 0.0])
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + push, state.base_ang_vel,
                           state.feet_pos)
    error = velocity_error(previous, pushed)
    settings = ReplanParams(recovery_velocity=0.2, recovery_swing=0.12)
    assert recovering(error, settings)
    assert not recovering(error, replace(settings, recovery_velocity=1.01 * np.hypot(*error[:2])))
    assert not recovering(error, replace(settings, recovery_velocity=None))
    (leg,) = np.flatnonzero(remaining_gait(previous.form.gait, state.t)[1])
    outcomes = {}
    for name, chosen in (("recovers", settings), ("off", replace(settings, recovery_velocity=None))):
        out = replan(planned, pushed, anymal, flat, DynParams(), settings=chosen)
        assert out.success, (name, out.plan.reason)
        assert out.recovery == (name == "recovers") and out.record()["recovery"] == out.recovery
        s = out.plan.samples
        assert np.allclose(s["base_pos"][-1, :2], planned.samples["base_pos"][-1, :2], atol=1e-6)
        outcomes[name] = s["contact"][np.searchsorted(s["t"], [0.13, 0.2]), leg]
    assert outcomes["recovers"].all() and not outcomes["off"].any()


def test_a_gaits_stride_is_its_repeated_run_of_phases():
    from legplan.dyn.rest_gait import gait_stride

    trot = gait_stride(make_gait("trot", 4, 2.4, DynParams().line_support))
    assert trot.stance.sum(axis=1).tolist() == [2, 0, 2, 0] and trot.duration == pytest.approx(0.6)
    walk = gait_stride(make_gait("walk", 4, 5.5))
    assert len(walk.durations) == 8 and walk.duration == pytest.approx(5.5 / 4, rel=0.1)
    lift_offs = (walk.stance & ~np.roll(walk.stance, -1, axis=0)).sum(axis=0)
    assert lift_offs.tolist() == [1, 1, 1, 1]  # each foot swings once a stride
    assert gait_stride(make_gait("walk", 1, 2.0)) is None


def test_inserted_strides_keep_the_order_of_steps_and_map_onto_the_stride_before():
    """Strides go in before the last phase that starts one, so every foot's steps alternate as
    before; the inserted time maps onto the stride before it, the rest after it onto its own time."""
    from legplan.dyn.rest_gait import gait_stride, insert_strides

    gait = make_gait("trot", 4, 2.4, DynParams().line_support)
    stride = gait_stride(gait)
    rest, _ = remaining_gait(gait, 1.2)
    longer, ins = insert_strides(rest, stride, 2)
    assert longer.duration == pytest.approx(rest.duration + 1.2) and ins.length == pytest.approx(1.2)
    for leg in range(4):  # the same alternation of stance and swing per foot, two more steps
        before, after = rest.foot_phases(leg), longer.foot_phases(leg)
        assert len(after) == len(before) + 4 and all(a.stance != b.stance for a, b in zip(after, after[1:]))
    assert np.array_equal(longer.stance[-2:], rest.stance[-2:])  # the last pair and the Stand stay last
    times = np.array([0.1, ins.at + 0.05, ins.at + 0.65, ins.at + 1.25])
    assert ins.previous_time(times) == pytest.approx([0.1, ins.at - 0.55, ins.at - 0.55, ins.at + 0.05])
    assert insert_strides(rest, stride, 0) == (rest, None)


def test_recovery_time_is_the_pendulums_stop_and_walk_back_at_the_feets_reach(anymal):
    from legplan.dyn.constraints import GRAVITY
    from legplan.dyn.capture import recovery_time

    reach = anymal.range_of_motion[1]
    expected = (1 + np.sqrt(2)) * 1.2 * anymal.base_height / (GRAVITY * reach)
    assert recovery_time(np.array([0.0, -1.2, 0.3]), anymal) == pytest.approx(expected)
    assert recovery_time(np.array([1.2, 0.0, 0.0]), anymal) < expected  # the box reaches further along x
    assert recovery_time(np.zeros(3), anymal) == 0.0


def test_a_pushed_replan_inserts_strides_within_its_extension(trot4, anymal, flat):
    """A trot pushed sideways at 1 m/s mid-plan with `extension` 1.2 s: the recovering replan inserts
    two 0.6 s strides (its `recovery_time` asks more), starts from the measured state, ends at the
    same goal 1.2 s later and converges; a plan already extended by the whole allowance inserts none."""
    state = MeasuredState.from_samples(trot4.samples, 1.2)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 1.0, 0.0],
                           state.base_ang_vel, state.feet_pos)
    previous = Previous.from_plan(trot4)
    out = replan(previous, pushed, anymal, flat, DynParams(), settings=ReplanParams(extension=1.2))
    assert out.recovery and out.extension == pytest.approx(1.2)
    s = out.plan.samples
    assert s["t"][-1] == pytest.approx(2.4 - pushed.t + 1.2)
    assert np.allclose(s["base_vel"][0], pushed.base_vel, atol=1e-9)
    assert np.allclose(s["base_pos"][-1, :2], trot4.samples["base_pos"][-1, :2], atol=1e-6)
    assert np.all(np.diff(out.plan.problem.form.knots) > 0)
    assert out.status.name in ("CONVERGED", "MAX_ITERATIONS"), out.plan.reason
    spent = replace(previous, extended=1.2)
    assert replan(spent, pushed, anymal, flat, DynParams(), settings=ReplanParams(extension=1.2)).extension == 0.0
    assert replan(previous, pushed, anymal, flat, DynParams()).extension == 0.0  # off by default


def test_a_pushed_trot_replans_without_flights(trot4, anymal, flat):
    """`ReplanParams.recovery_support`: a flying trot pushed sideways at 1 m/s recovers on a rest
    without a flight (every phase stands on some foot), its strides still inserted with `extension`
    and its end and goal kept; with it off, or unpushed, the rest keeps the plan's flights."""
    state = MeasuredState.from_samples(trot4.samples, 1.2)
    pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0.0, 1.0, 0.0],
                           state.base_ang_vel, state.feet_pos)

    def flights(out):
        return int((~out.plan.problem.form.gait.stance.any(axis=1)).sum())

    grounded = replan(trot4, pushed, anymal, flat, DynParams())
    assert grounded.recovery and flights(grounded) == 0
    assert grounded.plan.samples["t"][-1] == pytest.approx(2.4 - pushed.t)
    assert np.allclose(grounded.plan.samples["base_pos"][-1, :2], trot4.samples["base_pos"][-1, :2], atol=1e-6)
    assert grounded.status.name in ("CONVERGED", "MAX_ITERATIONS"), grounded.plan.reason
    extended = replan(trot4, pushed, anymal, flat, DynParams(), settings=ReplanParams(extension=1.2))
    assert extended.extension == pytest.approx(1.2) and flights(extended) == 0
    assert flights(replan(trot4, pushed, anymal, flat, DynParams(), settings=ReplanParams(recovery_support=False))) > 0
    assert flights(replan(trot4, state, anymal, flat, DynParams())) > 0


def test_grounded_flights_stand_every_flight_of_the_rest():
    """`grounded_flights`: every phase after the first with no foot down stands on every foot, the
    durations and every other phase unchanged; a rest without flights (a walk) is left as it is, and
    so is a first phase in the air."""
    from legplan.dyn.rest_gait import grounded_flights

    gait = make_gait("trot", 4, 2.4)
    ends = np.cumsum(gait.durations)
    flights = np.flatnonzero(~gait.stance.any(axis=1))
    assert flights.size >= 3
    rest, _ = remaining_gait(gait, ends[flights[0]] + 0.01)  # just after the first pair lands
    grounded = grounded_flights(rest)
    assert np.array_equal(grounded.durations, rest.durations)
    flying = ~rest.stance.any(axis=1)
    assert flying[1:].any() and grounded.stance[flying].all()
    assert np.array_equal(grounded.stance[~flying], rest.stance[~flying])
    assert not (~grounded.stance.any(axis=1)).any()
    in_flight, _ = remaining_gait(gait, ends[flights[0] - 1] + 0.01)  # in a flight: its hold stands
    assert in_flight.stance[0].all()
    walk, _ = remaining_gait(make_gait("walk", 2, 3.0), 0.5)
    assert grounded_flights(walk) is walk


def test_a_late_foot_swings_down_and_stands_to_its_planned_lift_off():
    """`remaining_gait(lifted=...)`: a foot its plan has in stance at t but which is in the air (a
    late touchdown) is held, swings `late_swing` and stands from there to its planned lift-off; the
    other feet, the total duration and everything after that lift-off are unchanged. With less than
    `late_swing` left of its stance it swings on into its planned swing."""
    gait = make_gait("trot", 4, 2.4)
    ends = np.cumsum(gait.durations)
    k = next(k for k in range(1, len(ends)) if 0 < gait.stance[k].sum() < 4)  # the first pair's stance
    t = ends[k - 1] + 0.05
    (leg, other) = np.flatnonzero(gait.stance[k])
    lifted = np.zeros(4, bool)
    lifted[leg] = True
    rest, airborne = remaining_gait(gait, t, hold=0.02, lifted=lifted, late_swing=0.05)
    plain, _ = remaining_gait(gait, t, hold=0.02)
    assert np.array_equal(airborne, lifted | ~gait.stance[k])
    assert rest.duration == pytest.approx(plain.duration)
    assert rest.stance[0].all() and rest.durations[0] == pytest.approx(0.02)
    lift_off = ends[k] - t
    contact = rest.contact(np.array([0.021, 0.069, 0.071, lift_off - 1e-3, lift_off + 1e-3]))[:, leg]
    assert list(contact) == [False, False, True, True, False]
    after = np.linspace(0.02 + 1e-3, rest.duration - 1e-3, 500)
    assert np.array_equal(rest.contact(after)[:, other], plain.contact(after)[:, other])
    later = after[after > lift_off + 1e-3]
    assert np.array_equal(rest.contact(later), plain.contact(later))
    short, _ = remaining_gait(gait, ends[k] - 0.04, hold=0.01, lifted=lifted, late_swing=0.05)
    times = np.linspace(0.01 + 1e-3, 0.1, 50)
    assert not short.contact(times)[:, leg].any()


def test_lifted_feet_are_planned_down_sensed_up_and_above_the_terrain(flat):
    """`lifted_feet`: a stance foot the measured state senses out of contact and above the terrain
    by more than the height; not a foot in contact, not one within the height, not a swing foot,
    and none without sensing or with the height None."""
    from legplan.dyn.replan import lifted_feet

    gait = make_gait("trot", 4, 2.4)
    ends = np.cumsum(gait.durations)
    k = next(k for k in range(1, len(ends)) if 0 < gait.stance[k].sum() < 4)
    t = ends[k - 1] + 0.05
    feet = np.array([[0.3, 0.2, 0.0], [0.3, -0.2, 0.0], [-0.3, 0.2, 0.0], [-0.3, -0.2, 0.0]])
    feet[:, 2] = [0.05, 0.005, 0.05, 0.05]
    sensed = np.array([False, False, True, False])
    state = MeasuredState(t, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), feet, sensed)
    expected = gait.stance[k] & ~sensed & (feet[:, 2] > 0.01)
    assert expected.any()
    assert np.array_equal(lifted_feet(gait, state, flat, 0.01), expected)
    assert not lifted_feet(gait, state, flat, None).any()
    unsensed = MeasuredState(t, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), feet)
    assert not lifted_feet(gait, unsensed, flat, 0.01).any()


def test_a_replan_lands_a_late_foot_from_where_it_is(planned, anymal, flat):
    """A walk's foot measured 4 cm above its foothold and out of contact while its plan stands on it
    (a late touchdown). Taken as in stance (`touchdown_height` None) the replan stands it on the
    terrain at once, 4 cm from where it is, and pushes on it from t: a support the robot does not
    have. Taken as in the air it starts where it is with no force, swings down within `late_swing`
    and stands on the terrain from there; the replan converges."""
    gait = planned.problem.form.gait
    state = MeasuredState.from_samples(planned.samples, 0.05)  # every foot down, the first to lift at 0.256 s
    leg = 3
    assert gait.contact(np.array([0.05, 0.3]))[:, leg].all()
    feet = state.feet_pos.copy()
    feet[leg, 2] += 0.04
    contact = np.ones(4, bool)
    contact[leg] = False
    late = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel, state.base_ang_vel, feet, contact)
    landing = AIRBORNE_HOLD + ReplanParams.late_swing
    stays = replan(planned, late, anymal, flat, DynParams(), settings=ReplanParams(touchdown_height=None)).plan.samples
    early = stays["t"] < landing - 1e-6
    assert stays["contact"][early, leg].all() and abs(stays["feet_pos"][0, leg, 2]) < 1e-3
    assert stays["forces"][early, leg, 2].max() > 10.0
    out = replan(planned, late, anymal, flat, DynParams(), settings=ReplanParams())
    assert out.success, out.plan.reason
    s = out.plan.samples
    early = s["t"] < landing - 1e-6
    assert np.allclose(s["feet_pos"][0, leg], feet[leg], atol=1e-6)
    assert not s["contact"][early, leg].any() and np.abs(s["forces"][early, leg]).max() < 1e-6
    down = s["contact"][:, leg] & ~early
    assert down.any() and np.abs(s["feet_pos"][down, leg, 2]).max() < 1e-3
