"""Kinodynamic A*: hard constraints on resampling, start velocity, lattice optimality, failures."""

import heapq
from pathlib import Path

import numpy as np
import pytest

from legplan.nav import NavGrid, NavParams, Trajectory, plan_kinodynamic
from legplan.nav.heuristic import GeodesicTimeBound, GoalHeuristic, optimal_polynomial
from legplan.nav.kinoastar import (MIN_STAGE_EXPANSIONS, ONESHOT_STRETCH, _KeyEncoder,
                                   analytic_expansion)
from legplan.nav.primitives import PrimitiveSet, input_lattice, sample_count
from legplan.robots import load_robot
from legplan.terrain import build_map

from navgrids import grid_from_occupancy

PARAMS = NavParams(weight=2.0)
MAPS = Path(__file__).resolve().parents[2] / "maps"


def assert_feasible(grid, result, params):
    """Limits and lethal cells checked on a resampling 10× denser than the search's samples."""
    assert result.success, result.reason
    trajectory = result.trajectory
    step = grid.resolution / params.v_max / 10.0
    _, p, v, a = trajectory.sample(step)
    assert not grid.lethal_at(p).any()
    assert np.abs(v).max() <= params.v_max + 1e-9
    assert np.abs(a).max() <= params.a_max + 1e-9
    np.testing.assert_allclose(p[0], result.start[:2], atol=1e-12)
    np.testing.assert_allclose(v[0], result.start[2:], atol=1e-12)
    end_p, end_v = trajectory.end_state()
    np.testing.assert_allclose(end_p, result.goal[:2], atol=1e-9)
    np.testing.assert_allclose(end_v, result.goal[2:], atol=1e-9)


@pytest.mark.parametrize("start, goal", [((0.5, 0.5, 0, 0), (9.5, 5.5, 0, 0)),
                                         ((0.5, 5.5, 0, 0.3), (9.5, 0.5, 0.2, 0)),
                                         ((5.0, 5.5, 0, 0), (3.0, 0.4, 0, 0))])
def test_paths_are_feasible_and_collision_free_under_dense_resampling(pillars_grid, start, goal):
    result = plan_kinodynamic(pillars_grid, start, goal, PARAMS)
    assert_feasible(pillars_grid, result, PARAMS)
    assert result.expansions > 0 and np.isfinite(result.cost)


def test_nonzero_start_velocity_is_kept_without_turning_around():
    grid = grid_from_occupancy(np.zeros((80, 200), bool), 0.05)
    start, goal = (1.0, 2.0, 0.7, 0.0), (8.0, 2.0, 0.0, 0.0)
    result = plan_kinodynamic(grid, start, goal, PARAMS)
    assert_feasible(grid, result, PARAMS)
    _, _, v, _ = result.trajectory.sample(0.01)
    assert v[:, 0].min() >= -1e-9  # never backs up (paper Fig. 4)
    # From rest the same goal takes longer: the initial velocity is used, not discarded.
    rest = plan_kinodynamic(grid, (1.0, 2.0, 0.0, 0.0), goal, PARAMS)
    assert result.trajectory.duration < rest.trajectory.duration


def maze():
    """6 m × 6 m maze at 0.25 m: walls force a detour."""
    cells = np.zeros((24, 24), bool)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = True
    cells[:16, 8] = True
    cells[8:, 16] = True
    return grid_from_occupancy(cells, 0.25, l1=0.05, origin=(0.125, 0.125))


def lattice_dijkstra(grid, params, start, goal):
    """Exhaustive uniform-cost search over the same primitive lattice (exact states, no hashing)."""
    inputs = input_lattice(params.mu, params.a_max)
    tau = params.tau
    t = np.linspace(0.0, tau, sample_count(params.v_max, tau, grid.resolution))[:, None]
    source = (tuple(start[:2]), tuple(start[2:]))
    target = (tuple(goal[:2]), tuple(goal[2:]))
    best = {source: 0.0}
    heap = [(0.0, source)]
    while heap:
        cost, state = heapq.heappop(heap)
        if cost > best[state]:
            continue
        if state == target:
            return cost
        p, v = np.array(state[0]), np.array(state[1])
        for u in inputs:
            v_end = v + u * tau
            if np.abs(v_end).max() > params.v_max:
                continue
            samples = p + v * t + 0.5 * u * t**2
            if grid.blocked_at(samples).any():
                continue
            child = (tuple(samples[-1]), tuple(v_end))
            child_cost = cost + (u @ u + params.rho) * tau
            if child_cost < best.get(child, np.inf):
                best[child] = child_cost
                heapq.heappush(heap, (child_cost, child))
    return np.inf


