"""Exact column distance: equal to the FCL surface distance of the column solid within reach,
conservative beyond, exact gradient; the box-corner case where the trilinear SDF reads too far."""

import numpy as np
import pytest

from legplan.terrain import ColumnDistance, Grid2D, terrain_from_heightmap
from legplan.validate.surface import SurfaceMesh

R = 0.01
GRID = Grid2D((-0.295, -0.295), R, (60, 60))  # cells cover [-0.3, 0.3]^2
REACH = 0.08


def _terrain():
    """Ground at 0 with a 1 m deep pit (x < -0.1) and a 10 x 14 cm pillar 3 cm high (x, y > 0)."""
    X, Y = GRID.centres()
    height = np.zeros(GRID.shape)
    height[X < -0.1] = -1.0
    height[(np.abs(X - 0.1) < 0.05) & (np.abs(Y - 0.1) < 0.07)] = 0.03
    return terrain_from_heightmap(height, GRID)


@pytest.fixture(scope="module")
def scene():
    terrain = _terrain()
    surface = SurfaceMesh(terrain.height, terrain.grid.origin, terrain.grid.resolution)
    return terrain, surface, ColumnDistance.of(terrain, REACH)


def test_values_equal_fcl_within_reach_and_never_exceed_it(scene):
    terrain, surface, columns = scene
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.25, 0.25, (4000, 2)), rng.uniform(-0.15, 0.12, 4000)])
    exact = surface.fcl_distance(points)
    values = columns.values(points)
    near = np.abs(exact) <= REACH
    assert near.sum() > 2000 and (~near).sum() > 200
    np.testing.assert_allclose(values[near], exact[near], atol=1e-8)
    assert np.all(values[~near] <= exact[~near] + 1e-8)  # saturated at reach outside, never deeper inside
    assert np.all(values[(~near) & (exact > 0)] == REACH)


def test_gradient_matches_finite_differences(scene):
    _, surface, columns = scene
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-0.25, 0.25, (600, 2)), rng.uniform(-0.1, 0.1, 600)])
    values, grad = columns.value_and_gradient(points)
    h = 1e-6
    fd = np.stack([(columns.values(points + h * e) - columns.values(points - h * e)) / (2 * h) for e in np.eye(3)], 1)
    smooth = np.abs(values) < REACH - 1e-3
    close = np.all(np.abs(fd - grad) < 1e-5, axis=1)
    assert smooth.sum() > 300
    assert close[smooth].mean() > 0.98  # all but points within h of a kink (equidistant to two faces)
    unit = np.linalg.norm(grad[smooth], axis=1)
    np.testing.assert_allclose(unit, 1.0, atol=1e-9)


def test_outside_the_grid_the_border_cells_continue():
    """As the SDF lookup and the validator's vertical gaps: beyond the grid its border cells go on."""
    terrain = _terrain()
    columns = ColumnDistance.of(terrain, REACH)
    points = np.array([[0.33, 0.0, 0.05], [2.0, 0.0, -0.03], [-2.0, 0.0, -0.95], [-2.0, 0.005, -0.97]])
    values, grad = columns.value_and_gradient(points)
    np.testing.assert_allclose(values, [0.05, -0.03, 0.05, 0.03])  # ground; inside ground; over the pit
    np.testing.assert_allclose(grad[1], [0.0, 0.0, 1.0], atol=1e-12)
    beside_wall, grad = columns.value_and_gradient([[-0.12, 2.0, -0.5]])  # the pit wall x = -0.1, far out in y
    assert beside_wall[0] == pytest.approx(0.02)
    np.testing.assert_allclose(grad[0], [-1.0, 0.0, 0.0], atol=1e-12)


def test_sphere_passing_a_box_corner(scene):
    """A sphere (radius 13 mm) swept around the pillar's top corner 1 mm inside its 2 cm clearance
    (centre 32 mm from the corner, 15 mm above the top). The clearance row of the old lookup, the
    trilinear SDF, reads it clear along part of the sweep (> 1 mm too far there); the column
    distance reads the exact 32 mm, so the row is short by 1 mm everywhere."""
    terrain, surface, columns = scene
    corner, top, centre_distance, above = np.array([0.15, 0.17]), 0.03, 0.032, 0.015
    radius, clearance = 0.013, 0.02
    angle = np.linspace(0.0, np.pi / 2, 61)
    rho = np.sqrt(centre_distance ** 2 - above ** 2)
    path = np.column_stack([corner + rho * np.column_stack([np.cos(angle), np.sin(angle)]),
                            np.full(len(angle), top + above)])
    exact = surface.fcl_distance(path)
    np.testing.assert_allclose(exact, centre_distance, atol=1e-9)
    old_row = clearance - (terrain.sdf.values(path) - radius)  # g <= 0: the constraint reads as kept
    assert (old_row <= 0).any()  # the old lookup passes a sphere that is 1 mm short
    new_row = clearance - (columns.values(path) - radius)
    np.testing.assert_allclose(new_row, 1e-3, atol=1e-9)


