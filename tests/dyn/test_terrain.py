"""The optimizer's terrain model near a step edge: what keeps stance feet off edges."""

import numpy as np
import pytest

from legplan.dyn.terrain import TerrainModel
from legplan.terrain import Grid2D, terrain_from_heightmap


EDGE = -0.005


@pytest.fixture(scope="module")
def pallet_edge():
    """A 16.5 cm step on a 1 cm grid (the pallet maps' edge): cell centres ... −0.01 (0 m), 0.0 (0.165 m),
    so the heightmap's ramp spans x ∈ [−0.01, 0], edge at EDGE."""
    grid = Grid2D(origin=(-0.5, -0.2), resolution=0.01, shape=(41, 101))
    x, _ = grid.centres()
    return TerrainModel(terrain_from_heightmap(np.where(x >= 0.0, 0.165, 0.0), grid, name="edge"))


def _slope(terrain, d):
    d = np.asarray(d, float)
    return terrain.stance_slope(EDGE + d, np.zeros_like(d))


def test_stance_slope_is_large_on_the_edge_and_small_a_foot_away(pallet_edge):
    assert _slope(pallet_edge, [-0.005, 0.0, 0.005]).min() > 2.5  # smoothed step (σ 2 cm): 0.165·φ(0)/σ ≈ 3.3
    assert 0.5 < _slope(pallet_edge, [-0.03, 0.03]).min()  # 3 cm: still refused by the 0.5 bound
    assert _slope(pallet_edge, [-0.045, 0.045]).max() < 0.5  # a foot radius and more away: allowed


def test_stance_slope_gradient_points_away_from_the_edge_where_the_raw_ramp_has_none(pallet_edge):
    h = 1e-4
    for x in (-0.025, -0.015, 0.015, 0.025):
        d = (_slope(pallet_edge, [x + h]) - _slope(pallet_edge, [x - h]))[0] / (2 * h)
        assert np.sign(d) == -np.sign(x)  # descending it moves the foot away from the edge
    # inside the raw heightmap's one-cell ramp the slope is constant: no direction off it
    _, hx, _ = pallet_edge.height_gradient(EDGE + np.array([-0.004, 0.0, 0.004]), np.zeros(3))
    assert np.ptp(hx) == pytest.approx(0.0, abs=1e-9) and hx[0] > 10.0


def test_stance_slope_falls_away_from_the_crest_of_an_edge_on_both_sides(pallet_edge):
    """Within a cell of the edge, where the smoothed slope peaks, its gradient (exact: central
    differences agree) still points away from the edge on either side: a foothold on the crest has a
    direction off it, where an interpolation flat over the crest's cell leaves the solver none."""
    d = np.array([-0.008, -0.004, -0.001, 0.001, 0.004, 0.008])
    value, gx, gy = pallet_edge.stance_slope_gradient(EDGE + d, np.zeros_like(d))
    assert np.all(np.sign(gx) == -np.sign(d)) and np.abs(gx).min() > 10.0 and not gy.any()
    h = 1e-7
    np.testing.assert_allclose(gx, (_slope(pallet_edge, d + h) - _slope(pallet_edge, d - h)) / (2 * h), rtol=1e-6)
    assert value.max() < _slope(pallet_edge, [0.0])[0]  # the crest itself is the largest value


def test_a_foothold_on_the_crest_of_an_edge_is_moved_off_it(pallet_edge):
    """The `stance_off_edges` row alone (`StanceSlopeBlock` ≤ `DynParams.stance_slope_max`) on a
    foothold in the cell of the edge: the replans' projection solver moves it off the edge to the
    bound and converges, where a row without gradient there stalls at the crest's value."""
    from legplan.dyn.constraints import StanceSlopeBlock
    from legplan.dyn.formulation import Formulation
    from legplan.dyn.settings import DynParams
    from legplan.solve.auglag import Constraint, solve_augmented_lagrangian
    from legplan.solve.lm import Status
    from legplan.solve.variables import VariableBlock

    params = DynParams()
    for d in (-0.002, 0.003):
        feet = VariableBlock("feet", [EDGE + d, 0.0, 0.1, 0.0, 0.0, 0.0])
        row = Constraint(StanceSlopeBlock(pallet_edge, Formulation.node_selector([0], 1)), -np.inf,
                         params.stance_slope_max, name="stance_off_edges")
        out = solve_augmented_lagrangian([feet], [], [row], params.projection_solver)
        assert out.status is Status.CONVERGED, out.reason
        x = out.values["feet"][0]
        assert np.sign(x - EDGE) == np.sign(d) and _slope(pallet_edge, [x - EDGE])[0] <= params.stance_slope_max + 1e-3


