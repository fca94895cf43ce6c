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