def test_candidate_tables_do_not_depend_on_the_pair_block(monkeypatch):
    """The candidate pairs are built in blocks of offsets: any block size gives the same tables, in the
    same order (the order decides which of equally near columns a query reports)."""
    import legplan.terrain.columns as columns

    terrain = _terrain()
    whole = ColumnDistance.of(terrain, REACH)
    monkeypatch.setattr(columns, "PAIR_BLOCK", 97)  # a few offsets per block, blocks of uneven size
    pieces = ColumnDistance.of(terrain, REACH)
    def arrays(d):
        return [*d._rows, *d._clear, *(array for table in d._tables for array in table)]

    assert len(arrays(whole)) == 8
    assert all(np.array_equal(x, y) for x, y in zip(arrays(whole), arrays(pieces), strict=True))


def test_values_below_a_bound_are_exact_and_the_others_reach_it(scene):
    """`bound`: the distance is exact where it is below the bound, at least the bound elsewhere; the
    neighbour search is skipped for some points (what makes it cheaper), never for one below its bound."""
    _, _, columns = scene
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-0.25, 0.25, (4000, 2)), rng.uniform(-0.05, 0.12, 4000)])
    bound = rng.uniform(0.0, 0.05, 4000)
    exact, gradient = columns.value_and_gradient(points)
    values = columns.values(points, bound=bound)
    below = exact < bound
    assert below.sum() > 500 and (~below).sum() > 500
    np.testing.assert_array_equal(values[below], exact[below])
    assert np.all(values[~below] >= bound[~below])
    assert np.count_nonzero(values != exact) > 50
    bounded, bounded_gradient = columns.value_and_gradient(points, bound=bound)
    np.testing.assert_array_equal(bounded, values)
    np.testing.assert_array_equal(bounded_gradient[below], gradient[below])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_candidate_tables_list_each_cells_candidates_in_offset_order(seed):
    """The tables of `ColumnDistance`, against their definition written out cell by cell: per cell
    with candidates one row, its candidates (edge cells whose square is within reach of the cell's,
    passing the height test) in offset order (dy, then dx, ascending), padded with columns 1e9 m
    away; `clear` the smallest square distance (m) to a candidate."""
    from legplan.terrain.columns import _candidate_table, _neighbour_masks

    rng = np.random.default_rng(seed)
    height = rng.choice([0.0, 0.05, 0.12], size=(9, 11))
    reach_cells, origin = 2.6, np.array([-0.3, 0.2])
    ny, nx = height.shape
    k = int(np.ceil(reach_cells)) + 1
    for mask, keep in zip(_neighbour_masks(height), (np.greater, np.less)):
        rows, (centres, tops), clear = _candidate_table(height, mask, reach_cells, keep, origin, R)
        listed = 0
        for iy in range(ny):
            for ix in range(nx):
                found, gaps = [], []
                for dy in range(-k, k + 1):
                    for dx in range(-k, k + 1):
                        gap = np.hypot(max(abs(dx) - 1, 0), max(abs(dy) - 1, 0))
                        y, x = iy + dy, ix + dx
                        if (dx or dy) and gap <= reach_cells and 0 <= y < ny and 0 <= x < nx and mask[y, x] \
                                and keep(height[y, x], height[iy, ix]):
                            found.append((y, x))
                            gaps.append(gap)
                cell = iy * nx + ix
                assert clear[cell] == (R * min(gaps) if gaps else np.inf)
                if not found:
                    assert rows[cell] == -1
                    continue
                assert rows[cell] == listed
                listed += 1
                expected = np.array([[origin[0] + R * x, origin[1] + R * y] for y, x in found])
                assert np.array_equal(centres[rows[cell], :len(found)], expected)
                assert np.array_equal(tops[rows[cell], :len(found)], [height[y, x] for y, x in found])
                assert np.all(centres[rows[cell], len(found):] == 1e9)
        assert listed == len(centres) and listed > 0


def test_values_without_gradients_are_those_with_them(scene):
    """`values` (the search without the gradients' arithmetic) gives, bit for bit, the values of
    `value_and_gradient`, with and without a bound, inside and outside the terrain."""
    _, _, columns = scene
    rng = np.random.default_rng(9)
    points = np.column_stack([rng.uniform(-0.3, 0.3, (5000, 2)), rng.uniform(-0.2, 0.15, 5000)])
    bound = rng.uniform(0.0, 2 * REACH, 5000)
    for b in (None, bound):
        plain = columns.values(points, b)
        with_gradient, gradient = columns.value_and_gradient(points, b)
        assert plain.tobytes() == with_gradient.tobytes() and (plain < 0).any() and (plain > 0).any()
        assert np.isfinite(gradient).all()
