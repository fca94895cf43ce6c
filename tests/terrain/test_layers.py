"""Foothold mask, occupancy, obstacle distance and the costmap of eqs. (15)-(16)."""

import numpy as np
import pytest

from legplan.terrain import (FootholdParams, Grid2D, costmap_from_distance, foothold_mask,
                             obstacle_distance, occupancy_grid)


def test_costmap_follows_eqs_15_16():
    l1, l2, c_max, lam = 0.2, 0.6, 100.0, 5.0
    distance = np.array([0.0, 0.1, 0.1999, 0.2, 0.3, 0.5, 0.5999, 0.6, 2.0])
    cost = costmap_from_distance(distance, l1, l2, c_max, lam)
    expected = [c_max, c_max, c_max, c_max, c_max * np.exp(-lam * 0.1), c_max * np.exp(-lam * 0.3),
                c_max * np.exp(-lam * 0.3999), 0.0, 0.0]
    assert np.allclose(cost, expected)


def test_obstacle_distance_and_occupancy():
    height = np.zeros((20, 30))
    height[10, 5] = 0.5       # a tall post
    height[2, 25] = -1.0      # a hole
    occupied = occupancy_grid(height, 0.0, 0.15)
    assert occupied.sum() == 2 and occupied[10, 5] and occupied[2, 25]
    distance = obstacle_distance(occupied, 0.1)
    assert distance[10, 5] == 0.0
    assert distance[10, 8] == pytest.approx(0.3)
    assert distance[14, 8] == pytest.approx(0.5)
    explicit = np.zeros_like(occupied)
    explicit[0, 0] = True
    assert occupancy_grid(height, 0.0, 0.15, explicit)[0, 0]
    assert np.all(obstacle_distance(np.zeros((4, 4), bool), 1.0) > 0)


def test_foothold_mask_on_box_edge():
    r = 0.01
    grid = Grid2D((0.005, 0.005), r, (40, 60))
    X, _ = grid.centres()
    height = np.where(X > 0.3, 0.1, 0.0)      # a 10 cm step at x = 0.3
    params = FootholdParams(flat_radius=0.02, flat_tolerance=0.01, edge_margin=0.01)
    mask = foothold_mask(height, r, params)
    column = mask[20]
    xs = grid.xs
    # flat radius 2 cm + margin 1 cm: cells within 3 cm of the edge are excluded on both sides
    assert not column[(xs > 0.27) & (xs < 0.33)].any()
    assert column[(xs < 0.26) | (xs > 0.34)].all()
    holes = np.zeros_like(mask)
    holes[:, :5] = True
    assert not foothold_mask(height, r, params, holes)[:, :5].any()


def test_foothold_allows_gentle_slope_and_rejects_rough():
    r = 0.02
    grid = Grid2D((0.0, 0.0), r, (30, 30))
    X, _ = grid.centres()
    params = FootholdParams(flat_radius=0.04, flat_tolerance=0.02, edge_margin=0.0)
    assert foothold_mask(0.1 * X, r, params).all()                 # 5.7 deg: range 0.008 m
    rough = np.random.default_rng(0).uniform(0, 0.1, grid.shape)
    assert not foothold_mask(rough, r, params).any()