def test_search_finds_the_lattice_optimum_of_an_exhaustive_search():
    grid = maze()
    # τ = 1, a = 1, v_max = 1: velocities are integers, positions multiples of 0.5 m, so the hash
    # grid (0.5 m, 0.2 m/s) separates every lattice state and A* must match uniform-cost search.
    params = NavParams(v_max=1.0, a_max=1.0, mu=1, tau=1.0, rho=1.0, rho_c=0.0, weight=1.0,
                       pos_res=0.5, vel_res=0.2, oneshot_radius=0.0, goal_tolerance=1e-9,
                       goal_vel_tolerance=1e-9)
    start, goal = np.array([1.0, 1.0, 0.0, 0.0]), np.array([5.0, 1.0, 0.0, 0.0])
    result = plan_kinodynamic(grid, start, goal, params)
    optimum = lattice_dijkstra(grid, params, start, goal)
    assert result.success and np.isfinite(optimum)
    assert result.cost == pytest.approx(optimum, abs=1e-9)
    assert result.trajectory.effort() + params.rho * result.trajectory.duration == \
        pytest.approx(optimum, abs=1e-9)
    # Weighted A* stays within its bound.
    weighted = plan_kinodynamic(grid, start, goal, params.replace(weight=2.0))
    assert optimum - 1e-9 <= weighted.cost <= 2.0 * optimum + 1e-9
    # The obstacle-aware time bound keeps h admissible and consistent: the same optimum.
    geodesic = plan_kinodynamic(grid, start, goal, params.replace(geodesic_bound=True))
    assert geodesic.cost == pytest.approx(optimum, abs=1e-9)
    assert geodesic.expansions <= result.expansions


def straight_time(point, goal, v_max):
    return max(abs(point[0] - goal[0]), abs(point[1] - goal[1])) / v_max


def test_geodesic_time_bound_is_admissible_and_drops_at_most_tau_per_primitive(pillars_grid):
    params = PARAMS.replace(geodesic_bound=True)
    start, goal = np.array([0.5, 5.5, 0.0, 0.0]), np.array([9.5, 0.5, 0.0, 0.0])
    bound = GeodesicTimeBound(pillars_grid, goal[:2], params.v_max, params.tau)
    heuristic = GoalHeuristic(goal[:2], goal[2:], params.rho, params.v_max, bound)

    def floor(px, py):
        return bound(px, py, straight_time((px, py), goal, params.v_max))

    result = plan_kinodynamic(pillars_grid, start, goal, params)
    assert_feasible(pillars_grid, result, params)
    # Along the planned trajectory the bound never exceeds the time left to the goal.
    t, p, _, _ = result.trajectory.sample(0.01)
    remaining = result.trajectory.duration - t
    assert all(floor(*point) <= left + 1e-9 for point, left in zip(p.tolist(), remaining))
    # Along every feasible primitive of random nodes it drops by at most τ, and h = J*(T ≥ bound)
    # by at most the primitive's cost (consistency, eqs. (8), (19)).
    prims = PrimitiveSet.build(params, pillars_grid)
    rng = np.random.default_rng(14)
    checked = 0
    for _ in range(200):
        p0 = rng.uniform([0.3, 0.3], [9.7, 5.7])
        v0 = rng.uniform(-params.v_max, params.v_max, 2)
        if pillars_grid.blocked_at(p0):
            continue
        with np.errstate(invalid="ignore"):
            children, feasible = prims.expand(*p0, *v0)
        h0 = heuristic(*p0, *v0)[0]
        for px, py, vx, vy, cost in children[:, feasible].T.tolist():
            assert floor(*p0) <= params.tau + floor(px, py) + 1e-12
            assert h0 <= cost + heuristic(px, py, vx, vy)[0] + 1e-9
            checked += 1
    assert checked > 1000


def street_maze():
    """12 m × 12 m at 0.2 m: streets 1 m wide (free for the robot: x or y in [0.6, 1.2), [3.8, 4.4),
    [7.8, 8.4), [10.8, 11.4)) between blocks, two segments closed (detours), and alleys one cell
    wide that the robot cannot pass (open to a bound through non-lethal cells)."""
    cells = np.ones((60, 60), bool)
    for a in (2, 18, 38, 53):
        cells[2:58, a:a + 5] = cells[a:a + 5, 2:58] = False
    cells[25:38, 18:23] = True  # closed street segments
    cells[38:43, 43:53] = True
    cells[10, 7:18] = cells[25:38, 45] = False  # alleys
    return grid_from_occupancy(cells, 0.2, l1=0.2, l2=0.6)


