"""Base knots of the formulation: phase-aligned, short polynomials where the summed force vanishes."""

import numpy as np
import pytest

from legplan.dyn.formulation import Formulation, phase_knots, unloaded_phases
from legplan.dyn.gait import make_gait


def test_a_trots_support_pairs_are_unloaded_its_stands_and_flights_are_not():
    gait = make_gait("trot", 4, 2.4)
    feet = gait.stance.sum(axis=1)
    flags = unloaded_phases(gait)
    np.testing.assert_array_equal(flags, feet == 2)  # every diagonal pair ends or starts with a flight
    assert not unloaded_phases(make_gait("walk", 4, 3.5)).any()  # a walk hands its load from foot to foot


def test_a_stride_without_flight_still_unloads_at_the_exchange():
    """A diagonal pair handing over straight to the other pair (no flight): every contact is made or
    broken at the exchange, so both pairs are unloaded phases; a three-leg phase before a pair is not."""
    from legplan.dyn.gait import Gait

    stance = np.array([[1, 1, 1, 1], [1, 0, 0, 1], [0, 1, 1, 0], [1, 1, 1, 1]], bool)
    flags = unloaded_phases(Gait("t", np.array([0.2, 0.3, 0.3, 0.2]), stance))
    np.testing.assert_array_equal(flags, [False, True, True, False])
    stance = np.array([[1, 1, 1, 0], [1, 0, 0, 1], [1, 1, 1, 1]], bool)
    np.testing.assert_array_equal(unloaded_phases(Gait("w", np.array([0.2, 0.3, 0.2]), stance)), [False, False, False])


@pytest.mark.parametrize("polynomials", [4, 16])
def test_unloaded_phases_get_their_polynomials_at_every_phase_boundary(polynomials):
    gait = make_gait("trot", 4, 2.4)
    knots = Formulation(gait, 0.1, unloaded_polynomials=polynomials).knots
    np.testing.assert_allclose(knots, phase_knots(gait, 0.1, polynomials))
    bounds = np.concatenate([[0.0], np.cumsum(gait.durations)])
    assert np.abs(knots[:, None] - bounds[None]).min(axis=0).max() < 1e-12  # every boundary is a knot
    for t0, t1, unloaded in zip(bounds[:-1], bounds[1:], unloaded_phases(gait)):
        inside = knots[(knots >= t0 - 1e-12) & (knots <= t1 + 1e-12)]
        width = np.diff(inside)
        assert width == pytest.approx(np.full(width.size, width[0]))  # equal polynomials
        assert width.size == (polynomials if unloaded else int(np.ceil((t1 - t0) / 0.1 - 1e-9)))


def test_gaits_without_unloaded_phases_keep_evenly_spaced_knots():
    gait = make_gait("walk", 4, 3.5)
    np.testing.assert_array_equal(Formulation(gait, 0.1, unloaded_polynomials=16).knots, Formulation(gait, 0.1).knots)
    assert Formulation(gait, 0.1).knots == pytest.approx(np.linspace(0.0, 3.5, 36))


def test_heuristic_forces_of_a_support_pair_carry_the_weight_over_it_and_its_flights(anymal, flat):
    """The heuristic's summed force over an unloaded phase is a bump from zero to zero whose impulse
    is m·g over the phase and half of each flight next to it (what the base needs to end where it
    started); a walk's forces stay the weight shared over the feet down."""
    from legplan.dyn.init import heuristic
    from legplan.dyn.problem import DynParams, DynTask, build_problem

    task = DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 2.4)
    problem = build_problem(task, anymal, flat, DynParams(), heuristic)
    form = problem.form
    forces = next(v.value for v in problem.variables if v.name == "forces").reshape(-1, 3)
    gait = form.gait
    bounds = np.concatenate([[0.0], np.cumsum(gait.durations)])
    k = int(np.flatnonzero(unloaded_phases(gait))[1])  # a pair between two flights
    t = np.linspace(bounds[k], bounds[k + 1], 2001)
    total = sum(form.force_matrix(leg, t) @ forces for leg in range(form.legs))[:, 2]
    impulse = np.sum(0.5 * (total[1:] + total[:-1]) * np.diff(t))
    carried = gait.durations[k] + 0.5 * (gait.durations[k - 1] + gait.durations[k + 1])
    assert impulse == pytest.approx(anymal.mass * 9.81 * carried, rel=1e-6)
    assert abs(total[0]) < 1e-9 and abs(total[-1]) < 1e-9 and total.min() >= 0.0


