"""Eq. (4)'s filter and its auto g_max, eq. (3)'s weighted fit with normalization, init.h5 (no pickle)."""

import h5py
import numpy as np
import pytest

from legplan.errors import LegplanError
from legplan.learn.layout import CATEGORIES, check_layout, join, split
from legplan.learn.network import (DEFAULT_WEIGHTS, FitParams, Network, auto_g_max, filter_good, fit, load_bound,
                                   load_init, output_groups, parallel, save_init)

LAYOUT = {"base_lin": 3, "base_ang": 2, "feet": 2, "forces": 1, "phases": 0}
WITH_PHASES = {**LAYOUT, "phases": 2}


def test_auto_g_max_starts_the_tail_of_a_long_tailed_distribution():
    rng = np.random.default_rng(0)
    body = rng.normal(10.0, 1.0, 700)
    tail = 14.0 + rng.pareto(1.0, 300) * 10.0  # 30 % poor local minima, all beyond the body
    g_max = auto_g_max(np.concatenate([body, tail]))
    assert body.max() < 14.0 and 12.0 < g_max < 14.0
    assert np.mean(body <= g_max) > 0.97 and np.all(tail > g_max)


def test_filter_keeps_converged_tasks_under_g_max_and_refuses_an_empty_result():
    success = np.array([True, True, True, False, True])
    cost = np.array([1.0, 1.1, 50.0, 0.5, 0.9])
    good, bound = filter_good(success, cost, "auto")
    assert good.tolist() == [True, True, False, False, True] and 1.1 <= bound.threshold < 50.0
    assert filter_good(success, np.zeros(5), "auto")[0].tolist() == success.tolist()  # no costs: keep all converged
    with pytest.raises(LegplanError, match="field 'cost'"):
        filter_good(success, cost, 0.1, "d.h5")


def test_auto_filter_finds_the_poor_minima_of_every_task_distance_with_the_task_vectors():
    """Costs that rise steeply for the farthest tasks, 10 % poor local minima 1.0 above their task's
    cost: given x, `auto` cuts the poor minima at every distance; the constant rule cuts far tasks."""
    rng = np.random.default_rng(3)
    n = 600
    u = rng.random(n)  # 0: nearest start, 1: farthest
    x = np.column_stack([-1.0 - u, rng.uniform(-0.7, 0.7, n), rng.uniform(-0.5, 0.5, n),
                         np.full(n, 0.6), np.zeros(n), np.zeros(n)])  # goal fixed: constant columns
    cost = 3.0 + 2.0 * u ** 4 + rng.normal(0.0, 0.05, n)
    poor = rng.random(n) < 0.1
    cost[poor] += 1.0
    success = rng.random(n) > 0.05
    good, bound = filter_good(success, cost, "auto", "d.h5", x)
    assert bound.conditional
    far = u > 0.85
    assert not np.any(good & ~success)
    assert np.mean(good[success & ~poor]) > 0.97 and np.mean(good[success & ~poor & far]) > 0.9
    assert np.mean(good[success & poor]) < 0.1
    assert 0.05 < bound.threshold < 1.0  # a residual over the fit, not a cost
    constant, bound = filter_good(success, cost, "auto", "d.h5")
    assert not bound.conditional
    assert np.mean(constant[success & ~poor & far]) < 0.5
    few = np.flatnonzero(success)[:20]  # too few tasks to fit the quadratic: the constant rule
    mask = np.zeros(n, bool)
    mask[few] = True
    assert not filter_good(mask, cost, "auto", "d.h5", x)[1].conditional
    assert np.array_equal(filter_good(mask, cost, "auto", "d.h5", x)[0], filter_good(mask, cost, "auto", "d.h5")[0])
    assert np.array_equal(filter_good(success, cost, 3.5, "d.h5", x)[0], success & (cost <= 3.5))  # a number: eq. (4)


def _distance_costs(seed=3, n=600):
    """Task vectors and costs as in the test above: rising with the distance, 10 % poor minima."""
    rng = np.random.default_rng(seed)
    u = rng.random(n)
    x = np.column_stack([-1.0 - u, rng.uniform(-0.7, 0.7, n), rng.uniform(-0.5, 0.5, n),
                         np.full(n, 0.6), np.zeros(n), np.zeros(n)])
    cost = 3.0 + 2.0 * u ** 4 + rng.normal(0.0, 0.05, n) + (rng.random(n) < 0.1) * 1.0
    return x, cost, rng.random(n) > 0.05