def test_geodesic_bound_is_admissible_against_the_lattice_optimum():
    """h never exceeds the exact optimal cost-to-go of an exhaustive search over the lattice
    (τ = 1, v_max = a_max = 1: rest-to-rest moves are whole metres, so the street crossings at
    whole metres are lattice states)."""
    grid = street_maze()
    params = NavParams(v_max=1.0, a_max=1.0, mu=1, tau=1.0, rho=1.0, rho_c=0.0, weight=1.0)
    goal = np.array([11.0, 11.0, 0.0, 0.0])
    bound = GeodesicTimeBound(grid, goal[:2], params.v_max, params.tau)
    heuristic = GoalHeuristic(goal[:2], goal[2:], params.rho, params.v_max, bound)
    straight = GoalHeuristic(goal[:2], goal[2:], params.rho, params.v_max)
    tighter = 0
    for start in ((1.0, 11.0), (11.0, 1.0), (4.0, 8.0), (8.0, 4.0), (1.0, 1.0)):
        state = np.array([*start, 0.0, 0.0])
        optimum = lattice_dijkstra(grid, params, state, goal)
        h = heuristic(*state)[0]
        assert np.isfinite(optimum) and h <= optimum + 1e-9
        tighter += h > straight(*state)[0] + 0.1
    assert tighter >= 3


def test_street_query_the_straight_line_heuristic_floods_now_succeeds():
    grid = street_maze()
    start, goal = np.array([4.0, 4.0, 0.0, 0.0]), np.array([4.0, 9.0, 0.0, 0.0])  # street closed
    budget = PARAMS.replace(max_expansions=6000)
    old = plan_kinodynamic(grid, start, goal, budget.replace(geodesic_bound=False))
    assert not old.success and old.reason == "expansion limit (6000) reached"
    new = plan_kinodynamic(grid, start, goal, budget)  # weight 2 stalls, the restart at 3 passes
    assert_feasible(grid, new, PARAMS)
    assert new.expansions > MIN_STAGE_EXPANSIONS


def test_expansion_budget_scales_with_the_map():
    assert NavParams().expansion_budget(10) == 200_000
    assert NavParams().expansion_budget(1024 * 1024) == 1024 * 1024
    assert NavParams(max_expansions=7).expansion_budget(1024 * 1024) == 7


def test_failure_reasons(pillars_grid):
    result = plan_kinodynamic(pillars_grid, (3.0, 3.0, 0, 0), (9.0, 5.0, 0, 0), PARAMS)
    assert not result.success and result.reason.startswith("start in collision (a cell within one cell")
    result = plan_kinodynamic(pillars_grid, (0.5, 0.5, 0, 0), (12.0, 5.0, 0, 0), PARAMS)
    assert result.reason == "goal outside the map"
    result = plan_kinodynamic(pillars_grid, (0.5, 0.5, 2.0, 0), (9.0, 5.0, 0, 0), PARAMS)
    assert result.reason.startswith("start velocity exceeds")
    result = plan_kinodynamic(pillars_grid, (0.5, 0.5, 0, 0), (9.5, 5.5, 0, 0),
                              PARAMS.replace(max_expansions=5))
    assert result.reason == "expansion limit (5) reached" and result.expansions == 5
    assert result.trajectory is None
    walled = np.zeros((24, 24), bool)
    walled[6:18, 6] = walled[6:18, 17] = walled[6, 6:18] = walled[17, 6:18] = True
    grid = grid_from_occupancy(walled, 0.1)
    coarse = PARAMS.replace(pos_res=0.3, vel_res=0.5, mu=1, geodesic_bound=False)
    result = plan_kinodynamic(grid, (0.3, 0.3, 0, 0), (1.2, 1.2, 0, 0), coarse)
    assert result.reason == "goal unreachable (open list exhausted)"
    result = plan_kinodynamic(grid, (0.3, 0.3, 0, 0), (1.2, 1.2, 0, 0), PARAMS)
    assert result.reason == "goal unreachable (no route through passable cells)"


