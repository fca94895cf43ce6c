"""NavGrid lookups: the breadth-first step distance through passable cells."""

import collections

import numpy as np
from scipy.ndimage import binary_dilation

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
    occupancy[10:, 5] = True
    occupancy[15, 5] = False  # a crack one cell wide: not lethal, but blocked for the planners
    grid = grid_from_occupancy(occupancy, 0.1, l1=0.05)
    point = np.array([0.35, 1.55])
    (iy,), (ix,) = (np.atleast_1d(i) for i in grid.cell_of(point))
    steps = grid.step_distance(point)
    blocked = grid.blocked_at(grid.cell_center(*np.mgrid[0:30, 0:40]))
    passable = binary_dilation(~blocked, structure=np.ones((3, 3), bool))
    np.testing.assert_array_equal(steps, reference_steps(passable, (iy, ix)))
    assert np.isinf(steps[28, 37]) and not grid.lethal[28, 37]
    assert not grid.lethal[15, 5] and np.isinf(steps[15, 5])
    assert steps[15, 6] > reference_steps(~grid.lethal, (iy, ix))[15, 6] + 5  # no short cut
    # From a lethal cell nothing is reachable.
    assert np.isinf(grid.step_distance(grid.cell_center(np.array(10), np.array(20)))).all()


def test_dilate_3x3_matches_scipy_binary_dilation():
    from legplan.nav.collision import dilate_3x3

    rng = np.random.default_rng(5)
    for shape, density in (((17, 23), 0.05), ((1, 9), 0.3), ((30, 30), 0.5)):
        mask = rng.random(shape) < density
        expected = binary_dilation(mask, structure=np.ones((3, 3), bool))
        assert (dilate_3x3(mask) == expected).all()
