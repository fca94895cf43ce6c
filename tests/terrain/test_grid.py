"""Grid2D: bilinear value and gradient against an independent plane and finite differences."""

import numpy as np

from legplan.terrain.grid import Grid2D


def test_bilinear_reproduces_a_plane_and_its_gradient_inside_and_clamps_outside():
    grid = Grid2D((1.0, -2.0), 0.25, (6, 9))
    X, Y = grid.centres()
    plane = 0.5 + 2.0 * X - 3.0 * Y  # bilinear interpolation is exact on a plane
    rng = np.random.default_rng(1)
    xmin, xmax = grid.xs[0], grid.xs[-1]
    ymin, ymax = grid.ys[0], grid.ys[-1]
    inside = np.column_stack([rng.uniform(xmin, xmax, 50), rng.uniform(ymin, ymax, 50)])
    value, gradient = grid.bilinear(plane, inside, gradient=True)
    np.testing.assert_allclose(value, 0.5 + 2.0 * inside[:, 0] - 3.0 * inside[:, 1], atol=1e-12)
    np.testing.assert_allclose(gradient, np.tile([2.0, -3.0], (50, 1)), atol=1e-9)
    # beyond the left border: the border value, no gradient across it (x), full gradient along (y)
    value, gradient = grid.bilinear(plane, [[xmin - 1.0, ymin + 0.3]], gradient=True)
    np.testing.assert_allclose(value, [0.5 + 2.0 * xmin - 3.0 * (ymin + 0.3)])
    np.testing.assert_allclose(gradient, [[0.0, -3.0]], atol=1e-9)
    assert np.array_equal(grid.bilinear(plane, inside), grid.bilinear(plane, inside, gradient=True)[0])


def test_bilinear_gradient_matches_central_differences_on_a_curved_layer():
    grid = Grid2D((0.0, 0.0), 0.1, (12, 15))
    X, Y = grid.centres()
    layer = np.sin(3 * X) * np.cos(2 * Y) + X * Y
    points = np.array([[0.33, 0.41], [1.02, 0.77], [0.57, 0.12]])  # away from cell centre lines
    _, gradient = grid.bilinear(layer, points, gradient=True)
    h = 1e-6
    for axis in range(2):
        step = np.zeros(2)
        step[axis] = h
        difference = (grid.bilinear(layer, points + step) - grid.bilinear(layer, points - step)) / (2 * h)
        np.testing.assert_allclose(gradient[:, axis], difference, rtol=1e-6, atol=1e-8)


def test_bilinear_on_a_single_row_grid():
    grid = Grid2D((0.0, 0.0), 1.0, (1, 3))
    assert grid.bilinear(np.array([[0.0, 1.0, 4.0]]), [[1.5, 7.0]])[0] == 2.5


def test_bilinear_takes_complex_points_for_complex_step_derivatives():
    grid = Grid2D((0.0, 0.0), 0.1, (12, 15))
    X, Y = grid.centres()
    layer = np.sin(3 * X) * np.cos(2 * Y) + X * Y
    points = np.array([[0.33, 0.41], [1.02, 0.77], [-0.5, 0.3]])  # the last beyond the left border
    value, gradient = grid.bilinear(layer, points, gradient=True)
    h = 1e-30
    for axis in range(2):
        step = np.zeros(2, complex)
        step[axis] = 1j * h
        shifted = grid.bilinear(layer, points + step)
        np.testing.assert_allclose(shifted.real, value, rtol=0, atol=1e-15)
        np.testing.assert_allclose(shifted.imag / h, gradient[:, axis], rtol=1e-12, atol=1e-12)