def test_state_keys_are_one_per_hash_cell(pillars_grid):
    """Keys equal exactly when (floor of position / pos_res, rint of velocity / vel_res) do."""
    params = NavParams(pos_res=0.1, vel_res=0.2)
    encode = _KeyEncoder(pillars_grid, params)
    rng = np.random.default_rng(12)
    xmin, xmax, ymin, ymax = pillars_grid.extent
    states = np.concatenate([rng.uniform([xmin, ymin], [xmax, ymax], (4000, 2)),
                             rng.uniform(-params.v_max, params.v_max, (4000, 2))], axis=1)
    states[::2] = np.round(states[::2], 1)  # many states on cell boundaries and sharing cells
    keys = encode(states.T)
    cells = np.concatenate([np.floor((states[:, :2] - [xmin, ymin]) * (1 / params.pos_res)),
                            np.rint(states[:, 2:] * (1 / params.vel_res))], axis=1)
    assert np.all(keys == np.round(keys))
    _, cell_ids = np.unique(cells, axis=0, return_inverse=True)
    _, key_ids = np.unique(keys, return_inverse=True)
    # Same partition of the states: a bijection between distinct cells and distinct keys.
    assert len(set(zip(cell_ids.tolist(), key_ids.tolist()))) == len(set(cell_ids.tolist())) \
        == len(set(key_ids.tolist()))


def reference_oneshot(grid, p, v, pg, vg, T_h, params):
    """The first stretched duration whose eq. (9) cubic keeps the limits (ends and velocity vertex)
    and has no blocked sample, checked one duration at a time on all samples."""
    for factor in ONESHOT_STRETCH:
        T = T_h * factor
        alpha, beta = optimal_polynomial(p, v, pg, vg, T)
        if max(np.abs(beta).max(), np.abs(beta + alpha * T).max()) > params.a_max + 1e-9:
            continue
        vertex = np.clip(np.divide(-beta, alpha, out=np.zeros(2), where=alpha != 0), 0, T)
        if np.abs(v + vertex * (beta + 0.5 * alpha * vertex)).max() > params.v_max + 1e-9:
            continue
        t = np.linspace(0.0, T, sample_count(params.v_max, T, grid.resolution))[:, None]
        if not grid.blocked_at(p + v * t + beta * t**2 / 2 + alpha * t**3 / 6).any():
            return T
    return None


def test_one_shot_batch_picks_the_first_feasible_duration(pillars_grid):
    """Same duration as a sequential check (or None) for one-shots near pillars and walls."""
    rng = np.random.default_rng(13)
    outcomes = set()
    for _ in range(300):
        p, pg = rng.uniform([0.3, 0.3], [9.7, 5.7], (2, 2))
        v, vg = rng.uniform(-0.7, 0.7, (2, 2)) * [[1.0], [rng.integers(0, 2)]]
        if pillars_grid.blocked_at(p) or pillars_grid.blocked_at(pg):
            continue
        heuristic = GoalHeuristic(pg, vg, PARAMS.rho, PARAMS.v_max)
        T_h = heuristic(*p, *v)[1]
        with np.errstate(invalid="ignore", divide="ignore"):
            shot = analytic_expansion(pillars_grid, p, v, pg, vg, T_h, PARAMS)
        expected = reference_oneshot(pillars_grid, p, v, pg, vg, T_h, PARAMS)
        if expected is None:
            assert shot is None
            outcomes.add("none")
            continue
        (p0, v0, a0, jerk, T), cost = shot
        assert T == pytest.approx(expected, rel=1e-12)
        outcomes.add("stretched" if T > T_h * (1 + 1e-9) else "T_h")
        trajectory = Trajectory.from_pieces([(p0, v0, a0, jerk, T)])
        end_p, end_v = trajectory.end_state()
        np.testing.assert_allclose(end_p, pg, atol=1e-9)
        np.testing.assert_allclose(end_v, vg, atol=1e-9)
        assert cost >= trajectory.effort() + PARAMS.rho * T - 1e-9
    assert outcomes == {"none", "stretched", "T_h"}



# nav_30m_queries.csv searched with the straight-line heuristic alone (commit 1b01c35): g, effort.
NAV_30M_BEFORE = ((60.6574, 1.278), (57.5223, 1.348), (54.5013, 1.142), (62.9897, 1.451))


def test_nav_30m_results_keep_their_cost_and_effort():
    """The shipped nav_30m queries (paper's open map): the geodesic bound changes the search order
    only near obstacles; cost within 1 % above or 5 % below, effort ∫‖a‖² not higher."""
    navigation = load_robot("jueying_mini").navigation
    grid = NavGrid.from_terrain(build_map(MAPS / "nav_30m.yaml"),
                                lethal_radius=navigation.inscribed_radius)
    params = NavParams.for_robot(navigation)
    queries = np.loadtxt(MAPS / "nav_30m_queries.csv", delimiter=",", skiprows=1)
    for query, (cost, effort) in zip(queries, NAV_30M_BEFORE, strict=True):
        result = plan_kinodynamic(grid, query[:4], query[4:], params)
        assert result.success
        assert 0.95 * cost <= result.cost <= 1.01 * cost
        assert result.trajectory.effort() <= effort + 1e-3