@pytest.mark.parametrize("g_max", ["auto", 3.6])
def test_cost_bound_is_the_filter_as_a_function_of_the_task(g_max, tmp_path):
    """Every task the filter keeps is within the bound of its x and every converged task it drops
    is above it; the bound of a new task follows the fitted cost; init.h5 keeps it as plain arrays."""
    x, cost, success = _distance_costs()
    good, bound = filter_good(success, cost, g_max, "d.h5", x)
    limits = np.array([bound(row) for row in x])
    assert np.array_equal(good, success & (cost <= limits + 1e-12))
    assert bound(x[0], 2.0) == pytest.approx(limits[0] + bound.threshold)  # the tolerance scales the threshold
    if bound.conditional:
        near, far = x[0].copy(), x[0].copy()
        near[0], far[0] = -1.05, -1.95
        assert bound(far) - bound(near) > 1.0  # 3 + 2u⁴: about 1.6 apart
    else:
        assert np.all(limits == g_max) and bound.coef.size == 0
    rng = np.random.default_rng(0)
    net, report, _ = fit(rng.normal(size=(20, 6)), rng.normal(size=(20, 8)), LAYOUT, DEFAULT_WEIGHTS, (4,), 0, max_iter=5)
    path = tmp_path / "init.h5"
    save_init(path, net, LAYOUT, {"map": "m.yaml"}, report, {}, 0, [], False, bound)
    loaded = load_bound(path)
    assert [loaded(row) for row in x[:20]] == [bound(row) for row in x[:20]]
    save_init(path, net, LAYOUT, {"map": "m.yaml"}, report, {}, 0, [], True)  # trained before: no bound
    assert load_bound(path) is None
    with h5py.File(path, "a") as f:  # a bound whose fit does not match its inputs
        for name in ("mean", "std", "coef"):
            f[f"filter/{name}"] = np.ones(3 if name == "coef" else 6)
        f["filter/threshold"] = 0.5
    with pytest.raises(LegplanError, match="filter/coef"):
        load_bound(path)
    with h5py.File(path, "a") as f:
        del f["filter/mean"]
        f["filter/mean"] = np.ones(5)
    with pytest.raises(LegplanError, match="filter/mean"):
        load_bound(path)


def test_fit_does_not_depend_on_the_blas_thread_count():
    """The same data and seed give the same weights with any number of BLAS threads."""
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(4)
    x, y = rng.normal(size=(200, 6)), rng.normal(size=(200, 1200))  # products large enough to be threaded
    layout = {**LAYOUT, "feet": 1194}
    with threadpool_limits(limits=2):
        two = fit(x, y, layout, DEFAULT_WEIGHTS, (256, 256), seed=0, max_iter=5)[0]
    with threadpool_limits(limits=1):
        one = fit(x, y, layout, DEFAULT_WEIGHTS, (256, 256), seed=0, max_iter=5)[0]
    assert all(np.array_equal(a, b) for a, b in zip(one.weights, two.weights))


def test_join_split_round_trip():
    y = np.arange(8.0)
    parts = split(y, LAYOUT)  # no phase durations: no such entry (the gait's timing stays)
    assert list(parts) == [c for c in CATEGORIES if c != "phases"] and parts["forces"].tolist() == [7.0]
    assert np.array_equal(join(parts), y)
    y = np.arange(10.0)
    parts = split(y, WITH_PHASES)
    assert list(parts) == list(CATEGORIES) and parts["phases"].tolist() == [8.0, 9.0]
    assert np.array_equal(join(parts), y)
    with pytest.raises(LegplanError, match="layout/feet"):
        check_layout(LAYOUT, {**LAYOUT, "feet": 4}, "init.h5")
    check_layout(LAYOUT, WITH_PHASES, "init.h5")  # a network without durations fits a problem with them
    with pytest.raises(LegplanError, match="layout/phases"):
        check_layout({**LAYOUT, "phases": 3}, WITH_PHASES, "init.h5")


def test_init_h5_without_the_phase_category_reads_as_predicting_none(tmp_path):
    """Files written before the fifth category have no layout/phases."""
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(20, 6)), rng.normal(size=(20, 10))
    net, report, _ = fit(x, y, WITH_PHASES, DEFAULT_WEIGHTS, (4, 4), seed=0, max_iter=5)
    assert "rms_phases" in report
    path = tmp_path / "init.h5"
    save_init(path, net, WITH_PHASES, {"map": "m.yaml"}, report, {}, 0, [], False)
    assert load_init(path)[1] == WITH_PHASES
    with h5py.File(path, "a") as f:
        del f["layout/phases"]
    assert load_init(path)[1] == {**WITH_PHASES, "phases": 0}