@pytest.mark.parametrize("radius", [0.0, 0.03, 0.06])
def test_envelope_within_a_radius_bounds_every_column_that_reaches_within_it(radius):
    """On random blocks, at random points: h̄_r is at least the height of every cell whose square
    comes within r of the point (the column terrain a sphere of radius r there could touch), and at
    most the highest cell within r + 3 cells."""
    rng = np.random.default_rng(int(radius * 100))
    grid = Grid2D(origin=(-0.3, -0.3), resolution=0.01, shape=(61, 61))
    heights = np.where(rng.random((6, 6)) < 0.3, rng.uniform(0.05, 0.3, (6, 6)), 0.0).repeat(10, 0).repeat(10, 1)
    terrain = TerrainModel(terrain_from_heightmap(np.pad(heights, ((0, 1), (0, 1)), mode="edge"), grid, name="blocks"))
    x, y = grid.centres()
    points = rng.uniform(-0.2, 0.2, (400, 2))
    bound = terrain.envelope_within(radius)(points[:, 0], points[:, 1])
    for (px, py), value in zip(points, bound):
        gap = np.hypot(np.maximum(np.abs(x - px) - 0.005, 0.0), np.maximum(np.abs(y - py) - 0.005, 0.0))
        assert value >= terrain.height_grid[gap <= radius].max() - 1e-12
        assert value <= terrain.height_grid[gap <= radius + 0.03].max() + 1e-12


def test_terrain_rows_closed_form_jacobians_match_complex_step_and_differences(pallet_edge):
    """The foot-terrain rows' closed-form Jacobians (height, envelope, stance slope: their bilinear
    gradients) against the blocks' generic complex step and against central differences away from
    cell lines, for feet on the flat, on the edge and off the map."""
    import scipy.sparse as sp

    from legplan.dyn.constraints import FootTerrainBlock, StanceSlopeBlock, TerrainHeightBlock

    rng = np.random.default_rng(12)
    lo, hi = pallet_edge.origin, pallet_edge.origin + pallet_edge.resolution * (np.array(pallet_edge.shape[::-1]) - 1)
    xy = rng.uniform(lo - 0.05, hi + 0.05, size=(300, 2))
    q = np.column_stack([xy, rng.uniform(0.0, 0.3, 300)])
    eye = sp.identity(len(q), format="csr")
    for block in (TerrainHeightBlock(pallet_edge, eye), TerrainHeightBlock(pallet_edge, eye, envelope=True),
                  StanceSlopeBlock(pallet_edge, eye)):
        value, jac = block._row_jacobian(q)
        reference, exact = FootTerrainBlock._row_jacobian(block, q)
        np.testing.assert_allclose(value, reference, atol=1e-12)
        np.testing.assert_allclose(jac, exact, atol=1e-12)
        h = 1e-7
        central = np.stack([(block._row(q + h * e) - block._row(q - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
        cell = (q[:, :2] - pallet_edge.origin) / pallet_edge.resolution
        away = np.all(np.abs(cell - np.round(cell)) > 1e-4, axis=1)  # no cell line within the step
        assert away.sum() > 200
        np.testing.assert_allclose(jac[away, 0], central[away], atol=1e-5)


@pytest.mark.parametrize("ground", [0.0, 0.37])
def test_a_level_map_gives_its_height_and_zero_gradients_as_the_interpolation_does(ground):
    """On a level map every grid of the model is one value: height, envelope, slope and their
    gradients are those of the bilinear interpolation (the same numbers at height 0, within rounding
    elsewhere), at real and complex points inside and outside the grid; a grid that is not level
    keeps the interpolation."""
    grid = Grid2D(origin=(-0.3, -0.2), resolution=0.02, shape=(21, 31))
    level = TerrainModel(terrain_from_heightmap(np.full(grid.shape, ground), grid, name="level"))
    x, y = np.linspace(-0.5, 0.5, 23), np.linspace(-0.3, 0.3, 23)  # some outside, some on cell centres
    interpolated = lambda g, xs, ys, d=False, frame=grid: frame.bilinear(g, np.stack([xs, ys], axis=-1), d)
    for name, function, g, frame in (("height", level.height, level.height_grid, grid),
                                     ("slope", level.stance_slope, level.slope_grid, level.slope_corners),
                                     ("envelope", level.envelope, level._envelope_grid(0.0), grid)):
        got = function(x.reshape(1, -1), y.reshape(1, -1))
        assert got.shape == (1, 23) and got.dtype == float, name
        np.testing.assert_allclose(got[0], interpolated(g, x, y, frame=frame), rtol=1e-15, atol=0.0)
        if ground == 0.0:
            np.testing.assert_array_equal(got[0], interpolated(g, x, y, frame=frame))
        stepped = function(x + 1e-20j, y)
        assert stepped.dtype == complex and np.all(stepped.imag == 0.0) and np.all(stepped.real == got[0])
    for (h, hx, hy), value in ((level.height_gradient(x, y), ground), (level.envelope_gradient(x, y), ground),
                               (level.stance_slope_gradient(x, y), 0.0)):
        assert np.all(h == value) and not hx.any() and not hy.any() and hx.shape == x.shape
    _, g = interpolated(level.height_grid, x, y, True)
    assert not g.any()  # the interpolation's gradient of a level grid: zero as well
    ramp = np.full(grid.shape, ground)
    ramp[:, 20:] += 0.05
    sloped = TerrainModel(terrain_from_heightmap(ramp, grid, name="ramp"))
    np.testing.assert_array_equal(sloped.height(x, y), interpolated(sloped.height_grid, x, y))
    assert sloped.height_gradient(x, y)[1].any()