def test_moving_phases_get_evenly_spaced_knots_as_dense_as_the_shortest_unloaded_phase():
    """With optimize_phases (or a guess that sets the timing) the phases leave their boundaries, so the
    knots are spaced evenly at the shortest unloaded phase's polynomial length; a walk keeps TOWR's."""
    from dataclasses import replace

    from legplan.dyn.problem import DynTask, task_formulation
    from legplan.dyn.settings import DynParams

    params = replace(DynParams(), optimize_phases=True)
    task = DynTask((0, 0, 0), (1, 0, 0), "trot", 4, 2.4)
    gait = make_gait("trot", 4, 2.4)
    for form in (task_formulation(task, params), task_formulation(task, DynParams(), timed=True)):
        steps = np.diff(form.knots)
        np.testing.assert_allclose(steps, steps[0])
        assert steps[0] <= gait.durations[unloaded_phases(gait)].min() / params.unloaded_polynomials + 1e-12
        assert form.knots[0] == 0.0 and form.knots[-1] == pytest.approx(gait.duration)
    fixed = task_formulation(task, DynParams())
    assert not np.allclose(np.diff(fixed.knots), np.diff(fixed.knots)[0])  # phase-aligned without them
    walk = task_formulation(DynTask((0, 0, 0), (1, 0, 0), "walk", 4, 3.5), params)
    np.testing.assert_allclose(np.diff(walk.knots), 0.1)


def test_heuristic_base_hops_with_its_forces(anymal, flat):
    """The heuristic's base height follows its force guess (m z̈ = Σf_z − m g, to the spline's
    resolution) over a flying trot: it falls freely in the flights and rises on each pair's bump, the
    hop vanishing at the start and the end; a walk's base guess stays level."""
    from legplan.dyn.init import heuristic
    from legplan.dyn.problem import DynParams, DynTask, build_problem

    problem = build_problem(DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 2.4), anymal, flat, DynParams(), heuristic)
    form, values = problem.form, {v.name: v.value for v in problem.variables}
    forces = values["forces"].reshape(-1, 3)
    t = np.linspace(0.6, form.duration - 0.6, 400)  # the strides between the first and the last pair
    total = sum(form.force_matrix(leg, t) @ forces for leg in range(form.legs))[:, 2]
    z_acc = (form.base_matrix(t, 2) @ values["base_lin"].reshape(-1, 3))[:, 2]
    weight = anymal.mass * 9.81
    residual = np.abs(anymal.mass * z_acc - (total - weight))
    assert residual.max() < 0.03 * weight  # a level base would leave the whole bump (up to ~m·g)
    flight = form.gait.contact(t).sum(axis=1) == 0
    assert flight.any() and np.all(z_acc[flight] < -0.5 * 9.81)  # it falls in the flights
    z = (form.base_matrix(np.array([0.0, form.duration])) @ values["base_lin"].reshape(-1, 3))[:, 2]
    assert z[0] == pytest.approx(problem.variables[0].value[2], abs=1e-9)
    walk = build_problem(DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "walk", 4, 3.5), anymal, flat, DynParams(), heuristic)
    lin = next(v.value for v in walk.variables if v.name == "base_lin").reshape(-1, 2, 3)
    np.testing.assert_allclose(lin[:, 0, 2], lin[0, 0, 2]) and np.testing.assert_allclose(lin[:, 1, 2], 0.0)


def test_a_slow_trots_pairs_hand_over_at_knots_and_a_walk_keeps_even_knots():
    """A trot cut to `line_support` hands its diagonal pairs over through four-leg support: no phase is
    unloaded, yet two feet make or break contact at every boundary (`pair_switches`), so every
    boundary is a knot; a walk changes one foot at a time and keeps TOWR's even knots."""
    from legplan.dyn.formulation import pair_switches

    slow = make_gait("trot", 4, 3.5, line_support=0.343)
    assert (slow.stance.sum(axis=1) == 4).sum() > 2 and not unloaded_phases(slow).any()
    assert pair_switches(slow).all()
    knots = Formulation(slow, 0.1, unloaded_polynomials=8).knots
    bounds = np.concatenate([[0.0], np.cumsum(slow.durations)])
    assert np.abs(knots[:, None] - bounds[None]).min(axis=0).max() < 1e-12
    assert np.diff(knots).max() <= 0.1 + 1e-12
    walk = make_gait("walk", 4, 5.5, line_support=0.343)
    assert not pair_switches(walk).any()
    assert Formulation(walk, 0.1, unloaded_polynomials=8).knots == pytest.approx(np.linspace(0.0, 5.5, 56))


def test_node_selector_is_scipys_csr_of_the_picked_columns():
    """`Formulation.node_selector` (its CSR written down directly) equals scipy's COO → CSR of one 1
    per row at column 2·node + derivative, array by array, dtypes included; a node outside the
    spline is refused."""
    import scipy.sparse as sp

    nodes = [4, 0, 2, 2, 7]
    for derivative in (0, 1):
        m = Formulation.node_selector(nodes, 8, derivative)
        m.check_format(full_check=True)
        expected = sp.csr_matrix((np.ones(len(nodes)), (np.arange(len(nodes)), 2 * np.array(nodes) + derivative)),
                                 shape=(len(nodes), 16))
        for name in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(m, name), getattr(expected, name))
            assert getattr(m, name).dtype == getattr(expected, name).dtype
    assert Formulation.node_selector([], 3).shape == (0, 6)
    with pytest.raises(ValueError):
        Formulation.node_selector([3], 3)