@pytest.fixture(scope="module")
def linear():
    """A known affine map with outputs of very different scales (m vs N), and its fitted network."""
    rng = np.random.default_rng(1)
    x = rng.uniform([-1.5, -0.7, -0.5, 0.6, 0.0, 0.0], [-0.5, 0.7, 0.5, 0.6, 0.0, 0.0], (200, 6))
    a = rng.normal(size=(6, 8)) * np.array([1, 1, 1, 0.1, 0.1, 0.5, 0.5, 300.0])
    y = x @ a + np.array([0, 0, 0.4, 0, 0, 0, 0, 500.0])
    net, report, model = fit(x, y, LAYOUT, DEFAULT_WEIGHTS, (8, 8), seed=0)
    return x, y, a, net, report, model


def test_weighted_fit_reproduces_a_known_linear_map(linear):
    x, y, a, net, report, _ = linear
    assert report["validation_tasks"] == 40 and report["train_tasks"] == 160
    assert report["validation_loss"] < 5e-3  # weighted MSE in standardized units: RMS < 7 % of a sigma
    fresh = np.random.default_rng(2).uniform([-1.4, -0.6, -0.4, 0.6, 0, 0], [-0.6, 0.6, 0.4, 0.6, 0, 0], (20, 6))
    truth = fresh @ a + np.array([0, 0, 0.4, 0, 0, 0, 0, 500.0])
    scale = y.std(axis=0)
    assert np.max(np.abs(net.predict(fresh) - truth) / scale) < 0.25
    assert np.allclose(net.predict(fresh[0]), net.predict(fresh[:1])[0])


def test_numpy_inference_equals_the_training_library(linear):
    x, _, _, net, _, model = linear
    library = model.predict((x - net.in_offset) / net.in_scale) * net.out_scale + net.out_offset
    assert np.allclose(net.predict(x), library, rtol=1e-10, atol=1e-9)


def test_init_h5_holds_plain_arrays_and_reloads_to_the_same_predictions(linear, tmp_path):
    x, _, _, net, report, _ = linear
    path = tmp_path / "init.h5"
    space = {"map": "m.yaml", "gait": "trot", "strides": 2, "duration": 2.4}
    save_init(path, net, LAYOUT, space, report, {"hidden": [8, 8]}, 0, [], False)
    loaded, layout, trained = load_init(path)
    assert isinstance(loaded, Network) and layout == LAYOUT and trained == space
    assert np.array_equal(loaded.predict(x), net.predict(x))
    kinds = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: kinds.append(obj.dtype.kind) if isinstance(obj, h5py.Dataset) else None)
    assert set(kinds) <= {"f", "i", "V"}  # floats, ints, the /summary table; no opaque or object data
    raw = path.read_bytes()
    assert b"\x80\x04\x95" not in raw and b"\x80\x05\x95" not in raw and b"sklearn" not in raw


NODES = {"base_lin": 12, "base_ang": 6, "feet": 6, "forces": 12, "phases": 2}  # (nodes, value|derivative, xyz) flat


