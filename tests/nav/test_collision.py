"""NavGrid lookups: the breadth-first step distance through passable cells."""

import collections

import numpy as np
from scipy.ndimage import binary_dilation

from navgrids import grid_from_occupancy


def reference_steps(free, start):
    steps = np.full(free.shape, np.inf)
    steps[start] = 0
    queue = collections.deque([start])
    while queue:
        y, x = queue.popleft()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                yy, xx = y + dy, x + dx
                if 0 <= yy < free.shape[0] and 0 <= xx < free.shape[1] and free[yy, xx] \
                        and steps[yy, xx] == np.inf:
                    steps[yy, xx] = steps[y, x] + 1
                    queue.append((yy, xx))
    return steps


def test_step_distance_is_an_8_connected_breadth_first_search():
    occupancy = np.zeros((30, 40), bool)
    occupancy[5:, 20] = True  # a wall with a gap at the bottom
    occupancy[20:25, 30:35] = True
    occupancy[26:, 36:] = True
    occupancy[27:, 37] = False  # a pocket closed off by lethal cells: unreachable
    occupancy[10:, 5] = True
    occupancy[15, 5] = False  # a crack one cell wide: not lethal, but blocked for the planners
    grid = grid_from_occupancy(occupancy, 0.1, l1=0.05)
    point = np.array([0.35, 1.55])
    (iy,), (ix,), _ = grid.frame.cell_of(point)
    steps = grid.step_distance(point)
    blocked = grid.blocked_at(grid.frame.cell_center(*np.mgrid[0:30, 0:40]))
    passable = binary_dilation(~blocked, structure=np.ones((3, 3), bool))
    np.testing.assert_array_equal(steps, reference_steps(passable, (iy, ix)))
    assert np.isinf(steps[28, 37]) and not grid.lethal[28, 37]
    assert not grid.lethal[15, 5] and np.isinf(steps[15, 5])
    assert steps[15, 6] > reference_steps(~grid.lethal, (iy, ix))[15, 6] + 5  # no short cut
    # From a lethal cell nothing is reachable.
    assert np.isinf(grid.step_distance(grid.frame.cell_center(10, 20))).all()


def test_dilate_3x3_matches_scipy_binary_dilation():
    from legplan.nav.collision import dilate_3x3

    rng = np.random.default_rng(5)
    for shape, density in (((17, 23), 0.05), ((1, 9), 0.3), ((30, 30), 0.5)):
        mask = rng.random(shape) < density
        expected = binary_dilation(mask, structure=np.ones((3, 3), bool))
        assert (dilate_3x3(mask) == expected).all()


def test_one_rounding_for_cell_lookups():
    """NavGrid's padded flat gathers and Grid2D.cell_of put every point, cell edges included, in
    the same cell (edges belong to the upper cell)."""
    rng = np.random.default_rng(2)
    grid = grid_from_occupancy(rng.random((7, 9)) < 0.3, 0.25, l1=0.1)
    x0, y0 = grid.origin
    edges = np.stack(np.meshgrid(x0 + 0.25 * (np.arange(-1, 10) + 0.5),
                                 y0 + 0.25 * (np.arange(-1, 8) + 0.5)), axis=-1).reshape(-1, 2)
    points = np.vstack([edges, rng.uniform(x0 - 0.2, x0 + 2.4, (200, 2)) * [1, 0.8]])
    iy, ix, inside = grid.frame.cell_of(points)
    padded_costs = grid.cost_flat.reshape(grid.shape[0] + 2, grid.shape[1] + 2)
    np.testing.assert_array_equal(grid.cost_at(points[inside]), padded_costs[iy[inside] + 1, ix[inside] + 1])
    np.testing.assert_array_equal(grid.lethal_at(points[inside]), grid.lethal[iy[inside], ix[inside]])
    assert np.all(grid.lethal_at(points[~inside]))
