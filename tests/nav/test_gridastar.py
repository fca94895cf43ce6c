"""Grid A*: exact optimality against scipy's Dijkstra on the same graph; trapezoidal timing."""

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from legplan.nav import NavParams, plan_grid
from legplan.nav.gridastar import grid_graph

PARAMS = NavParams()


def scipy_optimum(grid, rho_c, source, target):
    steps, lengths, factor = grid_graph(grid, rho_c)
    ny, nx = grid.shape
    rows, cols, weights = [], [], []
    iy, ix = np.mgrid[0:ny, 0:nx]
    for (dy, dx), length in zip(steps, lengths):
        ty, tx = iy + dy, ix + dx
        inside = (ty >= 0) & (ty < ny) & (tx >= 0) & (tx < nx)
        src = (iy * nx + ix)[inside]
        dst = (ty * nx + tx)[inside]
        w = length * factor.ravel()[dst]
        ok = np.isfinite(w) & np.isfinite(factor.ravel()[src])
        rows.append(src[ok]), cols.append(dst[ok]), weights.append(w[ok])
    graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(ny * nx, ny * nx)).tocsr()
    return dijkstra(graph, indices=source)[target]


@pytest.mark.parametrize("rho_c", [0.0, 0.01])
def test_grid_astar_cost_equals_dijkstra(pillars_grid, rho_c):
    params = PARAMS.replace(rho_c=rho_c)
    start, goal = np.array([0.5, 0.5, 0, 0]), np.array([9.5, 5.5, 0, 0])
    result = plan_grid(pillars_grid, start, goal, params)
    assert result.success
    nx = pillars_grid.shape[1]
    (sy,), (sx,), _ = pillars_grid.frame.cell_of(start[:2])
    (gy,), (gx,), _ = pillars_grid.frame.cell_of(goal[:2])
    optimum = scipy_optimum(pillars_grid, rho_c, int(sy * nx + sx), int(gy * nx + gx))
    assert result.cost == pytest.approx(optimum, rel=1e-12)


def test_grid_path_time_parametrization_is_feasible(pillars_grid):
    start, goal = (0.5, 0.5, 0, 0), (9.5, 5.5, 0, 0)
    result = plan_grid(pillars_grid, start, goal, PARAMS)
    trajectory = result.trajectory
    _, p, v, a = trajectory.sample(pillars_grid.resolution / PARAMS.v_max / 10.0)
    assert not pillars_grid.lethal_at(p).any()
    assert np.abs(v).max() <= PARAMS.v_max + 1e-9 and np.abs(a).max() <= PARAMS.a_max + 1e-9
    np.testing.assert_allclose(p[0], start[:2])
    np.testing.assert_allclose(p[-1], goal[:2], atol=1e-9)
    np.testing.assert_allclose(v[-1], 0.0, atol=1e-9)
    np.testing.assert_allclose(result.waypoints[[0, -1]], [start[:2], goal[:2]])
    # every waypoint is visited at rest (trapezoid per segment)
    knots_p, knots_v, _ = trajectory.evaluate(trajectory.knots)
    for waypoint in result.waypoints:
        at = np.linalg.norm(knots_p - waypoint, axis=1).argmin()
        assert np.linalg.norm(knots_p[at] - waypoint) < 1e-9 and np.allclose(knots_v[at], 0.0)


def test_grid_failures(pillars_grid):
    assert plan_grid(pillars_grid, (3.0, 3.0, 0, 0), (9, 5, 0, 0), PARAMS).reason.startswith(
        "start in collision (a cell within one cell of it is lethal")
    limited = plan_grid(pillars_grid, (0.5, 0.5, 0, 0), (9.5, 5.5, 0, 0),
                        PARAMS.replace(max_expansions=10))
    assert limited.reason == "expansion limit (10) reached"