def _node_data(seed=5, n=60):
    """Tasks whose outputs are smooth in x, a node category's derivatives 100× its values (N against N/s)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 3))
    y = np.tanh(x @ rng.normal(size=(3, sum(NODES.values()))))
    _, cats = output_groups(NODES, "category")
    groups, _ = output_groups(NODES, "order")
    return x, y * np.where(groups % 2 == 1, 100.0, 1.0) * np.where(cats == 3, 50.0, 1.0)


def test_output_groups_split_node_categories_into_values_and_derivatives():
    groups, cats = output_groups(NODES, "order")
    assert groups[:12].tolist() == [0, 0, 0, 1, 1, 1] * 2 and groups[18:24].tolist() == [4, 4, 4, 5, 5, 5]
    assert groups[-2:].tolist() == [8, 8] and np.array_equal(cats, output_groups(NODES, "category")[0])
    x, y = _node_data()
    by_category = fit(x, y, NODES, DEFAULT_WEIGHTS, (8,), 0, max_iter=5)[0]
    by_order = fit(x, y, NODES, DEFAULT_WEIGHTS, (8,), 0, max_iter=5, params=FitParams(scale="order"))[0]
    values, derivatives = by_order.out_scale[groups == 6], by_order.out_scale[groups == 7]  # forces
    assert np.allclose(values, values[0]) and derivatives[0] > 50 * values[0]  # each at its own spread
    assert np.allclose(by_category.out_scale[groups == 6], by_category.out_scale[groups == 7])  # one σ per category


def test_an_ensemble_is_one_network_that_predicts_its_members_mean():
    x, y = _node_data()
    members = [fit(x, y, NODES, DEFAULT_WEIGHTS, (6, 5), seed, max_iter=20)[0] for seed in (0, 1, 2)]
    for net in members[1:]:  # the same split and normalization, other weights (other fits' seeds)
        net.in_offset, net.in_scale = members[0].in_offset, members[0].in_scale
        net.out_offset, net.out_scale = members[0].out_offset, members[0].out_scale
    joined = parallel(members)
    assert [w.shape for w in joined.weights] == [(3, 18), (18, 15), (15, y.shape[1])]
    assert np.allclose(joined.predict(x), np.mean([m.predict(x) for m in members], axis=0), rtol=1e-12, atol=1e-12)
    net = fit(x, y, NODES, DEFAULT_WEIGHTS, (6, 5), 3, max_iter=20, params=FitParams(ensemble=3))[0]
    assert net.weights[1].shape == (18, 15) and np.count_nonzero(net.weights[1][:6, 5:]) == 0  # blocks apart


@pytest.mark.parametrize("params", [FitParams(), FitParams(alpha=0.1, scale="order", ensemble=2)])
def test_the_same_data_and_seed_give_the_same_network_bit_for_bit(params):
    x, y = _node_data()
    one, two = (fit(x, y, NODES, DEFAULT_WEIGHTS, (8, 8), 7, max_iter=30, params=params)[0] for _ in range(2))
    assert all(np.array_equal(a, b) for a, b in zip(one.weights + one.biases, two.weights + two.biases))
    assert np.array_equal(one.out_scale, two.out_scale)
    other = fit(x, y, NODES, DEFAULT_WEIGHTS, (8, 8), 8, max_iter=30, params=params)[0]
    assert not np.array_equal(one.weights[0], other.weights[0])


def test_the_weight_penalty_shrinks_the_weights():
    x, y = _node_data()
    norms = [sum(float(np.sum(w ** 2)) for w in fit(x, y, NODES, DEFAULT_WEIGHTS, (16, 16), 0, max_iter=200,
                                                    params=FitParams(alpha=alpha))[0].weights)
             for alpha in (1e-4, 30.0)]
    assert norms[1] < 0.5 * norms[0]


def test_fit_parameters_out_of_range_are_one_line_errors():
    for bad in ({"ensemble": 0}, {"ensemble": 9}, {"alpha": -1.0}, {"scale": "node"}, {"model": "tree"}, {"degree": 5},
                {"ridge": 0.0}):
        with pytest.raises(LegplanError, match=f"fit parameter '{next(iter(bad))}' out of range"):
            FitParams(**bad)


def test_a_polynomial_fit_recovers_a_cubic_map_and_reloads_from_plain_arrays(tmp_path):
    """The polynomial A_θ (FitParams.model): a map cubic in x is fitted to rounding on tasks it never
    saw, saved as a network without hidden layers whose input layer forms the monomials."""
    rng = np.random.default_rng(6)
    x = np.column_stack([rng.uniform(-1.2, -0.3, 80), rng.uniform(-0.7, 0.7, 80), rng.uniform(-0.5, 0.5, 80),
                         np.zeros((80, 3))])  # the goal fixed: constant columns, as in a task space
    coef = rng.normal(size=(3, 3, 8))

    def truth(x):
        a, b, c = x[:, 0], x[:, 1], x[:, 2]
        return np.column_stack([a * b, c ** 3, a ** 2 * c, b, np.ones_like(a), a * b * c, a ** 3, b ** 2]) @ np.diag(
            [1, 2, 3, 0.1, 500.0, 1, 1, 1]) + x[:, :3] @ coef[0]

    y = truth(x)
    net, report, model = fit(x, y, LAYOUT, DEFAULT_WEIGHTS, (256, 256), 0, params=FitParams(model="polynomial"))
    assert model is None and report["fit_iterations"] == 1 and len(net.weights) == 1 and net.degree == 3
    fresh = np.column_stack([rng.uniform(-1.1, -0.4, 20), rng.uniform(-0.6, 0.6, 20), rng.uniform(-0.4, 0.4, 20),
                             np.zeros((20, 3))])
    assert np.max(np.abs(net.predict(fresh) - truth(fresh))) < 1e-3
    quadratic = fit(x, y, LAYOUT, DEFAULT_WEIGHTS, (), 0, params=FitParams(model="polynomial", degree=2))[0]
    assert np.max(np.abs(quadratic.predict(fresh) - truth(fresh))) > 1e-2  # a cubic map is no quadratic
    path = tmp_path / "init.h5"
    save_init(path, net, LAYOUT, {"map": "m.yaml"}, report, {}, 0, [], False)
    loaded = load_init(path)[0]
    assert loaded.degree == 3 and np.array_equal(loaded.predict(fresh), net.predict(fresh))
    with h5py.File(path, "a") as f:
        f.attrs["degree"] = 7
    with pytest.raises(LegplanError, match="field 'degree'"):
        load_init(path)
