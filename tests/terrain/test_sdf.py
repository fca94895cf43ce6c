"""SDF: analytic distances (plane, box), exact gradient of the interpolant, queries outside the grid."""

import numpy as np
import pytest

from legplan.terrain import Grid2D, heightmap_sdf, terrain_from_heightmap

R = 0.02
GRID = Grid2D((-0.99, -0.99), R, (100, 100))   # cells cover [-1, 1]^2
HALF, TOP = 0.2, 0.2                            # box column [-0.2, 0.2]^2 x (-inf, 0.2]


def _box_height():
    X, Y = GRID.centres()
    height = np.zeros(GRID.shape)
    height[(np.abs(X) < HALF) & (np.abs(Y) < HALF)] = TOP
    return height


@pytest.fixture(scope="module")
def box_sdf():
    return heightmap_sdf(_box_height(), GRID.origin, R, -0.3, 0.5)


def _box_truth(points):
    """Exact signed distance to (ground half-space z < 0) union (box column), for the test regions."""
    x, y, z = points.T
    dx, dy = np.maximum(np.abs(x) - HALF, 0), np.maximum(np.abs(y) - HALF, 0)
    to_column = np.sqrt(dx ** 2 + dy ** 2 + np.maximum(z - TOP, 0) ** 2)
    in_column = (dx == 0) & (dy == 0) & (z < TOP)
    inside_box = -np.minimum.reduce([TOP - z, HALF - np.abs(x), HALF - np.abs(y)])
    free = np.minimum(np.where(z >= 0, z, 0.0), to_column)
    return np.where(in_column, inside_box, np.where(z < 0, z, free))


def test_plane_matches_analytic_within_one_cell():
    height = np.full(GRID.shape, 0.07)
    sdf = heightmap_sdf(height, GRID.origin, R, -0.3, 0.5)
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.9, 0.9, (2000, 2)), rng.uniform(-0.25, 0.45, 2000)])
    values, gradients = sdf.value_and_gradient(points)
    assert np.max(np.abs(values - (points[:, 2] - 0.07))) <= R
    away = np.abs(points[:, 2] - 0.07) > 2 * R
    assert np.allclose(gradients[away], [0, 0, 1], atol=1e-4)


def test_box_matches_analytic_within_one_cell(box_sdf):
    rng = np.random.default_rng(1)
    above = np.column_stack([rng.uniform(-0.8, 0.8, (3000, 2)), rng.uniform(0.0, 0.45, 3000)])
    inside = np.column_stack([rng.uniform(-0.18, 0.18, (500, 2)), rng.uniform(0.02, 0.2, 500)])
    ground = np.column_stack([rng.uniform(0.5, 0.8, (500, 2)), rng.uniform(-0.25, 0.0, 500)])
    points = np.vstack([above, inside, ground])
    error = np.abs(box_sdf.values(points) - _box_truth(points))
    assert error.max() <= R, f"max error {error.max():.4f} at {points[error.argmax()]}"


def test_diagonal_distance_above_box_edge(box_sdf):
    """Beside and above the top edge the distance is diagonal, not the vertical distance to ground."""
    point = np.array([[HALF + 0.1, 0.0, TOP + 0.1]])
    assert box_sdf.values(point)[0] == pytest.approx(np.hypot(0.1, 0.1), abs=R)


def test_gradient_is_derivative_of_interpolant(box_sdf):
    rng = np.random.default_rng(2)
    points = np.column_stack([rng.uniform(-0.95, 0.95, (4000, 2)), rng.uniform(-0.28, 0.48, 4000)])
    values, gradients = box_sdf.value_and_gradient(points)
    step = 1e-6
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        numeric = (box_sdf.values(points + offset) - box_sdf.values(points - offset)) / (2 * step)
        # Skip points within `step` of a cell face, where the interpolant has a kink.
        frac = ((points[:, axis] - box_sdf.origin[axis]) / R) % 1.0
        smooth = (frac > 1e-3) & (frac < 1 - 1e-3)
        assert np.allclose(gradients[smooth, axis], numeric[smooth], atol=1e-4)
    assert values.shape == (4000,) and gradients.shape == (4000, 3)


def test_out_of_grid_queries_are_defined(box_sdf):
    points = np.array([[5.0, 0.0, 0.1],      # beyond +x: terrain continues as the border cells
                       [-5.0, -5.0, 0.1],    # beyond a corner
                       [0.5, 0.5, 3.0],      # above the top layer: value grows with slope 1
                       [0.5, 0.5, -2.0],     # below the bottom layer: deeper inside
                       [np.inf, 0.0, 0.0]])
    values, gradients = box_sdf.value_and_gradient(points[:4])
    assert values[0] == pytest.approx(0.1, abs=1e-6) and gradients[0, 0] == 0.0
    assert values[1] == pytest.approx(0.1, abs=1e-6)
    assert values[2] == pytest.approx(3.0, abs=1e-6) and gradients[2, 2] == 1.0
    assert values[3] == pytest.approx(-2.0, abs=1e-6) and gradients[3, 2] == 1.0
    assert np.all(np.isfinite(box_sdf.values(points)))


def test_surface_distance_and_height_at():
    terrain = terrain_from_heightmap(_box_height(), GRID)
    xy = np.array([[0.0, 0.0], [0.6, 0.6], [5.0, 5.0]])
    assert np.allclose(terrain.height_at(xy), [TOP, 0.0, 0.0])
    feet = np.array([[0.0, 0.0, TOP], [0.6, 0.6, 0.0], [0.6, 0.6, 0.05]])
    assert np.allclose(terrain.surface_distance(feet, vertical=True), [0.0, 0.0, 0.05])
    assert np.allclose(terrain.surface_distance(feet), [0.0, 0.0, 0.05], atol=R / 2)
