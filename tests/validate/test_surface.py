import numpy as np
import pytest

from legplan.validate.surface import SurfaceMesh


def _step_map():
    """1.2 m x 1.0 m at 2 cm; ground z=0.1 with a 0.3 m-wide pit of depth 0.4 across x in [0.5, 0.8]."""
    h = np.full((51, 61), 0.1)
    x = np.arange(61) * 0.02
    h[:, (x >= 0.5) & (x <= 0.8)] = -0.3
    return h


def test_point_over_flat_ground_distance_is_height_above_it():
    mesh = SurfaceMesh(np.zeros((40, 40)), origin=(-0.4, -0.4), resolution=0.02)
    pts = np.array([[0.0, 0.0, 0.05], [0.1, -0.1, 0.3], [0.05, 0.05, -0.02]])
    np.testing.assert_allclose(mesh.signed_distance(pts), [0.05, 0.3, -0.02], atol=1e-8)
    # FCL itself (no shortcut) agrees with the height
    np.testing.assert_allclose(mesh.fcl_distance(pts), [0.05, 0.3, -0.02], atol=1e-8)


def test_surface_height_is_the_top_of_the_containing_column():
    h = np.array([[0.0, 1.0], [2.0, 4.0]])
    mesh = SurfaceMesh(h, origin=(0.0, 0.0), resolution=1.0)
    np.testing.assert_allclose(mesh.surface_height(np.array([[0.4, 0.1], [0.6, 0.4], [0.2, 0.7], [3.0, 3.0]])),
                               [0.0, 1.0, 2.0, 4.0])


def test_bounds_bracket_fcl_and_signed_distance_matches_fcl_everywhere():
    mesh = SurfaceMesh(_step_map(), origin=(0.0, 0.0), resolution=0.02, window=0.1)
    rng = np.random.default_rng(3)
    pts = rng.uniform([0.2, 0.2, -0.35], [1.0, 0.8, 0.4], size=(400, 3))
    exact = mesh.fcl_distance(pts)
    lb, ub, is_exact = mesh.distance_bounds(pts)
    assert np.all(lb <= exact + 1e-9) and np.all(exact <= ub + 1e-9)
    assert is_exact.any() and (~is_exact).any()
    np.testing.assert_allclose(mesh.signed_distance(pts), exact, atol=1e-8)


def test_point_beside_a_wall_measures_horizontal_distance_to_the_column_face():
    mesh = SurfaceMesh(_step_map(), origin=(0.0, 0.0), resolution=0.02)
    # the pit columns end at x = 0.80 + 0.01; a point at x = 0.75, 0.1 m below the rim, is 0.06 m
    # from that wall and 0.2 m above the pit floor
    d = mesh.signed_distance(np.array([[0.75, 0.5, 0.0]]))[0]
    assert d == pytest.approx(0.06, abs=1e-9)
    # just above the rim edge, diagonal to the corner of the column top
    d = mesh.signed_distance(np.array([[0.78, 0.5, 0.13]]))[0]
    assert d == pytest.approx(np.hypot(0.03, 0.03), abs=1e-9)
    # inside the ground column, 2 cm below its top and 5 cm from the wall: -0.02
    assert mesh.signed_distance(np.array([[0.88, 0.5, 0.08]]))[0] == pytest.approx(-0.02, abs=1e-9)
