"""NavGrid lookups: the breadth-first step distance through non-lethal cells."""

import collections

import numpy as np

from conftest import grid_from_occupancy


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
    grid = grid_from_occupancy(occupancy, 0.1, l1=0.05)
    point = np.array([0.35, 1.55])
    (iy,), (ix,) = (np.atleast_1d(i) for i in grid.cell_of(point))
    steps = grid.step_distance(point)
    np.testing.assert_array_equal(steps, reference_steps(~grid.lethal, (iy, ix)))
    assert np.isinf(steps[28, 37]) and not grid.lethal[28, 37]
    # From a lethal cell nothing is reachable.
    assert np.isinf(grid.step_distance(grid.cell_center(np.array(10), np.array(20)))).all()
